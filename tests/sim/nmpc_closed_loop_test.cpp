// Closed-loop proof of the NMPC pipeline in MuJoCo (issue 12), deterministic mode unless
// said otherwise: no fall (body roll and pitch within 5 deg), every joint inside its
// limits, the commanded velocity tracked within 10 % on average. Label `closedloop`.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include "sim/nmpc_expect.hpp"
#include "sim/nmpc_run.hpp"

namespace rollstep::sim::test {
namespace {

TEST(NmpcClosedLoop, StandTenSeconds) {
  NmpcScenario sc;
  sc.gait = planning::GaitKind::Standing;
  sc.duration = 10.0;
  const NmpcOutcome o = runNmpc(sc);
  std::printf("stand: %s\n", describe(o).c_str());
  expectUpright(o);
  EXPECT_LT((o.end - o.start).head<2>().norm(), 0.02) << describe(o);
}

// Mean speed within 10 % of the command (or 0.02 m/s of a zero command).
void expectTracked(double measured, double commanded, const NmpcOutcome& o) {
  EXPECT_NEAR(measured, commanded, std::max(0.1 * std::abs(commanded), 0.02)) << describe(o);
}

TEST(NmpcClosedLoop, RollForwardAtHalfAMetrePerSecond) {
  NmpcScenario sc;
  sc.gait = planning::GaitKind::Rolling;
  sc.command.v_x = 0.5;
  sc.duration = 10.0;
  const NmpcOutcome o = runNmpc(sc);
  std::printf("roll 0.5 m/s: %s\n", describe(o).c_str());
  expectUpright(o);
  expectTracked(o.mean_forward_speed, 0.5, o);
  EXPECT_LT(std::abs(o.mean_lateral_speed), 0.02) << describe(o);
}

TEST(NmpcClosedLoop, TurnOnTheSpotWithTheWheels) {
  NmpcScenario sc;
  sc.gait = planning::GaitKind::Rolling;
  sc.command.yaw_rate = 0.3;
  sc.duration = 10.0;
  // Four drive wheels with fixed headings turn on the spot only by sliding sideways: the
  // behaviour's settings (the OCP's lateral slip cost, the skid-steer wheel commands).
  sc.settings = control::loadControlSettings(std::string(ROLLSTEP_TEST_DATA_DIR) +
                                             "/../../config/behaviours/turn_in_place.yaml");
  ASSERT_GT(sc.settings.ocp.lateral_slip_weight, 0.0);
  const NmpcOutcome o = runNmpc(sc);
  std::printf("turn 0.3 rad/s: %s\n", describe(o).c_str());
  expectUpright(o);
  expectTracked(o.mean_yaw_rate, 0.3, o);
  EXPECT_LT((o.end - o.start).head<2>().norm(), 0.1) << describe(o);
}

TEST(NmpcClosedLoop, TrotInPlaceTenSeconds) {
  NmpcScenario sc;
  sc.gait = planning::GaitKind::Trot;
  sc.duration = 10.0;
  const NmpcOutcome o = runNmpc(sc);
  std::printf("trot in place: %s\n", describe(o).c_str());
  expectUpright(o);
  expectTracked(o.mean_forward_speed, 0.0, o);
  EXPECT_LT((o.end - o.start).head<2>().norm(), 0.15) << describe(o);
}

TEST(NmpcClosedLoop, TrotForwardTwentySeconds) {
  NmpcScenario sc;
  sc.gait = planning::GaitKind::Trot;
  sc.command.v_x = 0.15;
  sc.duration = 20.0;
  const NmpcOutcome o = runNmpc(sc);
  std::printf("trot 0.15 m/s: %s\n", describe(o).c_str());
  expectUpright(o);
  expectTracked(o.mean_forward_speed, 0.15, o);
  EXPECT_GT(o.end.x() - o.start.x(), 0.8 * 0.15 * 20.0 * 0.9) << describe(o);
}

// The same trot with a real MPC thread on the wall clock: completes upright (not compared
// bit for bit: the solutions arrive when the thread finishes them).
TEST(NmpcClosedLoop, TrotForwardAsynchronous) {
  NmpcScenario sc;
  sc.gait = planning::GaitKind::Trot;
  sc.command.v_x = 0.15;
  sc.duration = 5.0;
  sc.settings.mpc.timing = control::MpcTiming::Asynchronous;
  const NmpcOutcome o = runNmpc(sc);
  std::printf("trot 0.15 m/s, asynchronous: %s\n", describe(o).c_str());
  expectUpright(o);
  EXPECT_GT(o.counters.solutions_received, 10u) << describe(o);
  EXPECT_GT(o.end.x() - o.start.x(), 0.3) << describe(o);
}

// Paper Fig. 8: with naive state feedback the joint position commands oscillate; the
// internal state integrator removes it. Measure: the RMS of the commands' second
// difference (per tick), on the same trot.
TEST(NmpcClosedLoop, InternalIntegratorSmoothsTheJointCommands) {
  NmpcScenario sc;
  sc.gait = planning::GaitKind::Trot;
  sc.command.v_x = 0.15;
  sc.duration = 5.0;
  const NmpcOutcome internal = runNmpc(sc);
  sc.settings.integrator.mode = control::IntegratorMode::Naive;
  const NmpcOutcome naive = runNmpc(sc);
  std::printf(
      "integrator: internal %.4g, naive %.4g (RMS second difference of the joint "
      "position commands per tick)\n  internal: %s\n  naive: %s\n",
      internal.command_rms_second_difference, naive.command_rms_second_difference,
      describe(internal).c_str(), describe(naive).c_str());
  RecordProperty("rms_second_difference_internal",
                 std::to_string(internal.command_rms_second_difference));
  RecordProperty("rms_second_difference_naive",
                 std::to_string(naive.command_rms_second_difference));
  expectUpright(internal);
  EXPECT_LT(internal.command_rms_second_difference, naive.command_rms_second_difference);
}

TEST(NmpcClosedLoop, DeterministicTrotRepeatsBitForBit) {
  NmpcScenario sc;
  sc.gait = planning::GaitKind::Trot;
  sc.command.v_x = 0.15;
  sc.duration = 2.0;
  const NmpcOutcome a = runNmpc(sc);
  const NmpcOutcome b = runNmpc(sc);
  ASSERT_EQ(a.log.size(), b.log.size());
  EXPECT_TRUE(a.log == b.log) << "two deterministic runs differ";
}

}  // namespace
}  // namespace rollstep::sim::test
