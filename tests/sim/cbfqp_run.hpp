#pragma once
// Closed-loop runs of the CBF-QP baseline (sim::CbfQpController, config/baseline.yaml) in
// MuJoCo for the tests: the physical outcome of a run and the paper's Table 1 metrics.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <memory>
#include <string>

#include "rollstep/control/control_settings.hpp"
#include "rollstep/sim/cbfqp_controller.hpp"
#include "rollstep/sim/online_perception.hpp"
#include "rollstep/sim/plant.hpp"
#include "rollstep/sim/scene.hpp"
#include "rollstep/sim/scene_terrain.hpp"

namespace rollstep::sim::test {

struct CbfQpScenario {
  std::string scene = "flat";
  planning::BaseVelocityCommand command;
  double duration = 10.0;
  /// The command drops to zero once the base is this far (x) [m]; +inf: never.
  double stop_at_x = 1e9;
  /// Perception in closed loop (OnlinePerception, default settings) instead of the scene's
  /// ground-truth terrain.
  bool perception = false;
  OnlinePerceptionOptions perception_options;  ///< with perception: the sensor, the map...
  /// Called after every simulation step (e.g. to look at the perceived map on the way).
  std::function<void(const Plant&, const CbfQpController&)> observe;
};

struct CbfQpOutcome {
  double max_roll_deg = 0.0, max_pitch_deg = 0.0;
  double min_body_clearance = 1e9;  ///< [m] lowest body-box corner above the terrain under it
  double max_joint_limit_violation = 0.0;
  std::string worst_joint;
  double max_mf_wheel_z = 0.0;      ///< [m] highest MF wheel centre while in contact
  double mean_forward_speed = 0.0;  ///< over the whole run
  double stop_time = -1.0;          ///< when the command dropped to zero
  double drift_after_stop = 0.0;    ///< [m] planar base displacement over the last 2 s
  Eigen::Vector3d end = Eigen::Vector3d::Zero();
  control::PipelineCounters counters;
  int warnings = 0;
  double wall_time = 0.0;
  // The paper's Table 1 (step scenes): from the lift-off of MF's climbing swing to the
  // touch-down of MR's descending swing; means of |v_z| and |w_y| in the base frame.
  double traverse_start = -1.0, traverse_end = -1.0;
  double mean_abs_vz = 0.0, mean_abs_wy = 0.0;
};

inline std::string baselineConfig() {
  return std::string(ROLLSTEP_SOURCE_DIR) + "/config/baseline.yaml";
}

inline CbfQpOutcome runCbfQp(const CbfQpScenario& sc) {
  SceneConfig scene = loadScene(sc.scene);
  Plant plant(scene);
  const centroidal::RobotOcpDescription robot = centroidal::loadRobotOcpDescription(
      std::string(ROLLSTEP_ROBOTS_DIR) + "/tachyon3/centroidal.yaml");
  const control::ControlSettings settings = control::loadControlSettings(baselineConfig());
  std::unique_ptr<OnlinePerception> perception;
  if (sc.perception) {
    perception = std::make_unique<OnlinePerception>(sc.perception_options);
    perception->start(plant, plant.groundTruth().base_position,
                      plant.groundTruth().base_orientation);
  }
  CbfQpController controller(
      plant, robot, settings,
      perception ? perception->footholdTerrain(settings.baseline.foothold_margin)
                 : terrainFromScene(scene, settings.baseline.foothold_margin),
      perception ? perception->terrain() : terrainFromScene(scene, 0.0), planning::GaitKind::Trot,
      sc.command, perception ? perception->perception().settings().regions.directions : 0,
      perception ? perception->perception().settings().closed_loop.collision_capacity : 0);
  if (perception) controller.setPerception(std::move(perception));
  const planning::TerrainModel solids = terrainFromScene(scene, 0.0);
  const model::Model& m = controller.pipeline().robot().model();
  const GroundTruth& g = plant.groundTruth();
  CbfQpOutcome out;
  PlantCommand command = plant.command();
  const long steps = std::lround(sc.duration / plant.controlPeriod());
  const int warnings0 = plant.warningCount();
  constexpr int kMF = 1, kMR = 4;  // plant leg order LF MF RF LR MR RR
  bool mf_in_contact = true, mr_was_on_top = false;
  double mf_liftoff = -1.0, fwd = 0.0;
  Eigen::Vector2d before_end = Eigen::Vector2d::Zero();
  const auto wall0 = std::chrono::steady_clock::now();
  // Table 1 window: base-frame velocities every tick, summed when the window is known.
  std::vector<double> times, vz, wy;
  times.reserve(static_cast<size_t>(steps));
  vz.reserve(static_cast<size_t>(steps));
  wy.reserve(static_cast<size_t>(steps));
  for (long k = 0; k < steps; ++k) {
    if (out.stop_time < 0.0 && g.base_position.x() >= sc.stop_at_x) {
      out.stop_time = plant.time();
      controller.pipeline().setCommand({});
    }
    controller.compute(plant.time(), plant.sensors(), command);
    plant.setCommand(command);
    plant.step();
    if (sc.observe) sc.observe(plant, controller);
    const double t = plant.time();
    const Eigen::Matrix3d R = g.base_orientation.toRotationMatrix();
    const double roll = std::atan2(R(2, 1), R(2, 2));
    const double pitch = std::asin(std::clamp(-R(2, 0), -1.0, 1.0));
    out.max_roll_deg = std::max(out.max_roll_deg, std::abs(roll) * 180.0 / M_PI);
    out.max_pitch_deg = std::max(out.max_pitch_deg, std::abs(pitch) * 180.0 / M_PI);
    // The body box (robot/tachyon3.md: 0.90 x 0.50 x 0.16 m about the base centre).
    for (const double sx : {-0.45, 0.45}) {
      for (const double sy : {-0.25, 0.25}) {
        const Eigen::Vector3d c = g.base_position + R * Eigen::Vector3d(sx, sy, -0.08);
        out.min_body_clearance =
            std::min(out.min_body_clearance, c.z() - solids.heightAt(c.head<2>(), 0.0));
      }
    }
    for (int j = 0; j < m.nj; ++j) {
      const double qj = g.joint_position[controller.jointMap()[static_cast<size_t>(j)]];
      const double v = std::max(m.lowerPositionLimit[j] - qj, qj - m.upperPositionLimit[j]);
      if (v > out.max_joint_limit_violation) {
        out.max_joint_limit_violation = v;
        out.worst_joint = m.jointNames[static_cast<size_t>(j)];
      }
    }
    const Eigen::Vector3d v_local = g.base_orientation.conjugate() * g.base_linear_velocity;
    fwd += v_local.x();
    times.push_back(t);
    vz.push_back(std::abs(v_local.z()));
    wy.push_back(std::abs(g.base_angular_velocity.y()));
    if (k == steps - 2000) before_end = g.base_position.head<2>();
    // Table 1 events from the ground-truth contacts and wheel heights.
    const bool mf = g.foot_contact[kMF];
    const double mf_z = g.wheel_center[kMF].z(), mr_z = g.wheel_center[kMR].z();
    if (mf) out.max_mf_wheel_z = std::max(out.max_mf_wheel_z, mf_z);
    if (mf_in_contact && !mf) mf_liftoff = t;
    if (!mf_in_contact && mf && mf_z > 0.25 && out.traverse_start < 0.0) {
      out.traverse_start = mf_liftoff;  // the swing that put MF on the block
    }
    mf_in_contact = mf;
    if (g.foot_contact[kMR] && mr_z > 0.25) mr_was_on_top = true;
    if (mr_was_on_top && g.foot_contact[kMR] && mr_z < 0.1 && out.traverse_end < 0.0) {
      out.traverse_end = t;
    }
  }
  out.wall_time = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
  out.end = g.base_position;
  out.mean_forward_speed = steps > 0 ? fwd / steps : 0.0;
  out.drift_after_stop = (g.base_position.head<2>() - before_end).norm();
  out.counters = controller.pipeline().counters();
  out.warnings = plant.warningCount() - warnings0;
  if (out.traverse_start >= 0.0 && out.traverse_end > out.traverse_start) {
    double svz = 0.0, swy = 0.0;
    long n = 0;
    for (size_t k = 0; k < times.size(); ++k) {
      if (times[k] < out.traverse_start || times[k] > out.traverse_end) continue;
      svz += vz[k];
      swy += wy[k];
      ++n;
    }
    out.mean_abs_vz = svz / n;
    out.mean_abs_wy = swy / n;
  }
  return out;
}

inline std::string describe(const CbfQpOutcome& o) {
  char text[800];
  std::snprintf(
      text, sizeof text,
      "roll %.2f deg, pitch %.2f deg, body clearance %.3f m, joint limit violation "
      "%.4f (%s), MF wheel up to %.3f m, mean v_x %.3f m/s, end (%.3f, %.3f, %.3f), "
      "stopped at %.2f s (moved %.3f m in the last 2 s), %llu QP fallbacks in %llu ticks, "
      "%d MuJoCo warnings, %.1f s wall; Table 1: traverse %.2f s (%.2f -> %.2f s), "
      "mean |v_z| %.4f m/s, mean |w_y| %.4f rad/s (paper's CBF-QP: 18 s, 0.055, 0.065)",
      o.max_roll_deg, o.max_pitch_deg, o.min_body_clearance, o.max_joint_limit_violation,
      o.worst_joint.c_str(), o.max_mf_wheel_z, o.mean_forward_speed, o.end.x(), o.end.y(),
      o.end.z(), o.stop_time, o.drift_after_stop,
      static_cast<unsigned long long>(o.counters.qp_fallbacks),
      static_cast<unsigned long long>(o.counters.ticks), o.warnings, o.wall_time,
      o.traverse_end - o.traverse_start, o.traverse_start, o.traverse_end, o.mean_abs_vz,
      o.mean_abs_wy);
  return text;
}

}  // namespace rollstep::sim::test
