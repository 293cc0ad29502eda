#pragma once
// Small dense convex QP solver for the CBF-QP safety filter, real-time safe.
//
//   minimise    0.5 x^T H x + g^T x
//   subject to  A_eq x = b_eq                  (n_eq rows, may be rank deficient)
//               l <= C x <= u                  (n_ineq two-sided rows, sides may be +-inf)
//               lb <= x <= ub                  (simple bounds, sides may be +-inf)
//
// Method: Goldfarb-Idnani dual active set (Math. Prog. 27, 1983), the algorithm of
// quadprog and eiquadprog, with warm start. Why this and not a dense interior point:
// - The CBF-QP is small (n 20-40, 10-20 equalities, 40-100 inequality rows) and changes
//   little from one 1 kHz tick to the next, so the active set of the previous tick is
//   nearly right: a warm-started active-set method then needs a few O(n^2) steps, where
//   an interior point always pays 10-25 O(n^3) factorisations (it cannot warm start well).
// - The result is exact (a vertex of the active set, multipliers from a triangular
//   solve), so the complementarity is zero rather than ~barrier, and the active set is
//   reported exactly, which the filter's logs want.
// - Dual methods start from the unconstrained minimum, which is dual feasible for free:
//   no phase 1. Primal infeasibility is proven, not guessed: a violated constraint that no
//   step of the dual can reduce is a Farkas certificate (the loop ends there).
// - Its price: H must be positive definite (H = L L^T). A positive semidefinite H is
//   refused with NotConvex unless DenseQpSettings::hessian_regularization adds a multiple
//   of the identity (this changes the problem; the CBF-QP's H is a weighted sum of
//   squares plus a small damping, so it is definite by construction).
// Numerics: the active set is held as the factorisation L^-1 N = Q [R; 0] through
// J = L^-T Q, updated by a Householder reflection when a constraint is added and by Givens
// rotations when one is dropped (O(n^2) each), never refactorised. A constraint whose normal is
// (numerically) in the span of the active ones is never added: an equality row of that kind is
// checked for consistency (then skipped, its multiplier 0) or makes the problem Infeasible; an
// inequality takes the dual-only step of the method. Violations are measured in units of x (row
// divided by its norm), so the scaling of a row does not change which constraint enters.
//
// Memory (HPIPM-style): dimensions first (DenseQpDims, the largest problem), then the
// problem and the solver sized from them; solve() never allocates, locks or throws. The
// problem's actual sizes may change between solves (setDimensions, up to the maxima).
// H is factorised once per solve (O(n^3)), or not at all when it is bit for bit the H of
// the previous factorisation (the filter's constant weights): the factors are kept.
//
// Multiplier convention (every multiplier of an inequality side is >= 0):
//   H x + g = A_eq^T y + C^T (z_lower - z_upper) + (w_lower - w_upper)
// i.e. the gradient of the cost is a combination of the constraint normals written as
// "c_i^T x >= l_i", "-c_i^T x >= -u_i", "x_j >= lb_j", "-x_j >= -ub_j".
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <vector>

#include "rollstep/common/enum_names.hpp"

namespace rollstep::control {

/// Largest sizes a problem / solver is built for.
struct DenseQpDims {
  int n = 0;       ///< variables
  int n_eq = 0;    ///< equality rows
  int n_ineq = 0;  ///< two-sided general inequality rows
};

/// The problem data, sized once for the largest problem. Each accessor returns the block
/// of the current sizes; fill it in place (no allocation). C and A_eq are row-major so that
/// a row, which is what the solver reads, is contiguous.
class DenseQpProblem {
 public:
  using RowMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

  /// Current sizes = max sizes; H = 0, g = 0, rows and bounds unbounded (l, lb = -inf,
  /// u, ub = +inf). Throws std::invalid_argument on negative sizes (setup time only).
  explicit DenseQpProblem(const DenseQpDims& max);

  /// Sets the sizes of the next solves; false (and nothing changed) when a size is negative
  /// or above its maximum. Does not change any value (the data of dropped rows is kept).
  bool setDimensions(int n, int n_eq, int n_ineq);
  /// H = 0, g = 0, A_eq = 0, b_eq = 0, C = 0, every side unbounded (current sizes).
  void clear();

  int n() const { return n_; }
  int nEq() const { return me_; }
  int nIneq() const { return mi_; }
  const DenseQpDims& maxDims() const { return max_; }

  auto H() { return H_.topLeftCorner(n_, n_); }
  auto g() { return g_.head(n_); }
  auto Aeq() { return A_.topLeftCorner(me_, n_); }
  auto beq() { return b_.head(me_); }
  auto C() { return C_.topLeftCorner(mi_, n_); }
  auto l() { return l_.head(mi_); }
  auto u() { return u_.head(mi_); }
  auto lb() { return lb_.head(n_); }
  auto ub() { return ub_.head(n_); }
  auto H() const { return H_.topLeftCorner(n_, n_); }
  auto g() const { return g_.head(n_); }
  auto Aeq() const { return A_.topLeftCorner(me_, n_); }
  auto beq() const { return b_.head(me_); }
  auto C() const { return C_.topLeftCorner(mi_, n_); }
  auto l() const { return l_.head(mi_); }
  auto u() const { return u_.head(mi_); }
  auto lb() const { return lb_.head(n_); }
  auto ub() const { return ub_.head(n_); }

 private:
  DenseQpDims max_;
  int n_ = 0, me_ = 0, mi_ = 0;
  Eigen::MatrixXd H_;
  Eigen::VectorXd g_;
  RowMatrix A_;
  Eigen::VectorXd b_;
  RowMatrix C_;
  Eigen::VectorXd l_, u_, lb_, ub_;
};

enum class DenseQpStatus {
  Optimal,        ///< KKT point found (the unique minimiser)
  Infeasible,     ///< primal infeasible, proven (inconsistent equalities or a Farkas step)
  MaxIterations,  ///< DenseQpSettings::max_iterations reached
  NotConvex,      ///< H (+ regularisation) is not numerically positive definite
  InvalidInput,   ///< NaN/Inf data, l > u, a side at the wrong infinity, sizes, settings
};
constexpr std::array<EnumName<DenseQpStatus>, 5> enumNames(DenseQpStatus) {
  return {{{DenseQpStatus::Optimal, "Optimal"},
           {DenseQpStatus::Infeasible, "Infeasible"},
           {DenseQpStatus::MaxIterations, "MaxIterations"},
           {DenseQpStatus::NotConvex, "NotConvex"},
           {DenseQpStatus::InvalidInput, "InvalidInput"}}};
}
const char* toString(DenseQpStatus status);

/// Which side of a row / bound is in the final active set.
enum class ActiveSide : std::int8_t { Inactive = 0, Lower = 1, Upper = 2 };

struct DenseQpSettings {
  /// Cap on active-set changes (adds, drops, dual-only steps) per solve.
  int max_iterations = 200;
  /// Start from the active set of the last Optimal solve (see DenseQpSolver::solve).
  bool warm_start = true;
  /// Added to the diagonal of H before factorising (0: H must be positive definite).
  double hessian_regularization = 0.0;
  /// A side is satisfied when its violation, in units of x (residual / row norm), is at
  /// most feasibility_tolerance * (1 + |bound| / row norm). Also the consistency test of
  /// dependent equality rows.
  double feasibility_tolerance = 1e-9;
  /// A new constraint is dependent on the active ones when the part of its normal outside
  /// their span (H^-1 metric) is below this fraction of the whole.
  double dependency_tolerance = 1e-10;
  /// H is refused (NotConvex) when a Cholesky pivot^2 <= this times the largest diagonal.
  double definiteness_tolerance = 1e-13;
};

/// KKT residuals of a solution (max norms). All zero up to rounding at an Optimal result.
struct DenseQpKkt {
  double stationarity = 0.0;     ///< |H x + g - A^T y - C^T (zl - zu) - (wl - wu)|
  double primal = 0.0;           ///< largest violation of an equality, row side or bound
  double complementarity = 0.0;  ///< largest |multiplier * slack| of any inequality side
  double dual_sign = 0.0;        ///< largest negative part of an inequality multiplier
  double max() const;
};

class DenseQpSolver {
 public:
  /// Sizes every workspace for problems up to `max`. Throws std::invalid_argument on
  /// negative sizes (setup time only).
  explicit DenseQpSolver(const DenseQpDims& max, const DenseQpSettings& settings = {});

  /// Solves `qp`. Never allocates, locks or throws.
  ///
  /// Warm start (settings().warm_start): the active set of the last Optimal solve (with the
  /// same number of variables; rows and bounds by index, those that still exist and whose
  /// side is still finite, independent ones only) is made the first working set;
  /// its equality-constrained minimiser is computed, and sides with negative multipliers are
  /// dropped until the start is dual feasible; then the usual iterations. The result is the
  /// same optimum as a cold start (the QP is strictly convex), usually in fewer iterations.
  ///
  /// Outputs after a non-Optimal status:
  /// - Infeasible, MaxIterations: x is the last iterate of the dual method, with the
  ///   multipliers of its working set: it satisfies the (independent) equalities and the
  ///   working set's sides, and may violate any other side (the dual method is primal
  ///   infeasible until it ends), so it is not a safe command by itself: fall back.
  /// - NotConvex, InvalidInput: x = 0, every multiplier 0, no active side, 0 iterations.
  /// The warm-start set is only replaced by an Optimal solve.
  DenseQpStatus solve(const DenseQpProblem& qp) noexcept;

  /// Forgets the stored active set (the next solve is cold).
  void resetWarmStart() noexcept { warm_count_ = 0; }
  DenseQpSettings& settings() { return settings_; }
  const DenseQpSettings& settings() const { return settings_; }
  const DenseQpDims& maxDims() const { return max_; }

  DenseQpStatus status() const { return status_; }
  /// Active-set changes of the last solve (warm-start drops included).
  int iterations() const { return iterations_; }
  /// 0.5 x^T H x + g^T x at x (H without regularisation).
  double objective() const { return objective_; }

  auto x() const { return x_.head(n_); }
  /// Equality multipliers (0 for a row dependent on the others).
  auto yEq() const { return y_.head(me_); }
  auto zLower() const { return zl_.head(mi_); }
  auto zUpper() const { return zu_.head(mi_); }
  auto wLower() const { return wl_.head(n_); }
  auto wUpper() const { return wu_.head(n_); }
  ActiveSide rowSide(int i) const { return row_side_[static_cast<std::size_t>(i)]; }
  ActiveSide boundSide(int j) const { return bound_side_[static_cast<std::size_t>(j)]; }
  /// Inequality sides (rows and bounds) in the final active set.
  int numActiveInequalities() const { return num_active_ineq_; }

 private:
  // Constraint ids: equality i -> -(i + 1); inequality item k (rows 0..mi-1, then bounds
  // mi..mi+n-1) side s (0 lower, 1 upper) -> 2 k + s.
  bool validate(const DenseQpProblem& qp) const;
  bool factorize(const DenseQpProblem& qp);
  void normalTimesJ(const DenseQpProblem& qp, int id);  // d = J^T n_id
  double normalDot(const DenseQpProblem& qp, int id, const Eigen::VectorXd& v) const;
  double rhs(const DenseQpProblem& qp, int id) const;
  bool isDependent() const;
  void addToFactorization();
  void dropFromFactorization(int position);
  void solveOnWorkingSet(const DenseQpProblem& qp);
  bool pushWorking(const DenseQpProblem& qp, int id);
  DenseQpStatus finish(const DenseQpProblem& qp, DenseQpStatus status);
  DenseQpStatus fail(DenseQpStatus status);

  DenseQpDims max_;
  DenseQpSettings settings_;
  int n_ = 0, me_ = 0, mi_ = 0;
  int q_ = 0;   ///< working set size (equalities first)
  int qe_ = 0;  ///< equalities in the working set

  Eigen::MatrixXd U_;             ///< Cholesky factor of H = U^T U (upper)
  Eigen::MatrixXd H_cache_, J0_;  ///< H and U^-1 of the last factorisation
  int cached_n_ = -1;             ///< size of the cached factorisation, -1: none
  double cached_reg_ = 0.0;       ///< settings the cached factors were made with
  double cached_definiteness_ = 0.0;
  bool hessian_cached_ = false;  ///< this solve's H is the cached one
  Eigen::MatrixXd J_;            ///< L^-T Q
  Eigen::MatrixXd R_;            ///< upper triangular, q x q used
  Eigen::VectorXd d_, z_, r_, x0_, work_, a_, hh_;
  Eigen::VectorXd u_;             ///< multipliers of the working set, by position
  std::vector<int> active_;       ///< ids of the working set, by position
  std::vector<char> in_work_;     ///< per inequality id
  std::vector<char> eq_skipped_;  ///< equality rows dependent on earlier ones
  Eigen::VectorXd cx_, row_inv_norm_, eq_inv_norm_;

  std::vector<int> warm_ids_;
  int warm_count_ = 0, warm_n_ = -1, warm_me_ = -1, warm_mi_ = -1;

  DenseQpStatus status_ = DenseQpStatus::InvalidInput;
  int iterations_ = 0;
  double objective_ = 0.0;
  int num_active_ineq_ = 0;
  Eigen::VectorXd x_, y_, zl_, zu_, wl_, wu_;
  std::vector<ActiveSide> row_side_, bound_side_;
};

/// KKT residuals of the solver's current outputs on `qp` (the problem it last solved).
/// Allocates nothing.
DenseQpKkt computeKktResiduals(const DenseQpProblem& qp, const DenseQpSolver& solver);

}  // namespace rollstep::control
