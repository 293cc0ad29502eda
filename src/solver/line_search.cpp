// When is a step accepted? The filter line search of Waechter and Biegler on the barrier
// objective and the l1 constraint violation (converging mode), the full fraction-to-
// boundary step otherwise, and the update of the duals and multipliers with the step.
#include <cmath>
#include <cstdio>
#include <cstring>

#include "solver_impl.hpp"

namespace rollstep::solver {

using detail::kHard;
using detail::kSoft;
using detail::relaxedLog;

namespace {
// Margins of the filter (Waechter and Biegler 2006): a trial point must reduce the
// violation by the fraction kGammaTheta or the barrier objective by kGammaF theta.
constexpr double kGammaTheta = 1e-5, kGammaF = 1e-8;
}  // namespace

/// Backtracks from alpha until the trial point is acceptable to the filter; then moves
/// the iterate there and returns true (alpha, alpha_d: the step taken; corrections: the
/// second-order corrections it took, 0 for the Newton step). Returns false with the trial
/// point rejected (theta0_out, f0_out: the violation and barrier objective of the current
/// iterate).
bool Solver::Impl::filterLineSearch(double dphi, double& alpha, double& alpha_d, double& theta0_out,
                                    double& f0_out, int& corrections) {
  corrections = 0;
  const bool soc = set.max_second_order_corrections > 0 && has_curvature;
  double f0 = 0.0, theta0 = 0.0;
  for (int k = 0; k <= N; ++k) {
    Node& n = node(k);
    // Values of the current iterate: recompute rows from the linearisation.
    meritNode(k, n, n.s);
    f0 += n.merit_f;
    theta0 += n.merit_theta;
  }
  theta0 += dx0.lpNorm<1>();
  theta0_out = theta0;
  f0_out = f0;
  if (soc) {
    forNodes([this](int k) { keepIterateValues(k); });
    dx0_it = dx0;
  }
  // Filter line search (Waechter and Biegler 2006, Sec. 2.3) on the barrier objective
  // f and the l1 violation theta. (An l1 merit function rejected most full steps of the
  // Newton direction near the solution and crawled with alpha ~ 1e-2.)
  if (mu != filter_mu) {
    filter.clear();  // a new barrier problem
    filter_mu = mu;
  }
  if (iterations == 0) {
    theta_max = 1e4 * std::max(1.0, theta0);
    theta_min = 1e-4 * std::max(1.0, theta0);
  }
  bool accepted = false;
  bool f_type = false;
  bool filter_refused_last = false;  // the last rejected trial passed the decrease test
  for (int ls = 0; ls < std::max(set.max_line_search_steps, 1); ++ls) {
    double f = 0.0;
    const double theta = trialMerit(alpha, f);
    bool refused = false;
    if (acceptableToFilter(theta, f, theta0, f0, dphi, alpha, f_type, refused)) {
      accepted = true;
      break;
    }
    filter_refused_last = refused;
    // The full Newton step raised the violation: the constraints curve across it (Waechter
    // and Biegler's: second-order corrections before backtracking). Only for a unit
    // step (Ipopt: any first trial): after a step the fraction to the boundary cut, the
    // corrected direction's own cut can be far longer than the step that revealed the
    // curvature (the cart-pole of the solver tests from its interpolated start: 42
    // iterations with corrections after cut steps too, 15 without them, 17 without any).
    if (soc && ls == 0 && alpha >= 1.0 && !(theta < theta0)) {
      double alpha_soc = 0.0, alpha_d_soc = 0.0;
      corrections = secondOrderCorrection(alpha, theta0, f0, dphi, f_type, alpha_soc, alpha_d_soc);
      if (corrections > 0) {
        alpha = alpha_soc;
        alpha_d = alpha_d_soc;
        accepted = true;
        break;
      }
    }
    alpha *= 0.5;
  }
  noteFilterRefusals(filter_refused_last);
  if (accepted && !f_type) addFilterEntryFor(theta0, f0);
  if (!accepted) return false;
  acceptTrial();
  return true;
}

/// The fraction-to-boundary step lengths of the recovered direction (primal ap, dual ad:
/// the least over the nodes); false when some node's step is not finite.
bool Solver::Impl::stepLengths(double& ap, double& ad) const {
  bool finite = true;
  ap = ad = 1.0;
  for (const Node& n : nodes) {
    finite = finite && n.finite;
    ap = std::min(ap, n.alpha_p);
    ad = std::min(ad, n.alpha_d);
  }
  return finite;
}

/// The trial point alpha along the direction: evaluated, its barrier objective (f) and l1
/// violation (returned).
double Solver::Impl::trialMerit(double alpha, double& f) {
  forNodes([this, alpha](int k) { trialPoint(k, alpha); });
  forNodes([this](int k) { evaluateTrial(k); });
  double theta = 0.0;
  f = 0.0;
  for (int k = 0; k <= N; ++k) {
    f += node(k).merit_f;
    theta += node(k).merit_theta;
  }
  prob->stateSpace().difference(xs_trial[0], x0, dx0);
  theta += dx0.lpNorm<1>();
  if (!std::isfinite(theta) || !std::isfinite(f)) ++nonfinite_trials;
  return theta;
}

void Solver::Impl::noteNonFiniteTrials() {
  if (nonfinite_trials == 0) return;
  const std::size_t used = std::strlen(message);
  std::snprintf(message + used, sizeof(message) - used,
                "; %d trial points evaluated to non-finite values (is the problem undefined "
                "there, outside its model's domain?)",
                nonfinite_trials);
}

/// The filter's acceptance test of a trial point (theta, f) for the step alpha from the
/// iterate (theta0, f0) along a direction of barrier slope dphi: sufficient decrease
/// (Armijo on f when the switching condition holds: f_type) and acceptance by the filter.
/// filter_refused: the decrease test passed but the filter refused the point.
bool Solver::Impl::acceptableToFilter(double theta, double f, double theta0, double f0, double dphi,
                                      double alpha, bool& f_type, bool& filter_refused) const {
  constexpr double kEta = 1e-4;
  const double f_tol = 1e-13 * (1.0 + std::abs(f0));  // round-off of the sums
  filter_refused = false;
  bool decrease = std::isfinite(f) && std::isfinite(theta) && theta <= theta_max;
  if (decrease) {
    // Switching condition: the step promises an objective decrease that dominates
    // the (small) violation: then require Armijo on f, else decrease of theta or f.
    const bool switching = dphi < 0.0 && alpha * std::pow(-dphi, 2.3) > std::pow(theta0, 1.1);
    f_type = switching && theta0 <= theta_min;
    if (f_type) {
      decrease = f <= f0 + kEta * alpha * dphi + f_tol;
    } else {
      decrease = theta <= (1.0 - kGammaTheta) * theta0 || f <= f0 - kGammaF * theta0 + f_tol;
    }
  }
  if (!decrease) return false;
  for (const auto& entry : filter) {
    if (!(theta < entry.first || f < entry.second)) {
      filter_refused = true;
      return false;
    }
  }
  return true;
}

/// The iterate's constraint values of node k, which the trial points overwrite: the
/// right-hand sides of the second-order corrections and of the Newton step.
void Solver::Impl::keepIterateValues(int k) {
  Node& n = node(k);
  n.c_it = n.c;
  if (k < N) {
    n.defect_it = n.defect;
    if (n.d->ne > 0) n.e_it.head(n.d->ne) = n.d->e.head(n.d->ne);
  }
}

/// Second-order corrections (Waechter and Biegler 2006, A-5.5 to; Ipopt's max_soc):
/// the full step alpha0 was rejected and raised the violation. The step is re-solved with
/// the same factorisation (same Hessian and Jacobians, new vectors) for the constraint
/// values c_soc = alpha0 c(x) + c(x + alpha0 d) (dynamics defects, equalities, hard rows'
/// c - s, the initial state), which corrects the linearisation by the curvature the trial
/// point revealed; its fraction-to-boundary length gives the corrected trial point, judged
/// like the Newton step's full step (Armijo with alpha0). Repeated with c_soc = alpha c_soc +
/// c(x_soc) while each reduces the violation by 1 %. Returns the number of corrections of
/// the accepted point (then in the trial buffers; alpha, alpha_d its step lengths), or 0
/// with the Newton direction restored.
int Solver::Impl::secondOrderCorrection(double alpha0, double theta0, double f0, double dphi,
                                        bool& f_type, double& alpha, double& alpha_d) {
  constexpr double kKappaSoc = 0.99;
  // c_soc = alpha0 c(x) + c(x_trial); dx0 holds the trial point's initial-state residual.
  const auto accumulate = [this](double a, bool first) {
    forNodes([this, a, first](int k) {
      Node& n = node(k);
      for (int i = 0; i < nrows; ++i) {
        const double prev = first ? n.c_it(i) - n.s(i) : n.soc_rows(i);
        n.soc_rows(i) = a * prev + (n.c(i) - n.s_trial(i));
      }
      if (k < N) {
        n.soc_defect = a * (first ? n.defect_it : n.soc_defect) + n.defect;
        const int ne = n.d->ne;
        if (ne > 0) {
          n.soc_e.head(ne) = a * (first ? n.e_it.head(ne) : n.soc_e.head(ne)) + n.d->e.head(ne);
        }
      }
    });
    dx0_soc = a * (first ? dx0_it : dx0_soc) + dx0;
  };
  accumulate(alpha0, true);
  double theta_old = theta0;
  int p = 1;
  for (; p <= set.max_second_order_corrections; ++p) {
    forNodes([this](int k) { correctionVectors(k, true); });
    lq.resolveVectors(dx0_soc);
    forNodes([this](int k) { recoverNode(k); });
    double ap = 1.0, ad = 1.0;
    if (!stepLengths(ap, ad)) break;
    double f = 0.0;
    const double theta = trialMerit(ap, f);
    bool refused = false;
    if (acceptableToFilter(theta, f, theta0, f0, dphi, alpha0, f_type, refused)) {
      alpha = ap;
      alpha_d = ad;
      return p;
    }
    if (p == set.max_second_order_corrections || !(theta <= kKappaSoc * theta_old)) break;
    theta_old = theta;
    accumulate(ap, false);
  }
  // Back to the Newton direction for the backtracking.
  forNodes([this](int k) { correctionVectors(k, false); });
  lq.resolveVectors(dx0_it);
  forNodes([this](int k) { recoverNode(k); });
  return 0;
}

/// The right-hand side of node k's Newton system from the iterate's constraint values
/// (corrected: the second-order corrections' c_soc for the dynamics, the equalities and the
/// hard rows): the stage's defect and equality values, the row values c the condensed
/// gradient and the step recovery read (hard rows: s + the corrected c - s), the gradient.
void Solver::Impl::correctionVectors(int k, bool corrected) {
  Node& n = node(k);
  LqStage& st = lq.stage(k);
  n.c = n.c_it;
  if (corrected) {
    for (int i = 0; i < nrows; ++i) {
      if (n.kind(i) == kHard) n.c(i) = n.s(i) + n.soc_rows(i);
    }
  }
  if (k < N) {
    st.b = corrected ? n.soc_defect : n.defect_it;
    const int ne = n.d->ne;
    if (ne > 0) st.e.head(ne) = corrected ? n.soc_e.head(ne) : n.e_it.head(ne);
  }
  condenseGradient(k);
}

/// Moves the iterate by alpha along the direction without a line search.
void Solver::Impl::takeFullStep(double alpha) {
  forNodes([this, alpha](int k) {
    trialPoint(k, alpha);
    const auto kk = static_cast<std::size_t>(k);
    xs[kk] = xs_trial[kk];
    if (k < N) us[kk] = us_trial[kk];
    node(k).s = node(k).s_trial;
  });
}

/// Duals of the hard rows by their own step length alpha_d; costates and equality
/// multipliers by the primal step alpha.
void Solver::Impl::updateDuals(double alpha, double alpha_d) {
  const double ad = alpha_d;
  for (int k = 0; k <= N; ++k) {
    Node& n = node(k);
    for (int i = 0; i < nrows; ++i) {
      if (n.kind(i) == kHard) n.z(i) = std::max(n.z(i) + ad * n.dz(i), 1e-300);
    }
    n.lam += alpha * (lq.costate(k) - n.lam);
    if (k < N && n.d->ne > 0) {
      n.mult.head(n.d->ne) +=
          alpha * (lq.equalityMultipliers(k).head(n.d->ne) - n.mult.head(n.d->ne));
    }
  }
}

void Solver::Impl::trialPoint(int k, double alpha) {
  const auto kk = static_cast<std::size_t>(k);
  if (euclid) {
    xs_trial[kk] = xs[kk] + alpha * lq.dx(k);
  } else {
    scaled[kk] = alpha * lq.dx(k);
    prob->stateSpace().integrate(xs[kk], scaled[kk], xs_trial[kk]);
  }
  if (k < N) us_trial[kk] = us[kk] + alpha * lq.du(k);
  Node& n = node(k);
  n.s_trial = n.s + alpha * n.ds;
}

/// The iterate moves to the trial point (states, inputs, slacks).
void Solver::Impl::acceptTrial() {
  for (int k = 0; k <= N; ++k) {
    const auto kk = static_cast<std::size_t>(k);
    xs[kk] = xs_trial[kk];
    if (k < N) us[kk] = us_trial[kk];
    node(k).s = node(k).s_trial;
  }
}

/// The trial point of node k evaluated: defect, row values, merit.
void Solver::Impl::evaluateTrial(int k) {
  const auto kk = static_cast<std::size_t>(k);
  prob->evaluate(k, xs_trial[kk], k < N ? us_trial[kk] : zero_u, *node(k).d);
  trialRows(k, false);
}

/// After the trial point of node k was evaluated: its defect, row values and merit.
/// slacks_from_rows (the restoration's rollout): the hard rows' trial slacks first go to
/// max(c, 1e-3), so a row the trial point satisfies adds no violation.
void Solver::Impl::trialRows(int k, bool slacks_from_rows) {
  constexpr double kSlackMin = 1e-3;
  Node& n = node(k);
  const auto kk = static_cast<std::size_t>(k);
  const VectorXd& u = k < N ? us_trial[kk] : zero_u;
  if (k < N) prob->stateSpace().difference(xs_trial[kk + 1], n.d->xnext, n.defect);
  rowValues(k, xs_trial[kk], u, n);
  for (int i = 0; slacks_from_rows && i < nrows; ++i) {
    if (n.kind(i) == kHard) n.s_trial(i) = std::max(n.c(i), kSlackMin);
  }
  meritNode(k, n, n.s_trial);
}

/// f: cost + barrier terms; theta: l1 norm of the constraint violation.
void Solver::Impl::meritNode(int k, Node& n, const VectorXd& s) const {
  const NodeData& d = *n.d;
  double f = d.cost, theta = 0.0;
  if (k < N) {
    theta += n.defect.lpNorm<1>();
    if (d.ne > 0) theta += d.e.head(d.ne).lpNorm<1>();
  }
  for (int i = 0; i < nrows; ++i) {
    if (n.kind(i) == kHard) {
      f -= mu * std::log(s(i));
      theta += std::abs(n.c(i) - s(i));
    } else if (n.kind(i) == kSoft) {
      double d1 = 0.0, d2 = 0.0;
      f += softWeight(n, i) * relaxedLog(n.c(i), relaxation(n, i), d1, d2);
    }
  }
  n.merit_f = f;
  n.merit_theta = theta;
}

/// Ipopt's filter reset heuristic: when the filter (not the decrease test) refused the last
/// rejected trial point in filter_reset_trigger line searches in a row, the filter is
/// cleared (at most max_filter_resets times per solve). An old entry can forbid every
/// point along directions that must raise the barrier objective to reduce the violation.
void Solver::Impl::noteFilterRefusals(bool refused) {
  if (set.filter_reset_trigger <= 0 || filter_resets >= set.max_filter_resets) return;
  if (!refused) {
    filter_rejections_in_a_row = 0;
    return;
  }
  if (++filter_rejections_in_a_row >= set.filter_reset_trigger) {
    filter.clear();
    filter_was_reset = true;
    ++filter_resets;
    filter_rejections_in_a_row = 0;
  }
}

/// The entry of an iterate (theta, f) the next ones must improve on by the margins.
void Solver::Impl::addFilterEntryFor(double theta, double f) {
  addToFilter((1.0 - kGammaTheta) * theta, f - kGammaF * theta);
}

void Solver::Impl::addToFilter(double theta, double f) {
  // Drop the entries the new one dominates, then append (never beyond the capacity).
  std::size_t m = 0;
  for (std::size_t j = 0; j < filter.size(); ++j) {
    if (!(filter[j].first >= theta && filter[j].second >= f)) filter[m++] = filter[j];
  }
  filter.resize(m);
  if (filter.size() < filter.capacity()) filter.emplace_back(theta, f);
}

/// Proximal (Levenberg-Marquardt) shift of the Hessian, adapted to the step the line
/// search accepted: a short step (alpha < 0.1) says the quadratic model is poor far from
/// the solution (the Lagrangian's Hessian with multipliers that are still wrong), so the
/// next directions are shortened and turned towards the gradient (shift 1e-4, then x10 per
/// short step); full steps shrink it by 10 until it vanishes, which restores Newton's fast
/// local convergence. (Without it the planar quadrotor of the solver tests stalls at
/// alpha ~1e-5 from its default start with the exact Hessian.)
void Solver::Impl::adaptProximalShift(double alpha) {
  if (alpha < 0.1) {
    prox = std::min(1e4, std::max(1e-4, 10.0 * prox));
  } else if (alpha >= 1.0) {
    prox = prox > 1e-7 ? 0.1 * prox : 0.0;
  }
}

}  // namespace rollstep::solver
