// The proof of issue 11: the full-centroidal OCP of Tachyon 3 solved in converging mode from
// a cold start (the standing posture along the base reference), on flat ground (the 20 cm
// step: plan_step_test.cpp); each test checks convergence, that every constraint group
// holds to 1e-4 at the solution (evaluated afresh) and the physical outcome.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "centroidal/plan_fixture.hpp"
#include "rollstep/planning/swing_trajectory.hpp"

namespace rollstep::centroidal {
namespace {

using test::PlanRun;

planning::TerrainModel flatTerrain() {
  return planning::terrainFromBoxes({-20.0, 20.0, -5.0, 5.0, 0.0}, 0.0, {});
}

bool isDrive(const PlanRun& r, int foot) { return r.ocp->robot().contact(foot).drive_wheel; }

/// Velocity of foot i across its wheel: in the base's yaw frame (the feet only pitch).
double lateral(const PlanRun& r, int k, const Eigen::Matrix3Xd& v, int i) {
  const Eigen::Quaterniond q(r.x(k)[6], r.x(k)[3], r.x(k)[4], r.x(k)[5]);
  const Eigen::Vector3d forward = q * Eigen::Vector3d::UnitX();
  const double yaw = std::atan2(forward.y(), forward.x());
  return -std::sin(yaw) * v(0, i) + std::cos(yaw) * v(1, i);
}

/// Stance velocity tolerance [m/s]: 1e-3 where the equality holds it (to 1e-4, in the
/// contact frame's yaw, which differs slightly from the base yaw used here when the base
/// rolls), 5e-3 where the side-by-side rule leaves it to the freed-velocity cost.
double slipTolerance(const PlanRun& r, int k, int foot) {
  return r.ocp->robot().keepsVelocityConstraints(r.mode(k), foot) ? 1e-3 : 5e-3;
}

TEST(Plan, StandingOnFlatHoldsThePostureWithEqualNormalForces) {
  PlanRun r(flatTerrain(), planning::GaitKind::Standing, 0.0);
  const double weight = r.ocp->robot().mass() * 9.81;
  for (int k = 0; k < r.N(); ++k) {
    for (int i = 0; i < r.ocp->robot().nc(); ++i) {
      EXPECT_NEAR(r.force(k, i, 2), weight / 6.0, 0.01 * weight / 6.0)
          << "node " << k << " foot " << i;
    }
  }
  // The nominal posture: the base stays where it started, joints at the reference.
  const Eigen::VectorXd x0 = r.x(0);
  EXPECT_LT((r.x(r.N()).head<3>() - x0.head<3>()).norm(), 1e-3);
  EXPECT_LT((r.x(r.N()).segment(7, 12) - r.ocp->nominalJointPositions()).lpNorm<Eigen::Infinity>(),
            1e-3);
}

TEST(Plan, RollingForwardOnFlatRollsTheWheels) {
  PlanRun r(flatTerrain(), planning::GaitKind::Rolling, 0.5);
  // From rest, the robot catches up with a reference that starts at 0.5 m/s: the wheels
  // roll at 0.5 m/s on average over the horizon, none backwards, none sideways.
  int checked = 0;
  Eigen::VectorXd mean_vx = Eigen::VectorXd::Zero(r.ocp->robot().nc());
  for (int k = 0; k < r.N(); ++k) {
    const Eigen::Matrix3Xd v = r.ocp->footVelocities(r.x(k), r.u(k));
    mean_vx += v.row(0).transpose() / r.N();
    for (int i = 0; i < r.ocp->robot().nc(); ++i) {
      EXPECT_NEAR(v(2, i), 0.0, slipTolerance(r, k, i))
          << "foot z velocity, node " << k << " foot " << i;
      if (isDrive(r, i)) {
        EXPECT_NEAR(lateral(r, k, v, i), 0.0, slipTolerance(r, k, i))
            << "drive wheel lateral, foot " << i;
      }
      ++checked;
    }
  }
  EXPECT_GT(checked, 0);
  for (int i = 0; i < mean_vx.size(); ++i) EXPECT_NEAR(mean_vx[i], 0.5, 0.05) << "foot " << i;
  // The base advanced at about the commanded speed.
  EXPECT_NEAR(r.x(r.N())[0] - r.x(0)[0], 0.5 * r.N() * r.ocp->settings().dt, 0.15);
}

/// Swing feet follow the spline and carry no force; stance feet do not slide: no vertical
/// velocity, no lateral one at a drive wheel (rolling along the wheel is free).
void checkGait(const PlanRun& r) {
  int swings = 0;
  for (int k = 0; k < r.N(); ++k) {
    const ocp::NodeContext ctx = r.ocp->problem()->context(k);
    const Eigen::Matrix3Xd p = r.ocp->footPositions(r.x(k));
    const Eigen::Matrix3Xd v = r.ocp->footVelocities(r.x(k), r.u(k));
    for (int i = 0; i < r.ocp->robot().nc(); ++i) {
      const planning::FootReference ref =
          r.ocp->footPlanner().query(r.ocp->problem()->modeSchedule(), i, ctx.time);
      if (CentroidalRobot::inStance(ctx.mode, i)) {
        EXPECT_NEAR(v(2, i), 0.0, slipTolerance(r, k, i))
            << "stance foot moves vertically, node " << k;
        if (isDrive(r, i)) {
          EXPECT_NEAR(lateral(r, k, v, i), 0.0, slipTolerance(r, k, i))
              << "stance drive wheel slides";
        }
      } else {
        ++swings;
        for (int a = 0; a < 3; ++a) EXPECT_NEAR(r.force(k, i, a), 0.0, 1e-6) << "swing force";
        EXPECT_NEAR(p(2, i), ref.z_ref, 5e-3) << "swing height, node " << k << " foot " << i;
      }
    }
  }
  EXPECT_GT(swings, 0) << "the gait never lifted a foot";
}

TEST(Plan, TrotInPlaceOnFlat) {
  PlanRun r(flatTerrain(), planning::GaitKind::Trot, 0.0);
  checkGait(r);
  EXPECT_LT((r.x(r.N()).head<2>() - r.x(0).head<2>()).norm(), 0.05);  // in place
}

TEST(Plan, TrotForwardOnFlat) {
  PlanRun r(flatTerrain(), planning::GaitKind::Trot, 0.15);
  checkGait(r);
  EXPECT_GT(r.x(r.N())[0] - r.x(0)[0], 0.5 * 0.15 * r.N() * r.ocp->settings().dt);
}

TEST(Plan, StaticWalkOnFlat) {
  PlanRun r(flatTerrain(), planning::GaitKind::StaticWalk, 0.0);
  checkGait(r);
}

// constraintViolations names the row behind each group's largest violation (what
// `rollstep sim --log-violations` writes): the foot, and the region edge or friction row.
TEST(Plan, ViolationsNameTheFootAndTheRowBehindThem) {
  PlanRun r(flatTerrain(), planning::GaitKind::Standing, 0.0);
  std::vector<Eigen::VectorXd> xs = r.solver->states(), us = r.solver->inputs();
  const CentroidalRobot& robot = r.ocp->robot();
  // Node 40's base 30 m ahead: every foot leaves the floor region (x <= 20), the front
  // ones furthest; node 12's third foot pulls the ground (negative normal force).
  xs[40][0] += 30.0;
  us[12][robot.inputForceIndex(2) + 2] = -50.0;
  const auto find = [&](const std::string& group) {
    for (const ConstraintViolation& v : constraintViolations(*r.ocp->problem(), xs, us)) {
      if (v.group == group) return v;
    }
    ADD_FAILURE() << "no group " << group;
    return ConstraintViolation{};
  };
  const ConstraintViolation region = find("stance_region");
  EXPECT_EQ(region.node, 40);
  EXPECT_GT(region.value, 9.0);
  bool names_a_foot = false;
  for (int i = 0; i < robot.nc(); ++i) {
    names_a_foot |= region.row.rfind(robot.contact(i).frame + ": edge ", 0) == 0;
  }
  EXPECT_TRUE(names_a_foot) << region.row;
  EXPECT_NE(region.row.find(" of region 0"), std::string::npos) << region.row;
  const ConstraintViolation friction = find("friction");
  EXPECT_EQ(friction.node, 12);
  EXPECT_EQ(friction.row.rfind(robot.contact(2).frame + ": friction row ", 0), 0u) << friction.row;
  const ConstraintViolation dynamics = find("dynamics");
  EXPECT_TRUE(dynamics.node == 39 || dynamics.node == 40) << dynamics.node;
  EXPECT_EQ(dynamics.row, "base x");
  // A joint beyond its range at node 30 and a joint velocity beyond its bound at node 20:
  // named by the joint (the model's joint order, not the log's).
  const model::Model& model = robot.model();
  const int knee = 3;  // the fourth actuated joint of the model's order
  xs[30][7 + knee] = model.upperPositionLimit[knee] + 0.5;
  us[20][knee] = 100.0;
  const ConstraintViolation state_bound = find("state_bounds");
  EXPECT_EQ(state_bound.node, 30);
  EXPECT_EQ(state_bound.row, model.jointNames[knee] + " position");
  const ConstraintViolation input_bound = find("input_bounds");
  EXPECT_EQ(input_bound.node, 20);
  EXPECT_EQ(input_bound.row, model.jointNames[knee] + " velocity");
  // Nothing violated: no row.
  const ConstraintViolation torque = find("torque");
  EXPECT_EQ(torque.node, -1);
  EXPECT_EQ(torque.row, "");
  // A NaN is the worst of all (a diverged iterate must not read as a small violation).
  xs[60][1] = std::nan("");
  const ConstraintViolation nan = find("dynamics");
  EXPECT_TRUE(std::isnan(nan.value));
  EXPECT_TRUE(nan.node == 59 || nan.node == 60) << nan.node;
}

}  // namespace
}  // namespace rollstep::centroidal
