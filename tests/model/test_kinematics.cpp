#include <gtest/gtest.h>

#include "model_test_utils.hpp"

namespace rollstep::model {
namespace {

using test::closeRelative;

class Kinematics : public ::testing::TestWithParam<test::RobotCase> {};

// Frame velocities in the three reference frames against time finite differences of the
// frame placement along q(t) = q (+) t v, and frame Jacobians against the velocities.
TEST_P(Kinematics, FrameVelocityAndJacobian) {
  const Model m = buildModelFromUrdfFile(GetParam().path, GetParam().root);
  Data d(m);
  Data d2(m);
  std::mt19937 rng(17);
  Eigen::MatrixXd J(6, m.nv);
  for (int trial = 0; trial < 10; ++trial) {
    const Eigen::VectorXd q = test::randomConfiguration(m, rng);
    const Eigen::VectorXd v = test::randomVector(m.nv, rng);
    forwardKinematics(m, d, q, v);
    updateFramePlacements(m, d);
    const double h = 1e-6;
    Eigen::VectorXd qp(m.nq);
    Eigen::VectorXd qm(m.nq);
    integrate(m, q, h * v, qp);
    integrate(m, q, -h * v, qm);
    for (int f = 0; f < m.nframes(); ++f) {
      const lie::SE3 x = getFramePlacement(m, d, f);
      EXPECT_TRUE(x.translation.isApprox(d.opf[f]));
      forwardKinematics(m, d2, qp);
      const lie::SE3 xp = getFramePlacement(m, d2, f);
      forwardKinematics(m, d2, qm);
      const lie::SE3 xm = getFramePlacement(m, d2, f);
      // LOCAL twist: x(t) = x Exp(t V_local)
      const Vector6d local_fd = (lie::minus(xp, x) - lie::minus(xm, x)) / (2 * h);
      const Vector6d local = getFrameVelocity(m, d, f, ReferenceFrame::LOCAL);
      EXPECT_TRUE(closeRelative(local, local_fd, 1e-6)) << m.frames[f].name;
      const Eigen::Matrix3d R = d.oRf[f];
      const Vector6d lwa = getFrameVelocity(m, d, f, ReferenceFrame::LOCAL_WORLD_ALIGNED);
      EXPECT_TRUE(lwa.head<3>().isApprox(R * local.head<3>(), 1e-12));
      EXPECT_TRUE(lwa.tail<3>().isApprox(R * local.tail<3>(), 1e-12));
      EXPECT_TRUE(closeRelative(lwa.head<3>(), (xp.translation - xm.translation) / (2 * h), 1e-6));
      const Vector6d world = getFrameVelocity(m, d, f, ReferenceFrame::WORLD);
      EXPECT_TRUE(closeRelative(world, lie::adjoint(x) * local, 1e-12));
      for (ReferenceFrame rf :
           {ReferenceFrame::LOCAL, ReferenceFrame::WORLD, ReferenceFrame::LOCAL_WORLD_ALIGNED}) {
        getFrameJacobian(m, d, f, rf, J);
        EXPECT_TRUE(closeRelative(J * v, getFrameVelocity(m, d, f, rf), 1e-12));
      }
    }
  }
}

// The centre of mass against a direct sum, its Jacobian against finite differences.
TEST_P(Kinematics, CenterOfMass) {
  const Model m = buildModelFromUrdfFile(GetParam().path, GetParam().root);
  Data d(m);
  std::mt19937 rng(5);
  for (int trial = 0; trial < 10; ++trial) {
    const Eigen::VectorXd q = test::randomConfiguration(m, rng);
    forwardKinematics(m, d, q);
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    for (int i = 0; i < m.nbodies(); ++i) {
      c += m.bodies[i].mass * (d.opb[i] + d.oRb[i] * m.bodies[i].com);
    }
    c /= m.totalMass;
    EXPECT_TRUE(centerOfMass(m, d, q).isApprox(c, 1e-12));
    const Eigen::MatrixXd Jc = jacobianCenterOfMass(m, d, q);
    const Eigen::MatrixXd fd = test::fdConfiguration(
        m, q, [&](const Eigen::VectorXd& x) { return Eigen::VectorXd(centerOfMass(m, d, x)); });
    EXPECT_TRUE(closeRelative(Jc, fd, 1e-6));
  }
}

INSTANTIATE_TEST_SUITE_P(Robots, Kinematics, ::testing::ValuesIn(test::robotCases()),
                         test::robotCaseName);

}  // namespace
}  // namespace rollstep::model
