// The CBF-QP's dense QP solver (Goldfarb-Idnani): KKT conditions on random problems,
// brute-force enumeration of active sets on small ones, degenerate and rank-deficient
// constraints, infeasible and invalid problems, warm start, iteration cap, no allocation.
#include "rollstep/control/dense_qp.hpp"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "common/alloc_counter.hpp"
#include "qp_test_problems.hpp"

namespace {

using namespace rollstep;
using control::ActiveSide;
using control::DenseQpDims;
using control::DenseQpProblem;
using control::DenseQpSolver;
using control::DenseQpStatus;
using Eigen::MatrixXd;
using Eigen::VectorXd;
using qptest::kInf;

// Tolerance of the KKT residuals: the data are O(1)-O(10), H's condition <= 1e2 (1e4 in
// the ill-conditioned case), so the residuals of an exact method are ~1e-13.
constexpr double kKktTol = 1e-8;

void expectKkt(const DenseQpProblem& qp, const DenseQpSolver& s, double tol = kKktTol) {
  const control::DenseQpKkt k = control::computeKktResiduals(qp, s);
  EXPECT_LE(k.stationarity, tol);
  EXPECT_LE(k.primal, tol);
  EXPECT_LE(k.complementarity, tol);
  EXPECT_LE(k.dual_sign, tol);
}

TEST(DenseQp, RandomProblemsSatisfyKkt) {
  const std::vector<qptest::RandomQpSpec> specs = {{5, 0, 8},    {10, 3, 20},   {20, 8, 40},
                                                   {30, 12, 60}, {40, 20, 100}, {12, 0, 0}};
  int total_active = 0;
  for (const auto& spec : specs) {
    DenseQpProblem qp({spec.n, spec.n_eq, spec.n_ineq});
    DenseQpSolver solver({spec.n, spec.n_eq, spec.n_ineq});
    solver.settings().warm_start = false;
    for (unsigned seed = 1; seed <= 20; ++seed) {
      qptest::makeRandomQp(spec, seed, qp);
      ASSERT_EQ(solver.solve(qp), DenseQpStatus::Optimal) << spec.n << " seed " << seed;
      expectKkt(qp, solver);
      total_active += solver.numActiveInequalities();
      // The objective reported is the one at x.
      const VectorXd x = solver.x();
      EXPECT_NEAR(solver.objective(), 0.5 * x.dot(qp.H() * x) + qp.g().dot(x),
                  1e-9 * (1.0 + std::abs(solver.objective())));
    }
  }
  EXPECT_GT(total_active, 500);  // the problems are constrained, not trivially interior
}

TEST(DenseQp, RowAndCostScalingDoNotChangeTheSolution) {
  // Rows scaled by 10^-4 .. 10^4 (sides with them) and the cost by 10^3 describe the same
  // problem: the same x, and multipliers scaled inversely.
  qptest::RandomQpSpec spec{30, 12, 60};
  DenseQpProblem qp({30, 12, 60});
  DenseQpSolver solver({30, 12, 60});
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> E(-4.0, 4.0);
  for (unsigned seed = 1; seed <= 5; ++seed) {
    qptest::makeRandomQp(spec, seed, qp);
    ASSERT_EQ(solver.solve(qp), DenseQpStatus::Optimal);
    const VectorXd x_ref = solver.x(), zl_ref = solver.zLower(), zu_ref = solver.zUpper();
    VectorXd scale(60);
    for (int i = 0; i < 60; ++i) {
      scale(i) = std::pow(10.0, E(rng));
      qp.C().row(i) *= scale(i);
      qp.l()(i) *= scale(i);
      qp.u()(i) *= scale(i);
    }
    for (int i = 0; i < 12; ++i) {
      const double s = std::pow(10.0, E(rng));
      qp.Aeq().row(i) *= s;
      qp.beq()(i) *= s;
    }
    qp.H() *= 1e3;
    qp.g() *= 1e3;
    solver.resetWarmStart();
    ASSERT_EQ(solver.solve(qp), DenseQpStatus::Optimal) << seed;
    EXPECT_LE((solver.x() - x_ref).lpNorm<Eigen::Infinity>(), 1e-8) << seed;
    for (int i = 0; i < 60; ++i) {
      EXPECT_NEAR(solver.zLower()(i) * scale(i), 1e3 * zl_ref(i), 1e-6 * (1.0 + 1e3 * zl_ref(i)));
      EXPECT_NEAR(solver.zUpper()(i) * scale(i), 1e3 * zu_ref(i), 1e-6 * (1.0 + 1e3 * zu_ref(i)));
    }
  }
}

TEST(DenseQp, IllConditionedHessian) {
  qptest::RandomQpSpec spec{30, 12, 60};
  spec.h_condition = 1e4;
  DenseQpProblem qp({30, 12, 60});
  DenseQpSolver solver({30, 12, 60});
  for (unsigned seed = 1; seed <= 10; ++seed) {
    qptest::makeRandomQp(spec, seed, qp);
    ASSERT_EQ(solver.solve(qp), DenseQpStatus::Optimal) << seed;
    expectKkt(qp, solver, 1e-7);
  }
}

// ---------------------------------------------------------------------------------------
// Brute force: every subset of the inequality sides as the active set.

struct BruteForce {
  bool feasible = false;
  VectorXd x;
  double cost = kInf;
};

BruteForce bruteForce(const DenseQpProblem& qp) {
  const int n = qp.n(), me = qp.nEq();
  // One-sided constraints n_k^T x >= b_k.
  std::vector<VectorXd> normals;
  std::vector<double> rhs;
  for (int i = 0; i < qp.nIneq(); ++i) {
    if (qp.l()(i) > -kInf) normals.push_back(qp.C().row(i).transpose()), rhs.push_back(qp.l()(i));
    if (qp.u()(i) < kInf) normals.push_back(-qp.C().row(i).transpose()), rhs.push_back(-qp.u()(i));
  }
  for (int j = 0; j < n; ++j) {
    if (qp.lb()(j) > -kInf) normals.push_back(VectorXd::Unit(n, j)), rhs.push_back(qp.lb()(j));
    if (qp.ub()(j) < kInf) normals.push_back(-VectorXd::Unit(n, j)), rhs.push_back(-qp.ub()(j));
  }
  const int m = static_cast<int>(normals.size());
  BruteForce best;
  for (unsigned mask = 0; mask < (1u << m); ++mask) {
    std::vector<int> set;
    for (int k = 0; k < m; ++k)
      if (mask & (1u << k)) set.push_back(k);
    const int na = me + static_cast<int>(set.size());
    if (na > n) continue;
    MatrixXd K = MatrixXd::Zero(n + na, n + na);
    VectorXd rhs_k(n + na);
    K.topLeftCorner(n, n) = qp.H();
    rhs_k.head(n) = -qp.g();
    for (int a = 0; a < na; ++a) {
      const VectorXd nk = a < me ? VectorXd(qp.Aeq().row(a).transpose()) : normals[set[a - me]];
      K.block(0, n + a, n, 1) = -nk;
      K.block(n + a, 0, 1, n) = nk.transpose();
      rhs_k(n + a) = a < me ? qp.beq()(a) : rhs[set[a - me]];
    }
    const Eigen::FullPivLU<MatrixXd> lu(K);
    if (lu.rank() < n + na) continue;
    const VectorXd sol = lu.solve(rhs_k);
    const VectorXd x = sol.head(n);
    bool ok = true;
    for (int a = me; a < na && ok; ++a) ok = sol(n + a) >= -1e-9;
    for (int k = 0; k < m && ok; ++k) ok = normals[k].dot(x) - rhs[k] >= -1e-9;
    if (!ok) continue;
    const double cost = 0.5 * x.dot(qp.H() * x) + qp.g().dot(x);
    if (cost < best.cost) best = {true, x, cost};
  }
  return best;
}

TEST(DenseQp, MatchesBruteForceEnumeration) {
  DenseQpProblem qp({4, 2, 6});
  DenseQpSolver solver({4, 2, 6});
  solver.settings().warm_start = false;
  int optimal = 0, infeasible = 0;
  unsigned seed = 100;
  for (int n = 1; n <= 4; ++n) {
    for (int trial = 0; trial < 60; ++trial, ++seed) {
      qptest::RandomQpSpec spec;
      spec.n = n;
      spec.n_eq = trial % 3 == 0 ? std::min(n - 1, 1 + trial % 2) : 0;
      // At most 6 finite one-sided constraints in all (rows + bounds).
      spec.n_ineq = std::min(6, 1 + trial % 4);
      spec.p_bounded = 0.0;
      spec.p_infinite_side = 0.6;
      spec.g_scale = 3.0;
      spec.feasible = trial % 4 != 3;  // a quarter drawn without a feasible point
      qptest::makeRandomQp(spec, seed, qp);
      const BruteForce bf = bruteForce(qp);
      const DenseQpStatus st = solver.solve(qp);
      if (!bf.feasible) {
        EXPECT_EQ(st, DenseQpStatus::Infeasible) << "n " << n << " seed " << seed;
        ++infeasible;
        continue;
      }
      ASSERT_EQ(st, DenseQpStatus::Optimal) << "n " << n << " seed " << seed;
      EXPECT_LE((solver.x() - bf.x).lpNorm<Eigen::Infinity>(), 1e-8) << "seed " << seed;
      EXPECT_NEAR(solver.objective(), bf.cost, 1e-8 * (1.0 + std::abs(bf.cost)));
      expectKkt(qp, solver);
      ++optimal;
    }
  }
  EXPECT_GT(optimal, 150);
  EXPECT_GT(infeasible, 5);  // the infeasible branch was exercised
}

TEST(DenseQp, MatchesBruteForceWithBounds) {
  DenseQpProblem qp({3, 1, 2});
  DenseQpSolver solver({3, 1, 2});
  int optimal = 0;
  for (unsigned seed = 500; seed < 620; ++seed) {
    qptest::RandomQpSpec spec{3, seed % 2 == 0 ? 1 : 0, 2};
    spec.p_bounded = 0.5;
    spec.p_infinite_side = 0.5;
    qptest::makeRandomQp(spec, seed, qp);
    // Keep m <= 6 one-sided sides: drop sides beyond six.
    int m = 0;
    for (int i = 0; i < 2; ++i) m += (qp.l()(i) > -kInf) + (qp.u()(i) < kInf);
    for (int j = 0; j < 3; ++j) {
      if (m >= 6) qp.lb()(j) = -kInf, qp.ub()(j) = kInf;
      m += (qp.lb()(j) > -kInf) + (qp.ub()(j) < kInf);
    }
    const BruteForce bf = bruteForce(qp);
    ASSERT_TRUE(bf.feasible);
    ASSERT_EQ(solver.solve(qp), DenseQpStatus::Optimal) << seed;
    EXPECT_LE((solver.x() - bf.x).lpNorm<Eigen::Infinity>(), 1e-8) << seed;
    expectKkt(qp, solver);
    ++optimal;
  }
  EXPECT_EQ(optimal, 120);
}

// ---------------------------------------------------------------------------------------
// Degenerate constraints

// min 0.5 |x - target|^2: the projection of target on the feasible set.
void setProjection(DenseQpProblem& qp, const VectorXd& target) {
  qp.H().setIdentity();
  qp.g() = -target;
}

TEST(DenseQp, DuplicateAndParallelRows) {
  // x0 + x1 >= 1 written five ways (duplicates, scaled copies, the same as an upper side
  // of the negated row), plus x0 - x1 = 0: the optimum is (0.5, 0.5) from target 0.
  DenseQpProblem qp({2, 1, 5});
  DenseQpSolver solver({2, 1, 5});
  qp.clear();
  setProjection(qp, VectorXd::Zero(2));
  qp.Aeq() << 1, -1;
  qp.beq() << 0;
  qp.C() << 1, 1, 1, 1, 2, 2, 0.5, 0.5, -1, -1;
  qp.l() << 1, 1, 2, 0.5, -kInf;
  qp.u() << kInf, kInf, kInf, kInf, -1;
  ASSERT_EQ(solver.solve(qp), DenseQpStatus::Optimal);
  EXPECT_NEAR(solver.x()(0), 0.5, 1e-12);
  EXPECT_NEAR(solver.x()(1), 0.5, 1e-12);
  expectKkt(qp, solver, 1e-12);
  EXPECT_EQ(solver.numActiveInequalities(), 1);  // one copy carries the whole multiplier
  const double total = solver.zLower()(0) + solver.zLower()(1) + 2 * solver.zLower()(2) +
                       0.5 * solver.zLower()(3) + solver.zUpper()(4);
  EXPECT_NEAR(total, 0.5, 1e-12);  // d/dt of the cost along (1,1)/2
}

TEST(DenseQp, ManyConstraintsActiveAtAVertex) {
  // Eight planes through the vertex v = (1, 1, 1) of a cone containing the feasible set;
  // target - v = (9, 19, 29) is inside the cone of the normals e1, e2, e3, so the
  // projection is the vertex, where every plane is active (degenerate: eight sides through
  // the point, three variables; the multipliers are not unique).
  DenseQpProblem qp({3, 0, 8});
  DenseQpSolver solver({3, 0, 8});
  qp.clear();
  setProjection(qp, Eigen::Vector3d(10.0, 20.0, 30.0));
  const VectorXd v = VectorXd::Ones(3);
  qp.C() << 1, 0, 0, 0, 1, 0, 0, 0, 1, 1, 1, 0, 0, 1, 1, 1, 0, 1, 1, 1, 1, 2, 1, 1;
  for (int i = 0; i < 8; ++i) {
    qp.u()(i) = qp.C().row(i).dot(v);
    qp.l()(i) = -kInf;
  }
  ASSERT_EQ(solver.solve(qp), DenseQpStatus::Optimal);
  EXPECT_LE((solver.x() - v).lpNorm<Eigen::Infinity>(), 1e-12);
  expectKkt(qp, solver, 1e-10);
  EXPECT_EQ(solver.numActiveInequalities(), 3);  // at most n independent sides
}

TEST(DenseQp, RedundantRowsAndEqualSides) {
  // Random feasible problem plus copies of its rows turned into redundant and equal-sided
  // (l = u) rows: same solution as the problem with the equal-sided rows as equalities.
  qptest::RandomQpSpec spec{8, 2, 10};
  DenseQpProblem base({8, 4, 10});
  qptest::makeRandomQp(spec, 7, base);
  DenseQpSolver solver({8, 4, 30});
  ASSERT_EQ(solver.solve(base), DenseQpStatus::Optimal);
  const VectorXd x_base = solver.x();

  DenseQpProblem qp({8, 4, 30});
  qp.setDimensions(8, 2, 30);
  qp.clear();
  qp.H() = base.H();
  qp.g() = base.g();
  qp.Aeq() = base.Aeq();
  qp.beq() = base.beq();
  qp.lb() = base.lb();
  qp.ub() = base.ub();
  for (int i = 0; i < 10; ++i) {
    for (int c = 0; c < 3; ++c) {  // row, 3x the row with the same set, looser copy
      const double s = c == 1 ? 3.0 : 1.0;
      qp.C().row(3 * i + c) = s * base.C().row(i);
      qp.l()(3 * i + c) = s * base.l()(i) - (c == 2 ? 0.5 : 0.0);
      qp.u()(3 * i + c) = s * base.u()(i) + (c == 2 ? 0.5 : 0.0);
    }
  }
  ASSERT_EQ(solver.solve(qp), DenseQpStatus::Optimal);
  EXPECT_LE((solver.x() - x_base).lpNorm<Eigen::Infinity>(), 1e-10);
  expectKkt(qp, solver);

  // Equal sides (l = u) on two rows of the base problem == the same rows as equalities.
  const VectorXd cx = base.C() * x_base;
  for (int i = 0; i < 2; ++i) base.l()(i) = base.u()(i) = cx(i) + 0.05;
  ASSERT_EQ(solver.solve(base), DenseQpStatus::Optimal);
  const VectorXd x_eqsides = solver.x();
  expectKkt(base, solver);
  base.setDimensions(8, 4, 10);
  base.Aeq().bottomRows(2) = base.C().topRows(2);
  base.beq().tail(2) = cx.head(2).array() + 0.05;
  base.l().head(2).setConstant(-kInf);
  base.u().head(2).setConstant(kInf);
  ASSERT_EQ(solver.solve(base), DenseQpStatus::Optimal);
  EXPECT_LE((solver.x() - x_eqsides).lpNorm<Eigen::Infinity>(), 1e-10);
}

TEST(DenseQp, ManyRowsThroughTheOptimum) {
  // Rows added through the optimum x* of a problem keep x* optimal (x* is still feasible
  // and the feasible set only shrank), but make it heavily degenerate: 20 more sides with
  // zero slack at x*, and a duplicate and a scaled copy of each original row.
  qptest::RandomQpSpec spec{30, 12, 20};
  DenseQpProblem qp({30, 12, 80});
  DenseQpSolver solver({30, 12, 80});
  std::mt19937 rng(42);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  for (unsigned seed = 1; seed <= 10; ++seed) {
    qptest::makeRandomQp(spec, seed, qp);
    ASSERT_EQ(solver.solve(qp), DenseQpStatus::Optimal);
    const VectorXd x_star = solver.x();
    qp.setDimensions(30, 12, 80);
    for (int i = 0; i < 20; ++i) {
      for (int c = 1; c <= 2; ++c) {
        const double s = c == 1 ? 1.0 : 0.5 + 2.5 * std::abs(U(rng));
        qp.C().row(20 * c + i) = s * qp.C().row(i);
        qp.l()(20 * c + i) = s * qp.l()(i);
        qp.u()(20 * c + i) = s * qp.u()(i);
      }
      for (int j = 0; j < 30; ++j) qp.C()(60 + i, j) = U(rng);
      const double v = qp.C().row(60 + i).dot(x_star);
      qp.l()(60 + i) = i % 2 == 0 ? v : -kInf;  // through x*, on either side
      qp.u()(60 + i) = i % 2 == 0 ? kInf : v;
    }
    for (bool warm : {false, true}) {
      solver.settings().warm_start = warm;
      ASSERT_EQ(solver.solve(qp), DenseQpStatus::Optimal) << seed;
      EXPECT_LE((solver.x() - x_star).lpNorm<Eigen::Infinity>(), 1e-9) << seed;
      expectKkt(qp, solver);
    }
  }
}

TEST(DenseQp, RankDeficientEqualities) {
  qptest::RandomQpSpec spec{10, 3, 15};
  DenseQpProblem qp({10, 6, 15});
  qptest::makeRandomQp(spec, 11, qp);
  DenseQpSolver solver({10, 6, 15});
  ASSERT_EQ(solver.solve(qp), DenseQpStatus::Optimal);
  const VectorXd x_ref = solver.x();
  const double cost_ref = solver.objective();

  // Append a duplicate, a combination and a zero row (all consistent).
  const MatrixXd A = qp.Aeq();
  const VectorXd b = qp.beq();
  qp.setDimensions(10, 6, 15);
  qp.Aeq().row(3) = A.row(1);
  qp.beq()(3) = b(1);
  qp.Aeq().row(4) = 2.0 * A.row(0) - 0.5 * A.row(2);
  qp.beq()(4) = 2.0 * b(0) - 0.5 * b(2);
  qp.Aeq().row(5).setZero();
  qp.beq()(5) = 0.0;
  ASSERT_EQ(solver.solve(qp), DenseQpStatus::Optimal);
  EXPECT_LE((solver.x() - x_ref).lpNorm<Eigen::Infinity>(), 1e-10);
  EXPECT_NEAR(solver.objective(), cost_ref, 1e-9 * (1.0 + std::abs(cost_ref)));
  expectKkt(qp, solver);

  // Inconsistent: the combination's right-hand side moved, or the zero row = 1.
  qp.beq()(4) += 1e-3;
  EXPECT_EQ(solver.solve(qp), DenseQpStatus::Infeasible);
  EXPECT_EQ(solver.iterations(), 0);
  qp.beq()(4) -= 1e-3;
  qp.beq()(5) = 1.0;
  EXPECT_EQ(solver.solve(qp), DenseQpStatus::Infeasible);
}

TEST(DenseQp, MoreIndependentEqualitiesThanVariables) {
  DenseQpProblem qp({2, 3, 0});
  DenseQpSolver solver({2, 3, 0});
  qp.clear();
  setProjection(qp, VectorXd::Zero(2));
  qp.Aeq() << 1, 0, 0, 1, 1, 1;
  qp.beq() << 1, 2, 3;  // consistent: x = (1, 2)
  ASSERT_EQ(solver.solve(qp), DenseQpStatus::Optimal);
  EXPECT_NEAR(solver.x()(0), 1.0, 1e-12);
  EXPECT_NEAR(solver.x()(1), 2.0, 1e-12);
  expectKkt(qp, solver, 1e-12);
  qp.beq()(2) = 3.1;
  EXPECT_EQ(solver.solve(qp), DenseQpStatus::Infeasible);
}

// ---------------------------------------------------------------------------------------
// Infeasible problems

TEST(DenseQp, InfeasibleProblemsAreDetectedQuickly) {
  qptest::RandomQpSpec spec{30, 12, 60};
  DenseQpProblem qp({30, 12, 62});
  DenseQpSolver solver({30, 12, 62});
  for (unsigned seed = 1; seed <= 10; ++seed) {
    qptest::makeRandomQp(spec, seed, qp);
    qp.setDimensions(30, 12, 62);
    // sum x >= 1 and sum x <= -1 hidden among feasible rows.
    qp.C().row(60).setOnes();
    qp.l()(60) = 1.0;
    qp.u()(60) = kInf;
    qp.C().row(61).setConstant(-1.0);
    qp.l()(61) = 1.0;
    qp.u()(61) = kInf;
    EXPECT_EQ(solver.solve(qp), DenseQpStatus::Infeasible) << seed;
    EXPECT_LT(solver.iterations(), 60) << seed;  // proven, not run into the cap
    // The last iterate is reported: it satisfies the equalities.
    EXPECT_LE((qp.Aeq() * solver.x() - qp.beq()).lpNorm<Eigen::Infinity>(), 1e-9);
    qp.setDimensions(30, 12, 60);
  }
}

TEST(DenseQp, InfeasibleSmallCases) {
  DenseQpProblem qp({2, 1, 2});
  DenseQpSolver solver({2, 1, 2});
  // Row against bound: x0 + x1 >= 3 with x <= 1.
  qp.setDimensions(2, 0, 1);
  qp.clear();
  setProjection(qp, VectorXd::Zero(2));
  qp.C() << 1, 1;
  qp.l() << 3;
  qp.ub().setConstant(1.0);
  EXPECT_EQ(solver.solve(qp), DenseQpStatus::Infeasible);
  // Equality against bounds: x0 + x1 = 3 with x <= 1.
  qp.setDimensions(2, 1, 0);
  qp.clear();
  setProjection(qp, VectorXd::Zero(2));
  qp.Aeq() << 1, 1;
  qp.beq() << 3;
  qp.ub().setConstant(1.0);
  EXPECT_EQ(solver.solve(qp), DenseQpStatus::Infeasible);
  // Zero row with 0 outside [l, u].
  qp.setDimensions(2, 0, 1);
  qp.clear();
  setProjection(qp, VectorXd::Zero(2));
  qp.C().setZero();
  qp.l() << 0.5;
  EXPECT_EQ(solver.solve(qp), DenseQpStatus::Infeasible);
  qp.l() << -0.5;  // now always satisfied
  EXPECT_EQ(solver.solve(qp), DenseQpStatus::Optimal);
  // Parallel rows with empty intersection: x0 >= 1 and 2 x0 <= 1.
  qp.setDimensions(2, 0, 2);
  qp.clear();
  setProjection(qp, VectorXd::Zero(2));
  qp.C() << 1, 0, 2, 0;
  qp.l() << 1, -kInf;
  qp.u() << kInf, 1;
  EXPECT_EQ(solver.solve(qp), DenseQpStatus::Infeasible);
  EXPECT_LE(solver.iterations(), 3);
}

// ---------------------------------------------------------------------------------------
// Unbounded sides, bad input, non-convexity

TEST(DenseQp, UnboundedSidesGiveTheUnconstrainedMinimum) {
  qptest::RandomQpSpec spec{6, 0, 5};
  DenseQpProblem qp({6, 0, 5});
  qptest::makeRandomQp(spec, 3, qp);
  qp.l().setConstant(-kInf);
  qp.u().setConstant(kInf);
  qp.lb().setConstant(-kInf);
  qp.ub().setConstant(kInf);
  DenseQpSolver solver({6, 0, 5});
  ASSERT_EQ(solver.solve(qp), DenseQpStatus::Optimal);
  const VectorXd x_unc = -qp.H().llt().solve(qp.g());
  EXPECT_LE((solver.x() - x_unc).lpNorm<Eigen::Infinity>(), 1e-10);
  EXPECT_EQ(solver.iterations(), 0);
  EXPECT_EQ(solver.numActiveInequalities(), 0);
  // One-sided rows only on the far side of the minimum: still unconstrained.
  const VectorXd cx = qp.C() * x_unc;
  qp.u() = cx.array() + 1.0;
  ASSERT_EQ(solver.solve(qp), DenseQpStatus::Optimal);
  EXPECT_LE((solver.x() - x_unc).lpNorm<Eigen::Infinity>(), 1e-10);
}

TEST(DenseQp, InvalidInputIsRefusedWithZeroOutput) {
  qptest::RandomQpSpec spec{5, 2, 6};
  DenseQpProblem qp({5, 2, 6});
  DenseQpSolver solver({5, 2, 6});
  const double nan = std::numeric_limits<double>::quiet_NaN();
  auto expectInvalid = [&](auto&& spoil, const char* what) {
    qptest::makeRandomQp(spec, 5, qp);
    ASSERT_EQ(solver.solve(qp), DenseQpStatus::Optimal) << what;
    spoil();
    EXPECT_EQ(solver.solve(qp), DenseQpStatus::InvalidInput) << what;
    EXPECT_EQ(solver.status(), DenseQpStatus::InvalidInput);
    EXPECT_EQ(solver.x().lpNorm<Eigen::Infinity>(), 0.0) << what;
    EXPECT_EQ(solver.numActiveInequalities(), 0) << what;
  };
  expectInvalid([&] { qp.H()(1, 2) = nan; }, "NaN in H");
  expectInvalid([&] { qp.H()(0, 0) = kInf; }, "Inf in H");
  expectInvalid([&] { qp.H()(1, 0) += 1.0; }, "asymmetric H");
  expectInvalid([&] { qp.g()(3) = nan; }, "NaN in g");
  expectInvalid([&] { qp.Aeq()(1, 1) = nan; }, "NaN in A_eq");
  expectInvalid([&] { qp.beq()(0) = kInf; }, "Inf in b_eq");
  expectInvalid([&] { qp.C()(4, 2) = -kInf; }, "Inf in C");
  expectInvalid([&] { qp.l()(2) = nan; }, "NaN in l");
  expectInvalid([&] { qp.u()(2) = nan; }, "NaN in u");
  expectInvalid([&] { qp.l()(2) = 1.0, qp.u()(2) = 0.5; }, "l > u");
  expectInvalid([&] { qp.l()(2) = kInf, qp.u()(2) = kInf; }, "l = +inf");
  expectInvalid([&] { qp.ub()(1) = -kInf; }, "ub = -inf");
  expectInvalid([&] { qp.lb()(1) = 2.0, qp.ub()(1) = 1.0; }, "lb > ub");
  expectInvalid([&] { solver.settings().feasibility_tolerance = nan; }, "settings");
  solver.settings() = {};
  expectInvalid([&] { solver.settings().max_iterations = -1; }, "settings");
  solver.settings() = {};

  // A problem larger than the solver was sized for.
  DenseQpProblem big({6, 2, 6});
  qptest::makeRandomQp({6, 2, 6}, 5, big);
  EXPECT_EQ(solver.solve(big), DenseQpStatus::InvalidInput);
  EXPECT_FALSE(qp.setDimensions(6, 2, 6));  // and the problem refuses to grow
  EXPECT_FALSE(qp.setDimensions(-1, 0, 0));
  EXPECT_EQ(qp.n(), 5);
}

TEST(DenseQp, SemidefiniteHessianIsNotConvexUnlessRegularised) {
  DenseQpProblem qp({3, 0, 1});
  DenseQpSolver solver({3, 0, 1});
  qp.clear();
  qp.H().diagonal() << 1, 1, 0;  // x2 free and without curvature
  qp.g() << -1, 0, 0;
  qp.C() << 0, 0, 1;
  qp.l() << 0;
  qp.u() << 1;
  EXPECT_EQ(solver.solve(qp), DenseQpStatus::NotConvex);
  EXPECT_EQ(solver.x().lpNorm<Eigen::Infinity>(), 0.0);
  qp.H()(2, 2) = -1.0;  // indefinite
  EXPECT_EQ(solver.solve(qp), DenseQpStatus::NotConvex);
  qp.H()(2, 2) = 0.0;
  solver.settings().hessian_regularization = 1e-6;
  ASSERT_EQ(solver.solve(qp), DenseQpStatus::Optimal);
  EXPECT_NEAR(solver.x()(0), 1.0 / (1.0 + 1e-6), 1e-12);
  EXPECT_NEAR(solver.x()(2), 0.0, 1e-12);

  // Nearly singular H: accepted at the default tolerance, refused at a stricter one even
  // though the same H was factorised just before (the kept factors do not hide it).
  solver.settings() = {};
  qp.H()(2, 2) = 1e-9;
  ASSERT_EQ(solver.solve(qp), DenseQpStatus::Optimal);
  ASSERT_EQ(solver.solve(qp), DenseQpStatus::Optimal);
  solver.settings().definiteness_tolerance = 1e-6;
  EXPECT_EQ(solver.solve(qp), DenseQpStatus::NotConvex);
}

// ---------------------------------------------------------------------------------------
// Warm start, iteration cap, changing sizes, allocation

TEST(DenseQp, WarmStartGivesTheSameSolutionInFewerIterations) {
  qptest::RandomQpSpec spec{30, 12, 60};
  DenseQpProblem qp({30, 12, 60});
  DenseQpSolver cold({30, 12, 60}), warm({30, 12, 60});
  cold.settings().warm_start = false;
  int cold_iters = 0, warm_iters = 0;
  for (unsigned seed = 1; seed <= 5; ++seed) {
    qptest::makeRandomQp(spec, seed, qp);
    const VectorXd g0 = qp.g();
    std::mt19937 rng(seed);
    std::normal_distribution<double> N(0.0, 1.0);
    // A sequence of slowly changing problems, as from one 1 kHz tick to the next.
    for (int tick = 0; tick < 20; ++tick) {
      for (int j = 0; j < 30; ++j) qp.g()(j) = g0(j) + 0.05 * tick * std::sin(j + 0.3 * tick);
      ASSERT_EQ(cold.solve(qp), DenseQpStatus::Optimal);
      ASSERT_EQ(warm.solve(qp), DenseQpStatus::Optimal);
      EXPECT_LE((cold.x() - warm.x()).lpNorm<Eigen::Infinity>(), 1e-10);
      expectKkt(qp, warm);
      if (tick > 0) {
        cold_iters += cold.iterations();
        warm_iters += warm.iterations();
      }
    }
  }
  EXPECT_LT(warm_iters * 3, cold_iters) << "warm " << warm_iters << " cold " << cold_iters;
  // The same problem again: the stored active set is already optimal.
  ASSERT_EQ(warm.solve(qp), DenseQpStatus::Optimal);
  EXPECT_EQ(warm.iterations(), 0);
  warm.resetWarmStart();
  ASSERT_EQ(warm.solve(qp), DenseQpStatus::Optimal);
  EXPECT_EQ(warm.iterations(), cold.iterations());
}

TEST(DenseQp, WarmStartFromAWrongActiveSet) {
  // The stored set is optimal for a very different problem (opposite g): the solver drops
  // what is wrong and still reaches the optimum of the new one.
  qptest::RandomQpSpec spec{20, 8, 40};
  DenseQpProblem qp({20, 8, 40});
  DenseQpSolver warm({20, 8, 40}), cold({20, 8, 40});
  cold.settings().warm_start = false;
  for (unsigned seed = 1; seed <= 10; ++seed) {
    qptest::makeRandomQp(spec, seed, qp);
    ASSERT_EQ(warm.solve(qp), DenseQpStatus::Optimal);
    qp.g() = -qp.g();
    ASSERT_EQ(warm.solve(qp), DenseQpStatus::Optimal);
    ASSERT_EQ(cold.solve(qp), DenseQpStatus::Optimal);
    EXPECT_LE((cold.x() - warm.x()).lpNorm<Eigen::Infinity>(), 1e-10);
    expectKkt(qp, warm);
  }
}

TEST(DenseQp, IterationCapEndsWithTheLastIterate) {
  qptest::RandomQpSpec spec{30, 12, 60};
  DenseQpProblem qp({30, 12, 60});
  qptest::makeRandomQp(spec, 2, qp);
  DenseQpSolver solver({30, 12, 60});
  ASSERT_EQ(solver.solve(qp), DenseQpStatus::Optimal);
  const int needed = solver.iterations();
  ASSERT_GT(needed, 3);
  solver.resetWarmStart();
  solver.settings().max_iterations = 3;
  EXPECT_EQ(solver.solve(qp), DenseQpStatus::MaxIterations);
  EXPECT_EQ(solver.iterations(), 3);
  // Last iterate: equalities hold, the multipliers of the working sides are >= 0.
  EXPECT_LE((qp.Aeq() * solver.x() - qp.beq()).lpNorm<Eigen::Infinity>(), 1e-9);
  const control::DenseQpKkt k = control::computeKktResiduals(qp, solver);
  EXPECT_LE(k.stationarity, 1e-9);
  EXPECT_LE(k.dual_sign, 1e-12);
  EXPECT_GT(k.primal, 1e-6);  // not yet feasible
  // The failed solve did not replace the (empty) warm-start set: a capped solve again
  // ends the same way.
  EXPECT_EQ(solver.solve(qp), DenseQpStatus::MaxIterations);
  solver.settings().max_iterations = needed;
  EXPECT_EQ(solver.solve(qp), DenseQpStatus::Optimal);
}

TEST(DenseQp, ChangingSizesBetweenSolves) {
  DenseQpProblem qp({40, 20, 100});
  DenseQpSolver solver({40, 20, 100});
  const std::vector<qptest::RandomQpSpec> specs = {{30, 12, 60}, {20, 5, 70}, {40, 20, 100},
                                                   {30, 12, 58}, {1, 0, 1},   {0, 0, 0}};
  for (int rep = 0; rep < 2; ++rep) {
    for (const auto& spec : specs) {
      qptest::makeRandomQp(spec, 9, qp);
      ASSERT_EQ(solver.solve(qp), DenseQpStatus::Optimal) << spec.n;
      EXPECT_EQ(solver.x().size(), spec.n);
      expectKkt(qp, solver);
    }
  }
}

TEST(DenseQp, SolveDoesNotAllocate) {
  qptest::RandomQpSpec spec{30, 12, 60};
  DenseQpProblem qp({30, 12, 62});
  DenseQpProblem nan_qp({30, 12, 62});
  qptest::makeRandomQp(spec, 1, nan_qp);
  nan_qp.H()(3, 3) = std::numeric_limits<double>::quiet_NaN();
  DenseQpSolver solver({30, 12, 62});
  std::vector<DenseQpProblem> problems;
  for (unsigned seed = 1; seed <= 4; ++seed) {
    problems.emplace_back(DenseQpDims{30, 12, 62});
    qptest::makeRandomQp(spec, seed, problems.back());
  }
  problems.emplace_back(DenseQpDims{30, 12, 62});  // infeasible
  qptest::makeRandomQp(spec, 5, problems.back());
  problems.back().setDimensions(30, 12, 62);
  problems.back().C().row(60).setOnes();
  problems.back().l()(60) = 1.0;
  problems.back().C().row(61).setConstant(-1.0);
  problems.back().l()(61) = 1.0;
  ASSERT_EQ(solver.solve(problems[0]), DenseQpStatus::Optimal);

  int statuses[5] = {0, 0, 0, 0, 0};
  double checksum = 0.0;
  {
    test::AllocationGuard guard;
    for (int rep = 0; rep < 3; ++rep) {
      solver.settings().warm_start = rep != 1;
      for (const auto& p : problems) {
        ++statuses[static_cast<int>(solver.solve(p))];
        checksum += solver.x().sum() + computeKktResiduals(p, solver).max();
      }
      ++statuses[static_cast<int>(solver.solve(nan_qp))];
      solver.settings().max_iterations = 2;
      ++statuses[static_cast<int>(solver.solve(problems[1]))];
      solver.settings().max_iterations = 200;
    }
    EXPECT_EQ(guard.count(), 0u);
  }
  EXPECT_EQ(statuses[static_cast<int>(DenseQpStatus::Optimal)], 12);
  EXPECT_EQ(statuses[static_cast<int>(DenseQpStatus::Infeasible)], 3);
  EXPECT_EQ(statuses[static_cast<int>(DenseQpStatus::InvalidInput)], 3);
  EXPECT_EQ(statuses[static_cast<int>(DenseQpStatus::MaxIterations)], 3);
  EXPECT_TRUE(std::isfinite(checksum));
}

TEST(DenseQp, StatusNames) {
  EXPECT_STREQ(control::toString(DenseQpStatus::Optimal), "Optimal");
  EXPECT_STREQ(control::toString(DenseQpStatus::Infeasible), "Infeasible");
  EXPECT_STREQ(control::toString(DenseQpStatus::MaxIterations), "MaxIterations");
  EXPECT_STREQ(control::toString(DenseQpStatus::NotConvex), "NotConvex");
  EXPECT_STREQ(control::toString(DenseQpStatus::InvalidInput), "InvalidInput");
}

}  // namespace
