// Closed-loop NMPC runs of issue 14's scenarios (deterministic mode, MuJoCo), label
// `closedloop`: the base velocity command schedule (there and back on flat) and the body
// rising ahead of the step20 block with config/behaviours/climb.yaml.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>

#include "sim/nmpc_run.hpp"

namespace rollstep::sim::test {
namespace {

void expectUpright(const NmpcOutcome& o, double max_tilt_deg = 5.0) {
  EXPECT_TRUE(o.initial_status == solver::SolverStatus::Converged ||
              o.initial_status == solver::SolverStatus::Acceptable)
      << describe(o);
  EXPECT_LT(o.max_roll_deg, max_tilt_deg) << describe(o);
  EXPECT_LT(o.max_pitch_deg, max_tilt_deg) << describe(o);
  EXPECT_GT(o.min_base_height, 0.25) << describe(o);
  EXPECT_LT(o.max_joint_limit_violation, 1e-3) << describe(o);
  EXPECT_EQ(o.counters.invalid_states, 0u);
  EXPECT_EQ(o.warnings, 0) << describe(o);
}

TEST(NmpcSchedule, TrotThereAndBack) {
  // 0.15 m/s forward for 4 s, then 0.15 m/s backwards for 4 s: the base reference chains
  // the two segments, so the robot turns back 0.6 m ahead and ends where it started.
  NmpcScenario sc;
  sc.gait = planning::GaitKind::Trot;
  sc.schedule = {{0.0, {0.15, 0.0, 0.0}}, {4.0, {-0.15, 0.0, 0.0}}};
  sc.duration = 8.0;
  const NmpcOutcome o = runNmpc(sc);
  std::printf("there and back: furthest x %.3f m, end x %.3f m (%s)\n", o.max_x, o.end.x(),
              describe(o).c_str());
  expectUpright(o);
  EXPECT_NEAR(o.max_x - o.start.x(), 0.6, 0.1) << describe(o);
  EXPECT_NEAR(o.end.x() - o.start.x(), 0.0, 0.1) << describe(o);
  EXPECT_LT(o.mean_forward_speed, -0.1) << describe(o);  // second half: backwards
}

TEST(NmpcStep20, BodyRisesBeforeTheBlock) {
  // config/behaviours/climb.yaml: the body height reference takes the block (0.2 m) within
  // base_height_reach of a nominal foot, with a ramp before; the body must be up by 0.1 m
  // and more before the front wheels (0.33 m ahead of the base) reach the block's face at
  // x = 1.0. Without these rules it sank 3 cm there (issue 14).
  NmpcScenario sc;
  sc.scene = SceneKind::kStep20;
  sc.gait = planning::GaitKind::Trot;
  sc.command = {0.15, 0.0, 0.0};
  sc.duration = 3.0;
  sc.settings = control::loadControlSettings(std::string(ROLLSTEP_SOURCE_DIR) +
                                             "/config/behaviours/climb.yaml");
  const NmpcOutcome o = runNmpc(sc);
  std::printf("step20 approach: base x %.3f m, height %.3f m at the end, max %.3f m (%s)\n",
              o.end.x(), o.end.z(), o.max_base_height, describe(o).c_str());
  expectUpright(o, 6.0);  // the body pitches up to 4.4 deg while it rises
  EXPECT_LT(o.max_x + 0.33 + 0.075, 1.0) << "a front wheel reached the block's face";
  EXPECT_GT(o.end.z() - o.start.z(), 0.1) << describe(o);
}

}  // namespace
}  // namespace rollstep::sim::test
