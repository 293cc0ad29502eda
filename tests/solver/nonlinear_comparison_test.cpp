// Proof of correctness on nonlinear problems (issue 4): our solver in Converging mode
// converges on the cart-pole swing-up, the unicycle with obstacles and a speed-profile
// equality, and the rigid body on SE(3); it matches Ipopt on the same multiple-shooting
// transcription (cost to 1e-6 relative), and its KKT residual, computed here from the
// problem's linearisation at our solution and our returned multipliers (not from the
// solver's own statistics), is below 1e-8.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "ipopt_reference.hpp"
#include "nonlinear_problems.hpp"
#include "rollstep/solver/solver.hpp"
#include "solver_multipliers.hpp"

namespace rollstep::nltest {
namespace {

using solver::Solver;
using solver::SolverSettings;
using solver::SolverStatus;

double maxInputDifference(const std::vector<VectorXd>& a, const std::vector<VectorXd>& b) {
  double m = 0.0;
  for (size_t k = 0; k < a.size(); ++k) m = std::max(m, (a[k] - b[k]).lpNorm<Eigen::Infinity>());
  return m;
}

/// The comparison settings: the solver's defaults (max_iterations = 100).
/// ROLLSTEP_NL_MAX_ITER overrides the limit (investigations).
SolverSettings comparisonSettings() {
  SolverSettings s;
  if (const char* env = std::getenv("ROLLSTEP_NL_MAX_ITER")) s.max_iterations = std::atoi(env);
  return s;
}

/// Iteration budget relative to Ipopt (exact Hessian, same transcription): with the
/// Gauss-Newton Hessian alone the swing-up took 879 iterations (Ipopt 61), now ~46.
int iterationBound(int ipopt_iterations) { return std::max(20, (3 * ipopt_iterations) / 2); }

void compareWithIpopt(const ProblemInstance& inst,
                      const SolverSettings& settings = comparisonSettings()) {
  const auto& pb = *inst.problem;
  const IpoptResult ref = solveWithIpopt(pb, inst.x0, inst.xs_guess, inst.us_guess);
  ASSERT_TRUE(ref.success) << inst.name << ": Ipopt " << ref.status_string;

  Solver s(inst.problem, settings);
  s.setInitialGuess(inst.xs_guess, inst.us_guess);
  const SolverStatus st = s.solve(inst.x0);
  const double ours = totalCost(pb, s.states(), s.inputs());
  const KktReport kkt = kktResidual(pb, inst.x0, s.states(), s.inputs(), solverMultipliers(s, pb));
  const KktReport fit = kktResidual(pb, inst.x0, s.states(), s.inputs());
  std::printf(
      "[%s] ours: status %s iters %d cost %.12g (solver %.12g) | ipopt: cost %.12g iters %d\n"
      "[%s] rel cost diff %.2e  max |du| %.2e  KKT (our duals): stat %.2e primal %.2e compl %.2e "
      "sign %.2e | KKT (fitted duals) %.2e\n",
      inst.name.c_str(), solver::toString(st), s.iterations(), ours, s.cost(), ref.cost,
      ref.iterations, inst.name.c_str(), std::abs(ours - ref.cost) / std::abs(ref.cost),
      maxInputDifference(s.inputs(), ref.us), kkt.stationarity, kkt.primal, kkt.complementarity,
      kkt.dual_sign, fit.max());
  EXPECT_EQ(st, SolverStatus::Converged) << inst.name << ": " << s.message();
  EXPECT_LE(s.iterations(), iterationBound(ref.iterations)) << inst.name;
  EXPECT_NEAR(ours, ref.cost, 1e-6 * std::abs(ref.cost)) << inst.name;
  EXPECT_NEAR(s.cost(), ours, 1e-9 * std::abs(ours)) << inst.name;
  EXPECT_LT(kkt.stationarity, 1e-8) << inst.name;
  EXPECT_LT(kkt.primal, 1e-8) << inst.name;
  EXPECT_LT(kkt.complementarity, 1e-8) << inst.name;
  EXPECT_LT(kkt.dual_sign, 1e-12) << inst.name;
}

TEST(NonlinearComparison, CartPoleSwingUpMatchesIpopt) { compareWithIpopt(makeCartPole()); }

TEST(NonlinearComparison, CartPoleEulerMatchesIpopt) {
  CartPoleOptions o;
  o.rk4 = false;
  o.horizon = 60;
  o.dt = 0.04;
  compareWithIpopt(makeCartPole(o));
}

TEST(NonlinearComparison, UnicycleWithObstaclesAndSpeedProfileMatchesIpopt) {
  compareWithIpopt(makeUnicycle());
}

TEST(NonlinearComparison, UnicycleTwoObstaclesMatchesIpopt) {
  UnicycleOptions o;
  o.hard_obstacles = {{1.5, -0.15, 0.4}, {3.0, 0.35, 0.3}};
  compareWithIpopt(makeUnicycle(o));
}

TEST(NonlinearComparison, UnicycleGaussNewtonOnlyStillMatchesIpopt) {
  // exact_hessian = false (Gauss-Newton Hessian, filter line search) stays usable: it
  // converges linearly, ~60 iterations here against ~11 with the curvature.
  SolverSettings set = comparisonSettings();
  set.exact_hessian = false;
  // Linear convergence: the count moves with rounding (63 here; a reordering of the
  // condensing arithmetic took it past 100), so leave room.
  set.max_iterations = 300;
  const auto inst = makeUnicycle();
  const IpoptResult ref = solveWithIpopt(*inst.problem, inst.x0, inst.xs_guess, inst.us_guess);
  ASSERT_TRUE(ref.success) << ref.status_string;
  Solver s(inst.problem, set);
  s.setInitialGuess(inst.xs_guess, inst.us_guess);
  // Linear convergence: it may stop at the acceptable level (KKT error below 1e-6 for 15
  // iterations in a row), reported as such.
  const SolverStatus st = s.solve(inst.x0);
  EXPECT_TRUE(st == SolverStatus::Converged || st == SolverStatus::Acceptable) << s.message();
  const double ours = totalCost(*inst.problem, s.states(), s.inputs());
  std::printf("[unicycle GN] iters %d cost %.12g ipopt %.12g\n", s.iterations(), ours, ref.cost);
  EXPECT_NEAR(ours, ref.cost, 1e-6 * std::abs(ref.cost));
}

TEST(NonlinearComparison, RigidBodyOnSE3MatchesIpopt) { compareWithIpopt(makeRigidBody()); }

TEST(NonlinearComparison, RigidBodyWithGravityAndActiveBoundsMatchesIpopt) {
  RigidBodyOptions o;
  o.params.gravity = Eigen::Vector3d(0.0, 0.0, -9.81);
  o.force_limit = 25.0;
  o.torque_limit = 0.6;  // active on about 16 of the 90 torque rows
  compareWithIpopt(makeRigidBody(o));
}

TEST(NonlinearComparison, GaussNewtonLimitLargeCostatesStillReachIpoptCost) {
  // Large costates (terminal weight 200, a 2.5 rad turn under a 0.3 N m torque limit,
  // |lambda| ~ 14): the Gauss-Newton Hessian alone misses lambda^T F'' of the SE(3)
  // defects and stalled near KKT 1e-7 (MaxIterations at 200, cost 2e-8 off); with the
  // constraint curvature (exact_hessian) it converges like Ipopt (48 iterations).
  RigidBodyOptions o;
  o.params.gravity = Eigen::Vector3d(0.0, 0.0, -9.81);
  o.force_limit = 25.0;
  o.torque_limit = 0.3;
  o.target_angle = 2.5;
  compareWithIpopt(makeRigidBody(o));
}

/// Slope of the relaxed log barrier (Feller and Jones), written out independently of the
/// solver: -1/c above delta, the quadratic extension below.
double relaxedLogSlope(double c, double delta) {
  return c > delta ? -1.0 / c : (c - 2.0 * delta) / (delta * delta);
}

struct SoftSolve {
  SolverStatus status;
  std::vector<VectorXd> xs, us;
  int iterations = 0;
  double clearance = 1e9;  ///< signed distance to the soft obstacle's boundary
  KktReport kkt;           ///< KKT of cost + weight * relaxed barrier (soft rows as costs)
};

SoftSolve solveWithSoftObstacle(double weight) {
  UnicycleOptions o;
  o.soft_obstacles = {{3.0, 0.3, 0.3}};
  o.soft_weight = weight;
  const auto inst = makeUnicycle(o);
  const auto& pb = *inst.problem;
  Solver s(inst.problem, comparisonSettings());
  s.setInitialGuess(inst.xs_guess, inst.us_guess);
  SoftSolve r;
  r.status = s.solve(inst.x0);
  r.xs = s.states();
  r.us = s.inputs();
  r.iterations = s.iterations();
  for (const auto& x : r.xs)
    r.clearance = std::min(r.clearance, std::hypot(x[0] - 3.0, x[1] - 0.3) - 0.3);
  // A soft row adds weight * beta(g) to the cost: its gradient is that of -z g with
  // z = -weight * beta'(g) > 0, so pass those as the duals of the soft rows.
  KktInputs in = solverMultipliers(s, pb);
  auto d = pb.createNodeData();
  std::vector<VectorXd> soft_z;
  for (int k = 0; k <= pb.horizon(); ++k) {
    const auto kk = static_cast<size_t>(k);
    pb.evaluate(k, r.xs[kk], k < pb.horizon() ? r.us[kk] : VectorXd::Zero(pb.nu()), *d);
    VectorXd z = s.inequalityDuals(k).head(d->ni);
    for (int i = 0; i < d->ni; ++i) {
      if (d->soft[i]) z[i] = -weight * relaxedLogSlope(d->g[i], d->relaxation[i]);
    }
    soft_z.push_back(z);
  }
  in.inequality_duals = [soft_z](int k) { return soft_z[static_cast<size_t>(k)]; };
  r.kkt = kktResidual(pb, inst.x0, r.xs, r.us, in);
  std::printf(
      "[soft obstacle w=%g] status %s iters %d cost %.12g, min clearance %.4g, KKT stat "
      "%.2e primal %.2e: %s\n",
      weight, solver::toString(r.status), r.iterations, s.cost(), r.clearance, r.kkt.stationarity,
      r.kkt.primal, s.message());
  return r;
}

TEST(NonlinearComparison, SoftObstacleConvergesToWeightedRelaxedBarrierMinimiser) {
  // Soft (relaxed-barrier) obstacle with its own fixed weight: the converged solution is a
  // KKT point of cost + weight * beta_delta(g) (no Ipopt reference: the relaxed barrier is
  // not reproduced there); the barrier does not fade with mu, so the weight matters.
  const SoftSolve light = solveWithSoftObstacle(1e-3);
  const SoftSolve heavy = solveWithSoftObstacle(1e-1);
  for (const SoftSolve* r : {&light, &heavy}) {
    EXPECT_EQ(r->status, SolverStatus::Converged);
    EXPECT_LE(r->iterations, 30);
    EXPECT_LT(r->kkt.stationarity, 1e-8);
    EXPECT_LT(r->kkt.primal, 1e-8);  // hard rows, equalities, defects (soft rows excluded)
    EXPECT_LT(r->kkt.complementarity, 1e-8);
    EXPECT_LT(r->kkt.dual_sign, 1e-12);
  }
  // The heavier barrier keeps the path further out of the soft obstacle.
  EXPECT_GT(heavy.clearance, light.clearance + 1e-2);
  EXPECT_GT(maxInputDifference(light.us, heavy.us), 1e-3);
}

}  // namespace
}  // namespace rollstep::nltest
