// Interior-point solver on linear-quadratic problems against independent dense solutions,
// failure statuses, thread-count invariance, real-time iterations and allocation freedom.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstring>
#include <stdexcept>
#include <string>

#include "common/alloc_counter.hpp"
#include "common/malloc_guard.hpp"
#include "common/mirrored_affine.hpp"
#include "lq_problems.hpp"
#include "robot_size_lq.hpp"
#include "rollstep/solver/solver.hpp"

namespace {

using namespace rollstep;
using lqtest::kInf;
using ocp::MatrixXd;
using ocp::VectorXd;
using solver::Solver;
using solver::SolverSettings;
using solver::SolverStatus;

SolverSettings tight() {
  SolverSettings s;
  s.kkt_tolerance = 1e-10;
  s.barrier_min = 1e-12;
  s.max_iterations = 100;
  return s;
}

bool allFinite(const Solver& s) {
  for (const auto& x : s.states())
    if (!x.allFinite()) return false;
  for (const auto& u : s.inputs())
    if (!u.allFinite()) return false;
  return true;
}

VectorXd stackSolution(const Solver& s, const lqtest::LqData& d) {
  VectorXd z(d.N * (d.nx + d.nu) + d.nx);
  for (int k = 0; k <= d.N; ++k) {
    z.segment(k * (d.nx + d.nu), d.nx) = s.states()[static_cast<std::size_t>(k)];
    if (k < d.N)
      z.segment(k * (d.nx + d.nu) + d.nx, d.nu) = s.inputs()[static_cast<std::size_t>(k)];
  }
  return z;
}

TEST(SolverLq, EqualityConstrainedMatchesDenseKkt) {
  const auto d = lqtest::randomLq(1, 4, 3, 15, 2, 0);
  auto p = lqtest::buildProblem(d);
  Solver s(p, tight());
  ASSERT_EQ(s.solve(d.x0), SolverStatus::Converged) << s.message();
  EXPECT_LE(s.iterations(), 2);  // one Newton step solves an LQ
  const auto q = lqtest::denseQp(d);
  const auto ref = lqtest::denseKkt(q, {});
  EXPECT_LT((stackSolution(s, d) - ref.z).lpNorm<Eigen::Infinity>(), 1e-8);
  // Multipliers: lambda_0, then (lambda_{k+1}, nu_k).
  int r = 0;
  const auto& ric = s.riccati();
  (void)ric;
  for (int k = 0; k < d.N; ++k) {
    if (k == 0) {
      r += d.nx;
    }
    r += d.nx;
    EXPECT_LT((s.equalityMultipliers(k).head(d.ne()) - ref.y.segment(r, d.ne()))
                  .lpNorm<Eigen::Infinity>(),
              1e-8)
        << "node " << k;
    r += d.ne();
  }
  EXPECT_NEAR(s.cost(),
              0.5 * ref.z.dot(q.H * ref.z) + q.h.dot(ref.z) +
                  d.N * d.dt * 0.5 * d.cr.dot(d.w.asDiagonal() * d.cr) +
                  0.5 * d.cf.dot(d.wf.asDiagonal() * d.cf),
              1e-8);
}

struct BoxCase {
  int ne, ni;
  bool state_bounds;
};
class SolverBoxLq : public ::testing::TestWithParam<BoxCase> {};

TEST_P(SolverBoxLq, MatchesActiveSetDenseKkt) {
  const BoxCase c = GetParam();
  auto d = lqtest::randomLq(7, 4, 3, 20, c.ne, c.ni);
  // Keep the problem feasible from any x0: the equality can use the free input u(2),
  // the general rows have margin.
  d.Ex *= 0.1;
  if (c.ne > 0) d.Eu.col(2).array() += 2.0;
  d.Gx *= 0.2;
  d.g.array() += 0.5;
  d.ulo = VectorXd::Constant(3, -0.4);
  d.uhi = VectorXd::Constant(3, 0.4);
  d.uhi(2) = kInf;
  d.ulo(2) = -kInf;
  d.uhi(1) = 0.3;
  d.x0 *= 2.0;
  // Guarantee feasibility by construction: a trajectory with u(0) = u(1) = 0 and u(2)
  // solving the equality; the state bounds and general rows are set around it (tight
  // enough to become active at the optimum).
  std::vector<VectorXd> xf(static_cast<std::size_t>(d.N) + 1, d.x0),
      uf(static_cast<std::size_t>(d.N), VectorXd::Zero(3));
  for (int k = 0; k < d.N; ++k) {
    const auto kk = static_cast<std::size_t>(k);
    if (c.ne > 0) uf[kk](2) = -(d.e(0) + d.Ex.row(0).dot(xf[kk])) / d.Eu(0, 2);
    xf[kk + 1] = d.A * xf[kk] + d.B * uf[kk] + d.c;
  }
  for (int i = 0; i < c.ni; ++i) {
    double worst = -kInf;
    for (int k = 0; k < d.N; ++k) {
      const auto kk = static_cast<std::size_t>(k);
      worst = std::max(worst, -(d.Gx.row(i).dot(xf[kk]) + d.Gu.row(i).dot(uf[kk])));
    }
    d.g(i) = std::max(d.g(i), worst + 0.05);
  }
  if (c.state_bounds) {
    double lo1 = kInf, hi1 = -kInf, hi3 = -kInf;
    for (int k = 1; k <= d.N; ++k) {
      const auto kk = static_cast<std::size_t>(k);
      lo1 = std::min(lo1, xf[kk](1));
      hi1 = std::max(hi1, xf[kk](1));
      hi3 = std::max(hi3, xf[kk](3));
    }
    d.xlo(1) = lo1 - 0.1;
    d.xhi(1) = hi1 + 0.1;
    d.xhi(3) = hi3 + 0.1;
  }
  auto p = lqtest::buildProblem(d);
  Solver s(p, tight());
  const auto st = s.solve(d.x0);
  if (st != SolverStatus::Converged) {
    for (const auto& it : s.stats())
      std::printf("it %d cost %g pr %g du %g co %g mu %g ap %g ad %g\n", it.iteration, it.cost,
                  it.primal_residual, it.dual_residual, it.complementarity, it.barrier,
                  it.primal_step, it.dual_step);
  }
  ASSERT_EQ(st, SolverStatus::Converged) << s.message();
  const auto q = lqtest::denseQp(d);
  // Active set from our solution: dual larger than slack.
  std::vector<int> active;
  for (int i = 0; i < q.Ain.rows(); ++i) {
    const int k = q.row_node[static_cast<std::size_t>(i)],
              j = q.row_index[static_cast<std::size_t>(i)];
    if (s.inequalityDuals(k)(j) > s.slacks(k)(j)) active.push_back(i);
  }
  ASSERT_FALSE(active.empty()) << "the test problem should have active constraints";
  // Refine the guess like a primal active-set method until the dense KKT point is
  // feasible with nonnegative multipliers (the reference does not trust our guess).
  auto ref = lqtest::denseKkt(q, active);
  int changes = 0;
  for (; changes < 50; ++changes) {
    const VectorXd slack = q.Ain * ref.z + q.bin;
    Eigen::Index worst = 0;
    if (slack.minCoeff(&worst) < -1e-12) {
      active.push_back(static_cast<int>(worst));
    } else if (ref.mu.size() > 0 && ref.mu.minCoeff(&worst) < -1e-12) {
      active.erase(active.begin() + worst);
    } else {
      break;
    }
    ref = lqtest::denseKkt(q, active);
  }
  EXPECT_EQ(changes, 0) << "our active set needed corrections";
  const VectorXd z = stackSolution(s, d);
  EXPECT_LT((z - ref.z).lpNorm<Eigen::Infinity>(), 1e-8);
  // Optimality of the reference (hence of ours): active multipliers >= 0, all rows feasible.
  EXPECT_GT(ref.mu.minCoeff(), 0.0);
  EXPECT_GT((q.Ain * ref.z + q.bin).minCoeff(), -1e-10);
  for (std::size_t a = 0; a < active.size(); ++a) {
    const int i = active[a];
    const int k = q.row_node[static_cast<std::size_t>(i)],
              j = q.row_index[static_cast<std::size_t>(i)];
    EXPECT_NEAR(s.inequalityDuals(k)(j), ref.mu(static_cast<int>(a)),
                1e-6 * (1.0 + ref.mu.cwiseAbs().maxCoeff()));
  }
  // Every iteration reported; the last one meets the tolerance.
  ASSERT_FALSE(s.stats().empty());
  EXPECT_LE(s.stats().back().primal_residual, 1e-10);
  EXPECT_LE(s.stats().back().dual_residual, 1e-8);
}

INSTANTIATE_TEST_SUITE_P(Cases, SolverBoxLq,
                         ::testing::Values(BoxCase{0, 0, false}, BoxCase{0, 0, true},
                                           BoxCase{1, 0, true}, BoxCase{1, 2, true},
                                           BoxCase{0, 3, false}));

using test::MirroredAffine;

// Two-sided limits lo <= Hx x + Hu u <= hi condensed pairwise (one product with the summed
// weights) give the solution and duals of the same rows condensed one by one.
TEST(SolverLq, MirroredRowsGiveTheSameSolutionAsSeparateRows) {
  auto d = lqtest::randomLq(11, 5, 3, 15, 0, 0);
  d.x0 *= 3.0;
  std::mt19937 rng(4);
  const int m = 3;
  const MatrixXd Hx = lqtest::randn(m, d.nx, rng, 0.3);
  const MatrixXd Hu = MatrixXd::Identity(m, d.nu) + lqtest::randn(m, d.nu, rng, 0.1);
  const VectorXd lo = VectorXd::Constant(m, -0.35), hi = VectorXd::Constant(m, 0.25);
  // Rows: h - lo (m), hi - h (m), and one unpaired row.
  MatrixXd Gx(2 * m + 1, d.nx), Gu(2 * m + 1, d.nu);
  VectorXd g(2 * m + 1);
  Gx << Hx, -Hx, lqtest::randn(1, d.nx, rng, 0.2);
  Gu << Hu, -Hu, lqtest::randn(1, d.nu, rng, 0.2);
  g << -lo, hi, 2.0;
  const auto build = [&](bool declared) {
    auto p = lqtest::buildProblem(d);
    const auto& s = p->dynamics().spacePtr();
    if (declared) {
      p->addInequality("limits", std::make_shared<MirroredAffine>(s, Gx, Gu, g, m));
    } else {
      p->addInequality("limits",
                       std::make_shared<ocp::AffineResidual>(s, VectorXd::Zero(d.nx), Gx, Gu, g));
    }
    return p;
  };
  Solver pairs(build(true), tight()), rows(build(false), tight());
  ASSERT_EQ(pairs.solve(d.x0), SolverStatus::Converged) << pairs.message();
  ASSERT_EQ(rows.solve(d.x0), SolverStatus::Converged) << rows.message();
  EXPECT_EQ(pairs.stats().size(), rows.stats().size());
  EXPECT_LT((stackSolution(pairs, d) - stackSolution(rows, d)).lpNorm<Eigen::Infinity>(), 1e-9);
  int active_lo = 0, active_hi = 0;
  for (int k = 0; k < d.N; ++k) {
    const VectorXd& z = pairs.inequalityDuals(k);
    EXPECT_LT((z - rows.inequalityDuals(k)).lpNorm<Eigen::Infinity>(),
              1e-8 * (1.0 + z.lpNorm<Eigen::Infinity>()))
        << "node " << k;
    for (int j = 0; j < m; ++j) {
      active_lo += z(j) > pairs.slacks(k)(j) ? 1 : 0;
      active_hi += z(j + m) > pairs.slacks(k)(j + m) ? 1 : 0;
    }
  }
  // Both sides of the limits bind somewhere, so both weights of a pair matter.
  EXPECT_GT(active_lo, 0);
  EXPECT_GT(active_hi, 0);
}

TEST(SolverLq, RankDeficientEqualitiesAreReported) {
  auto d = lqtest::randomLq(3, 4, 3, 10, 2, 0);
  d.Eu.row(1) = 3.0 * d.Eu.row(0);  // dependent rows in u
  auto p = lqtest::buildProblem(d);
  Solver s(p, tight());
  EXPECT_EQ(s.solve(d.x0), SolverStatus::RankDeficientEqualities);
  EXPECT_EQ(s.failedNode(), 0);
  EXPECT_NE(std::strstr(s.message(), "node 0"), nullptr) << s.message();
  EXPECT_TRUE(allFinite(s));
  // More equality rows than inputs.
  auto d2 = lqtest::randomLq(3, 4, 2, 10, 3, 0);
  Solver s2(lqtest::buildProblem(d2), tight());
  EXPECT_EQ(s2.solve(d2.x0), SolverStatus::RankDeficientEqualities);
  EXPECT_TRUE(allFinite(s2));
}

TEST(SolverLq, InfeasibleProblemEndsWithoutNaN) {
  auto d = lqtest::randomLq(5, 4, 3, 10, 1, 0);
  d.Ex.setZero();
  d.Eu.setZero();
  d.Eu(0, 0) = 1.0;
  d.e << -1.0;     // u_0 = 1 ...
  d.uhi(0) = 0.5;  // ... but u_0 <= 0.5
  auto p = lqtest::buildProblem(d);
  auto set = tight();
  set.max_iterations = 60;
  Solver s(p, set);
  const auto st = s.solve(d.x0);
  EXPECT_EQ(st, SolverStatus::Infeasible) << s.message();
  EXPECT_TRUE(allFinite(s)) << solver::toString(st);
  EXPECT_GT(std::strlen(s.message()), 0u);
  // Contradictory bounds are rejected when the problem is composed.
  EXPECT_THROW(p->setInputBounds(VectorXd::Constant(3, 1.0), VectorXd::Constant(3, 0.0)),
               std::invalid_argument);
}

TEST(SolverLq, InvalidInitialState) {
  const auto d = lqtest::randomLq(1, 4, 3, 10, 0, 0);
  Solver s(lqtest::buildProblem(d));
  VectorXd x0 = d.x0;
  x0(1) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(s.solve(x0), SolverStatus::InvalidInput);
  EXPECT_EQ(s.solve(VectorXd::Zero(3)), SolverStatus::InvalidInput);
  EXPECT_TRUE(allFinite(s));
  EXPECT_EQ(s.solve(d.x0), SolverStatus::Converged);
}

TEST(SolverLq, BadSettingsAreRejectedByName) {
  const auto d = lqtest::randomLq(1, 4, 3, 10, 0, 0);
  const auto p = lqtest::buildProblem(d);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  struct Case {
    const char* field;
    void (*spoil)(SolverSettings&, double nan, double inf);
  };
  const Case cases[] = {
      {"max_iterations", [](SolverSettings& s, double, double) { s.max_iterations = 0; }},
      {"kkt_tolerance", [](SolverSettings& s, double n, double) { s.kkt_tolerance = n; }},
      {"kkt_tolerance", [](SolverSettings& s, double, double) { s.kkt_tolerance = 0.0; }},
      {"barrier_initial", [](SolverSettings& s, double, double i) { s.barrier_initial = i; }},
      {"barrier_min", [](SolverSettings& s, double, double) { s.barrier_min = -1e-9; }},
      {"barrier_min", [](SolverSettings& s, double, double) { s.barrier_min = 1.0; }},
      {"barrier_decrease", [](SolverSettings& s, double, double) { s.barrier_decrease = 1.0; }},
      {"barrier_decrease", [](SolverSettings& s, double n, double) { s.barrier_decrease = n; }},
      {"barrier_realtime", [](SolverSettings& s, double, double) { s.barrier_realtime = 0.0; }},
      {"realtime_iterations", [](SolverSettings& s, double, double) { s.realtime_iterations = 0; }},
      {"fraction_to_boundary",
       [](SolverSettings& s, double, double) { s.fraction_to_boundary = 1.5; }},
      {"bound_push", [](SolverSettings& s, double, double) { s.bound_push = -1e-3; }},
      {"bound_push", [](SolverSettings& s, double, double) { s.bound_push = 0.5; }},
      {"bound_push", [](SolverSettings& s, double n, double) { s.bound_push = n; }},
      {"max_line_search_steps",
       [](SolverSettings& s, double, double) { s.max_line_search_steps = 0; }},
      {"rank_tolerance", [](SolverSettings& s, double n, double) { s.rank_tolerance = n; }},
      {"num_threads", [](SolverSettings& s, double, double) { s.num_threads = 0; }},
      {"num_threads", [](SolverSettings& s, double, double) { s.num_threads = 20000; }},
      {"max_iterations", [](SolverSettings& s, double, double) { s.max_iterations = 2000000; }},
      {"acceptable_tolerance",
       [](SolverSettings& s, double n, double) { s.acceptable_tolerance = n; }},
      {"acceptable_iterations",
       [](SolverSettings& s, double, double) { s.acceptable_iterations = 0; }},
      {"thread_spin_us", [](SolverSettings& s, double, double) { s.thread_spin_us = -1; }},
      {"divergence_threshold",
       [](SolverSettings& s, double n, double) { s.divergence_threshold = n; }},
      {"infeasibility_tolerance",
       [](SolverSettings& s, double, double) { s.infeasibility_tolerance = -1.0; }},
      {"filter_reset_trigger",
       [](SolverSettings& s, double, double) { s.filter_reset_trigger = -1; }},
      {"max_filter_resets", [](SolverSettings& s, double, double) { s.max_filter_resets = -1; }},
      {"max_second_order_corrections",
       [](SolverSettings& s, double, double) { s.max_second_order_corrections = -1; }},
  };
  Solver good(p);
  for (const Case& c : cases) {
    SolverSettings bad;
    c.spoil(bad, nan, inf);
    for (int where = 0; where < 2; ++where) {
      try {
        if (where == 0) {
          Solver s(p, bad);
        } else {
          good.setSettings(bad);
        }
        ADD_FAILURE() << c.field << ": accepted (" << (where ? "setSettings" : "constructor")
                      << ")";
      } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::strstr(e.what(), c.field), nullptr) << e.what();
      }
    }
  }
  // The defaults and the limits that mean "never" are valid, and the solver still works
  // after the rejected calls.
  SolverSettings never;
  never.divergence_threshold = inf;
  never.infeasibility_tolerance = inf;
  EXPECT_NO_THROW(solver::checkSettings(never));
  EXPECT_NO_THROW(good.setSettings(tight()));
  EXPECT_EQ(good.solve(d.x0), SolverStatus::Converged);
}

// ---- nonlinear (pendulum) and SE(3) problems ----------------------------------------------------

std::shared_ptr<ocp::OptimalControlProblem> pendulumProblem(int N = 40) {
  auto dyn = std::make_shared<ocp::RungeKutta4>(std::make_shared<testmodels::Pendulum>());
  auto p = std::make_shared<ocp::OptimalControlProblem>(dyn, N, 0.05);
  auto s = dyn->spacePtr();
  p->addCost("x", std::make_shared<ocp::LeastSquaresCost>(
                      std::make_shared<ocp::StateErrorResidual>(s, 1, VectorXd::Zero(2)),
                      (VectorXd(2) << 10.0, 1.0).finished()));
  p->addCost("u", std::make_shared<ocp::LeastSquaresCost>(
                      std::make_shared<ocp::InputErrorResidual>(2, VectorXd::Zero(1)),
                      VectorXd::Constant(1, 0.1)));
  p->addCost("xN",
             std::make_shared<ocp::LeastSquaresCost>(
                 std::make_shared<ocp::StateErrorResidual>(s, 1, VectorXd::Zero(2)),
                 VectorXd::Constant(2, 100.0)),
             ocp::Stage::Terminal);
  p->setInputBounds(VectorXd::Constant(1, -3.0), VectorXd::Constant(1, 3.0));
  p->setStateBounds((VectorXd(2) << -kInf, -2.0).finished(), (VectorXd(2) << kInf, 2.0).finished());
  // A soft state-only inequality: angle <= 1.2 (relaxed barrier).
  p->addInequality("soft",
                   std::make_shared<ocp::AffineResidual>(
                       s, VectorXd::Zero(2), (MatrixXd(1, 2) << -1.0, 0.0).finished(),
                       MatrixXd::Zero(1, 1), VectorXd::Constant(1, 1.2)),
                   ocp::Stage::All, {true, 0.05});
  return p;
}

TEST(SolverNonlinear, PendulumConverges) {
  auto p = pendulumProblem();
  Solver s(p, tight());
  const VectorXd x0 = (VectorXd(2) << 1.0, 0.0).finished();
  ASSERT_EQ(s.solve(x0), SolverStatus::Converged) << s.message();
  EXPECT_LT(s.iterations(), 60);
  EXPECT_LT(s.states().back().norm(), 0.2);
  for (const auto& u : s.inputs()) EXPECT_LE(std::abs(u(0)), 3.0 + 1e-9);
  EXPECT_NEAR(s.states()[0](0), 1.0, 1e-12);
}

TEST(SolverNonlinear, ResultsAreIdenticalForAnyThreadCount) {
  const VectorXd x0 = (VectorXd(2) << 1.0, 0.0).finished();
  std::vector<std::vector<VectorXd>> xs, us;
  std::vector<int> its;
  for (int threads : {1, 2, 3}) {
    auto set = tight();
    set.num_threads = threads;
    Solver s(pendulumProblem(), set);
    ASSERT_EQ(s.solve(x0), SolverStatus::Converged);
    xs.push_back(s.states());
    us.push_back(s.inputs());
    its.push_back(s.iterations());
  }
  for (std::size_t t = 1; t < xs.size(); ++t) {
    EXPECT_EQ(its[t], its[0]);
    for (std::size_t k = 0; k < xs[0].size(); ++k) EXPECT_TRUE(xs[t][k] == xs[0][k]) << k;
    for (std::size_t k = 0; k < us[0].size(); ++k) EXPECT_TRUE(us[t][k] == us[0][k]) << k;
  }
  // Same for a constrained LQ with equalities and general rows.
  auto d = lqtest::randomLq(7, 4, 3, 20, 1, 2);
  d.ulo = VectorXd::Constant(3, -0.4);
  d.uhi = VectorXd::Constant(3, 0.4);
  // Then real-time iterations from a perturbed state (the pipelined multi-thread
  // condensing / backward and forward / recovery paths of every update).
  std::vector<VectorXd> ref, ref_rt;
  for (int threads : {1, 2, 3}) {
    auto set = tight();
    set.num_threads = threads;
    Solver s(lqtest::buildProblem(d), set);
    ASSERT_EQ(s.solve(d.x0), SolverStatus::Converged);
    const std::vector<VectorXd> converged = s.states();
    set.mode = solver::SolverMode::RealTime;
    s.setSettings(set);
    for (int i = 1; i <= 4; ++i) {
      ASSERT_EQ(s.update(0.0, 0.9 * s.states()[1]), SolverStatus::IterationDone);
    }
    if (threads == 1) {
      ref = converged;
      ref_rt = s.states();
    } else {
      for (std::size_t k = 0; k < ref.size(); ++k) EXPECT_TRUE(converged[k] == ref[k]) << k;
      for (std::size_t k = 0; k < ref_rt.size(); ++k) EXPECT_TRUE(s.states()[k] == ref_rt[k]) << k;
    }
  }
}

TEST(SolverNonlinear, SolveAndUpdateDoNotAllocate) {
  for (int threads : {1, 2}) {
    auto set = tight();
    set.num_threads = threads;
    auto p = pendulumProblem();
    Solver s(p, set);
    const VectorXd x0 = (VectorXd(2) << 1.0, 0.0).finished();
    {
      test::AllocationGuard guard;
      test::MallocGuard mguard;
      EXPECT_EQ(s.solve(x0), SolverStatus::Converged);
      EXPECT_EQ(guard.count(), 0u);
      EXPECT_EQ(mguard.count(), 0u);
    }
    set.mode = solver::SolverMode::RealTime;
    s.setSettings(set);
    {
      test::AllocationGuard guard;
      test::MallocGuard mguard;
      for (int i = 1; i <= 5; ++i) {
        EXPECT_EQ(s.update(i * 0.05, s.states()[1]), SolverStatus::IterationDone);
      }
      (void)s.feedbackGain(0);
      EXPECT_EQ(guard.count(), 0u);
      EXPECT_EQ(mguard.count(), 0u);
    }
  }
  // The malloc guard does see Eigen's allocations.
  if (test::MallocGuard::enabled()) {
    test::MallocGuard mguard;
    VectorXd v(1000);
    v.setZero();
    EXPECT_GT(mguard.count(), 0u);
  }
}

// The curvature workspace of exact_hessian (H2 per node, a second NodeData and difference
// vectors per thread) exists only for settings that use it: a solver built for real-time
// iterations has none; setSettings (not real-time) allocates it the first time it asks for
// converging mode with the exact Hessian, and only then; the solver then converges exactly
// as one built in that mode, and its solve() allocates nothing.
TEST(SolverNonlinear, CurvatureWorkspaceOnlyForSettingsThatUseIt) {
  auto p = pendulumProblem();
  const VectorXd x0 = (VectorXd(2) << 1.0, 0.0).finished();
  const SolverSettings conv = tight();
  SolverSettings rt = tight(), gauss_newton = tight();
  rt.mode = solver::SolverMode::RealTime;
  gauss_newton.exact_hessian = false;
  std::size_t with = 0, without = 0;
  {
    test::AllocationGuard guard;
    Solver s(p, conv);
    with = guard.count();
  }
  {
    test::AllocationGuard guard;
    Solver s(p, rt);
    without = guard.count();
  }
  // H2 of every node comes from Eigen's malloc, which only the malloc guard sees (it is off
  // in sanitizer builds, whose allocator owns malloc).
  if (test::MallocGuard::enabled()) {
    EXPECT_GE(with, without + static_cast<std::size_t>(p->horizon()) + 1);
  } else {
    EXPECT_GT(with, without);
  }
  Solver ref(p, conv);
  ASSERT_EQ(ref.solve(x0), SolverStatus::Converged) << ref.message();
  Solver s(p, rt);
  {
    test::AllocationGuard guard;
    s.setSettings(gauss_newton);  // no curvature: nothing to allocate
    EXPECT_EQ(guard.count(), 0u);
  }
  {
    test::AllocationGuard guard;
    s.setSettings(conv);
    EXPECT_EQ(guard.count(), with - without);
  }
  {
    test::AllocationGuard guard;
    s.setSettings(rt);
    s.setSettings(conv);  // kept
    EXPECT_EQ(guard.count(), 0u);
  }
  {
    test::AllocationGuard guard;
    test::MallocGuard mguard;
    ASSERT_EQ(s.solve(x0), SolverStatus::Converged) << s.message();
    EXPECT_EQ(guard.count(), 0u);
    EXPECT_EQ(mguard.count(), 0u);
  }
  EXPECT_EQ(s.iterations(), ref.iterations());
  for (int k = 0; k <= p->horizon(); ++k) {
    EXPECT_TRUE(s.states()[static_cast<std::size_t>(k)] ==
                ref.states()[static_cast<std::size_t>(k)])
        << k;
  }
}

TEST(SolverLq, ConstrainedSolveDoesNotAllocate) {
  auto d = lqtest::randomLq(7, 4, 3, 20, 1, 2);
  d.Ex *= 0.1;
  d.Eu.col(2).array() += 2.0;
  d.Gx *= 0.2;
  d.g.array() += 0.5;
  d.ulo = VectorXd::Constant(3, -0.4);
  d.uhi = VectorXd::Constant(3, 0.4);
  d.ulo(2) = -kInf;
  d.uhi(2) = kInf;
  d.xhi(1) = 5.0;
  for (int threads : {1, 2}) {
    auto set = tight();
    set.num_threads = threads;
    Solver s(lqtest::buildProblem(d), set);
    test::AllocationGuard guard;
    test::MallocGuard mguard;
    EXPECT_EQ(s.solve(d.x0), SolverStatus::Converged);
    (void)s.feedbackGain(3);
    EXPECT_EQ(guard.count(), 0u);
    EXPECT_EQ(mguard.count(), 0u);
  }
}

TEST(SolverRealTime, IterationsConvergeAndShiftWarmStarts) {
  auto set = tight();
  set.mode = solver::SolverMode::RealTime;
  set.barrier_realtime = 1e-3;
  auto p = pendulumProblem(60);
  Solver s(p, set);
  const VectorXd x0 = (VectorXd(2) << 0.8, 0.0).finished();
  for (int i = 0; i < 40; ++i) ASSERT_EQ(s.update(0.0, x0), SolverStatus::IterationDone);
  ASSERT_EQ(s.stats().size(), 1u);
  EXPECT_LT(s.stats()[0].primal_residual, 1e-8);
  EXPECT_LT(s.stats()[0].dual_residual, 1e-6);
  EXPECT_DOUBLE_EQ(s.stats()[0].barrier, 1e-3);
  // Shift by two nodes, starting from the predicted state: the shifted guess is nearly
  // feasible (only the repeated tail adds a defect).
  const auto prev = s.states();
  ASSERT_EQ(s.update(2 * 0.05 + 1e-9, prev[2]), SolverStatus::IterationDone);
  EXPECT_LT(s.stats()[0].primal_residual, 5e-2);
  EXPECT_NEAR(s.states()[0](0), prev[2](0), 1e-12);
  // The feedback gain of node 0 maps state deviations to input changes (nu x ndx).
  EXPECT_EQ(s.feedbackGain(0).rows(), 1);
  EXPECT_EQ(s.feedbackGain(0).cols(), 2);
  EXPECT_TRUE(s.feedbackGain(0).allFinite());
}

/// A pendulum whose input cost (weight 10) wants u = 5 while its bound allows |u| <= 3.
std::shared_ptr<ocp::OptimalControlProblem> inputAgainstItsBound(
    int N, const ocp::InequalityOptions& bound_options) {
  auto dyn = std::make_shared<ocp::RungeKutta4>(std::make_shared<testmodels::Pendulum>());
  auto p = std::make_shared<ocp::OptimalControlProblem>(dyn, N, 0.05);
  auto space = dyn->spacePtr();
  p->addCost("x", std::make_shared<ocp::LeastSquaresCost>(
                      std::make_shared<ocp::StateErrorResidual>(space, 1, VectorXd::Zero(2)),
                      (VectorXd(2) << 0.01, 0.01).finished()));
  p->addCost("u", std::make_shared<ocp::LeastSquaresCost>(
                      std::make_shared<ocp::InputErrorResidual>(2, VectorXd::Constant(1, 5.0)),
                      VectorXd::Constant(1, 10.0)));
  p->setInputBounds(VectorXd::Constant(1, -3.0), VectorXd::Constant(1, 3.0), bound_options);
  return p;
}

// The new tail of a shift repeats the last node's input and takes its slacks and duals
// with it: an input bound active there stays active with its dual. A tail reinitialised
// with a weak barrier (z = mu / s) let the next Newton step run that input through its
// bound, and the fraction to the boundary then cut the whole horizon's step (the closed
// loop's MPC stalled at 1-5 % steps while trotting onto a step).
TEST(SolverRealTime, ShiftedTailKeepsItsActiveBound) {
  auto set = tight();
  set.mode = solver::SolverMode::RealTime;
  set.barrier_realtime = 1e-3;
  // The input wants 5, its bound allows 3: active at every node.
  auto p = inputAgainstItsBound(30, {});
  Solver s(p, set);
  const VectorXd x0 = (VectorXd(2) << 0.2, 0.0).finished();
  for (int i = 0; i < 60; ++i) ASSERT_EQ(s.update(0.0, x0), SolverStatus::IterationDone);
  const int N = p->horizon();
  ASSERT_NEAR(s.inputs()[static_cast<std::size_t>(N - 1)](0), 3.0, 1e-3);
  const int upper_row = p->maxInequalities() + 1;  // [lower, upper] of the one input bound
  const double z_last = s.inequalityDuals(N - 1)(upper_row);
  ASSERT_GT(z_last, 1.0);  // the bound holds the input against a cost gradient of 20
  const auto prev = s.states();
  ASSERT_EQ(s.update(p->dt() + 1e-9, prev[1]), SolverStatus::IterationDone);
  ASSERT_EQ(s.lastShift(), 1);
  EXPECT_GT(s.stats()[0].primal_step, 0.9);
  EXPECT_GT(s.inequalityDuals(N - 1)(upper_row), 0.5 * z_last);
  EXPECT_LE(s.inputs()[static_cast<std::size_t>(N - 1)](0), 3.0);
}

// realtime_iterations = k: one update runs k relinearised Newton iterations, the same
// iterate as k updates of one iteration each from the same state and time.
TEST(SolverRealTime, SeveralIterationsPerUpdateEqualSuccessiveUpdates) {
  auto set = tight();
  set.mode = solver::SolverMode::RealTime;
  auto p1 = pendulumProblem(30), p3 = pendulumProblem(30);
  Solver one(p1, set);
  set.realtime_iterations = 3;
  Solver three(p3, set);
  const VectorXd x0 = (VectorXd(2) << 0.8, 0.0).finished();
  ASSERT_EQ(three.update(0.0, x0), SolverStatus::IterationDone);
  ASSERT_EQ(three.stats().size(), 3u);
  EXPECT_EQ(three.iterations(), 3);
  for (int i = 0; i < 3; ++i) ASSERT_EQ(one.update(0.0, x0), SolverStatus::IterationDone);
  for (std::size_t k = 0; k < one.states().size(); ++k) {
    EXPECT_LT((one.states()[k] - three.states()[k]).norm(), 1e-12) << "node " << k;
  }
  // The first iteration's residual is that of the start, the last one's much smaller.
  EXPECT_LT(three.stats().back().primal_residual, three.stats().front().primal_residual);
}

// Soft input bounds (relaxed barrier): a real-time step that runs the input through its
// bound is taken whole (a hard bound cuts it by the fraction to the boundary), and the
// converged input exceeds the bound by an amount its weight sets.
TEST(SolverRealTime, SoftInputBoundsNeverCutTheStep) {
  const auto problem = [](bool soft, double weight) {
    ocp::InequalityOptions options;
    options.soft = soft;
    options.relaxation = 1e-3;
    options.weight = weight;
    return inputAgainstItsBound(20, options);  // wants 5, allowed 3
  };
  const VectorXd x0 = (VectorXd(2) << 0.2, 0.0).finished();
  auto set = tight();
  set.mode = solver::SolverMode::RealTime;
  Solver hard_rt(problem(false, 1.0), set), soft_rt(problem(true, 1e-3), set);
  ASSERT_EQ(hard_rt.update(0.0, x0), SolverStatus::IterationDone);
  ASSERT_EQ(soft_rt.update(0.0, x0), SolverStatus::IterationDone);
  EXPECT_LT(hard_rt.stats()[0].primal_step, 0.9);
  EXPECT_EQ(soft_rt.stats()[0].primal_step, 1.0);

  set.mode = solver::SolverMode::Converging;
  const auto worst = [](const Solver& s) {
    double u = -1e9;
    for (const auto& v : s.inputs()) u = std::max(u, v(0));
    return u;
  };
  Solver hard(problem(false, 1.0), set), light(problem(true, 1e-4), set),
      heavy(problem(true, 1e-2), set);
  ASSERT_EQ(hard.solve(x0), SolverStatus::Converged);
  ASSERT_EQ(light.solve(x0), SolverStatus::Converged);
  ASSERT_EQ(heavy.solve(x0), SolverStatus::Converged);
  EXPECT_LE(worst(hard), 3.0);
  // The input cost's slope at the bound is dt W (5 - 3) = 1. Against the relaxed barrier
  // w B(c), c = 3 - u, with slope w / c for c >= delta and (w / delta)(2 - c / delta)
  // below: w = 1e-2 stops at c = 0.01 (inside), w = 1e-4 at c = -8 delta (outside).
  EXPECT_NEAR(worst(heavy), 2.99, 1e-3);
  EXPECT_NEAR(worst(light), 3.008, 1e-3);
}

TEST(SolverRealTime, UpdatesFasterThanTheNodeStepAddUpToShifts) {
  auto set = tight();
  set.mode = solver::SolverMode::RealTime;
  auto p = pendulumProblem(30);
  const double dt = p->dt();
  Solver s(p, set);
  VectorXd x = (VectorXd(2) << 0.5, 0.0).finished();
  ASSERT_EQ(s.update(0.0, x), SolverStatus::IterationDone);
  EXPECT_EQ(s.lastShift(), 0);
  // An MPC updating every 0.4 dt: the solution must have moved floor(t / dt) nodes in
  // total at every update, not 0 (each update less than a node after the previous one).
  int total = 0;
  for (int i = 1; i <= 20; ++i) {
    const double t = i * 0.4 * dt;
    x = s.states()[1];
    ASSERT_EQ(s.update(t, x), SolverStatus::IterationDone) << s.message();
    EXPECT_GE(s.lastShift(), 0);
    EXPECT_LE(s.lastShift(), 1);
    total += s.lastShift();
    EXPECT_EQ(total, static_cast<int>(std::floor(i * 0.4 + 1e-9))) << "update " << i;
  }
  // Time going backwards restarts the grid there without a shift; a whole node later
  // shifts by one again. solve() never shifts.
  const double t_back = 3.0 * dt;
  ASSERT_EQ(s.update(t_back, x), SolverStatus::IterationDone);
  EXPECT_EQ(s.lastShift(), 0);
  ASSERT_EQ(s.update(t_back + dt, x), SolverStatus::IterationDone);
  EXPECT_EQ(s.lastShift(), 1);
  ASSERT_EQ(s.update(t_back + 3.5 * dt, x), SolverStatus::IterationDone);
  EXPECT_EQ(s.lastShift(), 2);
  s.solve(x);
  EXPECT_EQ(s.lastShift(), 0);
}

/// Input upper bound that exists only in mode 1: r = 2 - u(0) >= 0 (one row), none otherwise.
class ModeBound final : public ocp::Residual {
 public:
  ModeBound() : Residual(2, 1, 1) {}
  int rows(const ocp::NodeContext& ctx) const override { return ctx.mode == 1 ? 1 : 0; }
  void calc(const ocp::NodeContext&, ocp::ConstVecRef, ocp::ConstVecRef u,
            ocp::ResidualData& d) const override {
    d.r(0) = 2.0 - u(0);
  }
  void calcDiff(const ocp::NodeContext&, ocp::ConstVecRef, ocp::ConstVecRef,
                ocp::ResidualData& d) const override {
    d.Rx.setZero();
    d.Ru(0, 0) = -1.0;
  }
};

/// ModeBound whose declaration leaves out the input column its Jacobian uses.
class UndeclaredInputBound final : public ocp::Residual {
 public:
  UndeclaredInputBound() : Residual(2, 1, 1) {}
  ocp::ColumnRange inputColumns() const override { return {0, 0}; }
  void calc(const ocp::NodeContext&, ocp::ConstVecRef, ocp::ConstVecRef u,
            ocp::ResidualData& d) const override {
    d.r(0) = 2.0 - u(0);
  }
  void calcDiff(const ocp::NodeContext&, ocp::ConstVecRef, ocp::ConstVecRef,
                ocp::ResidualData& d) const override {
    d.Rx.setZero();
    d.Ru(0, 0) = -1.0;
  }
};

// The solver keeps the inequality Jacobians' columns the terms declare: a term whose
// Jacobian is non-zero outside them is reported, in either mode and with any thread count,
// not silently cut.
TEST(SolverLq, JacobianOutsideTheDeclaredColumnsIsReported) {
  for (const auto mode : {solver::SolverMode::Converging, solver::SolverMode::RealTime}) {
    for (int threads : {1, 2}) {
      auto p = pendulumProblem(10);
      p->addInequality("bound", std::make_shared<UndeclaredInputBound>());
      auto set = tight();
      set.mode = mode;
      set.num_threads = threads;
      Solver s(p, set);
      const VectorXd x = (VectorXd(2) << 1.0, 0.0).finished();
      try {
        if (mode == solver::SolverMode::RealTime) {
          s.update(0.0, x);
        } else {
          s.solve(x);
        }
        ADD_FAILURE() << "no error, threads " << threads;
      } catch (const std::logic_error& e) {
        EXPECT_NE(std::string(e.what()).find("inputColumns"), std::string::npos) << e.what();
      }
    }
  }
}

TEST(SolverRealTime, ShiftAcrossModeSwitchesDoesNotAllocate) {
  auto p = pendulumProblem(30);
  p->addInequality("mode1", std::make_shared<ModeBound>());
  auto set = tight();
  set.mode = solver::SolverMode::RealTime;
  set.num_threads = 2;
  Solver s(p, set);
  const std::vector<double> times{0.3, 0.6, 0.9, 1.2, 1.5, 1.8, 2.1};
  const std::vector<int> modes{0, 1, 0, 1, 0, 1, 0, 1};
  p->modeSchedule().set(times, modes);
  VectorXd x = (VectorXd(2) << 1.0, 0.0).finished();
  ASSERT_EQ(s.update(0.0, x), SolverStatus::IterationDone);
  test::AllocationGuard guard;
  test::MallocGuard mguard;
  for (int i = 1; i <= 40; ++i) {
    // Advance by one or two nodes; the rows of the shifted nodes change with the mode.
    const double t = i * 0.075;
    x = s.states()[1];
    ASSERT_EQ(s.update(t, x), SolverStatus::IterationDone) << s.message();
    for (int k = 0; k < p->horizon(); ++k) {
      const auto& d = s.nodeData(k);
      ASSERT_EQ(d.ni, d.context.mode == 1 ? 2 : 1);  // soft row + the mode-1 bound
    }
  }
  EXPECT_EQ(guard.count(), 0u);
  EXPECT_EQ(mguard.count(), 0u);
  EXPECT_TRUE(allFinite(s));
  // A row that appears with a shift starts violated (its slack is reinitialised); further
  // iterations at a fixed time make the bound hold.
  const double t_end = 40 * 0.075;
  for (int i = 0; i < 15; ++i) ASSERT_EQ(s.update(t_end, x), SolverStatus::IterationDone);
  for (int k = 0; k < p->horizon(); ++k) {
    if (s.nodeData(k).context.mode == 1) {
      EXPECT_LE(s.inputs()[static_cast<std::size_t>(k)](0), 2.0 + 1e-6) << k;
    }
  }
}

// OptimalControlProblem::InputGuess: a real-time update refits the inputs the shift
// appended and those of nodes whose mode changed since they were solved (the grid moved by
// 1.5 nodes: nodes near a switch change mode), and no others; without allocating.
TEST(SolverRealTime, InputGuessRefitsAppendedAndModeChangedNodes) {
  auto p = pendulumProblem(30);
  p->addInequality("mode1", std::make_shared<ModeBound>());
  const int N = p->horizon();
  const double dt = p->dt();
  p->modeSchedule().set({0.32, 0.62, 0.92, 1.22, 1.52, 1.82, 2.12}, {0, 1, 0, 1, 0, 1, 0, 1});
  std::array<int, 64> calls{};
  p->setInputGuess([&calls](const ocp::NodeContext& ctx, ocp::ConstVecRef, ocp::VecRef u) {
    ++calls[static_cast<std::size_t>(ctx.node)];
    u(0) = ctx.mode == 1 ? 1.0 : 0.0;
  });
  auto set = tight();
  set.mode = solver::SolverMode::RealTime;
  Solver s(p, set);
  VectorXd x = (VectorXd(2) << 1.0, 0.0).finished();
  ASSERT_EQ(s.update(0.0, x), SolverStatus::IterationDone);
  EXPECT_EQ(std::count(calls.begin(), calls.end(), 0), 64);  // nothing solved before
  x = s.states()[1];
  test::AllocationGuard guard;
  ASSERT_EQ(s.update(1.5 * dt, x), SolverStatus::IterationDone);
  EXPECT_EQ(guard.count(), 0u);
  ASSERT_EQ(s.lastShift(), 1);
  int refitted = 0;
  for (int k = 0; k < N; ++k) {
    // Node k now holds what node k + 1 was (time (k + 1) dt); it lies at 1.5 dt + k dt.
    const int old_mode = p->modeSchedule().modeAt((k + 1) * dt);
    const int new_mode = p->modeSchedule().modeAt(1.5 * dt + k * dt);
    const bool expected = k == N - 1 || old_mode != new_mode;
    EXPECT_EQ(calls[static_cast<std::size_t>(k)], expected ? 1 : 0) << "node " << k;
    refitted += expected ? 1 : 0;
  }
  EXPECT_GE(refitted, 4);  // the appended node and a node at each switch in the horizon
}

/// A double integrator whose model breaks (NaN) above a speed of 3.
class FragileIntegrator final : public ocp::ContinuousDynamics {
 public:
  FragileIntegrator() : ContinuousDynamics(std::make_shared<ocp::EuclideanSpace>(2), 1) {}
  std::unique_ptr<ocp::DynamicsData> createData() const override {
    return std::make_unique<ocp::DynamicsData>();
  }
  void calc(const ocp::NodeContext&, ocp::ConstVecRef x, ocp::ConstVecRef u, ocp::DynamicsData&,
            ocp::VecRef xdot) const override {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    xdot(0) = std::abs(x(1)) > 3.0 ? nan : x(1);
    xdot(1) = u(0);
  }
  void calcDiff(const ocp::NodeContext&, ocp::ConstVecRef, ocp::ConstVecRef, ocp::DynamicsData&,
                ocp::MatRef fx, ocp::MatRef fu) const override {
    fx << 0.0, 1.0, 0.0, 0.0;
    fu << 0.0, 1.0;
  }
};

// A real-time iteration recovers each hard row's slack step from the row's Jacobian blocks
// (kept packed after the linearising pass): for linear rows the step moves s - g by
// (1 - alpha), s_new - g(x_new, u_new) = (1 - alpha) (s_old - g(x_old, u_old)). Rows with
// zero columns at both ends, x-only and u-only rows and mirrored pairs give several blocks
// per node; with one and two threads.
TEST(SolverRealTime, SlackStepsFollowTheRowsLinearisation) {
  auto d = lqtest::randomLq(21, 6, 5, 20, 0, 0);
  std::mt19937 rng(9);
  const int m = 2;
  MatrixXd Hx = lqtest::randn(m, d.nx, rng, 0.4), Hu = lqtest::randn(m, d.nu, rng, 0.4);
  Hx.col(0).setZero();
  Hx.col(1).setZero();
  Hx.col(5).setZero();
  Hu.col(0).setZero();
  MatrixXd Gx(2 * m, d.nx), Gu(2 * m, d.nu);
  Gx << Hx, -Hx;
  Gu << Hu, -Hu;
  const VectorXd g = (VectorXd(2 * m) << 0.3, 0.3, 0.2, 0.2).finished();
  // An x-only row (columns 2..3), a u-only row (columns 1..3), a row on x(4) and u(4).
  MatrixXd Px = MatrixXd::Zero(3, d.nx), Pu = MatrixXd::Zero(3, d.nu);
  Px.block(0, 2, 1, 2) = lqtest::randn(1, 2, rng, 0.5);
  Pu.block(1, 1, 1, 3) = lqtest::randn(1, 3, rng, 0.5);
  Px(2, 4) = 0.7;
  Pu(2, 4) = -0.4;
  const VectorXd pc = VectorXd::Constant(3, 0.4);
  for (const int threads : {1, 2}) {
    auto p = lqtest::buildProblem(d);
    const auto& space = p->dynamics().spacePtr();
    p->addInequality("limits", std::make_shared<test::MirroredAffine>(space, Gx, Gu, g, m));
    p->addInequality(
        "parts", std::make_shared<ocp::AffineResidual>(space, VectorXd::Zero(d.nx), Px, Pu, pc));
    auto set = tight();
    set.mode = solver::SolverMode::RealTime;
    set.num_threads = threads;
    Solver s(p, set);
    // From near the solution to a moved initial state: a long step, rows that move.
    for (int it = 0; it < 30; ++it) ASSERT_EQ(s.update(0.0, d.x0), SolverStatus::IterationDone);
    const VectorXd x0 = d.x0 + lqtest::randn(d.nx, 1, rng, 0.3);
    std::vector<VectorXd> s_old, g_old;
    auto nd = p->createNodeData();
    for (int k = 0; k < d.N; ++k) {
      s_old.push_back(s.slacks(k));
      p->evaluate(k, s.states()[static_cast<std::size_t>(k)],
                  s.inputs()[static_cast<std::size_t>(k)], *nd);
      g_old.push_back(nd->g.head(nd->ni));
    }
    ASSERT_EQ(s.update(0.0, x0), SolverStatus::IterationDone) << s.message();
    const double alpha = s.stats().back().primal_step;
    ASSERT_GT(alpha, 0.1) << threads << " threads";
    double moved = 0.0;
    for (int k = 0; k < d.N; ++k) {
      const auto kk = static_cast<std::size_t>(k);
      p->evaluate(k, s.states()[kk], s.inputs()[kk], *nd);
      ASSERT_EQ(nd->ni, 2 * m + 3);
      for (int i = 0; i < nd->ni; ++i) {
        const double before = s_old[kk](i) - g_old[kk](i);
        const double after = s.slacks(k)(i) - nd->g(i);
        EXPECT_NEAR(after, (1.0 - alpha) * before,
                    1e-10 * (1.0 + std::abs(s_old[kk](i)) + std::abs(g_old[kk](i))))
            << threads << " threads, node " << k << ", row " << i;
        moved = std::max(moved, std::abs(s.slacks(k)(i) - s_old[kk](i)));
      }
    }
    EXPECT_GT(moved, 1e-3) << "the slacks should move";
  }
}

TEST(SolverRealTime, DivergingIterateIsRestored) {
  auto dyn = std::make_shared<ocp::ExplicitEuler>(std::make_shared<FragileIntegrator>());
  auto p = std::make_shared<ocp::OptimalControlProblem>(dyn, 20, 0.05);
  auto sp = dyn->spacePtr();
  const VectorXd target = (VectorXd(2) << 10.0, 0.0).finished();  // far: asks for speed > 3
  p->addCost("x",
             std::make_shared<ocp::LeastSquaresCost>(
                 std::make_shared<ocp::StateErrorResidual>(sp, 1, target), VectorXd::Ones(2)),
             ocp::Stage::All);
  p->addCost("u", std::make_shared<ocp::LeastSquaresCost>(
                      std::make_shared<ocp::InputErrorResidual>(2, VectorXd::Zero(1)),
                      VectorXd::Constant(1, 1e-6)));
  auto set = tight();
  set.mode = solver::SolverMode::RealTime;
  Solver s(p, set);
  const VectorXd x0 = VectorXd::Zero(2);
  ASSERT_EQ(s.update(0.0, x0), SolverStatus::IterationDone);
  double vmax = 0.0;
  for (const auto& x : s.states()) vmax = std::max(vmax, std::abs(x(1)));
  ASSERT_GT(vmax, 3.0) << "the first step should enter the region where the model breaks";
  const auto before = s.states();
  EXPECT_EQ(s.update(0.0, x0), SolverStatus::Diverged) << s.message();
  EXPECT_TRUE(allFinite(s));
  // The last good iterate (the one the failed step started from) is restored.
  double vmax_after = 0.0;
  for (const auto& x : s.states()) vmax_after = std::max(vmax_after, std::abs(x(1)));
  EXPECT_LE(vmax_after, 3.0);
  EXPECT_NE(std::strstr(s.message(), "restored"), nullptr) << s.message();
}

TEST(SolverNonlinear, FloatingBodyOnSe3ReachesTarget) {
  auto f = std::make_shared<testmodels::FloatingBody>();
  auto dyn = std::make_shared<ocp::ExplicitEuler>(f);
  auto p = std::make_shared<ocp::OptimalControlProblem>(dyn, 30, 0.05);
  auto sp = dyn->spacePtr();
  VectorXd target(13);
  sp->neutral(target);
  target.head<3>() << 0.5, -0.3, 0.2;
  const Eigen::Quaterniond qt(Eigen::AngleAxisd(1.2, Eigen::Vector3d(1, 2, 3).normalized()));
  target.segment<4>(3) = qt.coeffs();
  VectorXd w = VectorXd::Constant(12, 1.0);
  p->addCost("x", std::make_shared<ocp::LeastSquaresCost>(
                      std::make_shared<ocp::StateErrorResidual>(sp, 6, target), w));
  p->addCost("u", std::make_shared<ocp::LeastSquaresCost>(
                      std::make_shared<ocp::InputErrorResidual>(12, VectorXd::Zero(6)),
                      VectorXd::Constant(6, 1e-2)));
  p->addCost(
      "xN",
      std::make_shared<ocp::LeastSquaresCost>(
          std::make_shared<ocp::StateErrorResidual>(sp, 6, target), VectorXd::Constant(12, 1e3)),
      ocp::Stage::Terminal);
  VectorXd lo = VectorXd::Constant(12, -kInf), hi = VectorXd::Constant(12, kInf);
  lo.tail<6>().setConstant(-3.0);
  hi.tail<6>().setConstant(3.0);
  p->setStateBounds(lo, hi);
  p->setInputBounds(VectorXd::Constant(6, -30.0), VectorXd::Constant(6, 30.0));
  Solver s(p, tight());
  VectorXd x0(13);
  sp->neutral(x0);
  {
    test::AllocationGuard guard;
    test::MallocGuard mguard;
    ASSERT_EQ(s.solve(x0), SolverStatus::Converged) << s.message();
    EXPECT_EQ(guard.count(), 0u);
    EXPECT_EQ(mguard.count(), 0u);
  }
  VectorXd err(12);
  sp->difference(target, s.states().back(), err);
  EXPECT_LT(err.head<6>().norm(), 0.05);
  for (const auto& x : s.states()) {
    EXPECT_NEAR(x.segment<4>(3).norm(), 1.0, 1e-12);
    EXPECT_LE(x.tail<6>().cwiseAbs().maxCoeff(), 3.0 + 1e-8);
  }
}

/// Active rows of a converged solve: the dual exceeds the slack (strict complementarity
/// separates them by orders of magnitude at the solution).
int activeRows(const Solver& s, int N) {
  int active = 0;
  for (int k = 0; k <= N; ++k) {
    const VectorXd& z = s.inequalityDuals(k);
    const VectorXd& sl = s.slacks(k);
    for (int i = 0; i < z.size(); ++i) active += (z(i) > sl(i)) ? 1 : 0;
  }
  return active;
}

TEST(SolverLq, RobotSizeQpWithManyActiveRowsConvergesInFewIterations) {
  // The Tachyon 3 sizes (nx 24, nu 30, N 100, 15 equalities and 100 inequality rows per
  // node) with about 720 rows active: Mehrotra's predictor-corrector from a
  // cold start in at most 25 iterations, at the optimum the monotone barrier with the
  // filter line search (an independent path through the solver) also reaches.
  const robotlq::Data d = robotlq::makeActiveData();
  const std::vector<VectorXd> xs(robotlq::kN + 1, VectorXd::Zero(robotlq::kNx));
  const std::vector<VectorXd> us(robotlq::kN, VectorXd::Zero(robotlq::kNu));
  SolverSettings set;
  Solver pc(robotlq::makeProblem(d), set);
  pc.setInitialGuess(xs, us);
  ASSERT_EQ(pc.solve(d.x0), SolverStatus::Converged) << pc.message();
  const int active = activeRows(pc, robotlq::kN);
  std::printf("[robot-size QP] predictor-corrector: %d iterations, %d active rows\n",
              pc.iterations(), active);
  EXPECT_LE(pc.iterations(), 25);
  EXPECT_GE(active, 600);

  set.predictor_corrector = false;
  set.max_iterations = 200;
  Solver mono(robotlq::makeProblem(d), set);
  mono.setInitialGuess(xs, us);
  ASSERT_EQ(mono.solve(d.x0), SolverStatus::Converged) << mono.message();
  std::printf("[robot-size QP] monotone barrier: %d iterations, cost %.12g vs %.12g\n",
              mono.iterations(), mono.cost(), pc.cost());
  EXPECT_NEAR(pc.cost(), mono.cost(), 1e-7 * std::max(1.0, std::abs(mono.cost())));
  double du = 0.0;
  for (int k = 0; k < robotlq::kN; ++k) {
    du = std::max(
        du, (pc.inputs()[static_cast<std::size_t>(k)] - mono.inputs()[static_cast<std::size_t>(k)])
                .lpNorm<Eigen::Infinity>());
  }
  EXPECT_LT(du, 1e-3);
}

}  // namespace
