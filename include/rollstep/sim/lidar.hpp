#pragma once
// Simulated LiDAR: a spinning multi-beam sensor on the robot's base, rays cast against
// the MuJoCo scene's terrain (Plant::raycast: robot geoms are not hit), with Gaussian
// range noise and random dropouts from a seeded generator (same seed, same scans).
//
// Sensor frame: x forward, z up, mounted on the base at mount_position, pitched down by
// mount_pitch_deg. Beam b points at elevation min + b (max - min) / (beams - 1) above the
// sensor's x-y plane; a scan sweeps azimuth over horizontal_fov_deg centred on +x. A ray
// that hits nothing within max_range, or drops out, returns a NaN point (as real drivers
// report misses), so the scan has a fixed size (beams x columns), preallocated.
#include <Eigen/Geometry>
#include <random>
#include <string>
#include <string_view>
#include <vector>

#include "rollstep/sim/plant.hpp"

namespace rollstep::sim {

struct LidarSettings {
  Eigen::Vector3d mount_position{0.35, 0.0, 0.12};  ///< base frame [m]
  double mount_pitch_deg = 10.0;                    ///< downward tilt [deg]
  int beams = 32;
  double min_elevation_deg = -45.0;  ///< lowest beam, sensor frame [deg]
  double max_elevation_deg = 15.0;   ///< highest beam [deg]
  double horizontal_fov_deg = 360.0;
  double horizontal_resolution_deg = 0.8;
  double rate = 10.0;         ///< scans per second [Hz]
  double max_range = 8.0;     ///< [m]
  double range_noise = 0.01;  ///< standard deviation of the range [m]
  double dropout = 0.02;      ///< probability that a ray returns nothing
  int seed = 1;

  /// Throws std::invalid_argument naming the first bad parameter and its value.
  void validate() const;
  int columns() const;
};

/// Reads lidar settings (config/lidar.yaml documents every key; absent keys keep their
/// defaults). Throws std::runtime_error "lidar settings '<source>': line L: <key>: ..."
/// for YAML errors, unknown or repeated keys, non-numbers and out-of-range values.
LidarSettings parseLidarSettings(std::string_view text, const std::string& source);
LidarSettings loadLidarSettings(const std::string& path);
/// Every key, one "key: value" line each; parseLidarSettings reads it back exactly.
std::string toYaml(const LidarSettings& settings);

class Lidar {
 public:
  explicit Lidar(const LidarSettings& settings = {});
  const LidarSettings& settings() const { return settings_; }

  /// Sensor pose in the world for a base pose.
  Eigen::Isometry3d sensorPose(const Eigen::Vector3d& base_position,
                               const Eigen::Quaterniond& base_orientation) const;
  /// One scan from the plant's current (ground-truth) base pose: points in the sensor
  /// frame, NaN for misses and dropouts. Does not allocate.
  const std::vector<Eigen::Vector3d>& scan(const Plant& plant);
  /// One scan from a given base pose (the robot "placed" there: only the terrain is hit,
  /// so the robot need not be simulated at that pose).
  const std::vector<Eigen::Vector3d>& scanFrom(const Plant& plant,
                                               const Eigen::Vector3d& base_position,
                                               const Eigen::Quaterniond& base_orientation);
  /// The pose of the last scan.
  const Eigen::Isometry3d& lastPose() const { return pose_; }
  /// Rays of the last scan that returned a point.
  int lastHits() const { return hits_; }

 private:
  LidarSettings settings_;
  Eigen::Isometry3d mount_;
  std::vector<Eigen::Vector3d> directions_;  // unit, sensor frame
  std::vector<Eigen::Vector3d> points_;
  Eigen::Isometry3d pose_ = Eigen::Isometry3d::Identity();
  std::mt19937 rng_;
  std::normal_distribution<double> noise_;
  std::uniform_real_distribution<double> uniform_{0.0, 1.0};
  int hits_ = 0;
};

}  // namespace rollstep::sim
