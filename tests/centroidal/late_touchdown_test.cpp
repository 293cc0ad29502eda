// Late touch-downs (CentroidalOcp::landLateFeet, OcpSettings::late_touchdown_*): a foot
// still in the air when its stance was due is not held there by the stance's zero vertical
// velocity. Its stance's start moves to a landing time, and the plan solved on that
// schedule brings the foot down onto its surface before it carries any load.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "centroidal/plan_fixture.hpp"
#include "common/alloc_counter.hpp"

namespace rollstep::centroidal {
namespace {

planning::TerrainModel flatTerrain() {
  return planning::terrainFromBoxes({-20.0, 20.0, -5.0, 5.0, 0.0}, 0.0, {});
}

/// The first switch after `after` where `foot` touches down under `schedule`.
double nextTouchdown(const ocp::ModeSchedule& schedule, int foot, double after) {
  for (double t : schedule.switchingTimes()) {
    if (t <= after) continue;
    const planning::FootPhase before = planning::footPhase(schedule, foot, t - 1e-9);
    if (!before.stance && planning::footPhase(schedule, foot, t).stance) return t;
  }
  return std::numeric_limits<double>::quiet_NaN();
}

/// x with foot `foot` raised by `dz`: through the joint that moves that foot's height the
/// most and no other foot (found by finite differences, so no joint order is assumed).
Eigen::VectorXd raiseFoot(const CentroidalOcp& ocp, const Eigen::VectorXd& x, int foot, double dz) {
  const CentroidalRobot& r = ocp.robot();
  const Eigen::Matrix3Xd p0 = ocp.footPositions(x);
  int best = -1;
  double best_slope = 0.0;
  for (int j = 0; j < r.nj(); ++j) {
    Eigen::VectorXd xj = x;
    xj[r.stateJointIndex() + j] += 1e-4;
    const Eigen::Matrix3Xd p = ocp.footPositions(xj);
    double others = 0.0;
    for (int i = 0; i < r.nc(); ++i) {
      if (i != foot) others += (p.col(i) - p0.col(i)).norm();
    }
    const double slope = (p(2, foot) - p0(2, foot)) / 1e-4;
    if (others < 1e-9 && std::abs(slope) > std::abs(best_slope)) {
      best = j;
      best_slope = slope;
    }
  }
  EXPECT_GE(best, 0);
  Eigen::VectorXd raised = x;
  raised[r.stateJointIndex() + best] += dz / best_slope;  // linear enough for a few cm
  return raised;
}

struct LateRun {
  RobotOcpDescription robot = test::tachyon3Description();
  OcpSettings settings;
  std::unique_ptr<CentroidalOcp> ocp;
  explicit LateRun(double tolerance) {
    settings.horizon = 40;
    settings.late_touchdown_tolerance = tolerance;
    ocp = std::make_unique<CentroidalOcp>(robot, settings, flatTerrain(), planning::GaitKind::Trot);
    ocp->reset(0.0, lie::SE3::Identity(), planning::BaseVelocityCommand{0.0, 0.0, 0.0});
  }
  ocp::ModeSchedule& schedule() { return ocp->problem()->modeSchedule(); }
};

constexpr int kFoot = 0;  // LF

TEST(LateTouchDown, AFootUpWhenItsStanceBeginsLandsFirstInThePlan) {
  LateRun run(0.01);
  CentroidalOcp& ocp = *run.ocp;
  const double T = nextTouchdown(run.schedule(), kFoot, 0.05);
  ASSERT_TRUE(std::isfinite(T));
  const double t = T + 0.02;
  ocp.advance(t);
  const Eigen::VectorXd standing = ocp.standingState(0.0, 0.0, 0.0);
  const Eigen::VectorXd x = raiseFoot(ocp, standing, kFoot, 0.035);
  const double z_up = ocp.footPositions(x)(2, kFoot);
  const double surface = ocp.footPositions(standing)(2, kFoot);
  ASSERT_NEAR(z_up - surface, 0.035, 1e-3);
  {
    rollstep::test::AllocationGuard guard;
    EXPECT_EQ(ocp.landLateFeet(run.schedule(), t, x), 1 << kFoot);
    EXPECT_EQ(guard.count(), 0u);
  }
  // LF is in swing at the first node and lands 0.035 m / 0.5 m/s later; its height
  // reference starts where the foot is.
  const ocp::OptimalControlProblem& problem = *ocp.problem();
  EXPECT_FALSE(CentroidalRobot::inStance(problem.context(0).mode, kFoot));
  const planning::FootPhase phase = planning::footPhase(run.schedule(), kFoot, t);
  EXPECT_NEAR(phase.touchdown, t + (z_up - surface) / run.settings.late_touchdown_speed, 1e-9);
  EXPECT_NEAR(ocp.footPlanner().query(run.schedule(), kFoot, t).z_ref, z_up, 1e-12);
  EXPECT_NEAR(ocp.footPlanner().query(run.schedule(), kFoot, phase.touchdown).z_ref, surface, 1e-9);

  // The plan from that state: LF carries nothing until it lands, and lands on the floor.
  solver::SolverSettings settings = run.settings.solver;
  settings.max_iterations = 100;
  solver::Solver s(ocp.problem(), settings);
  test::solveAndCheck(ocp, s, x);
  int landing_node = -1;
  for (int k = 0; k < problem.horizon(); ++k) {
    const bool stance = CentroidalRobot::inStance(problem.context(k).mode, kFoot);
    const Eigen::VectorXd& u = s.inputs()[static_cast<std::size_t>(k)];
    if (!stance) {
      EXPECT_LT(u.segment<3>(ocp.robot().inputForceIndex(kFoot)).norm(), 1e-6) << k;
    } else if (landing_node < 0) {
      landing_node = k;
    }
  }
  ASSERT_GT(landing_node, 0);
  const double z_land =
      ocp.footPositions(s.states()[static_cast<std::size_t>(landing_node)])(2, kFoot);
  EXPECT_NEAR(z_land, surface, 5e-3) << "landed at node " << landing_node;
  // On its way down from the start, never up: the descent's reference, followed.
  double previous = z_up;
  for (int k = 1; k <= landing_node; ++k) {
    const double z = ocp.footPositions(s.states()[static_cast<std::size_t>(k)])(2, kFoot);
    EXPECT_LE(z, previous + 1e-4) << k;
    previous = z;
  }
  const double z_mid =
      ocp.footPositions(s.states()[static_cast<std::size_t>(landing_node / 2)])(2, kFoot);
  EXPECT_LT(z_mid, z_up - 0.005);
  EXPECT_GT(z_mid, surface + 0.005);
}

TEST(LateTouchDown, ALandedStanceIsSettledAndTheDelayIsBounded) {
  LateRun run(0.01);
  CentroidalOcp& ocp = *run.ocp;
  const Eigen::VectorXd standing = ocp.standingState(0.0, 0.0, 0.0);
  const Eigen::VectorXd raised = raiseFoot(ocp, standing, kFoot, 0.05);
  const double T = nextTouchdown(run.schedule(), kFoot, 0.05);
  // On the floor at the first look after the touch-down: settled, so a foot raised later
  // in the same stance (a bump, a wheel lifted by the body) is not a late touch-down.
  ocp.advance(T + 0.01);
  EXPECT_EQ(ocp.landLateFeet(run.schedule(), T + 0.01, standing), 0);
  ocp.advance(T + 0.05);
  EXPECT_EQ(ocp.landLateFeet(run.schedule(), T + 0.05, raised), 0);
  EXPECT_TRUE(CentroidalRobot::inStance(ocp.problem()->context(0).mode, kFoot));
  // The next stance: late while up within half a swing of its start, then as scheduled.
  const double T2 = nextTouchdown(run.schedule(), kFoot, T + 0.1);
  ASSERT_TRUE(std::isfinite(T2));
  const planning::FootPhase swing = planning::footPhase(run.schedule(), kFoot, T2 - 1e-6);
  const double half = 0.5 * (swing.touchdown - swing.liftoff);
  ocp.advance(T2 + 0.5 * half);
  EXPECT_EQ(ocp.landLateFeet(run.schedule(), T2 + 0.5 * half, raised), 1 << kFoot);
  ocp.advance(T2 + half + 1e-3);
  EXPECT_EQ(ocp.landLateFeet(run.schedule(), T2 + half + 1e-3, raised), 0);
  EXPECT_TRUE(CentroidalRobot::inStance(ocp.problem()->context(0).mode, kFoot));
  // A bad state delays nothing.
  Eigen::VectorXd bad = raised;
  bad[0] = std::numeric_limits<double>::quiet_NaN();
  ocp.advance(T2 + 0.01);
  EXPECT_EQ(ocp.landLateFeet(run.schedule(), T2 + 0.01, bad), 0);
  EXPECT_EQ(ocp.landLateFeet(run.schedule(), T2 + 0.01, Eigen::VectorXd::Zero(3)), 0);
}

TEST(LateTouchDown, OffByDefault) {
  LateRun run(0.0);
  CentroidalOcp& ocp = *run.ocp;
  const double T = nextTouchdown(run.schedule(), kFoot, 0.05);
  ocp.advance(T + 0.02);
  const Eigen::VectorXd raised = raiseFoot(ocp, ocp.standingState(0.0, 0.0, 0.0), kFoot, 0.06);
  EXPECT_EQ(ocp.landLateFeet(run.schedule(), T + 0.02, raised), 0);
  EXPECT_TRUE(CentroidalRobot::inStance(ocp.problem()->context(0).mode, kFoot));
}

}  // namespace
}  // namespace rollstep::centroidal
