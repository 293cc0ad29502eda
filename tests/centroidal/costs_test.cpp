// Cost residuals: base velocity tracking, state tracking to x_ref(t), input tracking to
// u_ref(t). References, Jacobians and LeastSquaresCost gradients against central
// differences on the manifold, no allocation.
#include "rollstep/centroidal/costs.hpp"

#include <gtest/gtest.h>

#include "centroidal/fd_check.hpp"
#include "common/alloc_counter.hpp"
#include "rollstep/ocp/cost.hpp"

namespace rollstep::centroidal::test {
namespace {

struct Fixture {
  std::shared_ptr<const CentroidalRobot> robot = tachyon3Robot();
  std::shared_ptr<const CentroidalPrecomputation> pre =
      std::make_shared<const CentroidalPrecomputation>(robot);
  std::unique_ptr<ocp::NodeCache> cache = pre->createCache();
  Tachyon3Scene scene = makeTachyon3Scene("trot", 0.4);
  Eigen::VectorXd q_j_ref = nominalState(*robot).segment(7, 12);
  std::shared_ptr<const BaseVelocityResidual> velocity =
      std::make_shared<const BaseVelocityResidual>(pre, scene.base);
  std::shared_ptr<const StateTrackingResidual> state =
      std::make_shared<const StateTrackingResidual>(robot, q_j_ref, scene.base);
  std::shared_ptr<const InputTrackingResidual> input =
      std::make_shared<const InputTrackingResidual>(robot);
};

TEST(Costs, BaseVelocityResidual) {
  Fixture s;
  std::mt19937 rng(31);
  const auto& space = *s.robot->space();
  for (int trial = 0; trial < 4; ++trial) {
    const Eigen::VectorXd x = randomState(*s.robot, rng);
    const Eigen::VectorXd u = randomInput(*s.robot, rng);
    const auto ctx = makeContext(kAllStance, 0.2, s.scene.schedule.get(), nullptr);
    EXPECT_TRUE(
        checkResidualDerivatives(*s.velocity, space, {s.pre.get(), s.cache.get(), ctx}, x, u));
    EXPECT_TRUE(checkResidualDerivatives(*s.velocity, space, {nullptr, nullptr, ctx}, x, u));
    EXPECT_TRUE(refusesCallsWithoutNodeCache(*s.velocity, ctx, x, u));
    // Value: v_b - twist of the base reference.
    auto d = s.velocity->createData();
    d->rows = 6;
    s.velocity->calc(ctx, x, u, *d);
    model::Data data(s.robot->model());
    model::NodeQuantities nq(s.robot->model(), s.robot->frameIds());
    const lie::Vector6d h = x.tail<6>();
    model::computeNodeQuantitiesFromMomentum(s.robot->model(), data, x.head(19), h, u.head(12),
                                             u.tail(18), nq);
    const lie::Vector6d expected = nq.v.head<6>() - s.scene.base->twist();
    EXPECT_TRUE(d->r.head<6>().isApprox(expected, 1e-12));
    EXPECT_DOUBLE_EQ(s.scene.base->twist()[0], 0.4);
  }
  // Constant reference without a base reference.
  BaseVelocityResidual constant(s.pre);
  lie::Vector6d v_ref;
  v_ref << 0.1, 0.2, 0.0, 0.0, 0.0, -0.3;
  constant.setReference(v_ref);
  EXPECT_EQ(constant.reference(makeContext(0, 1.0, nullptr, nullptr)), v_ref);
  EXPECT_THROW(BaseVelocityResidual(nullptr), std::invalid_argument);
}

TEST(Costs, StateTrackingReference) {
  Fixture s;
  Eigen::VectorXd x_ref(s.robot->nx());
  for (double t : {0.0, 0.5, 1.3}) {
    s.state->reference(makeContext(kAllStance, t, nullptr, nullptr), x_ref);
    EXPECT_TRUE(x_ref.head<7>().isApprox(s.scene.base->poseAt(t).coeffs(), 1e-15));
    EXPECT_EQ(x_ref.segment(7, 12), s.q_j_ref);
    EXPECT_TRUE(x_ref.tail<6>().isZero(0.0));
  }
  // The base moves forward along the reference.
  s.state->reference(makeContext(kAllStance, 1.0, nullptr, nullptr), x_ref);
  EXPECT_GT(x_ref[0], 0.3);
  EXPECT_NEAR(x_ref[2], 0.375, 1e-12);
  // Constant base pose without a base reference.
  lie::Vector7d pose;
  pose << 1.0, 2.0, 0.4, 0.0, 0.0, std::sin(0.25), std::cos(0.25);
  const StateTrackingResidual constant(s.robot, s.q_j_ref, nullptr, pose);
  constant.reference(makeContext(0, 5.0, nullptr, nullptr), x_ref);
  EXPECT_EQ(x_ref.head<7>(), pose);
  EXPECT_THROW(StateTrackingResidual(s.robot, Eigen::VectorXd::Zero(3)), std::invalid_argument);
  pose[6] = 2.0;
  EXPECT_THROW(StateTrackingResidual(s.robot, s.q_j_ref, nullptr, pose), std::invalid_argument);
}

TEST(Costs, InputTrackingReference) {
  Fixture s;
  const double weight = s.robot->mass() * 9.81;
  Eigen::VectorXd u_ref(s.robot->nu());
  for (int mode : {kAllStance, maskOf({LF, RF, MR}), maskOf({MF}), 0}) {
    s.input->reference(makeContext(mode, 0.0, nullptr, nullptr), u_ref);
    const int n = planning::contactCount(mode);
    EXPECT_TRUE(u_ref.head(12).isZero(0.0));
    double total = 0.0;
    for (int i = 0; i < 6; ++i) {
      const Eigen::Vector3d f = u_ref.segment<3>(12 + 3 * i);
      EXPECT_EQ(f.head<2>(), Eigen::Vector2d::Zero());
      EXPECT_NEAR(f.z(), CentroidalRobot::inStance(mode, i) ? weight / n : 0.0, 1e-9);
      total += f.z();
    }
    EXPECT_NEAR(total, n > 0 ? weight : 0.0, 1e-9) << "mode " << mode;
  }
}

// The warm-start refit (CentroidalOcp's InputGuess): only the force entries change, to
// the input tracking reference of the mode; joint velocities are kept.
TEST(Costs, StanceForceReferenceKeepsJointVelocities) {
  Fixture s;
  std::mt19937 rng(33);
  Eigen::VectorXd u_ref(s.robot->nu());
  for (int mode : {kAllStance, maskOf({LF, RF, MR}), maskOf({MF, LR, RR}), 0}) {
    const Eigen::VectorXd u0 = randomInput(*s.robot, rng);
    Eigen::VectorXd u = u0;
    rollstep::test::AllocationGuard guard;
    setStanceForceReference(*s.robot, mode, u);
    EXPECT_EQ(guard.count(), 0u);
    s.input->reference(makeContext(mode, 0.0, nullptr, nullptr), u_ref);
    EXPECT_EQ(u.head(12), u0.head(12)) << "mode " << mode;
    EXPECT_EQ(u.tail(18), u_ref.tail(18)) << "mode " << mode;
  }
}

TEST(Costs, LeastSquaresGradientsMatchFiniteDifferences) {
  Fixture s;
  const auto& space = *s.robot->space();
  const ocp::LeastSquaresCost velocity_cost(s.velocity, Eigen::VectorXd::Constant(6, 2.0));
  const ocp::LeastSquaresCost state_cost(s.state,
                                         Eigen::VectorXd::LinSpaced(s.robot->ndx(), 0.5, 3.0));
  const ocp::LeastSquaresCost input_cost(s.input,
                                         Eigen::VectorXd::LinSpaced(s.robot->nu(), 0.1, 1.0));
  std::mt19937 rng(32);
  for (int mode : {kAllStance, maskOf({LF, RF, MR}), maskOf({MF, LR, RR})}) {
    const double t = s.scene.timeInMode(mode);
    const Eigen::VectorXd x = randomState(*s.robot, rng);
    const Eigen::VectorXd u = randomInput(*s.robot, rng);
    const NodeEvaluator ev{s.pre.get(), s.cache.get(),
                           makeContext(mode, t, s.scene.schedule.get(), nullptr)};
    const FdTolerance tol{1e-6, 1e-5, 1e-5};
    EXPECT_TRUE(checkResidualDerivatives(*s.state, space, ev, x, u, tol)) << mode;
    EXPECT_TRUE(checkResidualDerivatives(*s.input, space, ev, x, u, tol)) << mode;
    EXPECT_TRUE(checkCostGradient(velocity_cost, space, ev, x, u, tol)) << mode;
    EXPECT_TRUE(checkCostGradient(state_cost, space, ev, x, u, tol)) << mode;
    EXPECT_TRUE(checkCostGradient(input_cost, space, ev, x, u, tol)) << mode;
  }
}

TEST(Costs, AllocationFree) {
  Fixture s;
  const ocp::LeastSquaresCost velocity_cost(s.velocity, Eigen::VectorXd::Constant(6, 2.0));
  const ocp::LeastSquaresCost state_cost(s.state, Eigen::VectorXd::Ones(s.robot->ndx()));
  const ocp::LeastSquaresCost input_cost(s.input, Eigen::VectorXd::Ones(s.robot->nu()));
  const std::vector<const ocp::CostTerm*> costs{&velocity_cost, &state_cost, &input_cost};
  std::vector<std::unique_ptr<ocp::CostData>> data;
  for (const auto* c : costs) data.push_back(c->createData());
  std::mt19937 rng(33);
  const Eigen::VectorXd x = randomState(*s.robot, rng);
  const Eigen::VectorXd u = randomInput(*s.robot, rng);
  const int ndx = s.robot->ndx(), nu = s.robot->nu();
  Eigen::VectorXd lx = Eigen::VectorXd::Zero(ndx), lu = Eigen::VectorXd::Zero(nu);
  Eigen::MatrixXd Lxx = Eigen::MatrixXd::Zero(ndx, ndx), Luu = Eigen::MatrixXd::Zero(nu, nu),
                  Lux = Eigen::MatrixXd::Zero(nu, ndx);
  const auto ctx = makeContext(kAllStance, 0.3, s.scene.schedule.get(), s.cache.get());
  rollstep::test::AllocationGuard guard;
  s.pre->compute(ctx, x, u, true, *s.cache);
  for (std::size_t k = 0; k < costs.size(); ++k) {
    costs[k]->calc(ctx, x, u, *data[k]);
    costs[k]->calcDiff(ctx, x, u, *data[k], 0.015, lx, lu, Lxx, Luu, Lux);
  }
  EXPECT_EQ(guard.count(), 0u);
}

}  // namespace
}  // namespace rollstep::centroidal::test
