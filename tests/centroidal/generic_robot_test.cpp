// The layer is generic over the robot description: a quadruped with 3-DoF legs (the
// abduction joint rolls the feet, so the contact frame yaw differs from the base yaw),
// every foot a "drive wheel", a contact offset, side pairs {FL, FR} and {HL, HR}. Dynamics
// and every equality against central differences on the manifold, side-by-side rows.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "centroidal/fd_check.hpp"
#include "rollstep/centroidal/contact_equalities.hpp"
#include "rollstep/centroidal/dynamics.hpp"
#include "rollstep/centroidal/swing_height.hpp"

namespace rollstep::centroidal::test {
namespace {

enum QuadrupedFoot { FL = 0, FR = 1, HL = 2, HR = 3 };

struct Quadruped {
  std::shared_ptr<const CentroidalRobot> robot = std::make_shared<const CentroidalRobot>(
      std::make_shared<const model::Model>(
          model::buildModelFromUrdfFile(std::string(ROLLSTEP_TEST_DATA_DIR) + "/quadruped.urdf")),
      std::vector<ContactDescription>{
          {"FL_foot", true}, {"FR_foot", true}, {"HL_foot", true}, {"HR_foot", true}},
      std::vector<std::array<int, 2>>{{FL, FR}, {HL, HR}}, 0.02);
  std::shared_ptr<const CentroidalPrecomputation> pre =
      std::make_shared<const CentroidalPrecomputation>(robot);
  std::unique_ptr<ocp::NodeCache> cache = pre->createCache();
  planning::TerrainModel terrain = planning::terrainFromBoxes({-5.0, 5.0, -2.0, 2.0, 0.0}, 0.0, {});
  planning::BaseReference base{terrain, {0.3, {Eigen::Vector2d::Zero()}}};
  std::vector<Eigen::Vector2d> feet{{0.2, 0.1}, {0.2, -0.1}, {-0.2, 0.1}, {-0.2, -0.1}};
  std::shared_ptr<const planning::FootReferencePlanner> planner =
      std::make_shared<const planning::FootReferencePlanner>(
          terrain, base, planning::FootReferenceConfig{feet, 0.06, 0.02});
  planning::GaitScheduler scheduler{
      planning::Gait::trot(4, 0.6, 0.6, maskOf({FL, HR}), maskOf({FR, HL})), 1.0};
  ocp::ModeSchedule schedule{scheduler.requiredCapacity()};
  Quadruped() {
    base.reset(0.0, lie::SE3(), {0.3, 0.0, 0.0});
    scheduler.fill(0.0, 1.0, schedule);
  }
  double timeInMode(int mode) const {
    for (double t = 0.0; t < 1.0; t += 1e-3) {
      if (schedule.modeAt(t) == mode) return t + 0.01;
    }
    return std::nan("");
  }
};

TEST(GenericRobot, QuadrupedTermsMatchFiniteDifferences) {
  Quadruped q;
  const CentroidalDynamics f(q.pre);
  const SwingForceResidual force(q.robot);
  const StanceVelocityResidual velocity(q.pre);
  const SwingHeightResidual height(q.pre, q.planner, 5.0);
  std::mt19937 rng(41);
  // The light quadruped amplifies rounding through A_b^-1 (|omega| of tens of rad/s at the
  // random momenta): 1e-5 absolute.
  const FdTolerance tol{1e-6, 1e-5, 1e-5};
  for (int mode : {15, maskOf({FL, HR}), maskOf({FR, HL})}) {
    const double t = q.timeInMode(mode);
    ASSERT_TRUE(std::isfinite(t)) << mode;
    for (int trial = 0; trial < 3; ++trial) {
      const Eigen::VectorXd x = randomState(*q.robot, rng);
      const Eigen::VectorXd u = randomInput(*q.robot, rng);
      const NodeEvaluator ev{q.pre.get(), q.cache.get(),
                             makeContext(mode, t, &q.schedule, nullptr)};
      EXPECT_TRUE(checkContinuousDynamicsDerivatives(f, ev, x, u, tol)) << mode;
      for (const ocp::Residual* r : std::vector<const ocp::Residual*>{&force, &velocity, &height}) {
        EXPECT_TRUE(checkResidualDerivatives(*r, *q.robot->space(), ev, x, u, tol))
            << "mode " << mode << " " << typeid(*r).name();
      }
    }
  }
  // Side-by-side rows: all stance keeps FL and HL (z + lateral each); a diagonal pair
  // keeps both of its feet.
  EXPECT_EQ(velocity.rows(makeContext(15, 0.0, &q.schedule, nullptr)), 4);
  EXPECT_EQ(velocity.rows(makeContext(maskOf({FR, HL}), 0.0, &q.schedule, nullptr)), 4);
  EXPECT_EQ(velocity.rows(makeContext(maskOf({FR, HR}), 0.0, &q.schedule, nullptr)), 4);
  EXPECT_EQ(velocity.rows(makeContext(maskOf({FL, FR, HR}), 0.0, &q.schedule, nullptr)), 4);
}

TEST(GenericRobot, FootYawFollowsTheAbduction) {
  // With a rolled foot (abduction) on a yawed, pitched base the contact frame's yaw is
  // not the base yaw; the cache's yaw derivative is still exact (previous test), and the
  // yaw itself is atan2 of the frame's x axis.
  Quadruped q;
  std::mt19937 rng(42);
  auto& c = static_cast<CentroidalCache&>(*q.cache);
  const Eigen::VectorXd x = randomState(*q.robot, rng, 0.4);
  const Eigen::VectorXd u = randomInput(*q.robot, rng);
  q.pre->compute(x, u, false, c);
  const Eigen::Matrix3d Rb = Eigen::Quaterniond(x[6], x[3], x[4], x[5]).toRotationMatrix();
  const double base_yaw = std::atan2(Rb(1, 0), Rb(0, 0));
  double largest = 0.0;
  for (int i = 0; i < 4; ++i) {
    largest = std::max(largest, std::abs(std::remainder(c.footYaw[i] - base_yaw, 2 * M_PI)));
    const Eigen::Matrix3d& R = c.footRotation[static_cast<size_t>(i)];
    EXPECT_NEAR(c.footYaw[i], std::atan2(R(1, 0), R(0, 0)), 1e-15);
    EXPECT_TRUE((R.transpose() * R).isIdentity(1e-12));
  }
  EXPECT_GT(largest, 1e-2);
}

}  // namespace
}  // namespace rollstep::centroidal::test
