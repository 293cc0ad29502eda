// Analytic derivatives against central finite differences on the configuration manifold
// (q (+) dq, SE(3) right-plus on the free flyer) at many random states.
#include <gtest/gtest.h>

#include "model_test_utils.hpp"

namespace rollstep::model {
namespace {

using Eigen::MatrixXd;
using Eigen::VectorXd;
using test::closeRelative;

constexpr double kTol = 1e-6;

class Derivatives : public ::testing::TestWithParam<test::RobotCase> {};

TEST_P(Derivatives, NodeQuantitiesMatchFiniteDifferences) {
  const Model m = buildModelFromUrdfFile(GetParam().path, GetParam().root);
  const std::vector<FrameIndex> ids = test::frameIds(m, GetParam().contacts);
  const int nc = static_cast<int>(ids.size());
  Data d(m);
  Data d2(m);
  NodeQuantities node(m, ids);
  std::mt19937 rng(2024);
  for (int trial = 0; trial < 25; ++trial) {
    const VectorXd q = test::randomConfiguration(m, rng);
    const VectorXd v = test::randomVector(m.nv, rng);
    const VectorXd forces = test::randomVector(3 * nc, rng, 50.0);
    computeNodeQuantities(m, d, q, v, forces, node);

    auto positions = [&](const VectorXd& x) {
      forwardKinematics(m, d2, x);
      VectorXd out(3 * nc);
      for (int c = 0; c < nc; ++c)
        out.segment<3>(3 * c) = getFramePlacement(m, d2, ids[c]).translation;
      return out;
    };
    auto velocities = [&](const VectorXd& x, const VectorXd& w) {
      forwardKinematics(m, d2, x, w);
      VectorXd out(3 * nc);
      for (int c = 0; c < nc; ++c) {
        out.segment<3>(3 * c) =
            getFrameVelocity(m, d2, ids[c], ReferenceFrame::LOCAL_WORLD_ALIGNED).head<3>();
      }
      return out;
    };
    // Values.
    const VectorXd p0 = positions(q);
    const VectorXd v0 = velocities(q, v);
    for (int c = 0; c < nc; ++c) {
      EXPECT_TRUE(node.contactPositions.col(c).isApprox(p0.segment<3>(3 * c), 1e-12));
      EXPECT_TRUE(closeRelative(node.contactVelocities.col(c), v0.segment<3>(3 * c), 1e-12));
    }
    EXPECT_TRUE(closeRelative(node.h, computeCentroidalMomentum(m, d2, q, v), 1e-12));
    EXPECT_TRUE(closeRelative(node.h, node.A * v, 1e-12));
    EXPECT_TRUE(closeRelative(node.g, computeGeneralizedGravity(m, d2, q), 1e-12));
    EXPECT_TRUE(
        closeRelative(node.contactTorque, node.contactJacobians.transpose() * forces, 1e-12));
    EXPECT_TRUE(
        closeRelative(node.contactTorque, computeContactTorque(m, d2, q, ids, forces), 1e-12));
    EXPECT_TRUE(closeRelative(node.com, centerOfMass(m, d2, q), 1e-12));

    // Derivatives w.r.t. q.
    EXPECT_TRUE(closeRelative(node.contactJacobians, test::fdConfiguration(m, q, positions), kTol))
        << "contact positions, trial " << trial;
    EXPECT_TRUE(closeRelative(
        node.contactVelocityDerivatives,
        test::fdConfiguration(m, q, [&](const VectorXd& x) { return velocities(x, v); }), kTol))
        << "contact velocities, trial " << trial;
    EXPECT_TRUE(closeRelative(
        node.comJacobian,
        test::fdConfiguration(m, q,
                              [&](const VectorXd& x) { return VectorXd(centerOfMass(m, d2, x)); }),
        kTol))
        << "com, trial " << trial;
    EXPECT_TRUE(closeRelative(
        node.dh_dq,
        test::fdConfiguration(
            m, q,
            [&](const VectorXd& x) { return VectorXd(computeCentroidalMomentum(m, d2, x, v)); }),
        kTol))
        << "A(q) v, trial " << trial;
    EXPECT_TRUE(closeRelative(
        node.dg_dq,
        test::fdConfiguration(
            m, q, [&](const VectorXd& x) { return VectorXd(computeGeneralizedGravity(m, d2, x)); }),
        kTol))
        << "g(q), trial " << trial;
    EXPECT_TRUE(closeRelative(node.dContactTorque_dq,
                              test::fdConfiguration(m, q,
                                                    [&](const VectorXd& x) {
                                                      return VectorXd(computeContactTorque(
                                                          m, d2, x, ids, forces));
                                                    }),
                              kTol))
        << "J^T f, trial " << trial;

    // Derivatives w.r.t. v (linear in v: central differences are exact up to round-off).
    MatrixXd dvel_dv(3 * nc, m.nv);
    MatrixXd dh_dv(6, m.nv);
    for (int i = 0; i < m.nv; ++i) {
      const VectorXd e = VectorXd::Unit(m.nv, i);
      dvel_dv.col(i) = (velocities(q, v + e) - velocities(q, v - e)) / 2.0;
      const Vector6d hp = computeCentroidalMomentum(m, d2, q, v + e);
      const Vector6d hm = computeCentroidalMomentum(m, d2, q, v - e);
      dh_dv.col(i) = (hp - hm) / 2.0;
    }
    EXPECT_TRUE(closeRelative(node.contactJacobians, dvel_dv, 1e-10));
    EXPECT_TRUE(closeRelative(node.A, dh_dv, 1e-10));

    // The individual algorithms agree with the fused node computation.
    computeForwardKinematicsDerivatives(m, d2, q, v);
    MatrixXd a(3, m.nv);
    MatrixXd b(3, m.nv);
    for (int c = 0; c < nc; ++c) {
      getFrameLinearVelocityDerivatives(m, d2, ids[c], a, b);
      EXPECT_TRUE(closeRelative(a, node.contactVelocityDerivatives.middleRows(3 * c, 3), 1e-12));
      EXPECT_TRUE(closeRelative(b, node.contactJacobians.middleRows(3 * c, 3), 1e-12));
      getFramePositionDerivative(m, d2, ids[c], a);
      EXPECT_TRUE(closeRelative(a, node.contactJacobians.middleRows(3 * c, 3), 1e-12));
    }
    EXPECT_TRUE(
        closeRelative(computeCentroidalMomentumDerivatives(m, d2, q, v), node.dh_dq, 1e-12));
    EXPECT_TRUE(closeRelative(d2.Ag, node.A, 1e-12));
    EXPECT_TRUE(closeRelative(computeGeneralizedGravityDerivatives(m, d2, q), node.dg_dq, 1e-12));
    EXPECT_TRUE(closeRelative(computeContactTorqueDerivatives(m, d2, q, ids, forces),
                              node.dContactTorque_dq, 1e-12));
    EXPECT_TRUE(closeRelative(jacobianCenterOfMass(m, d2, q), node.comJacobian, 1e-12));
    EXPECT_TRUE(closeRelative(computeStaticTorque(m, d2, q, ids, forces),
                              node.g - node.contactTorque, 1e-12));
  }
}

// Full-centroidal variant: v_b solved from the momentum, and its derivatives.
TEST_P(Derivatives, BaseVelocityFromMomentum) {
  const Model m = buildModelFromUrdfFile(GetParam().path, GetParam().root);
  if (!m.hasFreeFlyer()) GTEST_SKIP() << "fixed base";
  const std::vector<FrameIndex> ids = test::frameIds(m, GetParam().contacts);
  const int nc = static_cast<int>(ids.size());
  Data d(m);
  NodeQuantities node(m, ids);
  NodeQuantities node2(m, ids);
  std::mt19937 rng(77);
  for (int trial = 0; trial < 25; ++trial) {
    const VectorXd q = test::randomConfiguration(m, rng);
    const Vector6d h = test::randomVector(6, rng, 20.0);
    const VectorXd vJ = test::randomVector(m.nj, rng);
    const VectorXd forces = test::randomVector(3 * nc, rng, 50.0);
    computeNodeQuantitiesFromMomentum(m, d, q, h, vJ, forces, node);
    EXPECT_TRUE(closeRelative(node.A * node.v, h, 1e-12));
    EXPECT_TRUE(closeRelative(node.h, h, 1e-12));
    EXPECT_TRUE(closeRelative(node.v.tail(m.nj), vJ, 0.0));
    EXPECT_TRUE(
        closeRelative(node.AbInverse * node.A.leftCols<6>(), MatrixXd::Identity(6, 6), 1e-12));
    // Same quantities as the plain node evaluation at that v.
    computeNodeQuantities(m, d, q, node.v, forces, node2);
    EXPECT_TRUE(closeRelative(node.dh_dq, node2.dh_dq, 1e-12));
    EXPECT_TRUE(
        closeRelative(node.contactVelocityDerivatives, node2.contactVelocityDerivatives, 1e-12));
    EXPECT_TRUE(closeRelative(node.dContactTorque_dq, node2.dContactTorque_dq, 1e-12));
    // v_b derivatives against finite differences.
    auto vb = [&](const VectorXd& x, const VectorXd& w) {
      computeNodeQuantitiesFromMomentum(m, d, x, h, w, forces, node2);
      return VectorXd(node2.v.head<6>());
    };
    EXPECT_TRUE(closeRelative(
        node.dvb_dq, test::fdConfiguration(m, q, [&](const VectorXd& x) { return vb(x, vJ); }),
        kTol))
        << trial;
    MatrixXd fd(6, m.nj);
    for (int j = 0; j < m.nj; ++j) {
      const VectorXd e = VectorXd::Unit(m.nj, j) * 1e-6;
      fd.col(j) = (vb(q, vJ + e) - vb(q, vJ - e)) / 2e-6;
    }
    EXPECT_TRUE(closeRelative(node.dvb_dvJ, fd, kTol)) << trial;
  }
}

INSTANTIATE_TEST_SUITE_P(Robots, Derivatives, ::testing::ValuesIn(test::robotCases()),
                         test::robotCaseName);

}  // namespace
}  // namespace rollstep::model
