// The NMPC pipeline in closed loop on the state estimator (issue 13): the plant's sensors
// with their noise model (robots/tachyon3/sensors.yaml defaults), the invariant EKF
// (robots/tachyon3/estimation.yaml, with the scene's terrain heights as its map) as the
// state source. The trot and roll scenarios of the
// pipeline's proof pass, and the estimate's drift against ground truth stays small:
// trotting under 5 % of the distance travelled and 3 deg of yaw, rolling at 0.5 m/s under
// 2 % and 2 deg. The ctest forms run 20 s; the 60 s forms of the issue are the DISABLED_
// tests (run them with --gtest_also_run_disabled_tests; figures in docs/PERFORMANCE.md).
// Label `closedloop`.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>

#include "sim/nmpc_run.hpp"

namespace rollstep::sim::test {
namespace {

NmpcScenario withEstimator(planning::GaitKind gait, double v_x, double duration) {
  NmpcScenario sc;
  sc.gait = gait;
  sc.command.v_x = v_x;
  sc.duration = duration;
  sc.sensor_noise = loadSensorNoiseConfig(std::string(ROLLSTEP_TEST_DATA_DIR) +
                                          "/../../robots/tachyon3/sensors.yaml");
  sc.source.kind = StateSourceKind::Inekf;
  sc.source.estimator =
      estimation::loadInekfSettings(std::string(ROLLSTEP_ROBOTS_DIR) + "/tachyon3/estimation.yaml");
  return sc;
}

std::string drift(const NmpcOutcome& o) {
  char text[400];
  std::snprintf(
      text, sizeof text,
      "estimator: distance %.2f m, final error %.3f m (%.2f %%), yaw %.2f deg; largest "
      "%.3f m, %.2f deg; contacts used %llu, rejected %llu; %s",
      o.distance, o.estimate_position_error,
      100.0 * o.estimate_position_error / std::max(o.distance, 1e-9), o.estimate_yaw_error_deg,
      o.max_estimate_position_error, o.max_estimate_yaw_error_deg,
      static_cast<unsigned long long>(o.estimator_counters.contacts_used),
      static_cast<unsigned long long>(o.estimator_counters.contacts_rejected), describe(o).c_str());
  return text;
}

void expectUprightAndTracked(const NmpcOutcome& o, double v_x) {
  EXPECT_TRUE(o.initial_status == solver::SolverStatus::Converged ||
              o.initial_status == solver::SolverStatus::Acceptable)
      << drift(o);
  EXPECT_LT(o.max_roll_deg, 5.0) << drift(o);
  EXPECT_LT(o.max_pitch_deg, 5.0) << drift(o);
  EXPECT_GT(o.min_base_height, 0.25) << drift(o);
  EXPECT_LT(o.max_joint_limit_violation, 1e-3) << drift(o);
  EXPECT_EQ(o.counters.invalid_states, 0u) << drift(o);
  EXPECT_EQ(o.warnings, 0) << drift(o);
  EXPECT_TRUE(o.estimate_finite);
  EXPECT_NEAR(o.mean_forward_speed, v_x, std::max(0.1 * v_x, 0.02)) << drift(o);
}

void trot(double duration) {
  const NmpcOutcome o = runNmpc(withEstimator(planning::GaitKind::Trot, 0.15, duration));
  std::printf("trot 0.15 m/s on the estimator, %.0f s: %s\n", duration, drift(o).c_str());
  ::testing::Test::RecordProperty("drift_percent",
                                  std::to_string(100.0 * o.estimate_position_error / o.distance));
  ::testing::Test::RecordProperty("yaw_error_deg", std::to_string(o.estimate_yaw_error_deg));
  expectUprightAndTracked(o, 0.15);
  EXPECT_GT(o.distance, 0.8 * 0.15 * duration) << drift(o);
  EXPECT_LT(o.estimate_position_error, 0.05 * o.distance) << drift(o);
  EXPECT_LT(o.estimate_yaw_error_deg, 3.0) << drift(o);
}

void roll(double duration) {
  const NmpcOutcome o = runNmpc(withEstimator(planning::GaitKind::Rolling, 0.5, duration));
  std::printf("roll 0.5 m/s on the estimator, %.0f s: %s\n", duration, drift(o).c_str());
  ::testing::Test::RecordProperty("drift_percent",
                                  std::to_string(100.0 * o.estimate_position_error / o.distance));
  ::testing::Test::RecordProperty("yaw_error_deg", std::to_string(o.estimate_yaw_error_deg));
  expectUprightAndTracked(o, 0.5);
  EXPECT_GT(o.distance, 0.8 * 0.5 * duration) << drift(o);
  EXPECT_LT(o.estimate_position_error, 0.02 * o.distance) << drift(o);
  EXPECT_LT(o.estimate_yaw_error_deg, 2.0) << drift(o);
}

TEST(NmpcEstimatorClosedLoop, TrotForwardTwentySeconds) { trot(20.0); }
TEST(NmpcEstimatorClosedLoop, RollForwardTwentySeconds) { roll(20.0); }
TEST(NmpcEstimatorClosedLoop, DISABLED_TrotForwardSixtySeconds) { trot(60.0); }
TEST(NmpcEstimatorClosedLoop, DISABLED_RollForwardSixtySeconds) { roll(60.0); }

}  // namespace
}  // namespace rollstep::sim::test
