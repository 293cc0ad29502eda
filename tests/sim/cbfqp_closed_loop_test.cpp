// The CBF-QP baseline in closed loop (issue 14, DESIGN.md section 6; label closedloop,
// Release only): with config/baseline.yaml it trots over the step20 block at 0.15 m/s on its
// own (up, along, down) and stops beyond it, and trots on flat ground, with the physical
// checks: no fall, the body never touches the terrain, every joint inside its limits. The
// step run prints the paper's Table 1 metrics.
#include <gtest/gtest.h>

#include <cstdio>

#include "sim/cbfqp_run.hpp"

namespace {

using namespace rollstep;
using namespace rollstep::sim::test;

void expectPhysical(const CbfQpOutcome& o, double max_tilt_deg) {
  EXPECT_LT(o.max_roll_deg, max_tilt_deg);
  EXPECT_LT(o.max_pitch_deg, max_tilt_deg);
  EXPECT_GT(o.min_body_clearance, 0.05);  // the body box stays 5 cm off the terrain
  EXPECT_LE(o.max_joint_limit_violation, 1e-3) << o.worst_joint;
  EXPECT_EQ(o.warnings, 0);
}

TEST(CbfQpClosedLoop, TrotsOverTheStep20BlockAndStopsBeyondIt) {
  CbfQpScenario sc;
  sc.scene = "step20";
  sc.command.v_x = 0.15;
  sc.duration = 28.0;
  sc.stop_at_x = 3.3;  // the rear wheels (0.33 m behind the base) 0.77 m beyond the block
  const CbfQpOutcome o = runCbfQp(sc);
  std::printf("cbfqp step20 0.15 m/s: %s\n", describe(o).c_str());
  // Measured: roll 0.04 deg, pitch 4.0 deg, body box 0.17 m above the terrain at its lowest.
  expectPhysical(o, 8.0);
  EXPECT_EQ(o.counters.qp_fallbacks, 0u);
  EXPECT_GT(o.max_mf_wheel_z, 0.26);  // MF rolled on the block (its top + the wheel radius)
  ASSERT_GT(o.traverse_start, 0.0);
  ASSERT_GT(o.traverse_end, o.traverse_start);
  EXPECT_LT(o.traverse_end - o.traverse_start, 25.0);
  EXPECT_GT(o.stop_time, 0.0);
  EXPECT_GT(o.end.x(), 3.3);
  // Trotting in place; no base position is held (myopic), so it creeps by about 1 cm/s.
  EXPECT_LT(o.drift_after_stop, 0.05);
  EXPECT_NEAR(o.end.z(), 0.375, 0.03);  // back at the nominal height on the floor
}

TEST(CbfQpClosedLoop, TrotsOnFlatGround) {
  CbfQpScenario sc;
  sc.command.v_x = 0.15;
  sc.duration = 10.0;
  const CbfQpOutcome o = runCbfQp(sc);
  std::printf("cbfqp flat 0.15 m/s: %s\n", describe(o).c_str());
  expectPhysical(o, 5.0);
  EXPECT_GT(o.mean_forward_speed, 0.12);
  EXPECT_LT(o.mean_forward_speed, 0.18);
  EXPECT_NEAR(o.end.y(), 0.0, 0.05);
  EXPECT_EQ(o.counters.qp_fallbacks, 0u);
}

}  // namespace
