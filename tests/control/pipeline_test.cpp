// The 1 kHz control pipeline on a flat floor, closed on an ideal plant (the robot does what
// it is commanded: the measured state of each tick is the internal integrator's state after
// the last). Tachyon 3: standing settles at the nominal posture; trotting, the contact modes
// are the contact planner's gait and every joint command stays inside its limits (the ideal
// plant has no ground to hold the body: its height drifts, which makes it a test of the
// safety filter too). wheelquad (a wheeled quadruped): standing, rolling at 1 m/s, and the
// trot at 0.3 m/s with the library's default control settings.
// tick() allocates nothing. The closed loops on the simulated robot are in tests/sim.
#include "rollstep/control/pipeline.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "common/alloc_counter.hpp"
#include "rollstep/control/control_settings.hpp"
#include "rollstep/planning/terrain.hpp"

namespace rollstep::control {
namespace {

const centroidal::RobotOcpDescription& tachyon3() {
  static const centroidal::RobotOcpDescription d = centroidal::loadRobotOcpDescription(
      std::string(ROLLSTEP_ROBOTS_DIR) + "/tachyon3/centroidal.yaml");
  return d;
}

/// The second robot: a wheeled quadruped, three revolute joints per leg, four drive wheels.
const centroidal::RobotOcpDescription& wheelquad() {
  static const centroidal::RobotOcpDescription d = centroidal::loadRobotOcpDescription(
      std::string(ROLLSTEP_ROBOTS_DIR) + "/wheelquad/centroidal.yaml");
  return d;
}

planning::TerrainModel flatFloor() {
  planning::TerrainBox floor;
  floor.x_min = -20.0;
  floor.x_max = 20.0;
  floor.y_min = -20.0;
  floor.y_max = 20.0;
  return planning::terrainFromBoxes(floor, 0.0, {});
}

/// Default settings with a shorter horizon (0.6 s: enough for a 0.8 s trot's swings).
ControlSettings settings() {
  ControlSettings s;
  s.ocp.horizon = 40;
  return s;
}

/// What a closed run on the ideal plant saw.
struct IdealRun {
  double min_height = 1e9, max_height = -1e9;  ///< of the base [m]
  double height_before_end = 0.0;              ///< 0.5 s before the end [m]
  double max_joint_error = 0.0;     ///< |joint command - nominal| [rad or m], the largest
  double joint_limit_excess = 0.0;  ///< the most a joint command left its limits by
  int mode_mismatches = 0;          ///< ticks whose mode is not the gait's at t
  std::size_t allocations = 0;      ///< in tick(), after the first second
  RobotState last;
};

/// Starts standing at the origin with `command` and runs `ticks` ticks of 1 ms, feeding
/// the internal integrator's state back as the measurement.
IdealRun runIdeal(ControlPipeline& pipeline, const planning::BaseVelocityCommand& command,
                  int ticks) {
  const centroidal::LoadedRobot& loaded = pipeline.loadedRobot();
  const model::Model& model = loaded.robot->model();
  const Eigen::VectorXd& nominal = loaded.description.nominal_joint_positions;
  RobotState state = pipeline.makeState();
  state.base_position.z() = pipeline.contactPlanner().stance().height;
  state.joint_position = nominal;
  EXPECT_EQ(pipeline.initialize(state, command), solver::SolverStatus::Converged);
  JointCommand out = pipeline.makeCommand();
  IdealRun run;
  const double dt = pipeline.settings().control_period;
  for (int k = 0; k < ticks; ++k) {
    state.time = k * dt;
    if (k == 1000) {
      test::AllocationGuard guard;
      pipeline.tick(state, out);
      run.allocations += guard.count();
    } else {
      pipeline.tick(state, out);
    }
    const TickRecord& r = pipeline.lastTick();
    EXPECT_TRUE(r.state_valid);
    // (at a switch, either side's mode: the gait's and the schedule's rounding differ)
    const planning::Gait& gait = pipeline.contactPlanner().gait();
    if (r.mode != gait.modeAt(state.time - 1e-9) && r.mode != gait.modeAt(state.time + 1e-9)) {
      ++run.mode_mismatches;
    }
    for (int j = 0; j < model.nj; ++j) {
      const double q = out.joint_position[j];
      run.joint_limit_excess = std::max({run.joint_limit_excess, model.lowerPositionLimit[j] - q,
                                         q - model.upperPositionLimit[j]});
      run.max_joint_error = std::max(run.max_joint_error, std::abs(q - nominal[j]));
    }
    fromModelState(state.time + dt, pipeline.integrator().q(), pipeline.integrator().v(), state);
    run.min_height = std::min(run.min_height, state.base_position.z());
    run.max_height = std::max(run.max_height, state.base_position.z());
    if (k == ticks - 500) run.height_before_end = state.base_position.z();
  }
  run.last = state;
  return run;
}

TEST(ControlPipeline, StandingOnAnIdealPlantHoldsTheNominalPosture) {
  ControlPipeline pipeline(tachyon3(), settings(), flatFloor(), planning::GaitKind::Standing);
  const double nominal = pipeline.contactPlanner().stance().height;
  const IdealRun run = runIdeal(pipeline, planning::BaseVelocityCommand{}, 1500);
  EXPECT_NEAR(run.min_height, nominal, 0.015);
  EXPECT_NEAR(run.max_height, nominal, 0.015);
  // Settled: the last half second moves the body by less than a millimetre.
  EXPECT_NEAR(run.last.base_position.z(), run.height_before_end, 1e-3);
  EXPECT_LT(run.max_joint_error, 0.02);
  EXPECT_LE(run.joint_limit_excess, 0.0);
  EXPECT_EQ(run.mode_mismatches, 0);
  EXPECT_LT(run.last.base_position.head<2>().norm(), 0.01);
  EXPECT_EQ(pipeline.counters().qp_fallbacks, 0u);
  EXPECT_EQ(pipeline.counters().solutions_rejected, 0u);
  EXPECT_EQ(run.allocations, 0u);
}

TEST(ControlPipeline, TrottingKeepsTheGaitsModesAndEveryJointInsideItsLimits) {
  ControlPipeline pipeline(tachyon3(), settings(), flatFloor(), planning::GaitKind::Trot);
  const IdealRun run = runIdeal(pipeline, planning::BaseVelocityCommand{0.15, 0.0, 0.0}, 3000);
  // The 1 kHz side's contact modes are the gait's (no holds or late feet on the flat).
  EXPECT_EQ(run.mode_mismatches, 0);
  EXPECT_LE(run.joint_limit_excess, 0.0);
  EXPECT_GT(run.max_joint_error, 0.1);  // the legs did swing
  EXPECT_GT(run.last.base_position.x(), 0.2);
  EXPECT_EQ(pipeline.counters().qp_fallbacks, 0u);
  EXPECT_EQ(pipeline.counters().solutions_rejected, 0u);
  EXPECT_EQ(pipeline.counters().watchdog_trips, 0u);
  EXPECT_EQ(run.allocations, 0u);
}

TEST(ControlPipeline, WheelquadStandingHoldsTheNominalPosture) {
  ControlPipeline pipeline(wheelquad(), settings(), flatFloor(), planning::GaitKind::Standing);
  const double nominal = pipeline.contactPlanner().stance().height;
  const IdealRun run = runIdeal(pipeline, planning::BaseVelocityCommand{}, 1500);
  EXPECT_NEAR(run.min_height, nominal, 0.015);
  EXPECT_NEAR(run.max_height, nominal, 0.015);
  EXPECT_NEAR(run.last.base_position.z(), run.height_before_end, 1e-3);
  EXPECT_LT(run.max_joint_error, 0.03);
  EXPECT_LE(run.joint_limit_excess, 0.0);
  EXPECT_EQ(run.mode_mismatches, 0);
  EXPECT_LT(run.last.base_position.head<2>().norm(), 0.01);
  EXPECT_EQ(pipeline.counters().qp_fallbacks, 0u);
  EXPECT_EQ(pipeline.counters().solutions_rejected, 0u);
  EXPECT_EQ(run.allocations, 0u);
}

TEST(ControlPipeline, WheelquadRollsAtOneMetrePerSecond) {
  ControlPipeline pipeline(wheelquad(), settings(), flatFloor(), planning::GaitKind::Rolling);
  const double nominal = pipeline.contactPlanner().stance().height;
  const IdealRun run = runIdeal(pipeline, planning::BaseVelocityCommand{1.0, 0.0, 0.0}, 3000);
  EXPECT_EQ(run.mode_mismatches, 0);
  EXPECT_LE(run.joint_limit_excess, 0.0);
  EXPECT_NEAR(run.min_height, nominal, 0.015);
  EXPECT_NEAR(run.max_height, nominal, 0.015);
  // 3 s at 1 m/s, the reference ramped up from rest at the command acceleration (the speed
  // rule's ramp) or, without it, starting at the command's speed (the robot then runs a
  // little faster for a while to catch up with it).
  const double ramp = settings().ocp.speed_adaptation
                          ? 1.0 * 1.0 / (2.0 * settings().ocp.command_acceleration)
                          : 0.0;
  EXPECT_GT(run.last.base_position.x(), 3.0 - ramp - 0.3);
  EXPECT_LT(run.last.base_position.x(), 3.0 - ramp + 0.2);
  EXPECT_NEAR(run.last.base_linear_velocity.x(), 1.0, 0.1);
  EXPECT_LT(std::abs(run.last.base_position.y()), 0.02);
  EXPECT_EQ(pipeline.counters().qp_fallbacks, 0u);
  EXPECT_EQ(pipeline.counters().solutions_rejected, 0u);
  EXPECT_EQ(run.allocations, 0u);
}

TEST(ControlPipeline, WheelquadTrotsOnItsDiagonalsWithTheNmpcSettings) {
  // The library's defaults (what `rollstep sim --controller nmpc` runs: the speed rule's trot
  // timing, late touch-downs landing first, two Newton iterations per update, the weights
  // that damp bobbing and pitching, ...). With the earlier defaults (a 0.6 s horizon, one
  // iteration, fixed trot timing, no late touch-downs) the diagonal trot did not stay bounded
  // on this plant: near the ground the clearance barrier held each swing back, it touched
  // down about 1.5 cm in the air, and the body oscillated more with every step; none of the
  // climbing keys alone (late touch-downs, the speed rule, two iterations with 20 ms latency,
  // the weights) was enough.
  const ControlSettings s;
  ControlPipeline pipeline(wheelquad(), s, flatFloor(), planning::GaitKind::Trot);
  const double nominal = pipeline.contactPlanner().stance().height;
  const IdealRun run = runIdeal(pipeline, planning::BaseVelocityCommand{0.3, 0.0, 0.0}, 4000);
  EXPECT_EQ(run.mode_mismatches, 0);
  EXPECT_LE(run.joint_limit_excess, 0.0);
  EXPECT_GT(run.max_joint_error, 0.1);  // the legs did swing
  EXPECT_NEAR(run.min_height, nominal, 0.02);
  EXPECT_NEAR(run.max_height, nominal, 0.02);
  // 4 s at 0.3 m/s, ramped up from rest at the command acceleration.
  EXPECT_GT(run.last.base_position.x(), 0.8 * 0.3 * 4.0);
  EXPECT_LT(run.last.base_position.x(), 1.05 * 0.3 * 4.0);
  EXPECT_LT(std::abs(run.last.base_position.y()), 0.02);
  EXPECT_EQ(pipeline.counters().qp_fallbacks, 0u);
  EXPECT_EQ(pipeline.counters().solutions_rejected, 0u);
  EXPECT_EQ(pipeline.counters().watchdog_trips, 0u);
  EXPECT_EQ(run.allocations, 0u);
}

}  // namespace
}  // namespace rollstep::control
