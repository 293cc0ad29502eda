// Closed-loop NMPC runs over ramps (deterministic mode, MuJoCo), label `closedloop`:
// Tachyon 3 rolls at 0.3 m/s up an 8 deg ramp onto a 0.15 m plateau and down an 8 deg ramp
// to the far floor (tests/sim/scenes/ramp8.yaml). The stance wheels must follow the slope
// (their velocity along the terrain normal is zero, not their world vertical velocity:
// with that the robot pitched over on the ramp), and the body stands its nominal height
// above the slope (not above the front wheels' ground: the rear knees reached their stop).
#include <gtest/gtest.h>

#include <cstdio>
#include <string>

#include "sim/nmpc_expect.hpp"
#include "sim/nmpc_run.hpp"

namespace rollstep::sim::test {
namespace {

/// [m] Where the down ramp ends on the far floor (ramp8.yaml: its top face from x = 3.56 to
/// x = 4.63), plus the rear wheels' 0.33 m + 0.075 m behind the base.
constexpr double kFarFloorX = 4.63 + 0.33 + 0.075;

TEST(NmpcRamp, RollsUpAndDownAnEightDegreeRamp) {
  NmpcScenario sc;
  sc.scene = std::string(ROLLSTEP_SOURCE_DIR) + "/tests/sim/scenes/ramp8.yaml";
  sc.gait = planning::GaitKind::Rolling;
  sc.command = {0.3, 0.0, 0.0};
  sc.duration = 20.0;
  const NmpcOutcome o = runNmpc(sc);
  std::printf(
      "ramp8 rolling 0.3 m/s: furthest base x %.3f m, end (%.3f, %.3f) m, body contact %ld (%s)\n",
      o.max_x, o.end.x(), o.end.z(), o.body_contact_periods, describe(o).c_str());
  // Over the plateau (base above 0.15 m + most of its nominal height) and on the far floor.
  EXPECT_GT(o.max_base_height - o.start.z(), 0.12) << describe(o);
  EXPECT_GT(o.end.x(), kFarFloorX) << describe(o);
  EXPECT_NEAR(o.end.z(), o.start.z(), 0.05) << describe(o);
  EXPECT_LT(o.max_pitch_deg, 15.0) << describe(o);
  EXPECT_LT(o.max_roll_deg, 15.0) << describe(o);
  EXPECT_LT(o.max_joint_limit_violation, 0.01) << describe(o);
  EXPECT_EQ(o.body_contact_periods, 0) << describe(o);
  EXPECT_EQ(o.counters.invalid_states, 0u);
  EXPECT_EQ(o.warnings, 0) << describe(o);
}

}  // namespace
}  // namespace rollstep::sim::test
