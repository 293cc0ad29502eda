// CentroidalDynamics: analytic Jacobians (continuous and explicit Euler) against central
// differences on the manifold, physical sanity, allocation-free evaluation.
#include "rollstep/centroidal/dynamics.hpp"

#include <gtest/gtest.h>

#include "centroidal/fd_check.hpp"
#include "common/alloc_counter.hpp"

namespace rollstep::centroidal::test {
namespace {

struct Fixture {
  std::shared_ptr<const CentroidalRobot> robot = tachyon3Robot();
  std::shared_ptr<const CentroidalPrecomputation> pre =
      std::make_shared<const CentroidalPrecomputation>(robot);
  std::shared_ptr<const CentroidalDynamics> f = std::make_shared<const CentroidalDynamics>(pre);
  std::unique_ptr<ocp::NodeCache> cache = pre->createCache();
};

TEST(CentroidalDynamics, JacobiansMatchFiniteDifferences) {
  Fixture s;
  std::mt19937 rng(11);
  const FdTolerance tol{1e-6, 1e-5, 1e-6};
  for (int trial = 0; trial < 6; ++trial) {
    const Eigen::VectorXd x = randomState(*s.robot, rng);
    const Eigen::VectorXd u = randomInput(*s.robot, rng);
    // Through the shared node cache, then through the term's own fallback cache.
    NodeEvaluator with_cache{s.pre.get(), s.cache.get(),
                             makeContext(kAllStance, 0.0, nullptr, nullptr)};
    NodeEvaluator without{nullptr, nullptr, makeContext(kAllStance, 0.0, nullptr, nullptr)};
    EXPECT_TRUE(checkContinuousDynamicsDerivatives(*s.f, with_cache, x, u, tol)) << trial;
    EXPECT_TRUE(checkContinuousDynamicsDerivatives(*s.f, without, x, u, tol)) << trial;
  }
}

TEST(CentroidalDynamics, ExplicitEulerJacobiansMatchFiniteDifferences) {
  Fixture s;
  const ocp::ExplicitEuler F(s.f);
  std::mt19937 rng(12);
  for (int trial = 0; trial < 4; ++trial) {
    const Eigen::VectorXd x = randomState(*s.robot, rng);
    const Eigen::VectorXd u = randomInput(*s.robot, rng);
    NodeEvaluator ev{s.pre.get(), s.cache.get(), makeContext(kAllStance, 0.0, nullptr, nullptr)};
    EXPECT_TRUE(checkDynamicsDerivatives(F, ev, x, u, {1e-6, 1e-5, 1e-6})) << trial;
  }
}

TEST(CentroidalDynamics, TermsMatchTheirDefinition) {
  Fixture s;
  const CentroidalRobot& r = *s.robot;
  std::mt19937 rng(13);
  const Eigen::VectorXd x = randomState(r, rng);
  const Eigen::VectorXd u = randomInput(r, rng);
  auto d = s.f->createData();
  Eigen::VectorXd xdot(r.ndx());
  s.f->calc(makeContext(kAllStance, 0.0, nullptr, nullptr), x, u, *d, xdot);
  // Independent evaluation through the model layer.
  model::Data data(r.model());
  model::NodeQuantities nq(r.model(), r.frameIds());
  const lie::Vector6d h = x.tail<6>();
  model::computeNodeQuantitiesFromMomentum(r.model(), data, x.head(r.nq()), h, u.head(12),
                                           u.tail(18), nq);
  Eigen::Vector3d force = r.mass() * r.model().gravity, torque = Eigen::Vector3d::Zero();
  for (int i = 0; i < 6; ++i) {
    const Eigen::Vector3d fi = u.segment<3>(12 + 3 * i);
    const Eigen::Vector3d ground =
        nq.contactPositions.col(i) - kTachyon3WheelRadius * Eigen::Vector3d::UnitZ();
    force += fi;
    torque += (ground - nq.com).cross(fi);
  }
  EXPECT_TRUE(xdot.head<6>().isApprox(nq.v.head<6>(), 1e-12));
  EXPECT_EQ(xdot.segment(6, 12), u.head(12));
  EXPECT_TRUE(xdot.segment<3>(18).isApprox(force, 1e-12));
  EXPECT_TRUE(xdot.tail<3>().isApprox(torque, 1e-12));
  // The base twist reproduces the momentum: A (v_b, v_J) = h.
  EXPECT_TRUE(
      (nq.A.leftCols<6>() * xdot.head<6>() + nq.A.rightCols(12) * u.head(12)).isApprox(h, 1e-9));
}

TEST(CentroidalDynamics, StandingStillIsAnEquilibrium) {
  Fixture s;
  const CentroidalRobot& r = *s.robot;
  const Eigen::VectorXd x = nominalState(r);
  Eigen::VectorXd u = Eigen::VectorXd::Zero(r.nu());
  for (int i = 0; i < 6; ++i) u[r.inputForceIndex(i) + 2] = r.mass() * 9.81 / 6.0;
  auto d = s.f->createData();
  Eigen::VectorXd xdot(r.ndx());
  s.f->calc(makeContext(kAllStance, 0.0, nullptr, nullptr), x, u, *d, xdot);
  EXPECT_LT(xdot.norm(), 1e-9) << xdot.transpose();
  // Unbalanced: all the weight on the front row.
  u.setZero();
  for (int i : {LF, MF, RF}) u[r.inputForceIndex(i) + 2] = r.mass() * 9.81 / 3.0;
  s.f->calc(makeContext(kAllStance, 0.0, nullptr, nullptr), x, u, *d, xdot);
  EXPECT_NEAR(xdot.segment<3>(18).norm(), 0.0, 1e-9);
  // Torque about y of an upward force ahead of the COM: (x e_x) x (F e_z) = -x F e_y.
  EXPECT_LT(xdot[22], -100.0);
  EXPECT_NEAR(xdot[21], 0.0, 1e-6);
  EXPECT_NEAR(xdot[23], 0.0, 1e-6);
}

TEST(CentroidalDynamics, PureTranslationMomentumMovesTheBaseAtHOverM) {
  Fixture s;
  const CentroidalRobot& r = *s.robot;
  std::mt19937 rng(14);
  for (int trial = 0; trial < 3; ++trial) {
    Eigen::VectorXd x = randomState(r, rng);
    const Eigen::Vector3d h_lin(3.0, -2.0, 1.5);
    x.segment<3>(r.stateMomentumIndex()) = h_lin;
    x.tail<3>().setZero();
    const Eigen::VectorXd u = Eigen::VectorXd::Zero(r.nu());
    auto d = s.f->createData();
    Eigen::VectorXd xdot(r.ndx());
    s.f->calc(makeContext(0, 0.0, nullptr, nullptr), x, u, *d, xdot);
    const Eigen::Matrix3d R = Eigen::Quaterniond(x[6], x[3], x[4], x[5]).toRotationMatrix();
    // Base linear velocity in the LOCAL frame: R^T h_lin / m; no rotation.
    EXPECT_TRUE(xdot.head<3>().isApprox(R.transpose() * h_lin / r.mass(), 1e-9));
    EXPECT_LT(xdot.segment<3>(3).norm(), 1e-9);
    // Free fall: only gravity.
    EXPECT_TRUE(xdot.segment<3>(18).isApprox(r.mass() * r.model().gravity, 1e-12));
    EXPECT_LT(xdot.tail<3>().norm(), 1e-12);
  }
}

TEST(CentroidalDynamics, AllocationFree) {
  Fixture s;
  const ocp::ExplicitEuler F(s.f);
  std::mt19937 rng(15);
  const Eigen::VectorXd x = randomState(*s.robot, rng);
  const Eigen::VectorXd u = randomInput(*s.robot, rng);
  auto dc = s.f->createData();
  auto dd = F.createData();
  Eigen::VectorXd xdot(s.robot->ndx()), xnext(s.robot->nx());
  Eigen::MatrixXd fx(24, 24), fu(24, 30);
  const auto with = makeContext(kAllStance, 0.0, nullptr, s.cache.get());
  const auto without = makeContext(kAllStance, 0.0, nullptr, nullptr);
  rollstep::test::AllocationGuard guard;
  s.pre->compute(with, x, u, true, *s.cache);
  s.f->calc(with, x, u, *dc, xdot);
  s.f->calcDiff(with, x, u, *dc, fx, fu);
  F.calc(with, x, u, *dd, xnext);
  F.calcDiff(with, x, u, *dd, fx, fu);
  s.f->calc(without, x, u, *dc, xdot);
  s.f->calcDiff(without, x, u, *dc, fx, fu);
  EXPECT_EQ(guard.count(), 0u);
}

TEST(CentroidalDynamics, CalcDiffNeedsACacheWithDerivatives) {
  Fixture s;
  std::mt19937 rng(16);
  const Eigen::VectorXd x = randomState(*s.robot, rng);
  const Eigen::VectorXd u = randomInput(*s.robot, rng);
  const auto ctx = makeContext(kAllStance, 0.0, nullptr, s.cache.get());
  s.pre->compute(ctx, x, u, false, *s.cache);
  auto d = s.f->createData();
  Eigen::MatrixXd fx(24, 24), fu(24, 30);
  EXPECT_THROW(s.f->calcDiff(ctx, x, u, *d, fx, fu), std::logic_error);
  // A workspace made for nodes with a shared cache has none of its own.
  auto shared = s.f->createDataWithNodeCache();
  Eigen::VectorXd xdot(24);
  EXPECT_THROW(s.f->calc(makeContext(kAllStance, 0.0, nullptr, nullptr), x, u, *shared, xdot),
               std::logic_error);
  EXPECT_THROW(CentroidalDynamics(nullptr), std::invalid_argument);
}

}  // namespace
}  // namespace rollstep::centroidal::test
