#pragma once
// Closed-loop runs of the NMPC pipeline in MuJoCo for the tests: the plant, the
// controller on ground truth, and the physical outcome of a run.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "rollstep/control/control_settings.hpp"
#include "rollstep/sim/estimator_source.hpp"
#include "rollstep/sim/nmpc_controller.hpp"
#include "rollstep/sim/plant.hpp"
#include "rollstep/sim/robot_folder.hpp"
#include "rollstep/sim/scenario.hpp"
#include "rollstep/sim/scene.hpp"
#include "rollstep/sim/scene_terrain.hpp"

namespace rollstep::sim::test {

inline std::string tachyon3Description() {
  return std::string(ROLLSTEP_ROBOTS_DIR) + "/tachyon3/centroidal.yaml";
}

struct NmpcScenario {
  /// A robot folder (name under robots/ or path); empty: Tachyon 3 with the plant's default
  /// options (the tests written for it).
  std::string robot;
  std::string scene = "flat";
  planning::GaitKind gait = planning::GaitKind::Standing;
  planning::BaseVelocityCommand command;
  /// A command schedule instead of `command` when not empty.
  std::vector<planning::TimedBaseCommand> schedule;
  double duration = 1.0;
  control::ControlSettings settings;
  /// Foothold regions are shrunk by the wheel radius + this clearance (as rollstep plan).
  double edge_clearance = 0.01;
  /// Sensor noise of the plant (unset: ideal readings) and the pipeline's state source.
  std::optional<SensorNoiseConfig> sensor_noise;
  StateSourceOptions source;
  /// Called on a copy of the readings before the controller sees them (fault injection).
  std::function<void(double t, SensorReadings& readings)> corrupt;
  /// Called once on the controller after its construction (fault injection).
  std::function<void(NmpcController& controller)> setup;
};

/// What happened in a run (measured, ground truth).
struct NmpcOutcome {
  solver::SolverStatus initial_status = solver::SolverStatus::InvalidInput;
  double max_roll_deg = 0.0, max_pitch_deg = 0.0;
  double min_base_height = 1e9, max_base_height = -1e9;
  double max_joint_limit_violation = 0.0;  ///< [rad or m] beyond the URDF limits
  double max_x = -1e9;                     ///< [m] furthest base x
  std::string worst_joint;
  double mean_forward_speed = 0.0;  ///< base frame, over the second half of the run
  double mean_lateral_speed = 0.0;
  double mean_yaw_rate = 0.0;  ///< over the second half [rad/s]
  Eigen::Vector3d start = Eigen::Vector3d::Zero(), end = Eigen::Vector3d::Zero();
  control::PipelineCounters counters;
  /// [s] the time the gait stood still at the steps' edges (the last plan's clock).
  double gait_held = 0.0;
  double mean_qp_correction = 0.0;
  double command_rms_second_difference = 0.0;  ///< joint position commands [rad or m]
  std::vector<double> log;  ///< every tick: time, base pose, joint commands, wheel commands
  int warnings = 0;
  long body_contact_periods = 0;  ///< control periods ending with a non-wheel contact
  double wall_time = 0.0;
  /// With the estimator: path length (horizontal, ground truth) and the estimate's error at
  /// the end (horizontal position, yaw), the largest errors over the run, its counters.
  double distance = 0.0;
  double estimate_position_error = 0.0, estimate_yaw_error_deg = 0.0;
  double max_estimate_position_error = 0.0, max_estimate_yaw_error_deg = 0.0;
  bool estimate_finite = true;
  estimation::EstimatorCounters estimator_counters;
};

/// Horizontal position and yaw [deg] errors of the estimator against ground truth.
inline void estimateErrors(const NmpcController& c, const GroundTruth& g, double& position,
                           double& yaw_deg) {
  const estimation::InvariantEkf& f = c.estimator()->filter();
  position = (f.position() - g.base_position).head<2>().norm();
  yaw_deg =
      std::abs(std::remainder(yawOf(f.orientation()) - yawOf(g.base_orientation), 2.0 * M_PI)) *
      180.0 / M_PI;
}

inline NmpcOutcome runNmpc(const NmpcScenario& sc) {
  SceneConfig scene = loadScene(sc.scene);
  const std::optional<RobotFolder> folder =
      sc.robot.empty() ? std::nullopt : std::optional<RobotFolder>(findRobotFolder(sc.robot));
  PlantOptions plant_options = folder ? plantOptionsFor(*folder) : PlantOptions{};
  plant_options.sensor_noise = sc.sensor_noise;
  Plant plant(scene, plant_options);
  const centroidal::RobotOcpDescription robot =
      centroidal::loadRobotOcpDescription(folder ? folder->description : tachyon3Description());
  const std::vector<planning::TimedBaseCommand> schedule =
      sc.schedule.empty() ? std::vector<planning::TimedBaseCommand>{{0.0, sc.command}}
                          : sc.schedule;
  NmpcController controller(plant, robot, sc.settings,
                            terrainFromScene(scene, robot.contact_offset + sc.edge_clearance),
                            sc.gait, schedule, sc.source);
  if (sc.setup) sc.setup(controller);
  NmpcOutcome out;
  SensorReadings readings;
  Eigen::Vector3d last_position = plant.groundTruth().base_position;
  out.initial_status = controller.initialStatus();
  const model::Model& m = controller.pipeline().robot().model();
  const GroundTruth& g = plant.groundTruth();
  out.start = g.base_position;
  PlantCommand command = plant.command();
  const long steps = std::lround(sc.duration / plant.controlPeriod());
  double fwd = 0.0, lat = 0.0, yaw_rate = 0.0, corr = 0.0;
  long half = 0;
  const int warnings0 = plant.warningCount();
  std::vector<JointVector> cmds;
  const auto wall0 = std::chrono::steady_clock::now();
  const bool paced = controller.paceToWallClock();
  for (long k = 0; k < steps; ++k) {
    if (paced) {
      std::this_thread::sleep_until(wall0 +
                                    std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                        std::chrono::duration<double>(k * plant.controlPeriod())));
    }
    readings = plant.sensors();
    if (sc.corrupt) sc.corrupt(plant.time(), readings);
    controller.compute(plant.time(), readings, command);
    if (controller.estimator() != nullptr) {
      // The estimate is of the readings' time: compare before stepping.
      double pe = 0.0, ye = 0.0;
      estimateErrors(controller, g, pe, ye);
      out.max_estimate_position_error = std::max(out.max_estimate_position_error, pe);
      out.max_estimate_yaw_error_deg = std::max(out.max_estimate_yaw_error_deg, ye);
      out.estimate_finite = out.estimate_finite && controller.estimator()->filter().finite();
    }
    plant.setCommand(command);
    plant.step();
    out.distance += (g.base_position - last_position).head<2>().norm();
    last_position = g.base_position;
    cmds.push_back(command.joint_position);
    out.log.push_back(plant.time());
    for (int i = 0; i < 3; ++i) out.log.push_back(g.base_position[i]);
    for (int i = 0; i < 4; ++i) out.log.push_back(g.base_orientation.coeffs()[i]);
    for (Eigen::Index j = 0; j < command.joint_position.size(); ++j) {
      out.log.push_back(command.joint_position[j]);
    }
    for (Eigen::Index w = 0; w < command.wheel_velocity.size(); ++w) {
      out.log.push_back(command.wheel_velocity[w]);
    }
    const Eigen::Matrix3d R = g.base_orientation.toRotationMatrix();
    const double roll = std::atan2(R(2, 1), R(2, 2));
    const double pitch = std::asin(std::clamp(-R(2, 0), -1.0, 1.0));
    out.max_roll_deg = std::max(out.max_roll_deg, std::abs(roll) * 180.0 / M_PI);
    out.max_pitch_deg = std::max(out.max_pitch_deg, std::abs(pitch) * 180.0 / M_PI);
    out.min_base_height = std::min(out.min_base_height, g.base_position.z());
    out.max_base_height = std::max(out.max_base_height, g.base_position.z());
    out.max_x = std::max(out.max_x, g.base_position.x());
    // Joint limits, measured (the controller's plant <-> model joint map).
    for (int j = 0; j < m.nj; ++j) {
      const double qj = g.joint_position[controller.jointMap()[static_cast<size_t>(j)]];
      const double v = std::max(m.lowerPositionLimit[j] - qj, qj - m.upperPositionLimit[j]);
      if (v > out.max_joint_limit_violation) {
        out.max_joint_limit_violation = v;
        out.worst_joint = m.jointNames[static_cast<size_t>(j)];
      }
    }
    if (k >= steps / 2) {
      const Eigen::Vector3d v_local = g.base_orientation.conjugate() * g.base_linear_velocity;
      fwd += v_local.x();
      lat += v_local.y();
      yaw_rate += (R * g.base_angular_velocity).z();
      ++half;
    }
    corr += controller.pipeline().lastTick().correction;
  }
  out.wall_time = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
  out.end = g.base_position;
  if (controller.estimator() != nullptr) {
    controller.compute(plant.time(), plant.sensors(), command);  // the last readings
    estimateErrors(controller, g, out.estimate_position_error, out.estimate_yaw_error_deg);
    out.estimator_counters = controller.estimator()->filter().counters();
  }
  if (half > 0) {
    out.mean_forward_speed = fwd / half;
    out.mean_lateral_speed = lat / half;
    out.mean_yaw_rate = yaw_rate / half;
  }
  out.mean_qp_correction = steps > 0 ? corr / steps : 0.0;
  out.counters = controller.pipeline().counters();
  out.gait_held = controller.pipeline().lastSolution().gait_clock.totalHeld();
  out.warnings = plant.warningCount() - warnings0;
  out.body_contact_periods = g.body_contact_periods;
  double sum = 0.0;
  long n = 0;
  for (size_t k = 2; k < cmds.size(); ++k) {
    sum += (cmds[k] - 2.0 * cmds[k - 1] + cmds[k - 2]).squaredNorm();
    n += cmds[k].size();
  }
  out.command_rms_second_difference = n > 0 ? std::sqrt(sum / n) : 0.0;
  return out;
}

inline std::string describe(const NmpcOutcome& o) {
  char text[700];
  std::snprintf(text, sizeof text,
                "initial solve %s; roll %.2f deg, pitch %.2f deg, base z [%.3f, %.3f] m, joint "
                "limit violation %.4f (%s); mean v_x %.3f m/s, v_y %.3f m/s, yaw rate %.3f rad/s; "
                "moved (%.3f, %.3f) m; solutions %llu (rejected %llu), QP fallbacks %llu, mean "
                "correction %.3g, cmd RMS 2nd diff %.3g; %d warnings; %.1f s wall",
                solver::toString(o.initial_status), o.max_roll_deg, o.max_pitch_deg,
                o.min_base_height, o.max_base_height, o.max_joint_limit_violation,
                o.worst_joint.c_str(), o.mean_forward_speed, o.mean_lateral_speed, o.mean_yaw_rate,
                o.end.x() - o.start.x(), o.end.y() - o.start.y(),
                static_cast<unsigned long long>(o.counters.solutions_received),
                static_cast<unsigned long long>(o.counters.solutions_rejected),
                static_cast<unsigned long long>(o.counters.qp_fallbacks), o.mean_qp_correction,
                o.command_rms_second_difference, o.warnings, o.wall_time);
  return text;
}

}  // namespace rollstep::sim::test
