// What happens when no step is acceptable, and when is the problem infeasible? The
// restoration probe (a minimum-norm step towards the linearised constraints) after a
// failed line search, and the evidence of local infeasibility: duals that blew up, a
// violation that stalled.
#include "solver_impl.hpp"

namespace rollstep::solver {

using detail::kHard;
using detail::msSince;

/// After the filter line search rejected the Newton step: restores the iterate and, when
/// the violation is large, tries a restoration step. Returns true when that step was taken
/// (the iteration is done, the loop continues), false when the solve ends (status set).
bool Solver::Impl::stepRejected(const Kkt& kkt, double theta0, double f0, double dphi,
                                Clock::time_point t_upd, IterationStats& it) {
  const double primal = kkt.primal;
  restore();
  it.primal_step = 0.0;
  it.dual_step = 0.0;
  it.time_update_ms = msSince(t_upd);
  stats.push_back(it);
  if (primal > set.infeasibility_tolerance) {
    // Large violation: a restoration step (minimum-norm step towards the linearised
    // constraints) decides between "continue" and "stuck at an infeasible point".
    const double alpha_r = feasibilityStep(theta0);
    if (alpha_r > 0.0) {
      // The filter restarts with the entry of the point the restoration started from
      // (Ipopt augments it with that point): older entries may refuse all that follows.
      filter.clear();
      addFilterEntryFor(theta0, f0);
      // One entry per iteration (stats is reserved for max_iterations + 2 entries).
      IterationStats& last = stats.back();
      last.primal_step = alpha_r;
      last.restoration = true;
      last.time_update_ms = msSince(t_upd);
      ++iterations;
      return true;
    }
    forNodes([this](int k) { linearizeNode(k); });  // outputs of the kept iterate
    ROLLSTEP_MSG(
        "locally infeasible: neither the Newton step nor a minimum-norm feasibility "
        "step reduces the constraint violation (max %.3g, l1 %.3g)",
        primal, theta0);
    status = SolverStatus::Infeasible;
    return false;
  }
  if (kkt.error() <= set.acceptable_tolerance) {
    // The line search cannot improve on an acceptable point (rounding in the merit).
    ROLLSTEP_MSG(
        "stopped at an acceptable point: the line search found no better one (KKT error "
        "%.3g, tolerance %.3g)",
        kkt.error(), set.kkt_tolerance);
    status = SolverStatus::Acceptable;
    return false;
  }
  ROLLSTEP_MSG(
      "line search failed after %d backtracking steps (objective slope %.3g, "
      "violation %.3g)",
      set.max_line_search_steps, dphi, theta0);
  status = SolverStatus::LineSearchFailed;
  return false;
}

/// Restoration probe at the current iterate: one step of the minimum-norm problem
/// (Hessian I, no cost gradient, same linearised constraints and barrier), backtracked
/// on the violation alone. Takes the step and returns its length when it reduces the l1
/// violation theta0 by at least 0.1 %, else keeps the iterate and returns 0.
///
/// Where the constraints curve strongly (a cold start far from the dynamics' linear
/// range) the first backtracked step that reduces the violation can reduce it by far less
/// than the best step along the direction. Along the minimum-norm step the linearised
/// violation falls as theta0 (1 - alpha), so before the point is called stationary the
/// minimiser of the quadratic through theta0, that slope and the trial value is tried.
/// (Step20 seed 63's perception scene, every state row soft: 0.05 % at alpha 0.026, 0.65 %
/// at the quadratic's 0.013, and the solve converges.)
double Solver::Impl::feasibilityStep(double theta0) {
  use_curvature = false;
  condensed_early = false;  // the Hessian is replaced below: condense every node again
  derivatives_shared = false;
  forNodes([this](int k) {
    linearizeNode(k);
    NodeData& d = *node(k).d;
    d.Lxx.setIdentity();
    d.lx.setZero();
    if (k < N) {
      d.Luu.setIdentity();
      d.Lux.setZero();
      d.lu.setZero();
    }
  });
  prob->stateSpace().difference(xs[0], x0, dx0);
  if (condenseAndFactor() != Factorization::Ok) return 0.0;
  lq.forward(dx0);
  forNodes([this](int k) { recoverNode(k); });
  double alpha = 1.0;
  for (int k = 0; k <= N; ++k) {
    if (!node(k).finite) return 0.0;
    alpha = std::min(alpha, node(k).alpha_p);
  }
  const auto violationAt = [this](double a) {
    forNodes([this, a](int k) { trialPoint(k, a); });
    forNodes([this](int k) { evaluateTrial(k); });
    double theta = 0.0;
    for (int k = 0; k <= N; ++k) theta += node(k).merit_theta;
    prob->stateSpace().difference(xs_trial[0], x0, dx0);
    return theta + dx0.lpNorm<1>();
  };
  constexpr double kProgress = 1e-3;  // below this share: stationary for the violation
  for (int ls = 0; ls < std::max(set.max_line_search_steps, 1); ++ls) {
    double theta = violationAt(alpha);
    if (std::isfinite(theta) && theta <= (1.0 - 1e-4 * alpha) * theta0) {
      if (theta > (1.0 - kProgress) * theta0) {
        // theta(a) ~ theta0 (1 - a) + c a^2 through theta(alpha): its minimiser.
        const double c = (theta - theta0 * (1.0 - alpha)) / (alpha * alpha);
        const double best = c > 0.0 ? theta0 / (2.0 * c) : alpha;
        if (!(best < alpha)) return 0.0;
        theta = violationAt(best);
        if (!(theta <= (1.0 - kProgress) * theta0)) return 0.0;
        alpha = best;
      }
      for (int k = 0; k <= N; ++k) {
        const auto kk = static_cast<std::size_t>(k);
        xs[kk] = xs_trial[kk];
        if (k < N) us[kk] = us_trial[kk];
        node(k).s = node(k).s_trial;
      }
      return alpha;
    }
    alpha *= 0.5;
  }
  return 0.0;
}

bool Solver::Impl::dualsBlewUp(double primal) const {
  if (!(primal > set.infeasibility_tolerance)) return false;
  for (const Node& n : nodes) {
    for (int i = 0; i < nrows; ++i) {
      if (n.kind(i) == kHard && !(n.z(i) <= kDualBlowUp)) return true;
    }
  }
  return false;
}

}  // namespace rollstep::solver
