// The CBF-QP baseline's 1 kHz pipeline (config/baseline.yaml) on each robot of robots/, on a
// flat floor, closed on an ideal plant (the measured state of each tick is the internal
// integrator's state after the last): standing holds the nominal posture; rolling follows
// the command on the robot's wheels with every joint command inside its limits; tick()
// allocates nothing. The closed loops on the simulated robot are in tests/sim.
#include "rollstep/control/baseline_pipeline.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "common/alloc_counter.hpp"
#include "rollstep/control/control_settings.hpp"
#include "rollstep/planning/terrain.hpp"

namespace rollstep::control {
namespace {

planning::TerrainModel flatFloor() {
  planning::TerrainBox floor;
  floor.x_min = -20.0;
  floor.x_max = 20.0;
  floor.y_min = -20.0;
  floor.y_max = 20.0;
  return planning::terrainFromBoxes(floor, 0.0, {});
}

struct IdealRun {
  double min_height = 1e9, max_height = -1e9;  ///< of the base [m]
  double max_joint_error = 0.0;                ///< |joint command - nominal|, the largest
  double joint_limit_excess = 0.0;             ///< the most a joint command left its limits by
  std::size_t allocations = 0;                 ///< in tick(), after the first second
  RobotState last;
  Eigen::VectorXd wheel_velocity;  ///< the last command's [rad/s]
};

/// Starts standing at the origin with `command` and runs `ticks` ticks of 1 ms.
IdealRun runIdeal(BaselinePipeline& pipeline, const centroidal::RobotOcpDescription& description,
                  double height, const planning::BaseVelocityCommand& command, int ticks) {
  const model::Model& model = pipeline.robot().model();
  RobotState state = pipeline.makeState();
  state.base_position.z() = height;
  state.joint_position = description.nominal_joint_positions;
  pipeline.initialize(state, command);
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
    EXPECT_TRUE(pipeline.lastTick().state_valid);
    for (int j = 0; j < model.nj; ++j) {
      const double q = out.joint_position[j];
      run.joint_limit_excess = std::max({run.joint_limit_excess, model.lowerPositionLimit[j] - q,
                                         q - model.upperPositionLimit[j]});
      run.max_joint_error =
          std::max(run.max_joint_error, std::abs(q - description.nominal_joint_positions[j]));
    }
    fromModelState(state.time + dt, pipeline.integrator().q(), pipeline.integrator().v(), state);
    run.min_height = std::min(run.min_height, state.base_position.z());
    run.max_height = std::max(run.max_height, state.base_position.z());
  }
  run.last = state;
  run.wheel_velocity = out.wheel_velocity;
  return run;
}

class BaselineOnEachRobot : public ::testing::TestWithParam<std::string> {
 protected:
  centroidal::RobotOcpDescription description = centroidal::loadRobotOcpDescription(
      std::string(ROLLSTEP_ROBOTS_DIR) + "/" + GetParam() + "/centroidal.yaml");
  ControlSettings settings =
      loadControlSettings(std::string(ROLLSTEP_CONFIG_DIR) + "/baseline.yaml");
  double height = centroidal::loadRobot(description).stance.height;
};

TEST_P(BaselineOnEachRobot, StandingHoldsTheNominalPosture) {
  BaselinePipeline pipeline(description, settings, flatFloor(), flatFloor(),
                            planning::GaitKind::Standing);
  const IdealRun run = runIdeal(pipeline, description, height, {}, 1500);
  EXPECT_NEAR(run.min_height, height, 0.01);
  EXPECT_NEAR(run.max_height, height, 0.01);
  EXPECT_LT(run.max_joint_error, 0.02);
  EXPECT_LE(run.joint_limit_excess, 0.0);
  EXPECT_LT(run.last.base_position.head<2>().norm(), 0.01);
  EXPECT_EQ(pipeline.counters().qp_fallbacks, 0u);
  EXPECT_EQ(run.allocations, 0u);
}

TEST_P(BaselineOnEachRobot, RollingFollowsTheCommandOnTheWheels) {
  BaselinePipeline pipeline(description, settings, flatFloor(), flatFloor(),
                            planning::GaitKind::Rolling);
  const IdealRun run = runIdeal(pipeline, description, height, {0.5, 0.0, 0.0}, 3000);
  // 3 s at 0.5 m/s (from rest: the base velocity is tracked with its gains).
  EXPECT_GT(run.last.base_position.x(), 0.8 * 1.5);
  EXPECT_LT(run.last.base_position.x(), 1.05 * 1.5);
  EXPECT_LT(std::abs(run.last.base_position.y()), 0.01);
  EXPECT_NEAR(run.min_height, height, 0.01);
  EXPECT_NEAR(run.max_height, height, 0.01);
  EXPECT_LE(run.joint_limit_excess, 0.0);
  EXPECT_EQ(pipeline.counters().qp_fallbacks, 0u);
  // Every drive wheel rolls forward at the base speed over the wheel radius.
  ASSERT_GT(run.wheel_velocity.size(), 0);
  for (Eigen::Index w = 0; w < run.wheel_velocity.size(); ++w) {
    EXPECT_NEAR(run.wheel_velocity[w], 0.5 / description.contact_offset,
                0.05 * 0.5 / description.contact_offset)
        << "wheel " << w;
  }
  EXPECT_EQ(run.allocations, 0u);
}

INSTANTIATE_TEST_SUITE_P(Robots, BaselineOnEachRobot, ::testing::Values("tachyon3", "wheelquad"));

}  // namespace
}  // namespace rollstep::control
