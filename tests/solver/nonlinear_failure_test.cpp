// Infeasible, ill-posed or invalid nonlinear problems (issue 4): the solver ends with a
// clear status and its outputs contain no NaN.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "common/alloc_counter.hpp"
#include "nonlinear_problems.hpp"
#include "rollstep/ocp/cost.hpp"
#include "rollstep/ocp/dynamics.hpp"
#include "rollstep/ocp/problem.hpp"
#include "rollstep/ocp/residuals.hpp"
#include "rollstep/solver/solver.hpp"
#include "solver_multipliers.hpp"

namespace rollstep::nltest {
namespace {

using solver::Solver;
using solver::SolverSettings;
using solver::SolverStatus;

/// Solves from the instance's guess and prints the outcome (label: which test).
SolverStatus solveFromGuess(Solver& s, const ProblemInstance& inst, const char* label) {
  s.setInitialGuess(inst.xs_guess, inst.us_guess);
  const SolverStatus st = s.solve(inst.x0);
  std::printf("[%s] status %s: %s (node %d, %d iterations)\n", label, solver::toString(st),
              s.message(), s.failedNode(), s.iterations());
  return st;
}

void expectFiniteOutputs(const Solver& s) {
  const auto& pb = const_cast<Solver&>(s).problem();
  for (const auto& x : s.states()) EXPECT_TRUE(x.allFinite());
  for (const auto& u : s.inputs()) EXPECT_TRUE(u.allFinite());
  for (int k = 0; k <= pb.horizon(); ++k) {
    EXPECT_TRUE(s.equalityMultipliers(k).allFinite()) << k;
    EXPECT_TRUE(s.inequalityDuals(k).allFinite()) << k;
  }
  EXPECT_TRUE(std::isfinite(s.cost()));
  for (const auto& it : s.stats()) {
    EXPECT_FALSE(std::isnan(it.cost));
    EXPECT_FALSE(std::isnan(it.primal_residual));
  }
}

/// A solve that ended in or after the restoration phase still describes what it returns:
/// cost() is the cost of states() and inputs() (it was the cost before the phase's steps),
/// and each of the phase's stats entries holds the violation where its step started (they
/// were zero after the first).
void expectOutputsDescribed(const Solver& s) {
  const auto& pb = const_cast<Solver&>(s).problem();
  const double c = totalCost(pb, s.states(), s.inputs());
  EXPECT_NEAR(s.cost(), c, 1e-9 * std::max(1.0, std::abs(c)));
  int steps = 0;
  for (const auto& it : s.stats()) {
    if (!it.restoration) continue;
    ++steps;
    EXPECT_GT(it.primal_residual, 0.0) << "iteration " << it.iteration;
    EXPECT_GT(it.dual_residual, 0.0) << "iteration " << it.iteration;
    EXPECT_GE(it.kkt_error, it.primal_residual) << "iteration " << it.iteration;
  }
  EXPECT_GT(steps, 1);
}

TEST(NonlinearFailure, NanOrInfInitialStateIsInvalidInput) {
  for (const auto& inst : {makeCartPole(), makeUnicycle(), makeRigidBody()}) {
    for (double bad :
         {std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity()}) {
      Solver s(inst.problem);
      s.setInitialGuess(inst.xs_guess, inst.us_guess);
      VectorXd x0 = inst.x0;
      x0[1] = bad;
      EXPECT_EQ(s.solve(x0), SolverStatus::InvalidInput) << inst.name;
      EXPECT_EQ(s.status(), SolverStatus::InvalidInput);
      EXPECT_STRNE(s.message(), "");
      expectFiniteOutputs(s);
      // A valid state afterwards works again (the solver is not poisoned).
      SolverSettings few;
      few.max_iterations = 3;
      s.setSettings(few);
      const SolverStatus st = s.solve(inst.x0);
      EXPECT_NE(st, SolverStatus::InvalidInput) << inst.name;
      expectFiniteOutputs(s);
    }
  }
}

TEST(NonlinearFailure, StartInsideHardObstacleIsInfeasible) {
  // The obstacle row at node 0 acts on x_0 = x_init, which is inside: truly infeasible.
  UnicycleOptions o;
  o.x0 = VectorXd::Zero(3);
  o.x0[0] = 2.0;  // the centre-ish of the obstacle at (2, -0.2), r = 0.5
  o.horizon = 30;
  const auto inst = makeUnicycle(o);
  SolverSettings set;
  set.max_iterations = 60;
  Solver s(inst.problem, set);
  const SolverStatus st = solveFromGuess(s, inst, "infeasible start");
  EXPECT_EQ(st, SolverStatus::Infeasible) << s.message();
  EXPECT_NE(std::string(s.message()).find("infeasible"), std::string::npos) << s.message();
  EXPECT_STRNE(s.message(), "");
  expectFiniteOutputs(s);
  expectOutputsDescribed(s);
}

/// Cart-pole (horizon 20) whose force must equal 50 against the bounds |F| <= 20.
ProblemInstance makeForceContradictingBounds() {
  CartPoleOptions o;
  o.horizon = 20;
  const auto inst = makeCartPole(o);
  inst.problem->addEquality(
      "force", std::make_shared<ocp::AffineResidual>(inst.problem->dynamics().spacePtr(), inst.x0,
                                                     MatrixXd::Zero(1, 4), MatrixXd::Ones(1, 1),
                                                     VectorXd::Constant(1, -50.0)));
  return inst;
}

TEST(NonlinearFailure, EqualityContradictingInputBoundsIsInfeasible) {
  // Cart-pole with F = 50 imposed while |F| <= 20: truly infeasible.
  const auto inst = makeForceContradictingBounds();
  SolverSettings set;
  set.max_iterations = 60;
  Solver s(inst.problem, set);
  const SolverStatus st = solveFromGuess(s, inst, "eq vs bounds");
  EXPECT_EQ(st, SolverStatus::Infeasible) << s.message();
  EXPECT_STRNE(s.message(), "");
  expectFiniteOutputs(s);
  expectOutputsDescribed(s);
}

TEST(NonlinearFailure, InfeasibleWithFullStepsIsInfeasible) {
  // Full steps (line_search = false): no line search can fail; the duals of the
  // contradicting bound rows blow up while the violation stays: Infeasible, not Diverged.
  const auto inst = makeForceContradictingBounds();
  SolverSettings set;
  set.line_search = false;
  set.max_iterations = 40;
  Solver s(inst.problem, set);
  const SolverStatus st = solveFromGuess(s, inst, "stalled");
  EXPECT_EQ(st, SolverStatus::Infeasible) << s.message();
  EXPECT_NE(std::string(s.message()).find("duals blew up"), std::string::npos) << s.message();
  expectFiniteOutputs(s);
}

TEST(NonlinearFailure, ViolationLeftAtIterationLimitIsMaxIterationsNotInfeasible) {
  // The same problem stopped by the iteration limit before the duals blow up: a violation
  // left at the limit is no evidence of infeasibility (a feasible problem converging
  // slowly looks the same), so MaxIterations with the residuals in the message.
  SolverSettings set;
  set.line_search = false;
  set.max_iterations = 12;
  {
    const auto inst = makeForceContradictingBounds();
    Solver s(inst.problem, set);
    const SolverStatus st = solveFromGuess(s, inst, "limit, infeasible");
    EXPECT_EQ(st, SolverStatus::MaxIterations) << s.message();
    EXPECT_NE(std::string(s.message()).find("violation 44.9"), std::string::npos) << s.message();
    EXPECT_EQ(s.iterations(), 12);
    expectFiniteOutputs(s);
  }
  {
    // Control: the feasible cart-pole stopped at the same limit is only unfinished.
    CartPoleOptions o;
    o.horizon = 20;
    const auto inst = makeCartPole(o);
    Solver s(inst.problem, set);
    EXPECT_EQ(solveFromGuess(s, inst, "limit, feasible"), SolverStatus::MaxIterations)
        << s.message();
  }
}

TEST(NonlinearFailure, ContradictoryEqualitiesAreRankDeficient) {
  // Speed profile plus v = 5: two rows that only involve v (rank 1 in u).
  UnicycleOptions o;
  o.horizon = 20;
  const auto inst = makeUnicycle(o);
  MatrixXd D = MatrixXd::Zero(1, 2);
  D(0, 0) = 1.0;
  inst.problem->addEquality("v_fixed", std::make_shared<ocp::AffineResidual>(
                                           inst.problem->dynamics().spacePtr(), inst.x0,
                                           MatrixXd::Zero(1, 3), D, VectorXd::Constant(1, -5.0)));
  Solver s(inst.problem);
  const SolverStatus st = solveFromGuess(s, inst, "rank deficient");
  EXPECT_EQ(st, SolverStatus::RankDeficientEqualities);
  EXPECT_GE(s.failedNode(), 0);
  EXPECT_STRNE(s.message(), "");
  expectFiniteOutputs(s);
}

TEST(NonlinearFailure, ObstacleCoveringTheTargetStopsOutside) {
  // Feasible but the target is unreachable: the car must end outside the (hard) obstacle.
  // (Slightly off-centre: with the obstacle centred on the goal and the start on the axis,
  // the straight-on guess is a symmetric point where Ipopt too reports local infeasibility.)
  UnicycleOptions o;
  o.hard_obstacles = {{4.05, 0.1, 0.5}};
  o.horizon = 50;
  const auto inst = makeUnicycle(o);
  SolverSettings set;
  Solver s(inst.problem, set);  // default limit (100)
  const SolverStatus st = solveFromGuess(s, inst, "covered target");
  EXPECT_EQ(st, SolverStatus::Converged) << s.message();
  EXPECT_LE(s.iterations(), 40);
  expectFiniteOutputs(s);
  EXPECT_LT(maxViolation(*inst.problem, inst.x0, s.states(), s.inputs()), 1e-8);
  const auto& xN = s.states().back();
  EXPECT_GE(std::hypot(xN[0] - 4.05, xN[1] - 0.1), 0.5 - 1e-8);
  EXPECT_LT(std::hypot(xN[0] - 4.05, xN[1] - 0.1), 0.6);
}

TEST(NonlinearFailure, RestorationStepKeepsAFeasibleSolveGoing) {
  // A line search cut to two halvings rejects the cart-pole's early Newton steps while
  // the violation is large: the minimum-norm restoration step is taken instead, the solve
  // goes on, and the problem (feasible) is not reported Infeasible. Each iteration leaves
  // exactly one stats entry (the restoration one marked), and nothing is allocated.
  const auto inst = makeCartPole();
  SolverSettings set;
  set.max_line_search_steps = 2;
  Solver s(inst.problem, set);
  s.setInitialGuess(inst.xs_guess, inst.us_guess);
  SolverStatus st{};
  {
    test::AllocationGuard guard;
    st = s.solve(inst.x0);
    EXPECT_EQ(guard.count(), 0u);
  }
  std::printf("[restoration] status %s: %s (%d iterations)\n", solver::toString(st), s.message(),
              s.iterations());
  EXPECT_NE(st, SolverStatus::Infeasible) << s.message();
  const auto& stats = s.stats();
  ASSERT_EQ(stats.size(), static_cast<std::size_t>(s.iterations()) + 1);
  int restorations = 0, first = -1;
  for (std::size_t i = 0; i < stats.size(); ++i) {
    EXPECT_EQ(stats[i].iteration, static_cast<int>(i));
    if (!stats[i].restoration) continue;
    ++restorations;
    if (first < 0) first = static_cast<int>(i);
    EXPECT_GT(stats[i].primal_step, 0.0);
    EXPECT_EQ(stats[i].dual_step, 0.0);
    ASSERT_LT(i + 1, stats.size());
    std::printf("  restoration at %zu: violation %.4g -> %.4g\n", i, stats[i].primal_residual,
                stats[i + 1].primal_residual);
    EXPECT_LT(stats[i + 1].primal_residual, stats[i].primal_residual);
  }
  ASSERT_GE(restorations, 1);
  EXPECT_LT(first + 1, s.iterations()) << "the solve stopped at the restoration step";
  expectFiniteOutputs(s);
}

// A guess whose states are far from the dynamics and whose inputs are far beyond their
// bounds (the rigid body of the comparison tests, |F|, |tau| <= 1): closing the defects by
// the linearised dynamics asks for inputs beyond the bounds, so the fraction to the
// boundary cuts every feasibility step of the restoration phase, and the solve used to end
// Infeasible (after 38 iterations, the violation's inf-norm at 8.9) on this feasible
// problem. The phase's rollout (inputs inside their bounds, states simulated from x0: every
// defect closed at once) restores it: a restoration entry with a unit step, then
// convergence to a KKT point, without allocating.
TEST(NonlinearFailure, RolloutRestoresWhereTheFeasibilityStepsAreCut) {
  const auto inst = makeRigidBody();
  const auto& space = inst.problem->stateSpace();
  std::vector<VectorXd> xs = inst.xs_guess, us = inst.us_guess;
  VectorXd d(space.ndx());
  for (std::size_t k = 1; k < xs.size(); ++k) {
    for (int i = 0; i < d.size(); ++i)
      d[i] = 3.0 * std::sin(1.7 * static_cast<double>(k) + 0.9 * i);
    const VectorXd x = xs[k];
    space.integrate(x, d, xs[k]);
  }
  for (std::size_t k = 0; k < us.size(); ++k) {
    for (int i = 0; i < us[k].size(); ++i) {
      us[k][i] = 9.0 * std::cos(2.3 * static_cast<double>(k) + 1.1 * i);
    }
  }
  SolverSettings set;
  set.max_iterations = 300;
  Solver s(inst.problem, set);
  s.setInitialGuess(xs, us);
  SolverStatus st{};
  {
    test::AllocationGuard guard;
    st = s.solve(inst.x0);
    EXPECT_EQ(guard.count(), 0u);
  }
  std::printf("[rollout] %s after %d iterations\n", solver::toString(st), s.iterations());
  ASSERT_EQ(st, SolverStatus::Converged) << s.message();
  int rollouts = 0;
  for (std::size_t i = 0; i < s.stats().size(); ++i) {
    const auto& it = s.stats()[i];
    if (!it.restoration || it.primal_step != 1.0) continue;
    ++rollouts;
    ASSERT_LT(i + 1, s.stats().size());
    std::printf("  rollout at %zu: violation %.4g -> %.4g\n", i, it.primal_residual,
                s.stats()[i + 1].primal_residual);
    EXPECT_LT(s.stats()[i + 1].primal_residual, it.primal_residual);
  }
  EXPECT_GE(rollouts, 1);
  EXPECT_LE(maxViolation(*inst.problem, inst.x0, s.states(), s.inputs()), 1e-8);
  const KktReport kkt = kktResidual(*inst.problem, inst.x0, s.states(), s.inputs(),
                                    solverMultipliers(s, *inst.problem));
  EXPECT_LE(kkt.max(), 1e-6);
}

/// A user's model that fails, for the two tests below: a cart x = [position, velocity],
/// u = [force], with drag 0.1 v |v| and, with `spring`, a force 0.5 sqrt(2 - position)
/// pushing it back, undefined (NaN) beyond 2 m (a model outside its domain). armIn(n)
/// makes it throw from its n-th call on (a lookup out of range, a map that went away).
class FailingCart final : public ocp::ContinuousDynamics {
 public:
  explicit FailingCart(bool spring)
      : ContinuousDynamics(std::make_shared<ocp::EuclideanSpace>(2), 1), spring_(spring) {}
  std::unique_ptr<ocp::DynamicsData> createData() const override {
    return std::make_unique<ocp::DynamicsData>();
  }
  void calc(const ocp::NodeContext& ctx, ocp::ConstVecRef x, ocp::ConstVecRef u, ocp::DynamicsData&,
            ocp::VecRef xdot) const override {
    const long c = ++calls_;
    const long at = throw_at_.load();
    if ((at > 0 && c >= at) || ctx.node == throw_node_.load()) {
      throw std::runtime_error("cart model: lookup out of range");
    }
    const double spring = spring_ ? 0.5 * std::sqrt(2.0 - x[0]) : 0.0;
    xdot << x[1], u[0] - 0.1 * x[1] * std::abs(x[1]) - spring;
  }
  void calcDiff(const ocp::NodeContext&, ocp::ConstVecRef x, ocp::ConstVecRef, ocp::DynamicsData&,
                ocp::MatRef fx, ocp::MatRef fu) const override {
    const double dspring = spring_ ? 0.25 / std::sqrt(2.0 - x[0]) : 0.0;
    fx << 0.0, 1.0, dspring, -0.2 * std::abs(x[1]);
    fu << 0.0, 1.0;
  }
  long calls() const { return calls_.load(); }
  /// Throws from the n-th call after this one (0: never).
  void armIn(long n) const { throw_at_.store(n > 0 ? calls_.load() + n : 0); }
  /// Throws from every call at node k (-1: never).
  void armAtNode(int k) const { throw_node_.store(k); }

 private:
  bool spring_;
  mutable std::atomic<long> calls_{0};
  mutable std::atomic<long> throw_at_{0};
  mutable std::atomic<int> throw_node_{-1};
};

/// The cart driven to rest at goal_position over N steps of 0.05 s.
std::shared_ptr<ocp::OptimalControlProblem> cartProblem(std::shared_ptr<const FailingCart> cart,
                                                        int N, double goal_position) {
  auto pb = std::make_shared<ocp::OptimalControlProblem>(std::make_shared<ocp::RungeKutta4>(cart),
                                                         N, 0.05);
  const Eigen::Vector2d goal(goal_position, 0.0);
  auto to_goal = std::make_shared<ocp::StateErrorResidual>(cart->spacePtr(), 1, goal);
  pb->addCost("goal", std::make_shared<ocp::LeastSquaresCost>(to_goal, Eigen::Vector2d(1.0, 0.1)));
  pb->addCost("effort", std::make_shared<ocp::LeastSquaresCost>(
                            std::make_shared<ocp::InputErrorResidual>(2, Eigen::VectorXd::Zero(1)),
                            Eigen::VectorXd::Constant(1, 0.01)));
  pb->addCost("arrive",
              std::make_shared<ocp::LeastSquaresCost>(to_goal, Eigen::Vector2d(100.0, 100.0)),
              ocp::Stage::Terminal);
  return pb;
}

// An exception from a problem's callback reaches the caller of solve() or update() with
// any thread count (on a worker thread it would end the process), and the solver stays
// usable: the next solve from the same guess returns what a new solver returns.
TEST(NonlinearFailure, ACallbackExceptionReachesTheCallerWithAnyThreadCount) {
  auto cart = std::make_shared<FailingCart>(false);
  const int N = 40;
  auto pb = cartProblem(cart, N, 1.0);
  pb->setInputBounds(Eigen::VectorXd::Constant(1, -2.0), Eigen::VectorXd::Constant(1, 2.0));
  const double inf = ocp::OptimalControlProblem::kInfinity;
  pb->setStateBounds(Eigen::Vector2d(-inf, -0.8), Eigen::Vector2d(inf, 0.8));
  const Eigen::VectorXd x0 = Eigen::Vector2d::Zero();
  const std::vector<Eigen::VectorXd> xs(N + 1, x0), us(N, Eigen::VectorXd::Zero(1));
  for (int threads : {1, 2, 3}) {
    SolverSettings set;
    set.num_threads = threads;
    cart->armIn(0);
    Solver reference(pb, set);
    reference.setInitialGuess(xs, us);
    const long before = cart->calls();
    ASSERT_EQ(reference.solve(x0), SolverStatus::Converged) << reference.message();
    const long per_solve = cart->calls() - before;
    Solver s(pb, set);
    // Thrown in the first linearisation, in the middle of the solve, near its end.
    for (long at : {1L, per_solve / 2, per_solve - per_solve / 10}) {
      s.setInitialGuess(xs, us);
      cart->armIn(at);
      try {
        s.solve(x0);
        ADD_FAILURE() << "no exception, threads " << threads << ", call " << at;
      } catch (const std::runtime_error& e) {
        EXPECT_STREQ(e.what(), "cart model: lookup out of range");
      }
      cart->armIn(0);
      s.setInitialGuess(xs, us);
      ASSERT_EQ(s.solve(x0), SolverStatus::Converged) << s.message();
      EXPECT_EQ(s.iterations(), reference.iterations());
      for (int k = 0; k <= N; ++k) {
        EXPECT_EQ(s.states()[static_cast<std::size_t>(k)],
                  reference.states()[static_cast<std::size_t>(k)])
            << "threads " << threads << ", node " << k;
      }
    }
    // Real-time iterations: the same.
    cart->armIn(N);  // within its linearisation (four model calls per node)
    EXPECT_THROW(s.update(0.05, x0), std::runtime_error);
    cart->armIn(0);
    EXPECT_EQ(s.update(0.1, x0), SolverStatus::IterationDone) << s.message();
    expectFiniteOutputs(s);
  }
}

// With more threads a real-time iteration hands its backward sweep down from the last
// nodes' thread to the others: an exception there (the last running node's model) must
// reach the caller rather than leave the other threads waiting for the sweep, and the next
// update runs as usual.
TEST(NonlinearFailure, AnExceptionInTheLastNodesReachesTheCallerOfARealTimeUpdate) {
  auto cart = std::make_shared<FailingCart>(false);
  const int N = 40;
  auto pb = cartProblem(cart, N, 1.0);
  const Eigen::VectorXd x0 = Eigen::Vector2d::Zero();
  const std::vector<Eigen::VectorXd> xs(N + 1, x0), us(N, Eigen::VectorXd::Zero(1));
  for (int threads : {2, 3}) {
    SolverSettings set;
    set.num_threads = threads;
    Solver s(pb, set);
    s.setInitialGuess(xs, us);
    ASSERT_EQ(s.solve(x0), SolverStatus::Converged) << s.message();
    set.mode = solver::SolverMode::RealTime;
    s.setSettings(set);
    for (const int node : {N - 1, 0}) {  // the last chunk's, the first chunk's
      cart->armAtNode(node);
      EXPECT_THROW(s.update(0.0, x0), std::runtime_error) << "threads " << threads;
      cart->armAtNode(-1);
      EXPECT_EQ(s.update(0.0, x0), SolverStatus::IterationDone) << s.message();
      expectFiniteOutputs(s);
    }
  }
}

// A model undefined where the steps go: near its domain's edge the line search keeps the
// iterates inside; from an initial state outside it the solve fails and its message says
// that the trial points evaluated to non-finite values (not only "infeasible"), and the
// real-time iterations from there either step or restore the last good iterate, saying why.
TEST(NonlinearFailure, AModelUndefinedAtTheTrialPointsIsNamedInTheMessage) {
  const std::vector<Eigen::VectorXd> xs(31, Eigen::Vector2d::Zero()),
      us(30, Eigen::VectorXd::Zero(1));
  {
    Solver s(cartProblem(std::make_shared<FailingCart>(true), 30, 1.99), SolverSettings{});
    s.setInitialGuess(xs, us);
    EXPECT_EQ(s.solve(Eigen::Vector2d::Zero()), SolverStatus::Converged) << s.message();
    EXPECT_LT(s.states().back()[0], 2.0);
  }
  Solver s(cartProblem(std::make_shared<FailingCart>(true), 30, 1.0), SolverSettings{});
  s.setInitialGuess(xs, us);
  const Eigen::Vector2d outside(3.0, 0.0);
  const SolverStatus st = s.solve(outside);
  std::printf("[domain] %s: %s\n", solver::toString(st), s.message());
  EXPECT_NE(st, SolverStatus::Converged);
  EXPECT_NE(st, SolverStatus::Acceptable);
  EXPECT_NE(std::string(s.message()).find("trial points evaluated to non-finite values"),
            std::string::npos);
  expectFiniteOutputs(s);
  int restored = 0;
  for (int k = 1; k <= 6; ++k) {
    const SolverStatus rt = s.update(0.05 * k, outside);
    if (rt == SolverStatus::Diverged) {
      ++restored;
      EXPECT_NE(std::string(s.message()).find("non-finite values at the new iterate"),
                std::string::npos)
          << s.message();
    } else {
      EXPECT_EQ(rt, SolverStatus::IterationDone) << s.message();
    }
    for (const auto& x : s.states()) EXPECT_TRUE(x.allFinite());
  }
  EXPECT_GT(restored, 0);
}

}  // namespace
}  // namespace rollstep::nltest
