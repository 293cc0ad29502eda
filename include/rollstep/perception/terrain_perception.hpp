#pragma once
// The perception pipeline: point clouds -> elevation map -> plane segmentation -> convex
// foothold regions, as the planning layer's TerrainModel (the same type the scene's
// ground truth gives, so the planner and the safety filter take either).
//
// Bad data never replaces the terrain: update() reports a status, and terrain() keeps the
// last terrain built from good data (empty until the first).
#include <array>
#include <string>
#include <string_view>
#include <vector>

#include "rollstep/common/enum_names.hpp"
#include "rollstep/perception/convex_regions.hpp"
#include "rollstep/perception/elevation_map.hpp"
#include "rollstep/perception/plane_segmentation.hpp"
#include "rollstep/planning/terrain.hpp"

namespace rollstep::perception {

/// Perception in closed loop (sim::OnlinePerception and the controllers it feeds): how the
/// first terrain is built and how each perceived terrain is made usable by the planners.
/// config/perception.yaml's `closed_loop:` section documents every key.
struct ClosedLoopSettings {
  /// Scans fused from the start pose before the first terrain [-], 1 to 100.
  int warmup_scans = 10;
  /// At the start, the cells the sensor cannot see (under the robot) are filled from the
  /// wheels' ground contacts over their bounding box grown by this [m], [0, 1] ...
  double footprint_margin = 0.15;
  /// ... with this variance [m^2], (0, 1].
  double footprint_variance = 1e-4;
  /// At the start, the empty cells of the sensor's blind zone (the ground near it that its
  /// lowest beam passes over) within this distance of the sensor are filled from the
  /// wheels' contact plane too, in each direction up to the nearest measured ground and only
  /// where that ground is level with the contacts (within segmentation.step_height); see
  /// ElevationMap::fillBlindZone. 0: off [m], [0, 5]. On by default (the built-in sensor's
  /// zone reaches about 0.35 m ahead of it): a robot that starts close to a step never sees
  /// that strip of floor before the riser from further back (docs/PERCEPTION.md).
  double blind_zone_radius = 0.5;
  /// Perceived surfaces within this tilt of level are made level [deg], [0, 90) ...
  double level_max_tilt_deg = 2.0;
  /// ... and level ones within this of each other share one height [m], [0, 1).
  double level_height_tolerance = 0.01;
  /// Foothold regions are shrunk except along seams between convex pieces of one surface:
  /// an edge whose points this many map cells beyond it lie on another piece [-], 1 to 50 ...
  int seam_probe_cells = 2;
  /// ... at a height within this of its own [m], [0, 1).
  double seam_height_tolerance = 0.02;
  /// The most collision solids (perceived regions) the baseline's CBF-QP is sized for; a
  /// terrain with more is refused (the last stays) [-], 1 to 1000.
  int collision_capacity = 64;

  void validate() const;
};

struct PerceptionSettings {
  ElevationMapSettings map;
  SegmentationSettings segmentation;
  ConvexRegionSettings regions;
  ClosedLoopSettings closed_loop;

  void validate() const;
};

/// Reads perception settings (config/perception.yaml documents every key): a mapping with
/// optional sections map, segmentation, regions, closed_loop; absent keys keep their defaults.
/// Throws std::runtime_error "perception settings '<source>': line L: <key>: <problem>" for YAML
/// errors, unknown or repeated keys, values that are not numbers (booleans for the switches) or are
/// out of range.
PerceptionSettings parsePerceptionSettings(std::string_view text, const std::string& source);
PerceptionSettings loadPerceptionSettings(const std::string& path);
/// The settings as YAML text that parsePerceptionSettings reads back to the same values.
std::string toYaml(const PerceptionSettings& settings);

enum class PerceptionStatus {
  Ok,              ///< new terrain built
  NoPoints,        ///< the scan is empty or every ray missed (no return in range)
  NonFinite,       ///< no usable point: every return was NaN or infinite
  InvalidPose,     ///< the sensor pose is not finite: nothing fused
  NoPlanarRegion,  ///< the map holds no planar region large enough
};
constexpr std::array<EnumName<PerceptionStatus>, 5> enumNames(PerceptionStatus) {
  return {{{PerceptionStatus::Ok, "ok"},
           {PerceptionStatus::NoPoints, "no points (every ray missed)"},
           {PerceptionStatus::NonFinite, "no finite point"},
           {PerceptionStatus::InvalidPose, "sensor pose not finite"},
           {PerceptionStatus::NoPlanarRegion, "no planar region"}}};
}
const char* toString(PerceptionStatus status);

class TerrainPerception {
 public:
  explicit TerrainPerception(const PerceptionSettings& settings = {});

  /// One scan: points in the sensor frame (NaN for a ray that missed), the sensor's pose
  /// in the world (from the estimated base pose), the scan's time [s]. Recentres the map
  /// on the sensor, grows the cells' variance by the time since the last scan, fuses,
  /// segments and rebuilds the terrain. Only Ok replaces terrain().
  PerceptionStatus update(const std::vector<Eigen::Vector3d>& points,
                          const Eigen::Isometry3d& sensor_pose, double time);
  /// The start of closed-loop perception, after the scans from the start pose are fused:
  /// fills the cells the sensor cannot see from the robot's ground contacts (world; e.g. the
  /// wheels' from the leg kinematics): its blind zone around `sensor_position` (world,
  /// closed_loop.blind_zone_radius), then the footprint (closed_loop.footprint_margin).
  /// Returns the cells filled (0 for no or non-finite contacts). Call rebuild() after.
  int fillStartArea(const Eigen::Vector3d* contacts, int count,
                    const Eigen::Vector3d& sensor_position);
  /// Segmentation and terrain from the map as it is (e.g. after fusing several scans with
  /// map().update); Ok or NoPlanarRegion.
  PerceptionStatus rebuild();

  const PerceptionSettings& settings() const { return settings_; }
  const planning::TerrainModel& terrain() const { return terrain_; }
  bool hasTerrain() const { return has_terrain_; }
  double terrainTime() const { return terrain_time_; }
  PerceptionStatus lastStatus() const { return last_status_; }
  const MapUpdateStats& lastStats() const { return last_stats_; }
  ElevationMap& map() { return map_; }
  const ElevationMap& map() const { return map_; }
  const Segmentation& segmentation() const { return segmentation_; }
  ConvexRegionGrower& grower() { return grower_; }

 private:
  PerceptionSettings settings_;
  ElevationMap map_;
  ElevationMap filled_;  // map_ with its small gaps filled (segmentation.fill_gap)
  PlaneSegmenter segmenter_;
  ConvexRegionGrower grower_;
  Segmentation segmentation_;
  planning::TerrainModel terrain_;
  bool has_terrain_ = false;
  double terrain_time_ = 0.0, last_time_ = 0.0;
  bool has_time_ = false;
  PerceptionStatus last_status_ = PerceptionStatus::NoPoints;
  MapUpdateStats last_stats_;
};

}  // namespace rollstep::perception
