#include "rollstep/perception/terrain_perception.hpp"

#include <array>
#include <cmath>
#include <map>
#include <stdexcept>
#include <type_traits>
#include <variant>

#include "rollstep/common/number_text.hpp"
#include "rollstep/common/settings_table.hpp"
#include "rollstep/common/text_file.hpp"
#include "rollstep/common/yaml_tree.hpp"

namespace rollstep::perception {

namespace {

// The keys of each section, in config/perception.yaml's order (ranges: the settings'
// validate(), which names the key; the table refuses what is not a finite number).
settings::Table<ElevationMapSettings> makeMapFields() {
  using S = ElevationMapSettings;
  return settings::Table<S>()
      .field("length", &S::length)
      .field("resolution", &S::resolution)
      .field("sensor_noise", &S::sensor_noise)
      .field("range_noise_slope", &S::range_noise_slope)
      .field("gate", &S::gate)
      .field("process_noise", &S::process_noise)
      .field("max_variance", &S::max_variance)
      .field("min_variance", &S::min_variance)
      .field("visibility_cleanup", &S::visibility_cleanup)
      .field("visibility_stride", &S::visibility_stride)
      .field("visibility_margin", &S::visibility_margin)
      .field("max_range", &S::max_range)
      .field("min_range", &S::min_range);
}

settings::Table<SegmentationSettings> makeSegmentationFields() {
  using S = SegmentationSettings;
  return settings::Table<S>()
      .field("window_half", &S::window_half)
      .field("min_window_fill", &S::min_window_fill)
      .field("max_residual", &S::max_residual)
      .field("max_slope_deg", &S::max_slope_deg)
      .field("max_normal_angle_deg", &S::max_normal_angle_deg)
      .field("max_height_step", &S::max_height_step)
      .field("step_height", &S::step_height)
      .field("grow_tolerance", &S::grow_tolerance)
      .field("min_region_area", &S::min_region_area)
      .field("max_hole_area", &S::max_hole_area)
      .field("max_level_hole_area", &S::max_level_hole_area)
      .field("fill_gap", &S::fill_gap)
      .field("fill_shadow", &S::fill_shadow);
}

settings::Table<ConvexRegionSettings> makeRegionFields() {
  using S = ConvexRegionSettings;
  return settings::Table<S>()
      .field("directions", &S::directions)
      .field("margin", &S::margin)
      .field("min_clearance", &S::min_clearance)
      .field("search_radius", &S::search_radius)
      .field("height_weight", &S::height_weight)
      .field("max_pieces_per_region", &S::max_pieces_per_region)
      .field("cover_fraction", &S::cover_fraction)
      .field("cover_gap", &S::cover_gap)
      .field("min_piece_area", &S::min_piece_area)
      .field("max_notch_depth", &S::max_notch_depth);
}

settings::Table<ClosedLoopSettings> makeClosedLoopFields() {
  using S = ClosedLoopSettings;
  return settings::Table<S>()
      .field("warmup_scans", &S::warmup_scans)
      .field("footprint_margin", &S::footprint_margin)
      .field("footprint_variance", &S::footprint_variance)
      .field("blind_zone_radius", &S::blind_zone_radius)
      .field("level_max_tilt_deg", &S::level_max_tilt_deg)
      .field("level_height_tolerance", &S::level_height_tolerance)
      .field("seam_probe_cells", &S::seam_probe_cells)
      .field("seam_height_tolerance", &S::seam_height_tolerance)
      .field("collision_capacity", &S::collision_capacity);
}

settings::Table<PerceptionSettings> makeTable() {
  using S = PerceptionSettings;
  return settings::Table<S>()
      .section("map", &S::map, makeMapFields())
      .section("segmentation", &S::segmentation, makeSegmentationFields())
      .section("regions", &S::regions, makeRegionFields())
      .section("closed_loop", &S::closed_loop, makeClosedLoopFields());
}

const settings::Table<PerceptionSettings>& table() {
  static const settings::Table<PerceptionSettings> t = makeTable();
  return t;
}

void require(bool ok, const char* name, double value, const char* what) {
  if (!ok) {
    throw std::invalid_argument(std::string("closed loop: ") + name + " = " +
                                shortestNumberText(value) + ": " + what);
  }
}

}  // namespace

void ClosedLoopSettings::validate() const {
  require(warmup_scans >= 1 && warmup_scans <= 100, "warmup_scans", warmup_scans,
          "must be 1 to 100");
  require(std::isfinite(footprint_margin) && footprint_margin >= 0 && footprint_margin <= 1,
          "footprint_margin", footprint_margin, "must be in [0, 1] m");
  require(std::isfinite(footprint_variance) && footprint_variance > 0 && footprint_variance <= 1,
          "footprint_variance", footprint_variance, "must be in (0, 1] m^2");
  require(std::isfinite(blind_zone_radius) && blind_zone_radius >= 0 && blind_zone_radius <= 5,
          "blind_zone_radius", blind_zone_radius, "must be in [0, 5] m");
  require(std::isfinite(level_max_tilt_deg) && level_max_tilt_deg >= 0 && level_max_tilt_deg < 90,
          "level_max_tilt_deg", level_max_tilt_deg, "must be in [0, 90) deg");
  require(std::isfinite(level_height_tolerance) && level_height_tolerance >= 0 &&
              level_height_tolerance < 1,
          "level_height_tolerance", level_height_tolerance, "must be in [0, 1) m");
  require(seam_probe_cells >= 1 && seam_probe_cells <= 50, "seam_probe_cells", seam_probe_cells,
          "must be 1 to 50");
  require(std::isfinite(seam_height_tolerance) && seam_height_tolerance >= 0 &&
              seam_height_tolerance < 1,
          "seam_height_tolerance", seam_height_tolerance, "must be in [0, 1) m");
  require(collision_capacity >= 1 && collision_capacity <= 1000, "collision_capacity",
          collision_capacity, "must be 1 to 1000");
}

void PerceptionSettings::validate() const {
  map.validate();
  segmentation.validate();
  regions.validate();
  closed_loop.validate();
}

PerceptionSettings parsePerceptionSettings(std::string_view text, const std::string& source) {
  const std::string head = "perception settings '" + source + "': ";
  const yaml::Document doc = yaml::parseDocument(text, head);
  PerceptionSettings s;
  settings::Reader reader(head);
  table().read(doc.root(), s, reader);
  // Ranges: each section's validate() names the parameter; report it at its line.
  const auto check = [&](const char* section, auto&& validate) {
    try {
      validate();
    } catch (const std::invalid_argument& e) {
      const std::string what = e.what();
      // what: "<section>: <key> = <value>: <problem>".
      const std::string named = what.substr(what.find(": ") + 2);
      const settings::Reader::Seen* seen =
          reader.seen(std::string(section) + "." + named.substr(0, named.find(" = ")));
      if (seen != nullptr) reader.failAtLine(seen->line, section + ("." + named));
      throw std::runtime_error(head + section + "." + named);
    }
  };
  check("map", [&] { s.map.validate(); });
  check("segmentation", [&] { s.segmentation.validate(); });
  check("regions", [&] { s.regions.validate(); });
  check("closed_loop", [&] { s.closed_loop.validate(); });
  return s;
}

PerceptionSettings loadPerceptionSettings(const std::string& path) {
  return parsePerceptionSettings(readTextFile(path, "perception settings", std::size_t{1} << 20),
                                 path);
}

std::string toYaml(const PerceptionSettings& s) { return table().write(s); }

const char* toString(PerceptionStatus status) { return enumName(status); }

TerrainPerception::TerrainPerception(const PerceptionSettings& settings)
    : settings_((settings.validate(), settings)),
      map_(settings.map),
      filled_(settings.map),
      segmenter_(settings.segmentation),
      grower_(settings.regions) {}

PerceptionStatus TerrainPerception::update(const std::vector<Eigen::Vector3d>& points,
                                           const Eigen::Isometry3d& sensor_pose, double time) {
  last_stats_ = MapUpdateStats{};
  last_stats_.points = static_cast<int>(points.size());
  if (!sensor_pose.matrix().allFinite() || !std::isfinite(time)) {
    return last_status_ = PerceptionStatus::InvalidPose;
  }
  map_.moveTo(sensor_pose.translation().head<2>());
  if (has_time_) map_.predict(time - last_time_);
  last_time_ = time;
  has_time_ = true;
  last_stats_ = map_.update(points, sensor_pose);
  if (last_stats_.fused == 0) {
    return last_status_ =
               (last_stats_.non_finite > 0 && last_stats_.non_finite == last_stats_.points)
                   ? PerceptionStatus::NonFinite
                   : PerceptionStatus::NoPoints;
  }
  const PerceptionStatus s = rebuild();
  if (s == PerceptionStatus::Ok) terrain_time_ = time;
  return s;
}

int TerrainPerception::fillStartArea(const Eigen::Vector3d* contacts, int count,
                                     const Eigen::Vector3d& sensor_position) {
  const ClosedLoopSettings& cl = settings_.closed_loop;
  int filled = 0;
  // The blind zone first: it looks at measured cells only.
  if (cl.blind_zone_radius > 0) {
    filled += map_.fillBlindZone(sensor_position.head<2>(), contacts, count, cl.blind_zone_radius,
                                 settings_.segmentation.step_height, cl.footprint_variance);
  }
  return filled + map_.fillFootprint(contacts, count, cl.footprint_margin, cl.footprint_variance);
}

PerceptionStatus TerrainPerception::rebuild() {
  const SegmentationSettings& seg = settings_.segmentation;
  if (seg.fill_gap > 0.0 || seg.fill_shadow > 0.0) {
    // The unseen strips between the LiDAR's rings on the ground, filled across (a copy:
    // the fused map keeps only what was measured).
    filled_.copyFrom(map_);
    filled_.fillGaps(static_cast<int>(std::floor(seg.fill_gap / map_.resolution() + 1e-9)),
                     seg.step_height,
                     static_cast<int>(std::floor(seg.fill_shadow / map_.resolution() + 1e-9)));
    segmenter_.segment(filled_, segmentation_);
  } else {
    segmenter_.segment(map_, segmentation_);
  }
  if (segmentation_.regions.empty()) return last_status_ = PerceptionStatus::NoPlanarRegion;
  planning::TerrainModel terrain = grower_.terrain(segmentation_);
  if (terrain.size() == 0) return last_status_ = PerceptionStatus::NoPlanarRegion;
  terrain_ = std::move(terrain);
  has_terrain_ = true;
  return last_status_ = PerceptionStatus::Ok;
}

}  // namespace rollstep::perception
