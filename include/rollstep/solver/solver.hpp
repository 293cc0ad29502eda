#pragma once
// API change (solver engineer): added slacks(k), nodeData(k), barrier(), failedNode(),
// message() and riccati(); documented the layout of inequalityDuals(k) and that hard
// state bounds are not imposed at node 0 (x_0 is fixed by the initial state).
// Multiple-shooting primal-dual interior-point solver with Gauss-Newton Hessian,
// equality constraints eliminated by projection and a Riccati recursion for the search
// direction (paper Sec. 3.1-3.2). All memory is sized at construction; solve() and
// update() never allocate.
#include <cstdint>
#include <memory>
#include <vector>

#include "rollstep/ocp/problem.hpp"
#include "rollstep/solver/riccati.hpp"

namespace rollstep::solver {

using ocp::ConstVecRef;
using ocp::MatrixXd;
using ocp::VectorXd;

enum class SolverMode {
  Converging,  ///< decreasing barrier, several iterations, stops on the KKT tolerance
  RealTime,    ///< fixed barrier, one Newton iteration per update() (real-time iteration)
};

struct SolverSettings {
  SolverMode mode = SolverMode::Converging;
  int max_iterations = 100;            ///< converging mode
  double kkt_tolerance = 1e-8;         ///< converging mode: max of the scaled KKT residuals
  double barrier_initial = 1e-1;       ///< converging mode: first barrier parameter
  double barrier_min = 1e-10;          ///< converging mode: last barrier parameter
  double barrier_decrease = 0.2;       ///< mu <- max(barrier_min, min(k mu, mu^1.5))
  double barrier_realtime = 1e-3;      ///< real-time mode: fixed barrier parameter
  double fraction_to_boundary = 0.995;
  bool line_search = true;             ///< filter/merit backtracking (converging mode)
  int max_line_search_steps = 20;
  double rank_tolerance = 1e-9;        ///< projection: relative pivot below this = rank deficient
  int num_threads = 1;                 ///< linearisation threads; results are identical for any count
  double divergence_threshold = 1e12;  ///< primal residual above this = diverged
};

enum class SolverStatus {
  Converged,              ///< KKT tolerance reached (converging mode)
  IterationDone,          ///< one real-time iteration completed (real-time mode)
  MaxIterations,          ///< converging mode hit max_iterations
  LineSearchFailed,       ///< no acceptable step; the previous iterate is kept
  RankDeficientEqualities,///< equality rows not full row rank in u (node reported in stats)
  Diverged,               ///< residuals exploded or became non-finite; iterate restored
  InvalidInput,           ///< NaN/inf in the initial state or problem data
};
const char* toString(SolverStatus s);

struct IterationStats {
  int iteration = 0;
  double cost = 0.0;
  double primal_residual = 0.0;     ///< max |defect|, |e|, |g - s| (inf-norm)
  double dual_residual = 0.0;       ///< inf-norm of the Lagrangian gradient
  double complementarity = 0.0;     ///< max |s z - mu|
  double barrier = 0.0;
  double primal_step = 0.0, dual_step = 0.0;
  double time_linearize_ms = 0.0, time_riccati_ms = 0.0, time_update_ms = 0.0;
};

class Solver {
 public:
  Solver(std::shared_ptr<ocp::OptimalControlProblem> problem, SolverSettings settings = {});
  ~Solver();
  Solver(const Solver&) = delete;
  Solver& operator=(const Solver&) = delete;

  /// Initial guess (sizes N+1 x nx and N x nu). Not real-time.
  void setInitialGuess(const std::vector<VectorXd>& xs, const std::vector<VectorXd>& us);
  /// Converging solve from the initial state x0 (mode Converging), or one real-time
  /// iteration (mode RealTime). Never allocates.
  SolverStatus solve(ConstVecRef x0);
  /// Real-time update: shifts the previous solution to the new initial time t0 (warm
  /// start), then runs one Newton iteration from x0. Never allocates.
  SolverStatus update(double t0, ConstVecRef x0);

  const std::vector<VectorXd>& states() const;   ///< x_0..x_N
  const std::vector<VectorXd>& inputs() const;   ///< u_0..u_{N-1}
  /// Equality multipliers of node k: entry i belongs to equality row i of
  /// nodeData(k) (first nodeData(k).ne entries; the rest are zero). Sign convention: the
  /// Lagrangian is cost + nu^T e + lambda^T (defects) - z^T g.
  const VectorXd& equalityMultipliers(int k) const;
  /// Inequality duals z >= 0 of node k. Layout (size maxInequalities() + 2 nbu + 2 nbx,
  /// nbu = problem().inputBounds().size(), nbx = problem().stateBounds().size()):
  ///   [0, maxInequalities())   general rows (first nodeData(k).ni in use; 0 for soft rows)
  ///   next nbu                 input lower bounds,  then nbu input upper bounds
  ///   next nbx                 state lower bounds,  then nbx state upper bounds
  /// Entries of absent or inactive rows are 0. Hard state bounds are not imposed at node 0
  /// (x_0 is fixed by the initial state), nor input bounds at node N.
  const VectorXd& inequalityDuals(int k) const;
  /// Slacks s > 0 of node k (same layout as inequalityDuals; g - s = 0 at convergence).
  const VectorXd& slacks(int k) const;
  /// Feedback gain of node k (k < N): du = K dx (+ k) from the last Riccati pass, in the
  /// full input (equality projection included). Computed on first access after a solve.
  const MatrixXd& feedbackGain(int k) const;
  /// The problem's evaluation of node k at the last linearisation or trial point
  /// (ne, ni: rows in use; g, e values).
  const ocp::NodeData& nodeData(int k) const;
  const std::vector<IterationStats>& stats() const;  ///< of the last solve/update
  int iterations() const;
  SolverStatus status() const;
  double cost() const;
  double barrier() const;        ///< barrier parameter of the last iteration
  /// Node where the last solve failed (rank-deficient equalities, factorisation), or -1.
  int failedNode() const;
  /// Human-readable reason of the last non-successful status ("" otherwise).
  const char* message() const;
  const SolverSettings& settings() const;
  void setSettings(const SolverSettings& s);  ///< same num_threads as before; not real-time
  ocp::OptimalControlProblem& problem();
  /// The Riccati workspace of the last iteration (search direction dx, du; for tests).
  const RiccatiSolver& riccati() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace rollstep::solver
