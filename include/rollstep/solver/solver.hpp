#pragma once
// Multiple-shooting primal-dual interior-point solver, equality constraints eliminated by
// projection and a Riccati recursion for the search direction (paper Sec. 3.1-3.2). All
// memory is sized at construction (the curvature workspace of exact_hessian, a copy of a
// node's data per thread and the curvature per node, only for settings that use it: at
// construction or in setSettings); solve() and update() never allocate.
//
// Method, per iteration: linearise every node (in parallel), defects on the manifold
// b_k = F(x_k, u_k) (-) x_{k+1} with A = J Fx, B = J Fu (J: Jacobian of the difference at
// x_{k+1}), dx_0 = x_init (-) x_0; hard inequalities g(x, u) >= 0 and bounds get slacks
// s > 0 and duals z > 0 and are condensed into the node Hessian/gradient (G^T Z S^-1 G,
// bounds on the diagonal); soft state-only rows add the relaxed log barrier (quadratic
// below delta) times their own fixed weight (InequalityOptions::weight, not mu) to the
// cost; equalities are projected (RiccatiSolver); the Riccati recursion gives dx, du, the
// costates and the equality multipliers; ds and dz follow; fraction to boundary separately
// for s and z.
//
// Hessian. Gauss-Newton (what the terms' calcDiff give) in real-time mode and with
// exact_hessian = false. With exact_hessian (converging mode) the Hessian of the
// Lagrangian, on the manifold: the costs' exact Hessians (CostTerm::hessianIsExact) plus,
// for every term that has curvature (nonlinear dynamics and residuals, costs whose
// Hessian is Gauss-Newton), central differences of the Lagrangian's gradient
// (OptimalControlProblem::linearizeCurvatureTerms); terms declared linear cost nothing, and
// a problem without curvature (hasCurvature() false) is solved with the Gauss-Newton
// Hessian, which is then exact. In every mode, when the reduced Hessian is not positive
// definite (the Riccati factorisation fails or needs regularisation), Ipopt's inertia
// correction: delta I is added, delta grown until the factorisation succeeds unregularised
// (with the curvature, Gauss-Newton as a last resort).
//
// Node 0. The state x_0 is data (fixed by x_init), not a decision variable: hard state
// bounds and state-only inequality rows (general rows whose residual does not depend on
// the input, soft or hard) are not imposed at node 0. Rows that depend on u_0 are.
//
// Barrier and globalisation (converging mode). Problems without curvature and without
// soft rows (convex QPs) use Mehrotra's predictor-corrector (predictor_corrector): an
// affine-scaling predictor, the barrier sigma mu with sigma = (mu_aff / mu)^3, a corrector
// through the same factorisation, one step length for primal and dual variables and no
// line search. Other problems: Fiacco-McCormick barrier decrease and a backtracking filter
// line search (Waechter and Biegler 2006) on the barrier objective f and the l1 violation
// theta; the filter is reset when mu changes, when it alone refused the last trial point of
// filter_reset_trigger line searches in a row (Ipopt's heuristic: an entry from an
// iteration that raised the violation can refuse everything along directions that must
// raise the objective to reduce it), and after a restoration phase (it then holds the
// entry of the point the restoration started from). A step that is tiny relative to the
// iterate is taken whole (rounding cannot be line-searched). Optional second-order
// corrections of a rejected unit step (max_second_order_corrections, off by default). A hard
// row whose value exceeds its slack by more than 10 % takes its value as the slack at each
// linearisation (slack_reset: a convex row outgrows the linearisation its slack follows).
//
// Termination (converging mode), Ipopt's scaled tests: with s_d = max(100, mean |multiplier|)
// / 100 and s_c = max(100, mean z) / 100, Converged when max(primal, dual / s_d,
// max(s z) / s_c) <= kkt_tolerance; Acceptable when it stays below acceptable_tolerance for
// acceptable_iterations consecutive iterations, or when the iteration limit or a failed
// line search stops the solve at such a point. Infeasible only with evidence: when the
// line search fails with the violation above infeasibility_tolerance the restoration phase
// runs: a minimum-norm step towards the linearised constraints (Hessian I, no cost,
// backtracked on the violation alone), taken when it reduces the l1 violation by at least
// 0.1 %; else a rollout (inputs moved inside their bounds, states simulated from x_0: every
// defect closed at once), taken when it brings the violation to 0.9 of where the Newton
// step was rejected; else up to 10 such minimum-norm steps from slacks moved off their
// bounds (max(s, c, 0.1), barrier max(mu, violation)) until the violation is 0.9 of that.
// When none gets there (no step reduces the violation, five steps in a row do not reduce
// the least violation reached by 0.1 %, or ten steps do not reach 0.9) the
// iterate is taken for a stationary point of the violation with a non-zero violation:
// Infeasible. Infeasible also when the direction breaks down (not factorisable,
// non-finite) with the violation above the tolerance and a dual above 1e12 (the duals of
// contradicting rows blow up). An iteration limit with a violation left is MaxIterations
// (the residuals are in stats()), not Infeasible. LineSearchFailed: the line search fails
// with a violation below infeasibility_tolerance at a point that is not acceptable.
#include <array>
#include <cstdint>
#include <memory>
#include <vector>

#include "rollstep/common/enum_names.hpp"
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
constexpr std::array<EnumName<SolverMode>, 2> enumNames(SolverMode) {
  return {{{SolverMode::Converging, "converging"}, {SolverMode::RealTime, "realtime"}}};
}

/// Every field has its default here; config/solver.yaml lists them all, and
/// loadSolverSettings (settings_yaml.hpp) reads them from YAML.
struct SolverSettings {
  SolverMode mode = SolverMode::Converging;
  int max_iterations = 100;        ///< converging mode
  double kkt_tolerance = 1e-8;     ///< converging mode: max of the scaled KKT residuals
  double barrier_initial = 1e-1;   ///< converging mode: first barrier parameter
  double barrier_min = 1e-10;      ///< converging mode: last barrier parameter
  double barrier_decrease = 0.2;   ///< mu <- max(barrier_min, min(k mu, mu^1.5))
  double barrier_realtime = 1e-3;  ///< real-time mode: fixed barrier parameter
  /// Real-time mode: Newton iterations per update() (each relinearises; 1 = the classic
  /// real-time iteration). More let an update catch up where the fraction to the boundary
  /// cut the first step short (a reference that changed faster than the iterate followed).
  int realtime_iterations = 1;
  double fraction_to_boundary = 0.995;
  /// Converging mode: each solve first moves the guess's hard-bounded inputs and states (x_0
  /// excepted) inside their bounds, to at least bound_push max(1, |bound|) and at most
  /// bound_push (upper - lower) from each bound (Ipopt's bound_push and bound_frac, both 1e-2
  /// there); in [0, 0.5), 0: onto the violated bound. A start outside a bound otherwise lets
  /// the fraction to the boundary cut the steps towards the bound's side (random starts of
  /// the solver tests' problems: 55 instead of 53 of 56 solved,
  /// docs/history/PERFORMANCE_HISTORY.md).
  double bound_push = 1e-2;
  /// Converging mode: at each linearisation a hard inequality row whose value c exceeds its
  /// slack s by more than 10 % takes s = c (its dual kept): the violation |c - s| and the
  /// barrier term -mu log s both fall, so the point stays acceptable to the filter. Convex
  /// rows (keep-out discs |p - c|^2 - r^2) grow faster along a step than the linearisation
  /// the slack follows; without the reset their slacks lag far below the rows' values, the
  /// fraction to the boundary cuts every later step at them and their duals blow up.
  /// Random starts of the solver tests' problems: 4334 instead of 4801 iterations, the arm
  /// from its default guess 70 instead of 97 (Ipopt 80; docs/PERFORMANCE.md). Linear rows
  /// (bounds) never need it; real-time iterations never reset.
  bool slack_reset = true;
  bool line_search = true;  ///< filter line search (converging mode); false: full steps
  /// Converging mode: add the constraint curvature (multipliers times second derivatives
  /// of dynamics, equalities and general inequalities; on manifolds also of the cost and
  /// of the retraction) to the Gauss-Newton Hessian, by central differences of the
  /// Jacobians (2 (ndx + nu) extra linearisations per node and iteration); inertia
  /// correction when not convex on the null space, Gauss-Newton as a last resort.
  /// Restores fast local convergence when the multipliers are large.
  bool exact_hessian = true;
  int max_line_search_steps = 20;
  double rank_tolerance = 1e-9;  ///< projection: relative pivot below this = rank deficient
  int num_threads = 1;           ///< node-parallel work (linearisation, condensing,
                                 ///< projection, step recovery); results identical
                                 ///< for any count
  /// With num_threads > 1: how long an idle worker polls for the next node-parallel phase
  /// before it sleeps. The default spans the sequential sweeps between the phases of one
  /// iteration, so they are handed out through atomics alone; waking a worker that slept
  /// (the first phase after a longer pause) takes a mutex and costs tens of microseconds.
  /// A controller that must never lock sets this above its update period (its workers
  /// then keep their cores busy); 0: sleep at once. Fixed at construction.
  int thread_spin_us = 2000;
  double divergence_threshold = 1e12;  ///< primal residual above this = diverged
  /// Converging mode: a line search failure with a constraint violation (inf-norm) above
  /// this starts the restoration phase that decides Infeasible (see the header comment).
  double infeasibility_tolerance = 1e-6;
  /// Converging mode: Ipopt's filter reset heuristic. When in this many line searches in a
  /// row the last rejected trial point passed the decrease test but not the filter, the
  /// filter is cleared (0: never). An entry from an iteration that raised the violation
  /// can otherwise forbid every point along a direction that must raise the barrier
  /// objective to reduce the violation, leaving ever shorter steps.
  int filter_reset_trigger = 5;
  int max_filter_resets = 5;  ///< converging mode: resets per solve at most
  /// Converging mode: second-order corrections (Ipopt's max_soc, 4 there). When the unit
  /// Newton step is rejected and raised the violation (the constraints curve across it: the
  /// Maratos effect), the step is re-solved with the same factorisation for the constraint
  /// values alpha c(x) + c(x + alpha d), at most this many times per line search while each
  /// reduces the violation by 1 %, before backtracking. 0 (default): never. They save cut
  /// steps where curved equality constraints are active near the solution (Powell's circle:
  /// 53 against 64 iterations over four starts); on the solver tests' problems and the
  /// Tachyon 3 OCP's cold first solves they are about neutral (docs/PERFORMANCE.md).
  int max_second_order_corrections = 0;
  /// Converging mode: the KKT error (scaled as for kkt_tolerance) below which an iterate is
  /// acceptable: Acceptable after acceptable_iterations such iterations in a row, or when a
  /// failed line search or the iteration limit stops the solve at such a point.
  double acceptable_tolerance = 1e-6;
  int acceptable_iterations = 15;
  /// Converging mode, problems without curvature and soft rows (convex QPs): Mehrotra's
  /// predictor-corrector with an adaptive barrier instead of the monotone barrier and the
  /// filter line search.
  bool predictor_corrector = true;
  /// Linux: ask for the solver's memory (the nodes' data, the terms' workspaces, the
  /// Riccati stages: about 60 MB for the Tachyon 3 OCP at N = 100) to be backed by
  /// transparent huge pages, collapsing the pages already there at construction (madvise
  /// MADV_HUGEPAGE and MADV_COLLAPSE). An iteration touches a few kB in each of many 4 kB
  /// pages, and the TLB misses cost several percent of it (docs/history/PERFORMANCE_HISTORY.md).
  /// Advice only: results are the same; it costs up to some 30 ms at construction (more when the
  /// kernel must compact memory first) and is skipped for spans under
  /// 4 MB, in sanitizer builds and where the system has no transparent huge pages.
  /// Fixed at construction.
  bool huge_pages = true;
};

/// Valid range [min, max] of an integer setting. The upper ends keep a typo from reaching
/// the solver (20000 threads, a reserve of 1e9 iteration records).
struct IntSettingRange {
  int min, max;
};
inline constexpr IntSettingRange kIterationCountRange{1, 1000000};  ///< max_/acceptable_iterations
inline constexpr IntSettingRange kRealtimeIterationRange{1, 100};   ///< realtime_iterations
inline constexpr IntSettingRange kLineSearchStepsRange{1, 1000};    ///< max_line_search_steps
inline constexpr IntSettingRange kThreadCountRange{1, 256};         ///< num_threads
inline constexpr IntSettingRange kThreadSpinRange{0, 1000000};      ///< thread_spin_us
inline constexpr IntSettingRange kFilterResetRange{
    0, 1000000};  ///< filter_reset_trigger, max_filter_resets
inline constexpr IntSettingRange kSecondOrderCorrectionRange{
    0, 100};  ///< max_second_order_corrections

/// Checks every field of s: throws std::invalid_argument naming the first bad one
/// (a non-finite or non-positive tolerance or barrier, barrier_min above barrier_initial,
/// barrier_decrease or fraction_to_boundary outside (0, 1), bound_push outside [0, 0.5),
/// rank_tolerance outside [0, 1),
/// an integer outside its range above). The Solver constructor and setSettings call it.
void checkSettings(const SolverSettings& s);

/// How a solve ended. The outputs (states, inputs, duals) are finite after every status;
/// message() says what went wrong. An infeasible problem ends with Infeasible in converging
/// mode (criterion in the header comment), never Converged.
enum class SolverStatus {
  Converged,                ///< KKT tolerance reached (converging mode)
  Acceptable,               ///< converging mode: stopped at a point within
                            ///< acceptable_tolerance but not kkt_tolerance (header comment)
  IterationDone,            ///< one real-time iteration completed (real-time mode)
  MaxIterations,            ///< converging mode hit max_iterations
  LineSearchFailed,         ///< no acceptable step, violation small; the previous iterate is kept
  RankDeficientEqualities,  ///< equality rows not full row rank in u (failedNode(), message())
  Diverged,                 ///< residuals exploded, a non-finite or non-descent step; the
                            ///< last good iterate is restored
  InvalidInput,             ///< NaN/inf or wrong size in x0, or non-finite problem values at
                            ///< the initial guess
  Infeasible,               ///< converging mode: stuck at a locally infeasible point (neither
                            ///< the Newton step nor the restoration phase reduces the
                            ///< violation, or the duals of contradicting rows blew up); the
                            ///< iterate is kept
};
constexpr std::array<EnumName<SolverStatus>, 9> enumNames(SolverStatus) {
  return {{{SolverStatus::Converged, "Converged"},
           {SolverStatus::Acceptable, "Acceptable"},
           {SolverStatus::IterationDone, "IterationDone"},
           {SolverStatus::MaxIterations, "MaxIterations"},
           {SolverStatus::LineSearchFailed, "LineSearchFailed"},
           {SolverStatus::RankDeficientEqualities, "RankDeficientEqualities"},
           {SolverStatus::Diverged, "Diverged"},
           {SolverStatus::InvalidInput, "InvalidInput"},
           {SolverStatus::Infeasible, "Infeasible"}}};
}
/// The status's name ("Converged"; "Unknown" for a value outside the enum).
const char* toString(SolverStatus s);

/// One Newton iteration. Residuals are those of the linearisation point, BEFORE the step
/// (so the last entry of a Converged solve holds the final KKT residuals).
struct IterationStats {
  int iteration = 0;
  double cost = 0.0;
  double primal_residual = 0.0;  ///< max |defect|, |e|, |g - s| (inf-norm)
  double dual_residual = 0.0;    ///< inf-norm of the Lagrangian gradient
  double complementarity = 0.0;  ///< max |s z - mu|
  double kkt_error = 0.0;        ///< converging mode: the scaled KKT error tested for termination
  /// Diagonal shift delta of the inertia correction (0: the Hessian was positive definite
  /// on the null space as it was).
  double inertia_shift = 0.0;
  double barrier = 0.0;
  double primal_step = 0.0, dual_step = 0.0;
  /// A step of the restoration phase (converging mode: the Newton step was rejected with
  /// the violation above infeasibility_tolerance); primal_step is its length. Each step of
  /// the phase is an iteration (and an entry) of its own, with the cost and residuals where
  /// it started.
  bool restoration = false;
  /// The line search cleared its filter (filter_reset_trigger; converging mode). After a
  /// restoration phase the filter restarts too (with the entry of the point it started from).
  bool filter_reset = false;
  /// The step taken is a second-order correction of the Newton step (the count tried,
  /// max_second_order_corrections); 0: the Newton step itself, or none was tried.
  int second_order_corrections = 0;
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
  /// Real-time update: sets the problem's initial time to t0, shifts the previous
  /// solution by the whole nodes t0 moved along the node grid of the last solve (the last
  /// state and input are repeated; the new tail nodes take the old last node's slacks
  /// and duals), lets the problem refit the inputs of the appended nodes and of the nodes
  /// whose contact mode changed (OptimalControlProblem::InputGuess), then runs
  /// realtime_iterations Newton iterations (1 by default) from x0 with the fixed barrier
  /// barrier_realtime, whatever settings().mode is. Updates faster than dt add up: the
  /// grid moves by whole nodes only, so after any sequence of updates the solution has
  /// been shifted floor((t0 - t_solve) / dt) nodes in total. A t0 earlier than the grid
  /// start restarts the grid at t0 without a shift. Never allocates.
  ///
  /// The solver itself never throws from solve() or update(). An exception thrown by the
  /// problem's own callbacks (dynamics, costs, rows) reaches their caller with any
  /// num_threads, once every thread has ended its part of the pass (states() and inputs()
  /// then hold an iterate of the interrupted run, not a solution); the next solve() or
  /// update() starts as usual.
  SolverStatus update(double t0, ConstVecRef x0);

  const std::vector<VectorXd>& states() const;  ///< x_0..x_N
  const std::vector<VectorXd>& inputs() const;  ///< u_0..u_{N-1}
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
  /// (ne, ni: rows in use; g, e values). Its dynamics and equality Jacobians (Fx, Fu, Ex,
  /// Eu) are empty and its inequality Jacobians are not dense: every linearisation evaluates
  /// them into one set per thread, and Gx and Gu (one column each) hold only the non-zero
  /// blocks, packed. After a real-time iteration its cost Hessian (Lxx, Luu, Lux) is not
  /// the node's either: it was evaluated into the Riccati stage's Q, R, S (with one thread
  /// one shared set). The gradients are the node's.
  const ocp::NodeData& nodeData(int k) const;
  const std::vector<IterationStats>& stats() const;  ///< of the last solve/update
  int iterations() const;
  /// Nodes the last update() shifted the previous solution by (0 after solve()).
  int lastShift() const;
  SolverStatus status() const;
  /// Cost of the iterate the last solve returned (states(), inputs()); after a real-time
  /// iteration, of the point it linearised at (before its step, as stats().back()).
  double cost() const;
  double barrier() const;  ///< barrier parameter of the last iteration
  /// Node where the last solve failed (rank-deficient equalities, factorisation), or -1.
  int failedNode() const;
  /// Human-readable reason of the last non-successful status ("" otherwise).
  const char* message() const;
  const SolverSettings& settings() const;
  /// Same num_threads and thread_spin_us as before. Not real-time: the first settings in
  /// converging mode with exact_hessian (on a problem with curvature) allocate the
  /// curvature workspace, kept from then on.
  void setSettings(const SolverSettings& s);
  ocp::OptimalControlProblem& problem();
  /// The Riccati workspace of the last iteration (search direction dx, du; for tests).
  const RiccatiSolver& riccati() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace rollstep::solver
