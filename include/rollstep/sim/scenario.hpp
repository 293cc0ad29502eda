#pragma once
// Closed-loop runs of the plant with a controller, with an optional CSV log.
#include <functional>
#include <string>

#include "rollstep/common/text_file.hpp"
#include "rollstep/sim/plant.hpp"
#include "rollstep/sim/simple_controllers.hpp"

namespace rollstep::sim {

/// CSV log of a run, one row per logged control period. Every column name carries its
/// unit in brackets (csvHeader()):
///   time[s], base_x/y/z[m] (world), base_qw/qx/qy/qz[-] (base->world), base_vx/vy/vz[m/s]
///   (world), base_wx/wy/wz[rad/s] (base frame), q_<joint> (every plant joint, plant order:
///   revolute [rad], prismatic [m]), cmd_<joint> (same), wheel_vel_<leg>[rad/s] and
///   cmd_wheel_<leg>[rad/s] (the drive wheels), contact_<leg>[0/1] (ground truth) and
///   fz_<leg>[N] (world vertical force) for every leg, foot_z_<leg>[m] (wheel centre height,
///   world) for every leg, fx_<leg>[N] then fy_<leg>[N] (the horizontal components of the
///   wheel's contact force, world frame) for every leg, contact_point_x_<leg>[m],
///   contact_point_y_<leg>[m], contact_point_z_<leg>[m] (GroundTruth::contact_point, world) for
///   every leg, body_contact_periods[-] (GroundTruth::body_contact_periods).
///   Joint and leg names are the plant layout's (PlantLayout).
/// The file appears complete or not at all: rows go to a temporary file beside it
/// (AtomicFileWriter), every write is checked, and commit() renames it to `path`.
/// Without commit() (an exception left the run) the temporary is removed.
class CsvLog {
 public:
  /// Creates the temporary file and writes the header (csvHeader(layout) then
  /// `extra_columns`, a controller's Controller::logColumns()); throws OutputError naming the
  /// path and the reason on failure.
  CsvLog(const std::string& path, const PlantLayout& layout, const std::string& extra_columns = "");
  CsvLog(const CsvLog&) = delete;
  CsvLog& operator=(const CsvLog&) = delete;
  /// Appends a row (`extra`: the controller's Controller::logValues()); throws OutputError
  /// if writing fails (a full disk).
  void write(const GroundTruth& truth, const PlantCommand& command, const std::string& extra = "");
  /// Flushes, syncs and renames the file into place; throws OutputError on failure.
  void commit() { file_.commit(); }
  const std::string& path() const { return file_.path(); }

 private:
  AtomicFileWriter file_;
};

/// The header line of CsvLog (column names with units, comma-separated, no newline).
std::string csvHeader(const PlantLayout& layout);

struct RunSummary {
  double sim_time = 0.0;   ///< [s]
  double wall_time = 0.0;  ///< [s]
  double real_time_factor = 0.0;
  Eigen::Vector3d start_position = Eigen::Vector3d::Zero();
  Eigen::Vector3d end_position = Eigen::Vector3d::Zero();
  /// [rad] total rotation about world z from start to end, unwrapped (the sum of the
  /// yaw increments of every control period: two turns in place read 4 pi, not 0).
  double yaw_change = 0.0;
  double min_base_height = 0.0;  ///< [m] world z of the base centre
  double max_base_height = 0.0;
  double mean_forward_speed = 0.0;         ///< [m/s] mean base-frame x velocity
  double all_feet_contact_fraction = 0.0;  ///< share of steps with every wheel in contact
  int warnings = 0;                        ///< MuJoCo warnings during the run
};

/// Progress of a run, reported about once per second of wall time.
struct Progress {
  double sim_time = 0.0;   ///< [s] simulated so far
  double duration = 0.0;   ///< [s] of the whole run
  double wall_time = 0.0;  ///< [s] so far
};
using ProgressCallback = std::function<void(const Progress&)>;

/// Runs `duration` seconds from the plant's current state; logs every `log_every`
/// control periods if `log` is not null (the caller commits the log), with the
/// controller's extra columns; calls `progress` (if set) about once per wall second; runs in
/// step with the wall clock if the controller asks for it (Controller::paceToWallClock). Throws
/// std::invalid_argument if duration is not finite, negative or more than 1e6 s, or
/// log_every < 1; SimError if the simulation diverges; OutputError if the log cannot
/// be written; Interrupted (rollstep/common/interrupt.hpp) at the next control period after
/// a deferred SIGINT, SIGTERM or SIGHUP.
RunSummary runScenario(Plant& plant, Controller& controller, double duration, CsvLog* log = nullptr,
                       int log_every = 10, const ProgressCallback& progress = {});

/// Yaw [rad] of a base orientation (rotation about world z of the base x axis).
double yawOf(const Eigen::Quaterniond& q);

}  // namespace rollstep::sim
