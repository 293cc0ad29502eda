#pragma once
// Closed-loop runs of the plant with a controller, with an optional CSV log.
#include <cstdio>
#include <string>

#include "rollstep/sim/plant.hpp"
#include "rollstep/sim/simple_controllers.hpp"

namespace rollstep::sim {

/// CSV log of a run, one row per logged control period. Columns:
///   time, base_x/y/z (world, m), base_qw/qx/qy/qz (base->world), base_vx/vy/vz (world,
///   m/s), base_wx/wy/wz (base frame, rad/s), q_<joint> (12, URDF order), cmd_<joint>
///   (12), wheel_vel_<leg> and cmd_wheel_<leg> (4 drive wheels, rad/s),
///   contact_<leg> (0/1, ground truth) and fz_<leg> (world vertical force, N) for 6 legs.
class CsvLog {
 public:
  /// Opens (truncates) the file and writes the header; throws SimError on failure.
  explicit CsvLog(const std::string& path);
  ~CsvLog();
  CsvLog(const CsvLog&) = delete;
  CsvLog& operator=(const CsvLog&) = delete;
  void write(const GroundTruth& truth, const PlantCommand& command);
  const std::string& path() const { return path_; }

 private:
  std::string path_;
  std::FILE* file_ = nullptr;
};

struct RunSummary {
  double sim_time = 0.0;   ///< [s]
  double wall_time = 0.0;  ///< [s]
  double real_time_factor = 0.0;
  Eigen::Vector3d start_position = Eigen::Vector3d::Zero();
  Eigen::Vector3d end_position = Eigen::Vector3d::Zero();
  double yaw_change = 0.0;       ///< [rad] end minus start, wrapped to (-pi, pi]
  double min_base_height = 0.0;  ///< [m] world z of the base centre
  double max_base_height = 0.0;
  double mean_forward_speed = 0.0;         ///< [m/s] mean base-frame x velocity
  double all_feet_contact_fraction = 0.0;  ///< share of steps with six wheels in contact
  int warnings = 0;                        ///< MuJoCo warnings during the run
};

/// Runs `duration` seconds from the plant's current state; logs every `log_every`
/// control periods if `log` is not null.
RunSummary runScenario(Plant& plant, Controller& controller, double duration, CsvLog* log = nullptr,
                       int log_every = 10);

/// Yaw [rad] of a base orientation (rotation about world z of the base x axis).
double yawOf(const Eigen::Quaterniond& q);

}  // namespace rollstep::sim
