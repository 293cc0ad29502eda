// When does a solve stop, and when does the barrier problem change? The divergence
// guards, the convergence and iteration-limit tests on the KKT measures of a
// linearisation, and the monotone (Fiacco-McCormick) barrier update.
#include "solver_impl.hpp"

namespace rollstep::solver {

/// Non-finite values or a violation above divergence_threshold: restores the last good
/// iterate if there is one. Returns true when the solve ends here (status set).
bool Solver::Impl::diverged(const Kkt& kkt) {
  const double primal = kkt.primal;
  if (!kkt.finite || !std::isfinite(primal) || primal > set.divergence_threshold) {
    if (backup_valid) {
      restore();
      ROLLSTEP_MSG(
          "the iterate diverged (primal residual %.3g); the last good iterate was restored",
          primal);
      status = SolverStatus::Diverged;
      return true;
    }
    ROLLSTEP_MSG("the problem evaluates to non-finite values at the initial guess");
    status = SolverStatus::InvalidInput;
    return true;
  }
  return false;
}

/// Cost and residuals of the linearisation into the solver and the iteration's stats.
void Solver::Impl::recordResiduals(const Kkt& kkt, IterationStats& it) {
  cost = kkt.cost;
  it.cost = kkt.cost;
  it.primal_residual = kkt.primal;
  it.dual_residual = kkt.dual;
  it.complementarity = kkt.complementarity(mu);
}

/// Converging mode: KKT error below kkt_tolerance (Converged), or the iteration limit
/// (Infeasible if the violation stalled, else MaxIterations). Returns true when the solve
/// ends here (status set, the iteration's stats recorded).
bool Solver::Impl::terminated(const Kkt& kkt, int max_it, IterationStats& it) {
  const double primal = kkt.primal;
  const double e0 = std::max({primal, kkt.dual_scaled, kkt.sz_max});
  if (e0 <= set.kkt_tolerance) {
    it.barrier = mu;
    stats.push_back(it);
    has_solution = true;
    status = SolverStatus::Converged;
    return true;
  }
  if (iterations >= max_it) {
    it.barrier = mu;
    stats.push_back(it);
    has_solution = true;
    if (violationStalled(primal)) {
      ROLLSTEP_MSG(
          "locally infeasible: the constraint violation %.3g did not halve in the last %d "
          "of %d iterations",
          primal, kStallWindow, max_it);
      status = SolverStatus::Infeasible;
      return true;
    }
    ROLLSTEP_MSG("no convergence in %d iterations (KKT error %.3g)", max_it, e0);
    status = SolverStatus::MaxIterations;
    return true;
  }
  return false;
}

/// Monotone (Fiacco-McCormick) barrier update: mu decreases while the barrier problem of
/// the current mu is solved to 10 mu.
void Solver::Impl::updateBarrier(const Kkt& kkt) {
  while (mu > set.barrier_min &&
         std::max({kkt.primal, kkt.dual_scaled, kkt.complementarity(mu)}) <= 10.0 * mu) {
    mu = std::max(set.barrier_min, std::min(set.barrier_decrease * mu, std::pow(mu, 1.5)));
  }
}

/// Real-time mode after its one step: IterationDone, or Diverged (the previous iterate
/// restored) if the new iterate is not finite.
SolverStatus Solver::Impl::endRealTimeIteration() {
  // Guard against a non-finite iterate (should not happen: the step was finite).
  for (int k = 0; k <= N; ++k) {
    if (!xs[static_cast<std::size_t>(k)].allFinite() ||
        (k < N && !us[static_cast<std::size_t>(k)].allFinite())) {
      restore();
      ROLLSTEP_MSG("non-finite iterate; the last good iterate was restored");
      return status = SolverStatus::Diverged;
    }
  }
  return status = SolverStatus::IterationDone;
}

}  // namespace rollstep::solver
