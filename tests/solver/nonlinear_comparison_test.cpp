// Proof of correctness on nonlinear problems (issue 4): our solver in Converging mode
// converges on the cart-pole swing-up, the unicycle with obstacles and a speed-profile
// equality, and the rigid body on SE(3); it matches Ipopt on the same multiple-shooting
// transcription (cost to 1e-6 relative), and its KKT residual, computed here from the
// problem's linearisation at our solution and our returned multipliers (not from the
// solver's own statistics), is below 1e-8.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "ipopt_reference.hpp"
#include "nonlinear_problems.hpp"
#include "rollstep/solver/solver.hpp"

namespace rollstep::nltest {
namespace {

using solver::Solver;
using solver::SolverSettings;
using solver::SolverStatus;

/// The solver's multipliers in the layout kktResidual expects (documented in solver.hpp:
/// L = cost + nu^T e + lambda^T defects - z^T g; duals [general | input lo, hi | state lo, hi]).
KktInputs solverMultipliers(const Solver& s, const ocp::OptimalControlProblem& pb) {
  auto d = pb.createNodeData();
  std::vector<int> ne, ni;
  const VectorXd u0 = VectorXd::Zero(pb.nu());
  for (int k = 0; k <= pb.horizon(); ++k) {
    const auto kk = static_cast<size_t>(k);
    pb.evaluate(k, s.states()[kk], k < pb.horizon() ? s.inputs()[kk] : u0, *d);
    ne.push_back(k < pb.horizon() ? d->ne : 0);
    ni.push_back(d->ni);
  }
  const int mi = pb.maxInequalities(), nbu = pb.inputBounds().size(), nbx = pb.stateBounds().size();
  KktInputs in;
  in.equality_sign = 1.0;
  in.equality_multipliers = [&s, ne](int k) {
    return VectorXd(s.equalityMultipliers(k).head(ne[static_cast<size_t>(k)]));
  };
  in.inequality_duals = [&s, ni](int k) {
    return VectorXd(s.inequalityDuals(k).head(ni[static_cast<size_t>(k)]));
  };
  in.input_bound_duals = [&s, mi, nbu](int k) {
    return VectorXd(s.inequalityDuals(k).segment(mi, 2 * nbu));
  };
  in.state_bound_duals = [&s, mi, nbu, nbx](int k) {
    return VectorXd(s.inequalityDuals(k).segment(mi + 2 * nbu, 2 * nbx));
  };
  return in;
}

double maxInputDifference(const std::vector<VectorXd>& a, const std::vector<VectorXd>& b) {
  double m = 0.0;
  for (size_t k = 0; k < a.size(); ++k) m = std::max(m, (a[k] - b[k]).lpNorm<Eigen::Infinity>());
  return m;
}

/// The comparison settings: the solver's defaults with a generous iteration limit (the
/// Gauss-Newton Hessian converges linearly on large-residual problems such as the swing-up,
/// where Ipopt uses the exact Hessian). ROLLSTEP_NL_MAX_ITER overrides it (investigations).
SolverSettings comparisonSettings() {
  SolverSettings s;
  s.max_iterations = 2000;
  if (const char* env = std::getenv("ROLLSTEP_NL_MAX_ITER")) s.max_iterations = std::atoi(env);
  return s;
}

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

TEST(NonlinearComparison, RigidBodyOnSE3MatchesIpopt) { compareWithIpopt(makeRigidBody()); }

TEST(NonlinearComparison, RigidBodyWithGravityAndActiveBoundsMatchesIpopt) {
  RigidBodyOptions o;
  o.params.gravity = Eigen::Vector3d(0.0, 0.0, -9.81);
  o.force_limit = 25.0;
  o.torque_limit = 0.6;  // active on about 16 of the 90 torque rows
  compareWithIpopt(makeRigidBody(o));
}

TEST(NonlinearComparison, GaussNewtonLimitLargeCostatesStillReachIpoptCost) {
  // Known limitation, documented rather than hidden: with large costates (terminal weight
  // 200, a 2.5 rad turn under a 0.3 N m torque limit, |lambda| ~ 14) the Gauss-Newton
  // Hessian misses lambda^T F'' of the SE(3) defects and the iteration stalls near a KKT
  // error of 1e-7 (Ipopt, exact Hessian: 48 iterations). The solution must still be the
  // same to 1e-6 in cost and 1e-5 in the KKT residual.
  RigidBodyOptions o;
  o.params.gravity = Eigen::Vector3d(0.0, 0.0, -9.81);
  o.force_limit = 25.0;
  o.torque_limit = 0.3;
  o.target_angle = 2.5;
  const auto inst = makeRigidBody(o);
  const IpoptResult ref = solveWithIpopt(*inst.problem, inst.x0, inst.xs_guess, inst.us_guess);
  ASSERT_TRUE(ref.success) << ref.status_string;
  SolverSettings set = comparisonSettings();
  set.max_iterations = 200;
  Solver s(inst.problem, set);
  s.setInitialGuess(inst.xs_guess, inst.us_guess);
  const SolverStatus st = s.solve(inst.x0);
  const double ours = totalCost(*inst.problem, s.states(), s.inputs());
  const KktReport kkt = kktResidual(*inst.problem, inst.x0, s.states(), s.inputs(),
                                    solverMultipliers(s, *inst.problem));
  std::printf("[gn limit] status %s iters %d cost %.12g ipopt %.12g rel %.2e KKT %.2e\n",
              solver::toString(st), s.iterations(), ours, ref.cost,
              std::abs(ours - ref.cost) / ref.cost, kkt.max());
  EXPECT_TRUE(st == SolverStatus::Converged || st == SolverStatus::MaxIterations);
  EXPECT_NEAR(ours, ref.cost, 1e-6 * ref.cost);
  EXPECT_LT(kkt.max(), 1e-5);
}

TEST(NonlinearComparison, SoftObstacleConvergesCleanly) {
  // Soft (relaxed-barrier) obstacle: no Ipopt reference (the relaxed barrier is not
  // reproduced), but the solve must converge and give a finite, equality-feasible result.
  // Note: the relaxed barrier is scaled by the barrier parameter, so in Converging mode
  // (mu -> 1e-10) it vanishes and the path goes through the soft obstacle (printed
  // clearance < 0); soft rows only act in real-time mode (fixed mu).
  UnicycleOptions o;
  o.soft_obstacles = {{3.0, 0.3, 0.3}};
  const auto inst = makeUnicycle(o);
  Solver s(inst.problem, comparisonSettings());
  s.setInitialGuess(inst.xs_guess, inst.us_guess);
  const SolverStatus st = s.solve(inst.x0);
  double clearance = 1e9;  // signed distance to the soft obstacle's boundary
  for (const auto& x : s.states())
    clearance = std::min(clearance, std::hypot(x[0] - 3.0, x[1] - 0.3) - 0.3);
  std::printf("[soft obstacle] status %s iters %d cost %.12g, min clearance %.3g: %s\n",
              solver::toString(st), s.iterations(), s.cost(), clearance, s.message());
  EXPECT_EQ(st, SolverStatus::Converged) << s.message();
  EXPECT_TRUE(std::isfinite(s.cost()));
  EXPECT_LT(maxViolation(*inst.problem, inst.x0, s.states(), s.inputs()), 1e-8);
}

}  // namespace
}  // namespace rollstep::nltest
