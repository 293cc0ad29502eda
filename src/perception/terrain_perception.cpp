#include "rollstep/perception/terrain_perception.hpp"

#include <array>
#include <cmath>
#include <map>
#include <stdexcept>
#include <type_traits>
#include <variant>

#include "rollstep/common/number_text.hpp"
#include "rollstep/common/text_file.hpp"
#include "rollstep/common/yaml_tree.hpp"

namespace rollstep::perception {

namespace {

template <typename S>
using Member = std::variant<int S::*, double S::*, bool S::*>;
template <typename S>
struct Field {
  const char* key;
  Member<S> member;
};

// The keys of each section, in config/perception.yaml's order (ranges: the settings'
// validate(), which names the key).
const std::array<Field<ElevationMapSettings>, 13> kMapFields{{
    {"length", &ElevationMapSettings::length},
    {"resolution", &ElevationMapSettings::resolution},
    {"sensor_noise", &ElevationMapSettings::sensor_noise},
    {"range_noise_slope", &ElevationMapSettings::range_noise_slope},
    {"gate", &ElevationMapSettings::gate},
    {"process_noise", &ElevationMapSettings::process_noise},
    {"max_variance", &ElevationMapSettings::max_variance},
    {"min_variance", &ElevationMapSettings::min_variance},
    {"visibility_cleanup", &ElevationMapSettings::visibility_cleanup},
    {"visibility_stride", &ElevationMapSettings::visibility_stride},
    {"visibility_margin", &ElevationMapSettings::visibility_margin},
    {"max_range", &ElevationMapSettings::max_range},
    {"min_range", &ElevationMapSettings::min_range},
}};
const std::array<Field<SegmentationSettings>, 13> kSegmentationFields{{
    {"window_half", &SegmentationSettings::window_half},
    {"min_window_fill", &SegmentationSettings::min_window_fill},
    {"max_residual", &SegmentationSettings::max_residual},
    {"max_slope_deg", &SegmentationSettings::max_slope_deg},
    {"max_normal_angle_deg", &SegmentationSettings::max_normal_angle_deg},
    {"max_height_step", &SegmentationSettings::max_height_step},
    {"step_height", &SegmentationSettings::step_height},
    {"grow_tolerance", &SegmentationSettings::grow_tolerance},
    {"min_region_area", &SegmentationSettings::min_region_area},
    {"max_hole_area", &SegmentationSettings::max_hole_area},
    {"max_level_hole_area", &SegmentationSettings::max_level_hole_area},
    {"fill_gap", &SegmentationSettings::fill_gap},
    {"fill_shadow", &SegmentationSettings::fill_shadow},
}};
const std::array<Field<ConvexRegionSettings>, 10> kRegionFields{{
    {"directions", &ConvexRegionSettings::directions},
    {"margin", &ConvexRegionSettings::margin},
    {"min_clearance", &ConvexRegionSettings::min_clearance},
    {"search_radius", &ConvexRegionSettings::search_radius},
    {"height_weight", &ConvexRegionSettings::height_weight},
    {"max_pieces_per_region", &ConvexRegionSettings::max_pieces_per_region},
    {"cover_fraction", &ConvexRegionSettings::cover_fraction},
    {"cover_gap", &ConvexRegionSettings::cover_gap},
    {"min_piece_area", &ConvexRegionSettings::min_piece_area},
    {"max_notch_depth", &ConvexRegionSettings::max_notch_depth},
}};

const std::array<Field<ClosedLoopSettings>, 9> kClosedLoopFields{{
    {"warmup_scans", &ClosedLoopSettings::warmup_scans},
    {"footprint_margin", &ClosedLoopSettings::footprint_margin},
    {"footprint_variance", &ClosedLoopSettings::footprint_variance},
    {"blind_zone_radius", &ClosedLoopSettings::blind_zone_radius},
    {"level_max_tilt_deg", &ClosedLoopSettings::level_max_tilt_deg},
    {"level_height_tolerance", &ClosedLoopSettings::level_height_tolerance},
    {"seam_probe_cells", &ClosedLoopSettings::seam_probe_cells},
    {"seam_height_tolerance", &ClosedLoopSettings::seam_height_tolerance},
    {"collision_capacity", &ClosedLoopSettings::collision_capacity},
}};

template <typename S, std::size_t N>
std::string knownKeys(const std::array<Field<S>, N>& fields) {
  std::string keys;
  for (const Field<S>& f : fields) keys += (keys.empty() ? "" : ", ") + std::string(f.key);
  return keys;
}

template <typename S, std::size_t N, typename Fail>
void readSection(const yaml::Node& node, const std::string& name, S& section,
                 const std::array<Field<S>, N>& fields, std::map<std::string, int>& lines,
                 Fail fail) {
  if (node.isNull()) return;
  if (!node.isMapping()) fail(node, name + ": expected a mapping, got " + node.kindName());
  for (std::size_t item = 0; item < node.size(); ++item) {
    const yaml::Node key = node.key(item), value = node.value(item);
    const std::string k = key.isScalar() ? key.scalar() : std::string("<key>");
    const std::string path = name + "." + k;
    const Field<S>* field = nullptr;
    for (const Field<S>& f : fields) {
      if (k == f.key) field = &f;
    }
    if (field == nullptr) {
      fail(key, "unknown key '" + path + "' (known in " + name + ": " + knownKeys(fields) + ")");
    }
    if (const auto it = lines.find(path); it != lines.end()) {
      fail(key, path + ": given twice (first on line " + std::to_string(it->second) + ")");
    }
    lines.emplace(path, key.line());
    const std::string got = value.isScalar() ? "'" + value.scalar() + "'" : value.kindName();
    std::visit(
        [&](auto member) {
          using T = std::decay_t<decltype(section.*member)>;
          if constexpr (std::is_same_v<T, int>) {
            int v = 0;
            if (!value.isScalar() || !value.toInt(v))
              fail(value, path + ": expected an integer, got " + got);
            section.*member = v;
          } else if constexpr (std::is_same_v<T, double>) {
            double v = 0;
            if (!value.isScalar() || !value.toDouble(v) || !std::isfinite(v)) {
              fail(value, path + ": expected a finite number, got " + got);
            }
            section.*member = v;
          } else {
            bool v = false;
            if (!value.isScalar() || !value.toBool(v))
              fail(value, path + ": expected true or false, got " + got);
            section.*member = v;
          }
        },
        field->member);
  }
}

template <typename S, std::size_t N>
void writeSection(const S& section, const std::array<Field<S>, N>& fields, std::string& out) {
  for (const Field<S>& f : fields) {
    out += "  " + std::string(f.key) + ": ";
    std::visit(
        [&](auto member) {
          using T = std::decay_t<decltype(section.*member)>;
          if constexpr (std::is_same_v<T, int>) {
            out += std::to_string(section.*member);
          } else if constexpr (std::is_same_v<T, double>) {
            out += shortestNumberText(section.*member);
          } else {
            out += section.*member ? "true" : "false";
          }
        },
        f.member);
    out += "\n";
  }
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
  const auto fail = [&](const yaml::Node& node, const std::string& what) {
    throw std::runtime_error(head + "line " + std::to_string(node.line()) + ": " + what);
  };
  yaml::Document doc = yaml::parseDocument(text, head);
  PerceptionSettings s;
  const yaml::Node root = doc.root();
  if (root.isNull()) return s;
  if (!root.isMapping()) fail(root, std::string("expected a mapping, got ") + root.kindName());
  std::map<std::string, int> lines;
  for (std::size_t item = 0; item < root.size(); ++item) {
    const yaml::Node key = root.key(item), value = root.value(item);
    const std::string k = key.isScalar() ? key.scalar() : std::string("<key>");
    if (lines.count(k))
      fail(key, k + ": given twice (first on line " + std::to_string(lines[k]) + ")");
    lines.emplace(k, key.line());
    if (k == "map") {
      readSection(value, k, s.map, kMapFields, lines, fail);
    } else if (k == "segmentation") {
      readSection(value, k, s.segmentation, kSegmentationFields, lines, fail);
    } else if (k == "regions") {
      readSection(value, k, s.regions, kRegionFields, lines, fail);
    } else if (k == "closed_loop") {
      readSection(value, k, s.closed_loop, kClosedLoopFields, lines, fail);
    } else {
      fail(key, "unknown key '" + k + "' (known: map, segmentation, regions, closed_loop)");
    }
  }
  // Ranges: each section's validate() names the parameter; report it at its line.
  const auto check = [&](const char* section, auto&& validate) {
    try {
      validate();
    } catch (const std::invalid_argument& e) {
      const std::string what = e.what();
      int line = 0;
      for (const auto& [path, l] : lines) {
        const std::string prefix = std::string(section) + ".";
        if (path.rfind(prefix, 0) != 0) continue;
        const std::string key = path.substr(prefix.size());
        if (what.find(": " + key + " = ") != std::string::npos) line = l;
      }
      throw std::runtime_error(head + (line > 0 ? "line " + std::to_string(line) + ": " : "") +
                               section + "." + what.substr(what.find(": ") + 2));
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

std::string toYaml(const PerceptionSettings& s) {
  std::string out = "map:\n";
  writeSection(s.map, kMapFields, out);
  out += "segmentation:\n";
  writeSection(s.segmentation, kSegmentationFields, out);
  out += "regions:\n";
  writeSection(s.regions, kRegionFields, out);
  out += "closed_loop:\n";
  writeSection(s.closed_loop, kClosedLoopFields, out);
  return out;
}

const char* toString(PerceptionStatus status) {
  switch (status) {
    case PerceptionStatus::Ok:
      return "ok";
    case PerceptionStatus::NoPoints:
      return "no points (every ray missed)";
    case PerceptionStatus::NonFinite:
      return "no finite point";
    case PerceptionStatus::InvalidPose:
      return "sensor pose not finite";
    case PerceptionStatus::NoPlanarRegion:
      return "no planar region";
  }
  return "unknown";
}

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
