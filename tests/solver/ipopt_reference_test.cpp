// Trust in the Ipopt reference: on linear-quadratic problems with known answers (discrete
// Riccati, a one-step problem with an active bound) the adapter reproduces them, and on
// the nonlinear test problems Ipopt's solution satisfies our independent KKT check.
#include "ipopt_reference.hpp"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cstdio>
#include <string>
#include <vector>

#include "nonlinear_problems.hpp"
#include "rollstep/ocp/cost.hpp"
#include "rollstep/ocp/residuals.hpp"

namespace rollstep::nltest {
namespace {

/// xdot = A x + B u.
class LinearDynamics final : public ocp::ContinuousDynamics {
 public:
  LinearDynamics(const MatrixXd& A, const MatrixXd& B)
      : ContinuousDynamics(std::make_shared<ocp::EuclideanSpace>(static_cast<int>(A.rows())),
                           static_cast<int>(B.cols())),
        A_(A),
        B_(B) {}
  std::unique_ptr<ocp::DynamicsData> createData() const override {
    return std::make_unique<ocp::DynamicsData>();
  }
  void calc(const ocp::NodeContext&, ConstVecRef x, ConstVecRef u, ocp::DynamicsData&,
            VecRef xdot) const override {
    xdot = A_ * x + B_ * u;
  }
  void calcDiff(const ocp::NodeContext&, ConstVecRef, ConstVecRef, ocp::DynamicsData&, MatRef fx,
                MatRef fu) const override {
    fx = A_;
    fu = B_;
  }

 private:
  MatrixXd A_, B_;
};

struct Lq {
  std::shared_ptr<ocp::OptimalControlProblem> pb;
  MatrixXd A, B;  // discrete (explicit Euler)
  double q, r, qf, dt;
  int N;
};

Lq makeLq(int N, double dt, double q, double r, double qf) {
  MatrixXd Ac(2, 2), Bc(2, 1);
  Ac << 0, 1, -0.5, -0.1;
  Bc << 0, 1;
  auto f = std::make_shared<LinearDynamics>(Ac, Bc);
  auto pb =
      std::make_shared<ocp::OptimalControlProblem>(std::make_shared<ocp::ExplicitEuler>(f), N, dt);
  auto xerr = std::make_shared<ocp::StateErrorResidual>(f->spacePtr(), 1, VectorXd::Zero(2));
  pb->addCost("x", std::make_shared<ocp::LeastSquaresCost>(xerr, VectorXd::Constant(2, q)));
  pb->addCost("u", std::make_shared<ocp::LeastSquaresCost>(
                       std::make_shared<ocp::InputErrorResidual>(2, VectorXd::Zero(1)),
                       VectorXd::Constant(1, r)));
  pb->addCost("xf", std::make_shared<ocp::LeastSquaresCost>(xerr, VectorXd::Constant(2, qf)),
              ocp::Stage::Terminal);
  Lq lq{pb, MatrixXd::Identity(2, 2) + dt * Ac, dt * Bc, q, r, qf, dt, N};
  return lq;
}

TEST(IpoptReference, UnconstrainedLqMatchesRiccati) {
  const Lq lq = makeLq(30, 0.1, 1.0, 0.1, 10.0);
  const int N = lq.N;
  // Discrete Riccati on the same transcription (running cost dt * l).
  std::vector<MatrixXd> K(static_cast<size_t>(N));
  MatrixXd P = lq.qf * MatrixXd::Identity(2, 2);
  const MatrixXd Q = lq.q * lq.dt * MatrixXd::Identity(2, 2);
  const MatrixXd R = lq.r * lq.dt * MatrixXd::Identity(1, 1);
  for (int k = N - 1; k >= 0; --k) {
    const MatrixXd S = R + lq.B.transpose() * P * lq.B;
    K[static_cast<size_t>(k)] = S.ldlt().solve(lq.B.transpose() * P * lq.A);
    P = Q + lq.A.transpose() * P * (lq.A - lq.B * K[static_cast<size_t>(k)]);
  }
  VectorXd x0(2);
  x0 << 1.0, -0.5;
  const double cost_riccati = 0.5 * x0.dot(P * x0);
  std::vector<VectorXd> us_ref;
  VectorXd x = x0;
  for (int k = 0; k < N; ++k) {
    us_ref.push_back(-K[static_cast<size_t>(k)] * x);
    x = lq.A * x + lq.B * us_ref.back();
  }

  for (bool exact : {true, false}) {
    IpoptOptions opt;
    opt.exact_hessian = exact;
    const auto res = solveWithIpopt(
        *lq.pb, x0, std::vector<VectorXd>(static_cast<size_t>(N + 1), VectorXd::Zero(2)),
        std::vector<VectorXd>(static_cast<size_t>(N), VectorXd::Zero(1)), opt);
    ASSERT_TRUE(res.success) << res.status_string;
    EXPECT_NEAR(res.cost, cost_riccati, 1e-9 * cost_riccati) << "exact=" << exact;
    for (int k = 0; k < N; ++k)
      EXPECT_NEAR(res.us[static_cast<size_t>(k)][0], us_ref[static_cast<size_t>(k)][0], 1e-6);
    EXPECT_LT(res.max_violation, 1e-9);
    EXPECT_LT(kktResidual(*lq.pb, x0, res.xs, res.us).max(), 1e-7);
  }
}

TEST(IpoptReference, OneStepWithActiveInputBound) {
  // min dt/2 (q x0^2 + r u^2) + qf/2 x1^2 with x1 = A x0 + B u, u >= -umax.
  const Lq lq = makeLq(1, 0.1, 1.0, 0.1, 10.0);
  VectorXd x0(2);
  x0 << 2.0, 1.0;
  const double umax = 0.5;
  lq.pb->setInputBounds(VectorXd::Constant(1, -umax), VectorXd::Constant(1, 10.0));
  // Unconstrained minimiser (convex scalar): u = -(B'Qf A x0) / (r dt + B'Qf B) < -umax.
  const double bqa = (lq.B.transpose() * lq.qf * lq.A * x0)(0);
  const double bqb = (lq.B.transpose() * lq.qf * lq.B)(0);
  const double u_free = -bqa / (lq.r * lq.dt + bqb);
  ASSERT_LT(u_free, -umax);
  const VectorXd x1 = lq.A * x0 + lq.B * VectorXd::Constant(1, -umax);
  const double cost =
      0.5 * lq.dt * (lq.q * x0.squaredNorm() + lq.r * umax * umax) + 0.5 * lq.qf * x1.squaredNorm();
  const auto res = solveWithIpopt(*lq.pb, x0, {x0, x0}, {VectorXd::Zero(1)});
  ASSERT_TRUE(res.success) << res.status_string;
  EXPECT_NEAR(res.us[0][0], -umax, 1e-9);
  EXPECT_NEAR(res.cost, cost, 1e-9 * cost);
  const KktReport kkt = kktResidual(*lq.pb, x0, res.xs, res.us);
  EXPECT_LT(kkt.max(), 1e-8);
}

TEST(IpoptReference, KktCheckRejectsAPerturbedSolution) {
  const Lq lq = makeLq(20, 0.1, 1.0, 0.1, 10.0);
  VectorXd x0(2);
  x0 << 1.0, 0.0;
  auto res = solveWithIpopt(*lq.pb, x0, std::vector<VectorXd>(21, x0),
                            std::vector<VectorXd>(20, VectorXd::Zero(1)));
  ASSERT_TRUE(res.success);
  EXPECT_LT(kktResidual(*lq.pb, x0, res.xs, res.us).max(), 1e-8);
  res.us[5][0] += 1e-3;
  const auto xs = rollout(*lq.pb, x0, res.us);
  const KktReport bad = kktResidual(*lq.pb, x0, xs, res.us);
  EXPECT_GT(bad.stationarity, 1e-6);
  EXPECT_LT(bad.primal, 1e-12);
}

TEST(IpoptReference, SolvesTheNonlinearProblemsToAKktPoint) {
  for (const auto& inst : {makeCartPole(), makeUnicycle(), makeRigidBody()}) {
    const auto res = solveWithIpopt(*inst.problem, inst.x0, inst.xs_guess, inst.us_guess);
    ASSERT_TRUE(res.success) << inst.name << ": " << res.status_string;
    EXPECT_LT(res.max_violation, 1e-8) << inst.name;
    // Independent check with fitted multipliers, then with Ipopt's own ones
    // (Ipopt: L = f + lambda^T c, so z = -lambda for g >= 0).
    const KktReport fit = kktResidual(*inst.problem, inst.x0, res.xs, res.us);
    KktInputs in;
    in.equality_multipliers = [&](int k) {
      return k < inst.problem->horizon() ? res.equality_multipliers[static_cast<size_t>(k)]
                                         : VectorXd();
    };
    in.inequality_duals = [&](int k) {
      return VectorXd(-res.inequality_multipliers[static_cast<size_t>(k)]);
    };
    const KktReport given = kktResidual(*inst.problem, inst.x0, res.xs, res.us, in);
    std::printf("[ipopt] %-10s cost %.12g iters %d viol %.2e kkt(fit) %.2e kkt(ipopt duals) %.2e\n",
                inst.name.c_str(), res.cost, res.iterations, res.max_violation, fit.max(),
                given.max());
    EXPECT_LT(fit.max(), 1e-7) << inst.name;
    EXPECT_LT(given.max(), 1e-7) << inst.name;
    // The solutions do what the problems ask for.
    VectorXd err(inst.problem->ndx());
    inst.problem->stateSpace().difference(inst.x_goal, res.xs.back(), err);
    std::printf("[ipopt] %-10s terminal error inf-norm %.3g (position part %.3g)\n",
                inst.name.c_str(), err.lpNorm<Eigen::Infinity>(),
                err.head(2).lpNorm<Eigen::Infinity>());
    const double tol_goal = inst.name == "unicycle" ? 0.2 : 0.1;
    EXPECT_LT(err.head(inst.name == "unicycle" ? 2 : err.size()).lpNorm<Eigen::Infinity>(),
              tol_goal)
        << inst.name;
    const auto xs_guess = rollout(*inst.problem, inst.x0, inst.us_guess);
    if (inst.name != "unicycle") {  // the unicycle guess violates the speed profile
      EXPECT_LT(res.cost, totalCost(*inst.problem, xs_guess, inst.us_guess)) << inst.name;
    }
  }
}

/// Issue 17: the problems with many active bounds are solved by Ipopt (exact Hessian by
/// finite differences) from both starts to a KKT point, and their optima keep many rows
/// of the bounds and keep-out inequalities active (within 1e-6), so that the solver
/// comparison on them (nonlinear_robustness_test) keeps meaning what it says.
struct ActiveBoundCase {
  ProblemInstance inst;
  int min_input_active, min_state_active, min_inequality_active;
};

TEST(IpoptReference, ManyActiveBoundProblemsSolveFromTwoStarts) {
  // Measured (Ipopt 3.11.9, exact Hessian by differences; both starts reach the same
  // optimum; active rows within 1e-6: input bounds / state bounds / keep-out rows):
  //   problem           cost            iterations (default, interpolated)  active
  //   two_link_arm      4.09596258244   80, 28    37 / 12 (velocity, elbow limit) / 1
  //   planar_quadrotor  2.91948038213   57, 41    21 / 2 (tilt) / 3 (both discs)
  //   bicycle           12.5792415533   64, 55    42 / 23 (speed) / 2
  // The minimum counts asserted are about 80 % of these.
  const std::vector<ActiveBoundCase> cases = {
      {makeTwoLinkArm(), 30, 9, 1},
      {makePlanarQuadrotor(), 17, 2, 2},
      {makeBicycle(), 34, 18, 2},
  };
  for (const auto& c : cases) {
    const auto& pb = *c.inst.problem;
    std::vector<double> costs;
    for (const auto& start : twoStarts(c.inst)) {
      const auto res = solveWithIpopt(pb, c.inst.x0, start.xs, start.us);
      const std::string what = c.inst.name + " from " + start.name;
      ASSERT_TRUE(res.success) << what << ": " << res.status_string;
      EXPECT_LT(res.max_violation, 1e-8) << what;
      const KktReport fit = kktResidual(pb, c.inst.x0, res.xs, res.us);
      EXPECT_LT(fit.max(), 1e-7) << what;
      const ActiveSetCount n = countActive(pb, res.xs, res.us);
      VectorXd err(pb.ndx());
      pb.stateSpace().difference(c.inst.x_goal, res.xs.back(), err);
      std::printf(
          "[ipopt] %-16s %-12s cost %.12g iters %d kkt(fit) %.2e active: input %d state %d "
          "inequality %d, terminal error %.3g\n",
          c.inst.name.c_str(), start.name.c_str(), res.cost, res.iterations, fit.max(),
          n.input_bounds, n.state_bounds, n.inequalities, err.lpNorm<Eigen::Infinity>());
      EXPECT_GE(n.input_bounds, c.min_input_active) << what;
      EXPECT_GE(n.state_bounds, c.min_state_active) << what;
      EXPECT_GE(n.inequalities, c.min_inequality_active) << what;
      EXPECT_LT(err.lpNorm<Eigen::Infinity>(), 0.05) << what;  // reaches the goal
      costs.push_back(res.cost);
    }
    // One optimum from both starts (no local minimum trap: see the options' comments).
    EXPECT_NEAR(costs[0], costs[1], 1e-6 * std::abs(costs[0])) << c.inst.name;
  }
}

TEST(IpoptReference, SoftInequalitiesAreRejectedUnlessHard) {
  UnicycleOptions o;
  o.soft_obstacles = {{3.0, 0.8, 0.3}};
  const auto inst = makeUnicycle(o);
  EXPECT_THROW(solveWithIpopt(*inst.problem, inst.x0, inst.xs_guess, inst.us_guess),
               std::invalid_argument);
}

}  // namespace
}  // namespace rollstep::nltest
