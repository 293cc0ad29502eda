// Physics checks with quantities computed independently of the spatial-algebra code paths.
#include <gtest/gtest.h>

#include "common/alloc_counter.hpp"
#include "model_test_utils.hpp"

namespace rollstep::model {
namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;
using Eigen::VectorXd;
using test::closeRelative;

class Physics : public ::testing::TestWithParam<test::RobotCase> {};

// h = A(q) v equals the sum of the body momenta: each body's m v_com and its angular
// momentum about the total com, with body velocities from time finite differences of the
// body placements along q(t) = q (+) t v. And d/dt com = h_lin / m.
TEST_P(Physics, MomentumIsSumOfBodyMomenta) {
  const Model m = buildModelFromUrdfFile(GetParam().path, GetParam().root);
  Data d(m);
  Data dp(m);
  Data dm(m);
  std::mt19937 rng(99);
  const double h = 1e-6;
  for (int trial = 0; trial < 10; ++trial) {
    const VectorXd q = test::randomConfiguration(m, rng);
    const VectorXd v = test::randomVector(m.nv, rng);
    VectorXd qp(m.nq);
    VectorXd qm(m.nq);
    integrate(m, q, h * v, qp);
    integrate(m, q, -h * v, qm);
    forwardKinematics(m, d, q);
    forwardKinematics(m, dp, qp);
    forwardKinematics(m, dm, qm);
    Vector3d c = Vector3d::Zero();
    for (int i = 0; i < m.nbodies(); ++i) {
      c += m.bodies[i].mass * (d.opb[i] + d.oRb[i] * m.bodies[i].com);
    }
    c /= m.totalMass;
    Vector3d lin = Vector3d::Zero();
    Vector3d ang = Vector3d::Zero();
    for (int i = 0; i < m.nbodies(); ++i) {
      const Body& b = m.bodies[i];
      const Vector3d ci = d.opb[i] + d.oRb[i] * b.com;
      const Vector3d cdot =
          ((dp.opb[i] + dp.oRb[i] * b.com) - (dm.opb[i] + dm.oRb[i] * b.com)) / (2 * h);
      const Matrix3d Rdot = (dp.oRb[i] - dm.oRb[i]) / (2 * h);
      const Vector3d w = lie::vee(Rdot * d.oRb[i].transpose());
      lin += b.mass * cdot;
      ang += d.oRb[i] * b.inertia * d.oRb[i].transpose() * w + b.mass * (ci - c).cross(cdot);
    }
    const Vector6d hg = computeCentroidalMomentum(m, d, q, v);
    EXPECT_TRUE(closeRelative(hg.head<3>(), lin, 1e-6)) << trial;
    EXPECT_TRUE(closeRelative(hg.tail<3>(), ang, 1e-6)) << trial;
    // d/dt com = h_lin / m
    const Vector3d cp = centerOfMass(m, dp, qp);
    const Vector3d cm = centerOfMass(m, dm, qm);
    EXPECT_TRUE(closeRelative((cp - cm) / (2 * h), hg.head<3>() / m.totalMass, 1e-6)) << trial;
  }
}

// g(q) is the gradient of the potential energy U = -m gravity . com (virtual work), and
// J^T f is the virtual work of the world forces: f . dp/dq.
TEST_P(Physics, GravityIsPotentialGradient) {
  const Model m = buildModelFromUrdfFile(GetParam().path, GetParam().root);
  Data d(m);
  std::mt19937 rng(7);
  for (int trial = 0; trial < 10; ++trial) {
    const VectorXd q = test::randomConfiguration(m, rng);
    const Eigen::MatrixXd dU = test::fdConfiguration(m, q, [&](const VectorXd& x) {
      return VectorXd::Constant(1, -m.totalMass * m.gravity.dot(centerOfMass(m, d, x)));
    });
    EXPECT_TRUE(closeRelative(computeGeneralizedGravity(m, d, q), dU.transpose(), 1e-6));
  }
}

// Static equilibrium: vertical contact forces (on the robot) that balance the weight and
// its moment about the com make the base rows of g - J^T f vanish; the joint rows are the
// static joint torques.
TEST_P(Physics, StaticEquilibrium) {
  const Model m = buildModelFromUrdfFile(GetParam().path, GetParam().root);
  if (!m.hasFreeFlyer() || GetParam().contacts.size() < 3) GTEST_SKIP();
  const std::vector<FrameIndex> ids = test::frameIds(m, GetParam().contacts);
  const int nc = static_cast<int>(ids.size());
  Data d(m);
  std::mt19937 rng(8);
  for (int trial = 0; trial < 10; ++trial) {
    const VectorXd q = test::randomConfiguration(m, rng);
    const Vector3d c = centerOfMass(m, d, q);
    updateFramePlacements(m, d);
    // Minimum-norm vertical forces: sum fz = m g, sum fz (x - cx) = sum fz (y - cy) = 0.
    Eigen::MatrixXd A(3, nc);
    for (int i = 0; i < nc; ++i) {
      const Vector3d p = d.opf[ids[i]];
      A.col(i) << 1.0, p.x() - c.x(), p.y() - c.y();
    }
    const Vector3d b(-m.totalMass * m.gravity.z(), 0.0, 0.0);
    const VectorXd fz = A.transpose() * (A * A.transpose()).ldlt().solve(b);
    VectorXd f = VectorXd::Zero(3 * nc);
    for (int i = 0; i < nc; ++i) f[3 * i + 2] = fz[i];
    const VectorXd tau = computeStaticTorque(m, d, q, ids, f);
    EXPECT_LT(tau.head<6>().norm(), 1e-9 * m.totalMass) << tau.head<6>().transpose();
    EXPECT_TRUE(closeRelative(tau, d.g - d.tauContact, 1e-14));
    if (GetParam().name == "tachyon3") {
      // Prismatic knee (axis -z of the hip link): it pushes the wheel down with the
      // contact force minus the weight it carries, along the leg axis.
      for (int i = 0; i < nc; ++i) {
        const std::string leg = GetParam().contacts[static_cast<std::size_t>(i)].substr(0, 2);
        const int j = m.getJointId(leg + "_knee");
        const FrameIndex shank = m.getFrameId(leg + "_shank");
        const Vector3d axis = d.oRf[shank] * Vector3d(0, 0, -1);
        const double carried = m.bodies[static_cast<std::size_t>(m.frames[shank].body)].mass;
        const double expected =
            -axis.dot(f.segment<3>(3 * i)) + carried * m.gravity.dot(axis) * -1.0;
        EXPECT_NEAR(tau[m.nvBase + j], expected, 1e-9) << leg;
      }
    }
  }
}

// After Data (and NodeQuantities) are built, no algorithm allocates.
TEST_P(Physics, NoAllocation) {
  const Model m = buildModelFromUrdfFile(GetParam().path, GetParam().root);
  const std::vector<FrameIndex> ids = test::frameIds(m, GetParam().contacts);
  Data d(m);
  NodeQuantities node(m, ids);
  std::mt19937 rng(1);
  const VectorXd q = test::randomConfiguration(m, rng);
  const VectorXd v = test::randomVector(m.nv, rng);
  const VectorXd f = test::randomVector(3 * static_cast<int>(ids.size()), rng, 10.0);
  Eigen::MatrixXd J6(6, m.nv);
  Eigen::MatrixXd J3a(3, m.nv);
  Eigen::MatrixXd J3b(3, m.nv);
  VectorXd qout(m.nq);
  VectorXd dv(m.nv);
  double sink = 0.0;
  {
    rollstep::test::AllocationGuard guard;
    computeNodeQuantities(m, d, q, v, f, node);
    if (m.hasFreeFlyer()) {
      computeNodeQuantitiesFromMomentum(m, d, q, Vector6d::Ones(), v.tail(m.nj), f, node);
    }
    forwardKinematics(m, d, q);
    forwardKinematics(m, d, q, v);
    updateFramePlacements(m, d);
    sink += getFramePlacement(m, d, ids[0]).translation.x();
    sink += getFrameVelocity(m, d, ids[0], ReferenceFrame::LOCAL).norm();
    sink += getFrameVelocity(m, d, ids[0], ReferenceFrame::WORLD).norm();
    sink += getFrameVelocity(m, d, ids[0], ReferenceFrame::LOCAL_WORLD_ALIGNED).norm();
    computeJointJacobians(m, d, q);
    getFrameJacobian(m, d, ids[0], ReferenceFrame::LOCAL, J6);
    getFrameJacobian(m, d, ids[0], ReferenceFrame::WORLD, J6);
    getFrameJacobian(m, d, ids[0], ReferenceFrame::LOCAL_WORLD_ALIGNED, J6);
    computeForwardKinematicsDerivatives(m, d, q, v);
    getFramePositionDerivative(m, d, ids[0], J3a);
    getFrameLinearVelocityDerivatives(m, d, ids[0], J3a, J3b);
    sink += centerOfMass(m, d, q).x();
    sink += jacobianCenterOfMass(m, d, q)(0, 0);
    sink += computeCentroidalMap(m, d, q)(0, 0);
    sink += computeCentroidalMomentum(m, d, q, v)(0);
    sink += computeCentroidalMomentumDerivatives(m, d, q, v)(0, 0);
    sink += computeGeneralizedGravity(m, d, q)(0);
    sink += computeContactTorque(m, d, q, ids, f)(0);
    sink += computeStaticTorque(m, d, q, ids, f)(0);
    sink += computeGeneralizedGravityDerivatives(m, d, q)(0, 0);
    sink += computeContactTorqueDerivatives(m, d, q, ids, f)(0, 0);
    integrate(m, q, v, qout);
    difference(m, q, qout, dv);
    EXPECT_EQ(guard.count(), 0u);
  }
  EXPECT_TRUE(std::isfinite(sink));
}

INSTANTIATE_TEST_SUITE_P(Robots, Physics, ::testing::ValuesIn(test::robotCases()),
                         test::robotCaseName);

}  // namespace
}  // namespace rollstep::model
