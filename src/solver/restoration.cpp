// What happens when no step is acceptable, and when is the problem infeasible? The
// restoration phase (feasibility steps towards the linearised constraints) after a failed
// line search, and the evidence of local infeasibility: duals that blew up, a violation
// that stalled.
#include "solver_impl.hpp"

namespace rollstep::solver {

using detail::kHard;
using detail::msSince;

/// After the filter line search rejected the Newton step: restores the iterate and, when
/// the violation is large, runs the restoration phase. Returns true when the phase reached
/// a point with less violation (the iteration is done, the loop continues), false when the
/// solve ends (status set).
bool Solver::Impl::stepRejected(const Kkt& kkt, double theta0, double f0, double dphi,
                                Clock::time_point t_upd, IterationStats& it) {
  const double primal = kkt.primal;
  restore();
  it.primal_step = 0.0;
  it.dual_step = 0.0;
  it.time_update_ms = msSince(t_upd);
  stats.push_back(it);
  if (primal > set.infeasibility_tolerance) {
    if (restorationPhase(theta0, f0, primal, t_upd)) return true;
    // Outputs of the iterate kept (the phase's steps may have moved it): duals, cost.
    forNodes([this](int k) { linearizeNode(k); });
    prob->stateSpace().difference(xs[0], x0, dx0);
    cost = residualSummary().cost;
    if (iterations >= set.max_iterations) {
      // Still reducing the violation at the limit: no evidence of infeasibility.
      ROLLSTEP_MSG(
          "no convergence in %d iterations: the restoration phase was still reducing the "
          "constraint violation (l1 %.3g where it started)",
          set.max_iterations, theta0);
      noteNonFiniteTrials();
      status = SolverStatus::MaxIterations;
      return false;
    }
    ROLLSTEP_MSG(
        "locally infeasible: neither the Newton step nor the restoration phase reduces the "
        "constraint violation (max %.3g, l1 %.3g)",
        primal, theta0);
    noteNonFiniteTrials();
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
  noteNonFiniteTrials();
  status = SolverStatus::LineSearchFailed;
  return false;
}

/// The restoration phase. First the feasibility step of before (one minimum-norm step from
/// the slacks as they are, kept when it reduces the violation by 0.1 %: the cheapest way
/// back to the Newton steps, and what the Tachyon 3 first solves with every state row soft
/// take). When it does not, a rollout (rollout(): the inputs inside their bounds, the states
/// simulated from x0, so every defect is closed at once), kept when it reaches kappa_resto
/// theta0 (below). When it does not, up to kMaxSteps feasibility steps that first move the slacks
/// (after Ipopt's restoration phase, with the proximity to the current point as the
/// objective and its barrier mu_R = max(mu, max violation)), each an iteration of its own,
/// until the l1 violation is at most kappa_resto = 0.9 of theta0, the violation where the
/// Newton step was rejected. The phase fails (the solve ends Infeasible) when no step
/// reduces the violation, when kStallSteps steps in a row do not reduce the least violation
/// reached by 0.1 % (a stationary point of the violation), or after kMaxSteps steps; at the
/// iteration limit the solve ends MaxIterations. Afterwards the barrier is mu again, the
/// duals z = mu / s. When it succeeds the filter restarts with the entry of the point the
/// phase started from (Ipopt augments its filter with that point: older entries may refuse
/// all that follows).
///
/// Measured on 56 random starts of the solver tests' problems (noise of 0.3 to 1.2 on every
/// state and input of the default guesses), all of which Ipopt solved: with the single
/// step alone 19 ended Infeasible (the Newton steps had driven the slacks of rows the
/// violation pulls on to 1e-6..1e-12, where the fraction to the boundary cut every
/// feasibility step to 1e-3..1e-9 of its length); with the slack-moving steps 3 (none
/// needed more than 10 of them per phase). The infeasible problems of the solver tests are
/// still found Infeasible, after more iterations (29 instead of 8 for a start inside a hard
/// obstacle, 12 instead of 2 for an equality against the input bounds).
///
/// The rollout: the feasibility steps keep the linearised dynamics exact, so
/// where the guess's states are far from the dynamics, closing the defects asks for inputs
/// far beyond their bounds and the fraction to the boundary cuts every step (to 0.003-0.01;
/// Ipopt's elastic restoration relaxes the defects instead, which our Riccati structure
/// would need an input augmented by ndx for). The rollout closes them within the bounds:
/// 80 of 80 random starts solved (the two rigid-body starts left Infeasible converge in 54
/// and 63 iterations; Ipopt 304 and 305), 4801 iterations over them instead of 5887 with
/// the rollout as the last resort after the slack-moving steps (unicycle starts 132 -> 35,
/// 143 -> 38). The first solves of the Tachyon 3 OCP never take it (bit for bit the same);
/// the start inside a hard obstacle ends Infeasible after 17 iterations instead of 29.
bool Solver::Impl::restorationPhase(double theta0, double f0, double primal,
                                    Clock::time_point t_upd) {
  constexpr double kKappaResto = 0.9;
  constexpr double kProgress = 1e-3;  // below this share: no progress on the violation
  constexpr int kStallSteps = 5;
  constexpr int kMaxSteps = 10;  // slack-moving steps per phase
  bool first = true;
  // One entry per iteration (stats is reserved for max_iterations + 2 entries): the
  // rejected iteration's for the first step, a new one for each further step.
  const auto record = [&](double alpha) {
    if (!first) {
      // The residuals where this step started (feasibilityStep linearised there).
      IterationStats next;
      next.iteration = iterations;
      recordResiduals(step_start, next);
      next.kkt_error = step_start.error();
      stats.push_back(next);
    }
    first = false;
    IterationStats& last = stats.back();
    last.primal_step = alpha;
    last.restoration = true;
    last.barrier = mu;
    last.time_update_ms = msSince(t_upd);
    ++iterations;
  };
  double theta_start = theta0, theta_new = theta0;
  bool reached = false;
  const double alpha0 = feasibilityStep(false, kProgress, theta_start, theta_new);
  if (alpha0 > 0.0) {
    record(alpha0);
    reached = true;
  } else if (takeRollout(kKappaResto * theta0)) {
    record(1.0);
    reached = true;
  } else {
    const double mu_main = mu;
    mu = std::max(mu, primal);
    const int max_it = std::max(set.max_iterations, 0);
    int stalled = 0;
    double best = theta0;  // the least violation reached (the slack moves may raise it)
    for (int step = 0; step < kMaxSteps && iterations < max_it; ++step) {
      const double alpha = feasibilityStep(true, 0.0, theta_start, theta_new);
      if (!(alpha > 0.0)) break;
      record(alpha);  // (the next step sets the duals of its moved slacks)
      if (theta_new <= kKappaResto * theta0) {
        reached = true;
        break;
      }
      stalled = theta_new > (1.0 - kProgress) * best ? stalled + 1 : 0;
      best = std::min(best, theta_new);
      if (stalled >= kStallSteps) break;
    }
    mu = mu_main;
    centreDuals();
  }
  if (!reached) return false;
  filter.clear();
  addFilterEntryFor(theta0, f0);
  return true;
}

/// One step of the restoration phase at the current iterate. With move_slacks the slacks
/// of the hard rows first go to max(s, c, kSlackFloor) (a row whose value exceeds its slack
/// then adds no violation; a slack at its bound gets room) and their duals to mu / s. Then
/// the minimum-norm problem (Hessian I, no cost gradient, same linearised constraints, the
/// barrier mu) is solved and backtracked on the l1 violation alone, from the violation
/// theta_start (after the slack move). Takes the first step length with an Armijo decrease
/// that also reduces the violation by the share min_progress (theta_new: the violation
/// there) and returns it; returns 0 with the iterate kept (and the slacks moved) when none
/// does.
///
/// Slack floor, measured on 56 random starts of the solver tests' problems (noise of 0.3
/// to 1.2 on every state and input of the default guesses), all of which Ipopt solved:
/// Infeasible in 11 with a floor of 1e-3, 5 with 1e-2, 3 with 0.1 (the slack-moving steps
/// alone; 2 after the plain first step).
///
/// Where the constraints curve strongly (a cold start far from the dynamics' linear
/// range) the first backtracked step that reduces the violation can reduce it by far less
/// than the best step along the direction. Along the minimum-norm step the linearised
/// violation falls as theta_start (1 - alpha), so when that step reduces it by less than
/// 0.1 % the minimiser of the quadratic through theta_start, that slope and the trial
/// value is tried and taken when it does better. (Step20 seed 63's perception scene, every
/// state row soft: 0.05 % at alpha 0.026, 0.65 % at the quadratic's 0.013.)
double Solver::Impl::feasibilityStep(bool move_slacks, double min_progress, double& theta_start,
                                     double& theta_new) {
  constexpr double kSlackFloor = 0.1;
  use_curvature = false;
  condensed_early = false;  // the Hessian is replaced below: condense every node again
  derivatives_shared = false;
  target_mu = mu;
  forNodes([this, move_slacks](int k) {
    linearizeNode(k);
    Node& n = node(k);
    for (int i = 0; move_slacks && i < nrows; ++i) {
      if (n.kind(i) != kHard) continue;
      n.s(i) = std::max({n.s(i), n.c(i), kSlackFloor});
      n.z(i) = mu / n.s(i);
    }
    NodeData& d = *n.d;
    d.Lxx.setIdentity();
    d.lx.setZero();
    if (k < N) {
      d.Luu.setIdentity();
      d.Lux.setZero();
      d.lu.setZero();
    }
  });
  prob->stateSpace().difference(xs[0], x0, dx0);
  step_start = residualSummary();  // before the slack move: the iterate's residuals
  double theta0 = 0.0;             // summed as the line search sums it
  for (int k = 0; k <= N; ++k) {
    Node& n = node(k);
    meritNode(k, n, n.s);
    theta0 += n.merit_theta;
  }
  theta0 += dx0.lpNorm<1>();
  theta_start = theta0;
  if (condenseAndFactor() != Factorization::Ok) return 0.0;
  lq.forward(dx0);
  forNodes([this](int k) { recoverNode(k); });
  double alpha = 1.0, alpha_d = 1.0;
  if (!stepLengths(alpha, alpha_d)) return 0.0;
  const auto violationAt = [this](double a) {
    double f = 0.0;
    return trialMerit(a, f);
  };
  constexpr double kProgress = 1e-3;  // below this share: try the quadratic's minimiser
  for (int ls = 0; ls < std::max(set.max_line_search_steps, 1); ++ls) {
    double theta = violationAt(alpha);
    if (std::isfinite(theta) && theta <= (1.0 - 1e-4 * alpha) * theta0) {
      if (theta > (1.0 - kProgress) * theta0) {
        // theta(a) ~ theta0 (1 - a) + c a^2 through theta(alpha): its minimiser.
        const double c = (theta - theta0 * (1.0 - alpha)) / (alpha * alpha);
        const double best = c > 0.0 ? theta0 / (2.0 * c) : alpha;
        if (best < alpha) {
          const double theta_best = violationAt(best);
          if (theta_best < theta) {
            theta = theta_best;
            alpha = best;
          } else {
            violationAt(alpha);  // back to the Armijo point in the trial buffers
          }
        }
      }
      if (theta > (1.0 - min_progress) * theta0) return 0.0;
      acceptTrial();
      theta_new = theta;
      return alpha;
    }
    alpha *= 0.5;
  }
  return 0.0;
}

/// The rollout (rollout()) taken when its violation is at most theta_limit: the iterate moves
/// there, the hard rows' duals to mu / s. Returns whether it was taken.
bool Solver::Impl::takeRollout(double theta_limit) {
  const double theta = rollout();
  if (!(std::isfinite(theta) && theta <= theta_limit)) return false;
  acceptTrial();
  centreDuals();
  return true;
}

/// The hard rows' duals on the central path of the barrier mu: z = mu / s.
void Solver::Impl::centreDuals() {
  forNodes([this](int k) {
    Node& n = node(k);
    for (int i = 0; i < nrows; ++i) {
      if (n.kind(i) == kHard) n.z(i) = mu / n.s(i);
    }
  });
}

/// A rollout into the trial buffers: the inputs moved inside their bounds, the states
/// simulated from x0 through the dynamics (every defect closed, as a DDP forward pass), the
/// hard rows' slacks at max(c, 1e-3) (trialRows). Returns the l1 violation there (not
/// finite when the rollout diverged).
double Solver::Impl::rollout() {
  for (int k = 0; k < N; ++k) {
    us_trial[static_cast<std::size_t>(k)] = us[static_cast<std::size_t>(k)];
  }
  pushInputsIntoBounds(us_trial);
  xs_trial[0] = x0;
  for (int k = 0; k < N; ++k) {  // sequential: each state is the last one's successor
    const auto kk = static_cast<std::size_t>(k);
    NodeData& d = *node(k).d;
    prob->evaluate(k, xs_trial[kk], us_trial[kk], d);
    if (!d.xnext.allFinite()) {
      ++nonfinite_trials;
      return detail::kInf;
    }
    xs_trial[kk + 1] = d.xnext;
  }
  prob->evaluate(N, xs_trial[static_cast<std::size_t>(N)], zero_u, *node(N).d);
  forNodes([this](int k) { trialRows(k, true); });
  double theta = 0.0;
  for (int k = 0; k <= N; ++k) theta += node(k).merit_theta;
  prob->stateSpace().difference(xs_trial[0], x0, dx0);
  return theta + dx0.lpNorm<1>();
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
