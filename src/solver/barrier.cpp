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
      if (kkt.finite) {
        ROLLSTEP_MSG(
            "the iterate diverged (primal residual %.3g); the last good iterate was restored",
            primal);
      } else {
        ROLLSTEP_MSG(
            "the problem evaluates to non-finite values at the new iterate (is it undefined "
            "there, outside its model's domain?); the last good iterate was restored");
      }
      status = SolverStatus::Diverged;
      return true;
    }
    ROLLSTEP_MSG("the problem evaluates to non-finite values at the initial guess");
    status = SolverStatus::InvalidInput;
    return true;
  }
  return false;
}

/// Cost and residuals of a linearisation into an iteration's stats.
void Solver::Impl::recordResiduals(const Kkt& kkt, IterationStats& it) const {
  it.cost = kkt.cost;
  it.primal_residual = kkt.primal;
  it.dual_residual = kkt.dual;
  it.complementarity = kkt.complementarity(mu);
}

/// Converging mode: the scaled KKT error below kkt_tolerance (Converged), below
/// acceptable_tolerance for acceptable_iterations iterations in a row (Acceptable), or the
/// iteration limit (Acceptable at an acceptable point, else MaxIterations: a violation left
/// at the limit is no evidence of infeasibility). Returns true when the solve ends here
/// (status set, the iteration's stats recorded).
bool Solver::Impl::terminated(const Kkt& kkt, int max_it, IterationStats& it) {
  const double e0 = kkt.error();
  it.kkt_error = e0;
  acceptable_count = e0 <= set.acceptable_tolerance ? acceptable_count + 1 : 0;
  const bool converged = e0 <= set.kkt_tolerance;
  const bool acceptable = acceptable_count >= set.acceptable_iterations;
  if (!converged && !acceptable && iterations < max_it) return false;
  it.barrier = mu;
  stats.push_back(it);
  has_solution = true;
  if (converged) {
    status = SolverStatus::Converged;
  } else if (acceptable || e0 <= set.acceptable_tolerance) {
    ROLLSTEP_MSG(
        "stopped at an acceptable point (KKT error %.3g, tolerance %.3g) after %d "
        "iterations",
        e0, set.kkt_tolerance, iterations);
    status = SolverStatus::Acceptable;
  } else {
    ROLLSTEP_MSG(
        "no convergence in %d iterations (KKT error %.3g: violation %.3g, dual %.3g, "
        "complementarity %.3g)",
        max_it, e0, kkt.primal, kkt.dual_scaled, kkt.sz_scaled);
    noteNonFiniteTrials();
    status = SolverStatus::MaxIterations;
  }
  return true;
}

/// Monotone (Fiacco-McCormick) barrier update: mu decreases while the barrier problem of
/// the current mu is solved to 10 mu.
void Solver::Impl::updateBarrier(const Kkt& kkt) {
  const auto decrease = [this](double m) {
    return std::max(set.barrier_min, std::min(set.barrier_decrease * m, std::pow(m, 1.5)));
  };
  if (tiny_step) {  // the barrier problem cannot be improved further: next one
    tiny_step = false;
    mu = decrease(mu);
  }
  while (mu > set.barrier_min &&
         std::max({kkt.primal, kkt.dual_scaled, kkt.complementarity(mu)}) <= 10.0 * mu) {
    mu = decrease(mu);
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
