#include "rollstep/control/dense_qp.hpp"

#include <Eigen/Jacobi>
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace rollstep::control {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Templates, not Eigen::Ref: a Ref<const MatrixXd> of a row-major block would be a copy.
template <typename Mat>
bool allFinite(const Mat& m) {
  // inf * 0 and NaN * 0 are NaN: one vectorised sum instead of an element-wise test.
  return m.size() == 0 || (m.array() * 0.0).sum() == 0.0;
}

/// A two-sided range: no NaN, lower <= upper, and neither side at the infinity that would
/// make it empty (lower = +inf or upper = -inf).
template <typename Vec>
bool validRange(const Vec& lo, const Vec& hi) {
  for (Eigen::Index i = 0; i < lo.size(); ++i) {
    const double a = lo(i), b = hi(i);
    if (std::isnan(a) || std::isnan(b) || a > b || a == kInf || b == -kInf) return false;
  }
  return true;
}

void checkDims(const DenseQpDims& d, const char* who) {
  if (d.n < 0 || d.n_eq < 0 || d.n_ineq < 0)
    throw std::invalid_argument(std::string(who) + ": negative size (n = " + std::to_string(d.n) +
                                ", n_eq = " + std::to_string(d.n_eq) +
                                ", n_ineq = " + std::to_string(d.n_ineq) + ")");
}

}  // namespace

const char* toString(DenseQpStatus status) { return enumName(status, "Unknown"); }

double DenseQpKkt::max() const {
  return std::max(std::max(stationarity, primal), std::max(complementarity, dual_sign));
}

// ---------------------------------------------------------------------------------------
// Problem

DenseQpProblem::DenseQpProblem(const DenseQpDims& max) : max_(max) {
  checkDims(max, "DenseQpProblem");
  H_.setZero(max.n, max.n);
  g_.setZero(max.n);
  A_.setZero(max.n_eq, max.n);
  b_.setZero(max.n_eq);
  C_.setZero(max.n_ineq, max.n);
  l_.setConstant(max.n_ineq, -kInf);
  u_.setConstant(max.n_ineq, kInf);
  lb_.setConstant(max.n, -kInf);
  ub_.setConstant(max.n, kInf);
  n_ = max.n;
  me_ = max.n_eq;
  mi_ = max.n_ineq;
}

bool DenseQpProblem::setDimensions(int n, int n_eq, int n_ineq) {
  if (n < 0 || n_eq < 0 || n_ineq < 0 || n > max_.n || n_eq > max_.n_eq || n_ineq > max_.n_ineq)
    return false;
  n_ = n;
  me_ = n_eq;
  mi_ = n_ineq;
  return true;
}

void DenseQpProblem::clear() {
  H().setZero();
  g().setZero();
  Aeq().setZero();
  beq().setZero();
  C().setZero();
  l().setConstant(-kInf);
  u().setConstant(kInf);
  lb().setConstant(-kInf);
  ub().setConstant(kInf);
}

// ---------------------------------------------------------------------------------------
// Solver: workspace

DenseQpSolver::DenseQpSolver(const DenseQpDims& max, const DenseQpSettings& settings)
    : max_(max), settings_(settings) {
  checkDims(max, "DenseQpSolver");
  const int n = max.n;
  const auto ni = static_cast<std::size_t>(2 * (max.n_ineq + max.n));
  U_.setZero(n, n);
  H_cache_.setZero(n, n);
  J0_.setZero(n, n);
  J_.setZero(n, n);
  R_.setZero(n, n);
  d_.setZero(n);
  z_.setZero(n);
  r_.setZero(n);
  x0_.setZero(n);
  work_.setZero(n);
  hh_.setZero(n);
  a_.setZero(n);
  u_.setZero(n);
  active_.assign(static_cast<std::size_t>(n), 0);
  in_work_.assign(ni, 0);
  eq_skipped_.assign(static_cast<std::size_t>(max.n_eq), 0);
  cx_.setZero(max.n_ineq);
  row_inv_norm_.setZero(max.n_ineq);
  eq_inv_norm_.setZero(max.n_eq);
  warm_ids_.assign(static_cast<std::size_t>(n), 0);
  x_.setZero(n);
  y_.setZero(max.n_eq);
  zl_.setZero(max.n_ineq);
  zu_.setZero(max.n_ineq);
  wl_.setZero(n);
  wu_.setZero(n);
  row_side_.assign(static_cast<std::size_t>(max.n_ineq), ActiveSide::Inactive);
  bound_side_.assign(static_cast<std::size_t>(n), ActiveSide::Inactive);
}

bool DenseQpSolver::validate(const DenseQpProblem& qp) const {
  const DenseQpSettings& s = settings_;
  if (!(s.max_iterations >= 0) || !(s.hessian_regularization >= 0.0) ||
      !std::isfinite(s.hessian_regularization) || !(s.feasibility_tolerance >= 0.0) ||
      !std::isfinite(s.feasibility_tolerance) || !(s.dependency_tolerance >= 0.0) ||
      !(s.dependency_tolerance < 1.0) || !(s.definiteness_tolerance >= 0.0) ||
      !(s.definiteness_tolerance < 1.0))
    return false;
  if (qp.n() > max_.n || qp.nEq() > max_.n_eq || qp.nIneq() > max_.n_ineq) return false;
  const auto H = qp.H();
  const bool cached = hessian_cached_;  // identical to the last factorised H, checked then
  if ((!cached && !allFinite(H)) || !allFinite(qp.g()) || !allFinite(qp.Aeq()) ||
      !allFinite(qp.beq()) || !allFinite(qp.C()))
    return false;
  if (!validRange(qp.l(), qp.u()) || !validRange(qp.lb(), qp.ub())) return false;
  // H must be symmetric (only its upper triangle is factorised; an asymmetric H is a bug
  // of the caller, not something to hide).
  if (H.size() > 0 && (H - H.transpose()).cwiseAbs().maxCoeff() > 1e-10 * H.cwiseAbs().maxCoeff())
    return false;
  return true;
}

bool DenseQpSolver::factorize(const DenseQpProblem& qp) {
  const int n = n_;
  const auto H = qp.H();
  const double reg = settings_.hessian_regularization;
  if (hessian_cached_) {
    J_.topLeftCorner(n, n) = J0_.topLeftCorner(n, n);
    return true;
  }
  cached_n_ = -1;
  const double max_diag = (n > 0 ? H.diagonal().maxCoeff() : 0.0) + reg;
  const double pivot_min = settings_.definiteness_tolerance * max_diag;
  // H = U^T U with U = L^T upper triangular, column by column (up-looking), so that every
  // inner product runs along contiguous columns of U.
  for (int j = 0; j < n; ++j) {
    auto uj = U_.col(j);
    for (int i = 0; i < j; ++i) uj(i) = (H(i, j) - U_.col(i).head(i).dot(uj.head(i))) / U_(i, i);
    const double djj = H(j, j) + reg - uj.head(j).squaredNorm();
    if (!(djj > pivot_min) || !(djj > 0.0)) return false;
    uj(j) = std::sqrt(djj);
  }
  // J = L^-T = U^-1 (upper triangular): the active-set factorisation with no constraint.
  // Column c solves U J_c = e_c by column-oriented back substitution (axpy on U's columns).
  for (int c = 0; c < n; ++c) {
    auto jc = J_.col(c).head(n);
    jc.setZero();
    jc(c) = 1.0;
    for (int i = c; i >= 0; --i) {
      jc(i) /= U_(i, i);
      jc.head(i) -= jc(i) * U_.col(i).head(i);
    }
  }
  H_cache_.topLeftCorner(n, n) = H;
  J0_.topLeftCorner(n, n) = J_.topLeftCorner(n, n);
  cached_n_ = n;
  cached_reg_ = reg;
  cached_definiteness_ = settings_.definiteness_tolerance;
  return true;
}

// ---------------------------------------------------------------------------------------
// Constraint access by id

void DenseQpSolver::normalTimesJ(const DenseQpProblem& qp, int id) {
  const auto J = J_.topLeftCorner(n_, n_);
  auto d = d_.head(n_);
  if (id < 0) {
    d.noalias() = J.transpose() * qp.Aeq().row(-id - 1).transpose();
    return;
  }
  const int item = id / 2;
  const double sign = (id % 2 == 0) ? 1.0 : -1.0;
  if (item < mi_) {
    d.noalias() = J.transpose() * qp.C().row(item).transpose();
    if (sign < 0.0) d = -d;
  } else {
    d = sign * J.row(item - mi_).transpose();
  }
}

double DenseQpSolver::normalDot(const DenseQpProblem& qp, int id, const Eigen::VectorXd& v) const {
  if (id < 0) return qp.Aeq().row(-id - 1).dot(v.head(n_));
  const int item = id / 2;
  const double sign = (id % 2 == 0) ? 1.0 : -1.0;
  if (item < mi_) return sign * qp.C().row(item).dot(v.head(n_));
  return sign * v(item - mi_);
}

double DenseQpSolver::rhs(const DenseQpProblem& qp, int id) const {
  if (id < 0) return qp.beq()(-id - 1);
  const int item = id / 2;
  const bool lower = id % 2 == 0;
  if (item < mi_) return lower ? qp.l()(item) : -qp.u()(item);
  return lower ? qp.lb()(item - mi_) : -qp.ub()(item - mi_);
}

// ---------------------------------------------------------------------------------------
// Factorisation updates (a reflection to add, rotations to drop), after Goldfarb-Idnani

bool DenseQpSolver::isDependent() const {
  if (q_ >= n_) return true;
  const double outside = d_.segment(q_, n_ - q_).norm();
  return !(outside > settings_.dependency_tolerance * d_.head(n_).norm());
}

// Reflects d(q..n-1) onto d(q) (and J's columns with it) and appends d(0..q) to R.
void DenseQpSolver::addToFactorization() {
  const int m = n_ - q_;  // d(q..n-1) is reduced to its first entry
  if (m > 1) {
    // One Householder reflection P = I - beta v v^T of J's columns q..n-1: a matrix-vector
    // product and a rank-1 update (vectorised passes) instead of n - q - 1 rotations.
    auto d2 = d_.segment(q_, m);
    const double norm = d2.norm();
    const double alpha = d2(0) >= 0.0 ? -norm : norm;  // P d2 = alpha e1, no cancellation
    auto v = hh_.head(m);
    v = d2;
    v(0) -= alpha;
    const double beta = 1.0 / (norm * (norm + std::abs(d2(0))));  // 2 / |v|^2
    auto J2 = J_.block(0, q_, n_, m);
    auto w = work_.head(n_);
    w.noalias() = J2 * v;
    J2.noalias() -= (beta * w) * v.transpose();
    d2.setZero();
    d2(0) = alpha;
  }
  for (int i = 0; i <= q_; ++i) R_(i, q_) = d_(i);
  ++q_;
}

// Removes the working-set entry at `position`: R loses a column (Hessenberg), restored
// to triangular by rotations of its rows, applied to J's columns too (J R unchanged).
void DenseQpSolver::dropFromFactorization(int position) {
  auto J = J_.topLeftCorner(n_, n_);
  for (int i = position; i < q_ - 1; ++i) {
    active_[static_cast<std::size_t>(i)] = active_[static_cast<std::size_t>(i + 1)];
    u_(i) = u_(i + 1);
    for (int k = 0; k <= i + 1; ++k) R_(k, i) = R_(k, i + 1);
  }
  --q_;
  for (int k = 0; k <= q_; ++k) R_(k, q_) = 0.0;
  for (int j = position; j < q_; ++j) {
    const double h = std::sqrt(R_(j, j) * R_(j, j) + R_(j + 1, j) * R_(j + 1, j));
    if (h == 0.0) continue;
    const double c = R_(j, j) / h, s = R_(j + 1, j) / h;
    R_(j, j) = h;
    R_(j + 1, j) = 0.0;
    for (int k = j + 1; k < q_; ++k) {
      const double t1 = R_(j, k), t2 = R_(j + 1, k);
      R_(j, k) = c * t1 + s * t2;
      R_(j + 1, k) = -s * t1 + c * t2;
    }
    J.applyOnTheRight(j, j + 1, Eigen::JacobiRotation<double>(c, -s));
  }
}

// Minimiser of the cost on the working set's face and its multipliers, from scratch:
// with x0 = -H^-1 g, a = R^-T (b - N^T x0), x = x0 + J1 a, u = R^-1 a.
void DenseQpSolver::solveOnWorkingSet(const DenseQpProblem& qp) {
  const int q = q_;
  for (int k = 0; k < q; ++k) {
    const int id = active_[static_cast<std::size_t>(k)];
    a_(k) = rhs(qp, id) - normalDot(qp, id, x0_);
  }
  for (int i = 0; i < q; ++i) {  // R^T a = b (forward)
    double v = a_(i);
    for (int k = 0; k < i; ++k) v -= R_(k, i) * a_(k);
    a_(i) = v / R_(i, i);
  }
  x_.head(n_) = x0_.head(n_);
  if (q > 0) x_.head(n_).noalias() += J_.topLeftCorner(n_, q) * a_.head(q);
  for (int i = q - 1; i >= 0; --i) {  // R u = a (backward)
    double v = a_(i);
    for (int k = i + 1; k < q; ++k) v -= R_(i, k) * u_(k);
    u_(i) = v / R_(i, i);
  }
}

// Adds `id` to the working set with multiplier 0 if it is independent of it.
bool DenseQpSolver::pushWorking(const DenseQpProblem& qp, int id) {
  normalTimesJ(qp, id);
  if (isDependent()) return false;
  active_[static_cast<std::size_t>(q_)] = id;
  u_(q_) = 0.0;
  addToFactorization();
  if (id >= 0) in_work_[static_cast<std::size_t>(id)] = 1;
  return true;
}

// ---------------------------------------------------------------------------------------
// Solve

DenseQpStatus DenseQpSolver::fail(DenseQpStatus status) {
  q_ = qe_ = 0;
  num_active_ineq_ = 0;
  objective_ = 0.0;
  x_.setZero();
  y_.setZero();
  zl_.setZero();
  zu_.setZero();
  wl_.setZero();
  wu_.setZero();
  std::fill(row_side_.begin(), row_side_.end(), ActiveSide::Inactive);
  std::fill(bound_side_.begin(), bound_side_.end(), ActiveSide::Inactive);
  status_ = status;
  return status;
}

DenseQpStatus DenseQpSolver::finish(const DenseQpProblem& qp, DenseQpStatus status) {
  y_.head(me_).setZero();
  zl_.head(mi_).setZero();
  zu_.head(mi_).setZero();
  wl_.head(n_).setZero();
  wu_.head(n_).setZero();
  std::fill(row_side_.begin(), row_side_.end(), ActiveSide::Inactive);
  std::fill(bound_side_.begin(), bound_side_.end(), ActiveSide::Inactive);
  num_active_ineq_ = q_ - qe_;
  if (status == DenseQpStatus::Optimal) {
    warm_count_ = 0;
    warm_n_ = n_;
    warm_me_ = me_;
    warm_mi_ = mi_;
  }
  for (int k = 0; k < q_; ++k) {
    const int id = active_[static_cast<std::size_t>(k)];
    const double m = u_(k);
    if (id < 0) {
      y_(-id - 1) = m;
      continue;
    }
    const int item = id / 2;
    const bool lower = id % 2 == 0;
    if (item < mi_) {
      (lower ? zl_ : zu_)(item) = m;
      row_side_[static_cast<std::size_t>(item)] = lower ? ActiveSide::Lower : ActiveSide::Upper;
    } else {
      const int j = item - mi_;
      (lower ? wl_ : wu_)(j) = m;
      bound_side_[static_cast<std::size_t>(j)] = lower ? ActiveSide::Lower : ActiveSide::Upper;
    }
    // Stored independently of mi so that bounds keep their meaning if the row count
    // changes: rows 2k + s, bounds -(2j + s) - 1.
    if (status == DenseQpStatus::Optimal)
      warm_ids_[static_cast<std::size_t>(warm_count_++)] =
          item < mi_ ? id : -(2 * (item - mi_) + id % 2) - 1;
  }
  work_.head(n_).noalias() = qp.H() * x_.head(n_);
  objective_ = 0.5 * x_.head(n_).dot(work_.head(n_)) + qp.g().dot(x_.head(n_));
  status_ = status;
  return status;
}

DenseQpStatus DenseQpSolver::solve(const DenseQpProblem& qp) noexcept {
  iterations_ = 0;
  n_ = std::min(qp.n(), max_.n);
  me_ = std::min(qp.nEq(), max_.n_eq);
  mi_ = std::min(qp.nIneq(), max_.n_ineq);
  // The filter's H is often the same every tick (constant weights): then its checks and
  // factors are reused.
  hessian_cached_ = n_ == qp.n() && n_ == cached_n_ &&
                    settings_.hessian_regularization == cached_reg_ &&
                    settings_.definiteness_tolerance == cached_definiteness_ &&
                    qp.H() == H_cache_.topLeftCorner(n_, n_);
  if (!validate(qp)) return fail(DenseQpStatus::InvalidInput);
  if (!factorize(qp)) return fail(DenseQpStatus::NotConvex);
  const int n = n_, me = me_, mi = mi_;
  const double tol = settings_.feasibility_tolerance;

  // Unconstrained minimiser x0 = -H^-1 g = -J J^T g (J = L^-T here, and J J^T stays
  // H^-1 under the rotations to come).
  work_.head(n).noalias() = J_.topLeftCorner(n, n).transpose() * qp.g();
  x0_.head(n).noalias() = -J_.topLeftCorner(n, n) * work_.head(n);

  q_ = qe_ = 0;
  std::fill(in_work_.begin(), in_work_.begin() + 2 * (mi + n), 0);
  std::fill(eq_skipped_.begin(), eq_skipped_.begin() + me, 0);

  // Row norms (violations are measured in units of x). A zero row is a constant: either
  // always satisfied or the problem is infeasible.
  bool zero_row_infeasible = false;
  for (int i = 0; i < mi; ++i) {
    const double nrm = qp.C().row(i).norm();
    row_inv_norm_(i) = nrm > 0.0 ? 1.0 / nrm : 0.0;
    if (nrm == 0.0 && (qp.l()(i) > tol || qp.u()(i) < -tol)) zero_row_infeasible = true;
  }
  for (int i = 0; i < me; ++i) {
    const double nrm = qp.Aeq().row(i).norm();
    eq_inv_norm_(i) = nrm > 0.0 ? 1.0 / nrm : 0.0;
    if (nrm == 0.0) {
      eq_skipped_[static_cast<std::size_t>(i)] = 1;
      if (std::abs(qp.beq()(i)) > tol) zero_row_infeasible = true;
    }
  }
  x_.head(n) = x0_.head(n);
  if (zero_row_infeasible) {
    u_.setZero();
    return finish(qp, DenseQpStatus::Infeasible);
  }

  // Equalities first (never dropped); a row dependent on earlier ones is skipped here and
  // checked for consistency once x satisfies the others.
  for (int i = 0; i < me; ++i) {
    if (eq_skipped_[static_cast<std::size_t>(i)]) continue;
    if (pushWorking(qp, -i - 1)) continue;
    eq_skipped_[static_cast<std::size_t>(i)] = 1;
  }
  qe_ = q_;

  // Warm start: the last optimal active set, as far as it is still meaningful.
  if (settings_.warm_start && warm_n_ == n) {
    for (int k = 0; k < warm_count_; ++k) {
      const int w = warm_ids_[static_cast<std::size_t>(k)];
      int id;
      if (w >= 0) {
        const int row = w / 2;
        if (row >= mi || row_inv_norm_(row) == 0.0) continue;
        if ((w % 2 == 0 ? qp.l()(row) : qp.u()(row)) == (w % 2 == 0 ? -kInf : kInf)) continue;
        id = w;
      } else {
        const int b = -w - 1, j = b / 2;
        if ((b % 2 == 0 ? qp.lb()(j) : qp.ub()(j)) == (b % 2 == 0 ? -kInf : kInf)) continue;
        id = 2 * (mi + j) + b % 2;
      }
      if (in_work_[static_cast<std::size_t>(id)] || in_work_[static_cast<std::size_t>(id ^ 1)])
        continue;
      pushWorking(qp, id);
    }
  }
  solveOnWorkingSet(qp);

  for (int i = 0; i < me; ++i) {
    if (!eq_skipped_[static_cast<std::size_t>(i)] || eq_inv_norm_(i) == 0.0) continue;
    const double b = qp.beq()(i), inv = eq_inv_norm_(i);
    if (std::abs(normalDot(qp, -i - 1, x_) - b) * inv > tol * (1.0 + std::abs(b) * inv))
      return finish(qp, DenseQpStatus::Infeasible);
  }

  // A warm start must be dual feasible: drop sides with negative multipliers, re-solve.
  for (;;) {
    int worst = -1;
    for (int k = qe_; k < q_; ++k)
      if (u_(k) < 0.0 && (worst < 0 || u_(k) < u_(worst))) worst = k;
    if (worst < 0) break;
    if (iterations_ >= settings_.max_iterations) return finish(qp, DenseQpStatus::MaxIterations);
    ++iterations_;
    in_work_[static_cast<std::size_t>(active_[static_cast<std::size_t>(worst)])] = 0;
    dropFromFactorization(worst);
    solveOnWorkingSet(qp);
  }

  // Goldfarb-Idnani iterations: x is the minimiser on the working set with multipliers
  // u >= 0; add the most violated side p, dropping sides whose multiplier reaches 0 first.
  for (;;) {
    if (mi > 0) cx_.head(mi).noalias() = qp.C() * x_.head(n);
    int p = -1;
    double worst = 0.0;
    auto consider = [&](int id, double value, double bound, double inv_norm) {
      // value >= bound is the side; violation in units of x.
      if (in_work_[static_cast<std::size_t>(id)]) return;
      const double v = (bound - value) * inv_norm;
      if (v > tol * (1.0 + std::abs(bound) * inv_norm) && v > worst) {
        worst = v;
        p = id;
      }
    };
    for (int i = 0; i < mi; ++i) {
      const double inv = row_inv_norm_(i);
      if (inv == 0.0) continue;
      if (qp.l()(i) > -kInf) consider(2 * i, cx_(i), qp.l()(i), inv);
      if (qp.u()(i) < kInf) consider(2 * i + 1, -cx_(i), -qp.u()(i), inv);
    }
    for (int j = 0; j < n; ++j) {
      if (qp.lb()(j) > -kInf) consider(2 * (mi + j), x_(j), qp.lb()(j), 1.0);
      if (qp.ub()(j) < kInf) consider(2 * (mi + j) + 1, -x_(j), -qp.ub()(j), 1.0);
    }
    if (p < 0) {
      // Clean the rounding of the incremental updates: the exact face minimiser.
      solveOnWorkingSet(qp);
      for (int k = qe_; k < q_; ++k) u_(k) = std::max(u_(k), 0.0);
      return finish(qp, DenseQpStatus::Optimal);
    }

    double u_p = 0.0;  // multiplier of p along the way
    for (;;) {
      if (iterations_ >= settings_.max_iterations) return finish(qp, DenseQpStatus::MaxIterations);
      ++iterations_;
      normalTimesJ(qp, p);
      const bool dependent = isDependent();
      // Dual direction r = R^-1 d1 (how the working multipliers change per unit of u_p).
      for (int i = q_ - 1; i >= 0; --i) {
        double v = d_(i);
        for (int k = i + 1; k < q_; ++k) v -= R_(i, k) * r_(k);
        r_(i) = v / R_(i, i);
      }
      // Partial step: the first working side whose multiplier reaches 0.
      double t1 = kInf;
      int drop = -1;
      for (int k = qe_; k < q_; ++k) {
        if (r_(k) > 0.0) {
          const double t = u_(k) / r_(k);
          if (t < t1) {
            t1 = t;
            drop = k;
          }
        }
      }
      // Full step: p becomes active. z = J2 d2 is the primal direction, z^T n_p = |d2|^2.
      double t2 = kInf;
      if (!dependent) {
        z_.head(n).noalias() = J_.block(0, q_, n, n - q_) * d_.segment(q_, n - q_);
        const double s_p = normalDot(qp, p, x_) - rhs(qp, p);
        t2 = std::max(0.0, -s_p / d_.segment(q_, n - q_).squaredNorm());
      }
      const double t = std::min(t1, t2);
      if (t == kInf) return finish(qp, DenseQpStatus::Infeasible);  // Farkas: no step helps
      if (!dependent) x_.head(n) += t * z_.head(n);
      u_.head(q_) -= t * r_.head(q_);
      u_p += t;
      if (t2 <= t1) {
        active_[static_cast<std::size_t>(q_)] = p;
        u_(q_) = u_p;
        addToFactorization();
        in_work_[static_cast<std::size_t>(p)] = 1;
        break;
      }
      in_work_[static_cast<std::size_t>(active_[static_cast<std::size_t>(drop)])] = 0;
      dropFromFactorization(drop);
    }
  }
}

// ---------------------------------------------------------------------------------------
// KKT residuals

DenseQpKkt computeKktResiduals(const DenseQpProblem& qp, const DenseQpSolver& s) {
  DenseQpKkt k;
  const int n = qp.n(), me = qp.nEq(), mi = qp.nIneq();
  if (s.x().size() != n || s.yEq().size() != me || s.zLower().size() != mi) {
    k.stationarity = k.primal = kInf;
    return k;
  }
  const auto x = s.x();
  const auto H = qp.H();
  const auto A = qp.Aeq();
  const auto C = qp.C();
  for (int j = 0; j < n; ++j) {
    double r = qp.g()(j) - s.wLower()(j) + s.wUpper()(j);
    for (int c = 0; c < n; ++c) r += H(j, c) * x(c);
    for (int i = 0; i < me; ++i) r -= A(i, j) * s.yEq()(i);
    for (int i = 0; i < mi; ++i) r -= C(i, j) * (s.zLower()(i) - s.zUpper()(i));
    k.stationarity = std::max(k.stationarity, std::abs(r));
  }
  // Complementarity of an unbounded side: its multiplier must be 0.
  auto side = [&](double multiplier, double slack) {
    k.dual_sign = std::max(k.dual_sign, -multiplier);
    if (std::isinf(slack)) {
      if (multiplier != 0.0) k.complementarity = kInf;
    } else {
      k.complementarity = std::max(k.complementarity, std::abs(multiplier * slack));
    }
  };
  for (int i = 0; i < me; ++i)
    k.primal = std::max(k.primal, std::abs(A.row(i).dot(x) - qp.beq()(i)));
  for (int i = 0; i < mi; ++i) {
    const double cx = C.row(i).dot(x);
    k.primal = std::max(k.primal, std::max(qp.l()(i) - cx, cx - qp.u()(i)));
    side(s.zLower()(i), cx - qp.l()(i));
    side(s.zUpper()(i), qp.u()(i) - cx);
  }
  for (int j = 0; j < n; ++j) {
    k.primal = std::max(k.primal, std::max(qp.lb()(j) - x(j), x(j) - qp.ub()(j)));
    side(s.wLower()(j), x(j) - qp.lb()(j));
    side(s.wUpper()(j), qp.ub()(j) - x(j));
  }
  return k;
}

}  // namespace rollstep::control
