// When is a step accepted? The filter line search of Waechter and Biegler on the barrier
// objective and the l1 constraint violation (converging mode), the full fraction-to-
// boundary step otherwise, and the update of the duals and multipliers with the step.
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
/// the iterate there and returns true (alpha: the step taken). Returns false with the
/// trial point rejected (theta0_out, f0_out: the violation and barrier objective of the
/// current iterate).
bool Solver::Impl::filterLineSearch(double dphi, double& alpha, double& theta0_out,
                                    double& f0_out) {
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
  constexpr double kEta = 1e-4;
  const double f_tol = 1e-13 * (1.0 + std::abs(f0));  // round-off of the sums
  bool accepted = false;
  bool f_type = false;
  bool filter_refused_last = false;  // the last rejected trial passed the decrease test
  for (int ls = 0; ls < std::max(set.max_line_search_steps, 1); ++ls) {
    forNodes([this, alpha](int k) { trialPoint(k, alpha); });
    forNodes([this](int k) { evaluateTrial(k); });
    double f = 0.0, theta = 0.0;
    for (int k = 0; k <= N; ++k) {
      f += node(k).merit_f;
      theta += node(k).merit_theta;
    }
    prob->stateSpace().difference(xs_trial[0], x0, dx0);
    theta += dx0.lpNorm<1>();
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
    bool in_filter = true;
    for (std::size_t j = 0; decrease && in_filter && j < filter.size(); ++j) {
      in_filter = theta < filter[j].first || f < filter[j].second;
    }
    if (decrease && in_filter) {
      accepted = true;
      break;
    }
    filter_refused_last = decrease;
    alpha *= 0.5;
  }
  noteFilterRefusals(filter_refused_last);
  if (accepted && !f_type) addFilterEntryFor(theta0, f0);
  if (!accepted) return false;
  for (int k = 0; k <= N; ++k) {
    const auto kk = static_cast<std::size_t>(k);
    xs[kk] = xs_trial[kk];
    if (k < N) us[kk] = us_trial[kk];
    node(k).s = node(k).s_trial;
  }
  return true;
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

void Solver::Impl::evaluateTrial(int k) {
  Node& n = node(k);
  NodeData& d = *n.d;
  const auto kk = static_cast<std::size_t>(k);
  const VectorXd& u = k < N ? us_trial[kk] : zero_u;
  prob->evaluate(k, xs_trial[kk], u, d);
  if (k < N) prob->stateSpace().difference(xs_trial[kk + 1], d.xnext, n.defect);
  rowValues(k, xs_trial[kk], u, n);
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
