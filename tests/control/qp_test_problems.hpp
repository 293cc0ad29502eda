#pragma once
// Random dense QPs for the tests and the benchmark of the CBF-QP solver (deterministic:
// a fixed seed gives the same problem on every run of a given standard library).
#include <Eigen/Dense>
#include <cmath>
#include <limits>
#include <random>

#include "rollstep/control/dense_qp.hpp"

namespace rollstep::qptest {

inline constexpr double kInf = std::numeric_limits<double>::infinity();

struct RandomQpSpec {
  int n = 10, n_eq = 3, n_ineq = 20;
  /// Probability that a side of a row / bound is infinite.
  double p_infinite_side = 0.3;
  /// Probability that a variable has bounds at all.
  double p_bounded = 0.5;
  /// Scale of the linear term: larger pushes the unconstrained minimum far away, so that
  /// more constraints are active.
  double g_scale = 10.0;
  /// Condition of H: eigenvalues spread over [1, h_condition].
  double h_condition = 100.0;
  /// true: every constraint holds at a random point (the problem is feasible); false:
  /// the sides are drawn around 0 independently (may be infeasible).
  bool feasible = true;
};

/// Fills `qp` (resized to the spec's sizes, which must fit its maximum).
inline void makeRandomQp(const RandomQpSpec& s, unsigned seed, control::DenseQpProblem& qp) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> U(-1.0, 1.0), P(0.0, 1.0);
  auto rnd = [&](int r, int c) {
    Eigen::MatrixXd m(r, c);
    for (int j = 0; j < c; ++j)
      for (int i = 0; i < r; ++i) m(i, j) = U(rng);
    return m;
  };
  qp.setDimensions(s.n, s.n_eq, s.n_ineq);
  qp.clear();
  // H = Q diag(lambda) Q^T with lambda log-spaced on [1, cond].
  const Eigen::HouseholderQR<Eigen::MatrixXd> qr(rnd(s.n, s.n));
  const Eigen::MatrixXd Q = qr.householderQ();
  Eigen::VectorXd lambda(s.n);
  for (int i = 0; i < s.n; ++i)
    lambda(i) = std::pow(s.h_condition, s.n > 1 ? double(i) / (s.n - 1) : 0.0);
  Eigen::MatrixXd H = Q * lambda.asDiagonal() * Q.transpose();
  H = 0.5 * (H + H.transpose()).eval();
  qp.H() = H;
  qp.g() = s.g_scale * rnd(s.n, 1);
  const Eigen::VectorXd x_feas = rnd(s.n, 1);
  qp.Aeq() = rnd(s.n_eq, s.n);
  qp.beq() = s.feasible ? Eigen::VectorXd(qp.Aeq() * x_feas) : Eigen::VectorXd(rnd(s.n_eq, 1));
  qp.C() = rnd(s.n_ineq, s.n);
  for (int i = 0; i < s.n_ineq; ++i) {
    const double c = s.feasible ? qp.C().row(i).dot(x_feas) : 0.0;
    const double lo = c - (s.feasible ? P(rng) : U(rng)), hi = c + (s.feasible ? P(rng) : U(rng));
    const bool lo_inf = P(rng) < s.p_infinite_side, hi_inf = !lo_inf && P(rng) < s.p_infinite_side;
    qp.l()(i) = lo_inf ? -kInf : std::min(lo, hi);
    qp.u()(i) = hi_inf ? kInf : std::max(lo, hi);
  }
  for (int j = 0; j < s.n; ++j) {
    if (P(rng) >= s.p_bounded) continue;
    const double c = s.feasible ? x_feas(j) : 0.0;
    const double lo = c - 0.2 - P(rng), hi = c + 0.2 + P(rng);
    const bool lo_inf = P(rng) < s.p_infinite_side, hi_inf = !lo_inf && P(rng) < s.p_infinite_side;
    qp.lb()(j) = lo_inf ? -kInf : lo;
    qp.ub()(j) = hi_inf ? kInf : hi;
  }
}

}  // namespace rollstep::qptest
