// The proof of issue 11, item 4: trotting up onto and down from the 20 cm block of step20
// (its convex regions shrunk by the wheel radius + 1 cm), the full-centroidal OCP of Tachyon 3
// solved in converging mode from a cold start (the standing posture along the base reference). Each
// test checks convergence, that every constraint group holds to 1e-4 at the solution
// (evaluated afresh) and the physical outcome.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "centroidal/plan_fixture.hpp"

namespace rollstep::centroidal {
namespace {

using test::PlanRun;

/// robot/tachyon3.md's step20: a 0.20 m block, 1.20 m long, 3 m wide, its near edge 1.0 m
/// ahead of the start. The regions constrain the wheel centres: shrunk by the wheel radius
/// (0.075 m) + 1 cm so that no wheel rim reaches an edge (with 3 cm a swing wheel cut 2.5 cm
/// into the block's top edge while its centre kept to the floor region).
constexpr double kEdgeUp = 1.0, kEdgeDown = 2.2, kTop = 0.2;
planning::TerrainModel step20Terrain() {
  return planning::terrainFromBoxes({-20.0, 20.0, -5.0, 5.0, 0.0}, 0.0,
                                    {{kEdgeUp, kEdgeDown, -1.5, 1.5, kTop}}, 0.085);
}

/// The step scenarios' settings: the OCP without the climbing rules (these plans show the
/// paper's OCP alone climbing) with a longer trot cycle `gait_period` (0.8 s there; a
/// longer swing here). Two defaults come from these
/// scenarios: joint_velocity_weight 2.5 (with 0.1 a stance wheel, free to roll along x,
/// chattered at +-2 m/s node to node and explicit Euler turned it into a vertical drift the
/// stance velocity equality does not see; the solver stalled at a KKT error of 1e-3..1e-1)
/// and swing_height_gain 50 (with 20 the Euler-integrated swing lagged its spline on the
/// 0.2 m descent and a wheel touched down 7.5 mm below the floor).
OcpSettings stepSettings(double gait_period) {
  OcpSettings s = test::withoutClimbingRules();
  s.gait_period = gait_period;
  return s;
}

/// Over the step: torques within the URDF effort limits; every stance wheel stands on the
/// ground of its region (wheel centre one radius above it, to 5 mm: the OCP only holds its
/// vertical velocity at zero); no wheel (a disc of the contact offset's radius in the x-z
/// plane) cuts into the block by more than 5 mm. No foot leaves its region: the region groups of
/// solveAndCheck.
void checkStep(const PlanRun& r) {
  const auto& torque_limit = r.ocp->robot().model().effortLimit;
  const double radius = r.ocp->robot().contactOffset();
  for (int k = 0; k <= r.N(); ++k) {
    if (k < r.N()) {
      const Eigen::VectorXd tau = r.ocp->jointTorques(r.x(k), r.u(k));
      for (int j = 0; j < tau.size(); ++j) {
        EXPECT_LE(std::abs(tau[j]), torque_limit[j] + 1e-6) << "node " << k << " joint " << j;
      }
    }
    const ocp::NodeContext ctx = r.ocp->problem()->context(k);
    const Eigen::Matrix3Xd p = r.ocp->footPositions(r.x(k));
    for (int i = 0; i < r.ocp->robot().nc(); ++i) {
      if (CentroidalRobot::inStance(ctx.mode, i)) {
        const planning::FootReference ref =
            r.ocp->footPlanner().query(r.ocp->problem()->modeSchedule(), i, ctx.time);
        EXPECT_NEAR(p(2, i), ref.z_ref, 5e-3)
            << "stance wheel off the ground, node " << k << " foot " << i;
      }
      // Distance from the wheel centre to the block's x-z section.
      const double dx = std::max({kEdgeUp - p(0, i), 0.0, p(0, i) - kEdgeDown});
      const double dz = std::max(p(2, i) - kTop, 0.0);
      EXPECT_GE(std::hypot(dx, dz), radius - 5e-3)
          << "wheel cuts the block, node " << k << " foot " << i;
    }
  }
}

/// Base height above its start [m] at node k.
double rise(const PlanRun& r, int k) { return r.x(k)[2] - r.x(0)[2]; }

TEST(Plan, TrotUpOntoTheStep) {
  // 0.4 m/s from 0.75 m before the edge, a 1.2 s trot cycle: the front feet step up
  // within the horizon.
  PlanRun r(step20Terrain(), planning::GaitKind::Trot, 0.4, 0.25, stepSettings(1.2));
  checkStep(r);
  // A front foot ends in stance on the block top, and the body rose ahead of it: already
  // 0.1 m higher when the first foot touched down there (the knees retract only 5 cm).
  int first_on_top = -1;
  for (int k = 0; k <= r.N() && first_on_top < 0; ++k) {
    const Eigen::Matrix3Xd p = r.ocp->footPositions(r.x(k));
    for (int i = 0; i < r.ocp->robot().nc(); ++i) {
      if (CentroidalRobot::inStance(r.mode(std::min(k, r.N() - 1)), i) && p(2, i) > kTop + 0.07 &&
          p(0, i) > kEdgeUp) {
        first_on_top = k;
      }
    }
  }
  ASSERT_GE(first_on_top, 0) << "no foot stood on the block";
  std::printf("first stance on the block at node %d, base %.3f m higher; at the end %.3f m\n",
              first_on_top, rise(r, first_on_top), rise(r, r.N()));
  EXPECT_GT(rise(r, first_on_top), 0.1);
  EXPECT_GT(rise(r, r.N()), 0.1);
  const Eigen::Matrix3Xd feet = r.ocp->footPositions(r.x(r.N()));
  EXPECT_GT(feet.row(2).maxCoeff(), kTop + 0.07);  // a wheel centre on the block top
}

TEST(Plan, TrotDownFromTheStep) {
  // On the block, 0.6 m before its far edge, at 0.4 m/s with a 1.0 s trot cycle (with 1.2 s
  // the front feet step down so late that the body has come down only 1.4 cm at the end).
  PlanRun r(step20Terrain(), planning::GaitKind::Trot, 0.4, 1.6, stepSettings(1.0));
  checkStep(r);
  // A front foot ends in stance on the floor beyond the block, and the body came down.
  const Eigen::Matrix3Xd feet = r.ocp->footPositions(r.x(r.N()));
  bool on_floor = false;
  for (int i = 0; i < r.ocp->robot().nc(); ++i) {
    on_floor = on_floor || (CentroidalRobot::inStance(r.mode(r.N() - 1), i) && feet(2, i) < 0.08 &&
                            feet(0, i) > kEdgeDown);
  }
  EXPECT_TRUE(on_floor) << "no foot stands on the floor beyond the block";
  std::printf("base %.3f m lower at the end\n", -rise(r, r.N()));
  EXPECT_LT(rise(r, r.N()), -0.05);
}

}  // namespace
}  // namespace rollstep::centroidal
