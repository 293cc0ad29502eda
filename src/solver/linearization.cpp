// How is a node linearised? The problem's derivatives at the iterate, the defect and its
// Jacobians, the inequality rows (general rows, input and state bounds), the KKT residuals
// of every node and, in converging mode, the constraint curvature added to the
// Gauss-Newton Hessian.
#include "rollstep/ocp/small_products.hpp"
#include "solver_impl.hpp"

namespace rollstep::solver {

using detail::kHard;
using detail::kInactive;
using detail::kInf;
using detail::kSoft;
using detail::msSince;
using detail::relaxedLog;

/// Linearises every node at the current iterate and reduces the KKT measures (in a fixed
/// order, so that they do not depend on the thread count).
Solver::Impl::Kkt Solver::Impl::linearize(bool realtime, IterationStats& it) {
  auto t_lin = Clock::now();
  // The workspace exists for such settings (constructor, setSettings).
  use_curvature = !realtime && needsCurvature(set) && curvature_reserved;
  reset_slacks = !realtime && set.slack_reset;
  // A real-time iteration condenses with the barrier and targets it linearises with (no
  // barrier update, no proximal shift, no predictor-corrector in between): with one
  // thread, each node right after its linearisation, its derivatives still in cache, and
  // from the last node down, projected and factorised (backward Riccati step) at once,
  // its LQ stage still in cache too.
  condense_in_linearize = realtime && !pc_active && !corrector;
  if (condense_in_linearize) {
    target_mu = mu;
    early_factorization = pool.size() == 1 ? linearizeAndFactor() : linearizeProjectAndFactor();
  } else {
    forNodes([this](int k) { linearizeNode(k); });
  }
  condensed_early = condense_in_linearize;
  derivatives_shared = condense_in_linearize;
  condense_in_linearize = false;
  prob->stateSpace().difference(xs[0], x0, dx0);
  const Kkt r = residualSummary();
  it.time_linearize_ms = msSince(t_lin);
  return r;
}

/// The KKT residuals of the nodes' last linearisation and dx0, reduced in a fixed order.
Solver::Impl::Kkt Solver::Impl::residualSummary() const {
  Kkt r;
  r.finite = dx0.allFinite();
  r.primal = dx0.lpNorm<Eigen::Infinity>();
  for (int k = 0; k <= N; ++k) {
    const Node& n = nodes[static_cast<std::size_t>(k)];
    r.finite = r.finite && n.finite;
    r.primal = std::max(r.primal, n.primal);
    r.dual = std::max(r.dual, n.dual);
    r.sz_max = std::max(r.sz_max, n.sz_max);
    r.sz_min = std::min(r.sz_min, n.sz_min);
    r.msum += n.mult_sum;
    r.mcount += n.mult_count;
    r.zsum += n.z_sum;
    r.zcount += n.z_count;
    r.soft_rows = r.soft_rows || n.soft_rows;
    r.cost += n.d->cost;
  }
  const double sd = std::max(100.0, r.msum / std::max(r.mcount, 1)) / 100.0;
  r.dual_scaled = r.dual / sd;
  const double sc = std::max(100.0, r.zsum / std::max(r.zcount, 1)) / 100.0;
  r.sz_scaled = r.sz_max / sc;
  return r;
}

void Solver::Impl::linearizeNode(int k) {
  Node& n = node(k);
  NodeData& d = *n.d;
  const VectorXd& x = xs[static_cast<std::size_t>(k)];
  const VectorXd& u = uOf(k);
  // The Jacobians go to the set of the thread of k's chunk (every pass runs node k on that
  // thread: forNodes, linearizeAndFactor, linearizeProjectAndFactor), read only here (the
  // node holds none of its own) but the inequality Jacobians' non-zero blocks, which the
  // node keeps packed (the condensing of a pass that does not condense at once unpacks
  // them, withDenseJacobians).
  const int thread = chunkOf(k);
  const bool fused = condense_in_linearize;
  if (fused) swapStageHessian(k, d);
  swapSharedJacobians(d, thread);
  try {
    linearizeWithSharedJacobians(k, n, x, u);
  } catch (...) {
    swapSharedJacobians(d, thread);  // the thread's set back, whole
    throw;
  }
  if (fused) {
    swapStageHessian(k, d);  // the stage's Q, R, S hold the cost Hessian: condensed in place
    condenseRows(k, thread);
  } else {
    findJacobianBlocks(k);
  }
  swapSharedJacobians(d, thread);
  packJacobianBlocks(k, thread);
}

void Solver::Impl::linearizeWithSharedJacobians(int k, Node& n, const VectorXd& x,
                                                const VectorXd& u) {
  NodeData& d = *n.d;
  prob->linearize(k, x, u, d);
  n.mode_prev = d.context.mode;
  LqStage& st = lq.stage(k);
  if (k < N) {
    const VectorXd& xn = xs[static_cast<std::size_t>(k) + 1];
    prob->stateSpace().difference(xn, d.xnext, n.defect);
    if (euclid) {
      st.A = d.Fx;
      st.B = d.Fu;
    } else {
      // J1 = blockdiag(J1_b, I) with b = euclideanTangentOffset() (the Euclidean tail
      // differences by subtraction): only the top b rows of A and B mix.
      const int b = prob->stateSpace().euclideanTangentOffset(), m = ndx - b;
      LinearizeScratch& sc = scratchOf(k);
      prob->stateSpace().differenceJacobiansHead(xn, d.xnext, sc.J0.topLeftCorner(b, b),
                                                 sc.J1.topLeftCorner(b, b));
      ocp::smallDepthProduct(st.A.topRows(b), sc.J1.topLeftCorner(b, b), d.Fx.topRows(b), 1.0,
                             false);
      st.A.bottomRows(m) = d.Fx.bottomRows(m);
      ocp::smallDepthProduct(st.B.topRows(b), sc.J1.topLeftCorner(b, b), d.Fu.topRows(b), 1.0,
                             false);
      st.B.bottomRows(m) = d.Fu.bottomRows(m);
    }
    st.b = n.defect;
    // The stage's own copy: the node's is the thread's set, for this linearisation only.
    if (d.ne > 0) {
      st.Ex.topRows(d.ne) = d.Ex.topRows(d.ne);
      st.Eu.topRows(d.ne) = d.Eu.topRows(d.ne);
    }
  }
  rowValues(k, x, u, n);
  if (n.fresh || d.ni != n.ni_prev) {
    initRows(n);
  } else if (reset_slacks) {
    resetSlacks(n);
  }
  n.ni_prev = d.ni;
  n.fresh = false;
  residuals(k, n);
  n.h2_added = false;
  n.delta = 0.0;
  if (use_curvature && n.finite) addCurvature(k, n);
}

/// Sets kind and value c of every row of node k from d (general rows) and (x, u).
void Solver::Impl::rowValues(int k, const VectorXd& x, const VectorXd& u, Node& n) const {
  const NodeData& d = *n.d;
  const bool terminal = (k == N);
  n.kind.setZero();
  for (int i = 0; i < d.ni; ++i) {
    // x_0 is data (fixed by x_init): state-only rows cannot be acted upon at node 0.
    n.kind(i) = (k == 0 && d.state_only(i)) ? kInactive : d.soft(i) ? kSoft : kHard;
    n.c(i) = d.g(i);
  }
  for (int i = d.ni; i < ni_max; ++i) n.c(i) = 0.0;
  const auto& ub = prob->inputBounds();
  const int uk = ub.options.soft ? kSoft : kHard;
  for (int j = 0; j < nbu; ++j) {
    const int lo = ni_max + j, hi = ni_max + nbu + j;
    const double v = terminal ? 0.0 : u(ub.index[static_cast<std::size_t>(j)]);
    n.c(lo) = v - ub.lower(j);
    n.c(hi) = ub.upper(j) - v;
    if (!terminal) {
      if (ub.has_lower[static_cast<std::size_t>(j)]) n.kind(lo) = uk;
      if (ub.has_upper[static_cast<std::size_t>(j)]) n.kind(hi) = uk;
    }
  }
  const auto& xb = prob->stateBounds();
  const int sk = xb.options.soft ? kSoft : kHard;
  for (int j = 0; j < nbx; ++j) {
    const int lo = ni_max + 2 * nbu + j, hi = lo + nbx;
    const double v = x(xb.index[static_cast<std::size_t>(j)] + rep_off);
    n.c(lo) = v - xb.lower(j);
    n.c(hi) = xb.upper(j) - v;
    if (k > 0) {  // x_0 is fixed by the initial state: its bounds cannot be acted upon
      if (xb.has_lower[static_cast<std::size_t>(j)]) n.kind(lo) = sk;
      if (xb.has_upper[static_cast<std::size_t>(j)]) n.kind(hi) = sk;
    }
  }
}

void Solver::Impl::initRows(Node& n) const {
  const double floor = std::max(1e-3, std::sqrt(std::max(mu, 1e-16)));
  for (int i = 0; i < nrows; ++i) {
    if (n.kind(i) == kHard) {
      n.s(i) = std::max(n.c(i), floor);
      n.z(i) = mu / n.s(i);
    } else {
      n.s(i) = 1.0;
      n.z(i) = 0.0;
    }
  }
  n.mult.setZero();
}

/// The slack reset (SolverSettings::slack_reset): a hard row whose value exceeds its slack
/// by more than kSlackResetRatio takes its value as the slack, its dual kept. Both measures
/// of the filter fall (|c - s| and -mu log s), so the iterate stays acceptable. A linear row
/// never needs it (its slack follows its value, c - s shrinking by 1 - alpha per step); a
/// convex one (a keep-out disc) grows faster along a step than the linearisation its slack
/// follows, and the slacks of the solver tests' obstacles lagged their rows' values by
/// factors of 10..1e5, where the fraction to the boundary cut every step.
///
/// The ratio, measured (1597 random starts of the solver tests' problems, iterations;
/// the 220 cold first solves of the Tachyon 3 OCP): without the reset 98513 iterations; any
/// lag (ratio 1) 90020, but the Tachyon 3 solves, whose rows lag their slacks by 1e-16..1e-3
/// after most steps, took 6 % more iterations (83 of 110 longer) and, with every state row
/// soft, 36 of 110 hit the iteration limit; ratio 1.1 90315 with those solves bit for bit
/// unchanged; ratio 2 91702.
void Solver::Impl::resetSlacks(Node& n) const {
  constexpr double kSlackResetRatio = 1.1;
  for (int i = 0; i < nrows; ++i) {
    if (n.kind(i) == kHard && n.c(i) > kSlackResetRatio * n.s(i)) n.s(i) = n.c(i);
  }
}

/// KKT residuals of node k at the current linearisation and multipliers.
void Solver::Impl::residuals(int k, Node& n) {
  const NodeData& d = *n.d;
  const LqStage& st = lq.stage(k);
  // Values are checked here; a non-finite Jacobian or Hessian shows up in the step,
  // which recoverNode checks.
  n.finite = std::isfinite(d.cost) && d.lx.allFinite() && n.c.allFinite();
  double primal = 0.0;
  n.rx = d.lx;
  n.rx -= n.lam;
  if (k < N) {
    n.finite = n.finite && n.defect.allFinite() && d.lu.allFinite() && d.e.head(d.ne).allFinite();
    primal = std::max(primal, n.defect.lpNorm<Eigen::Infinity>());
    if (d.ne > 0) primal = std::max(primal, d.e.head(d.ne).lpNorm<Eigen::Infinity>());
    const VectorXd& lam_next = node(k + 1).lam;
    n.rx.noalias() += st.A.transpose() * lam_next;
    n.ru = d.lu;
    n.ru.noalias() += st.B.transpose() * lam_next;
    if (d.ne > 0) {
      n.rx.noalias() += d.Ex.topRows(d.ne).transpose() * n.mult.head(d.ne);
      n.ru.noalias() += d.Eu.topRows(d.ne).transpose() * n.mult.head(d.ne);
    }
  } else {
    n.ru.setZero();
  }
  // Inequalities: hard rows contribute -z grad c; soft rows their barrier gradient.
  double sz_max = 0.0, sz_min = kInf, msum = n.lam.lpNorm<1>() + n.mult.lpNorm<1>();
  int mcount = ndx + d.ne;
  // Derivative of the Lagrangian w.r.t. the value c_i of inequality row i; hard rows
  // also add to the primal residual, complementarity range and multiplier average.
  double zsum = 0.0;
  int zcount = 0;
  const auto rowCoefficient = [&](int i, double relax) {
    if (n.kind(i) == kInactive) return 0.0;
    if (n.kind(i) == kHard) {
      primal = std::max(primal, std::abs(n.c(i) - n.s(i)));
      const double sz = n.s(i) * n.z(i);
      sz_max = std::max(sz_max, sz);
      sz_min = std::min(sz_min, sz);
      msum += n.z(i);
      ++mcount;
      zsum += n.z(i);
      ++zcount;
      return -n.z(i);
    }
    double d1 = 0.0, d2 = 0.0;
    relaxedLog(n.c(i), relax, d1, d2);
    return softWeight(n, i) * d1;
  };
  for (int i = 0; i < d.ni; ++i) {
    n.tmp(i) = rowCoefficient(i, d.relaxation(i));
  }
  if (d.ni > 0) {
    n.rx.noalias() += d.Gx.topRows(d.ni).transpose() * n.tmp.head(d.ni);
    if (k < N) n.ru.noalias() += d.Gu.topRows(d.ni).transpose() * n.tmp.head(d.ni);
  }
  for (int i = ni_max; i < nrows; ++i) {
    if (n.kind(i) == kInactive) continue;
    const auto [input, lower, idx] = bound_rows[static_cast<std::size_t>(i - ni_max)];
    const double coef = rowCoefficient(i, relaxation(n, i));
    const double g = lower ? coef : -coef;
    if (input) {
      n.ru(idx) += g;
    } else {
      n.rx(idx) += g;
    }
  }
  n.finite = n.finite && n.rx.allFinite() && n.ru.allFinite();
  n.primal = primal;
  n.dual = std::max(n.rx.lpNorm<Eigen::Infinity>(), n.ru.lpNorm<Eigen::Infinity>());
  n.sz_max = sz_max;
  n.sz_min = sz_min;
  n.mult_sum = msum;
  n.mult_count = mcount;
  n.z_sum = zsum;
  n.z_count = zcount;
  n.soft_rows = (n.kind.array() == kSoft).any();
}

/// Constraint part of the Lagrangian gradient at the point evaluated in dd, with the
/// multipliers of the current iterate: [Fx; Fu]^T lam_{k+1} + E^T nu + G^T hcoef.
void Solver::Impl::constraintGradient(int k, const Node& n, const NodeData& dd,
                                      const VectorXd& coef, VectorXd& out) const {
  auto ox = out.head(ndx);
  auto ou = out.segment(ndx, nu);
  out.setZero();
  if (k < N) {
    const VectorXd& lam_next = nodes[static_cast<std::size_t>(k) + 1].lam;
    ox.noalias() += dd.Fx.transpose() * lam_next;
    ou.noalias() += dd.Fu.transpose() * lam_next;
    if (dd.ne > 0) {
      ox.noalias() += dd.Ex.topRows(dd.ne).transpose() * n.mult.head(dd.ne);
      ou.noalias() += dd.Eu.topRows(dd.ne).transpose() * n.mult.head(dd.ne);
    }
  }
  if (dd.ni > 0) {
    ox.noalias() += dd.Gx.topRows(dd.ni).transpose() * coef.head(dd.ni);
    if (k < N) ou.noalias() += dd.Gu.topRows(dd.ni).transpose() * coef.head(dd.ni);
  }
}

/// Adds the curvature the Gauss-Newton Hessian misses to the node's Hessian, so that it
/// becomes the Hessian of the Lagrangian: second derivatives of the dynamics, equalities
/// and general inequalities times their multipliers, and of the costs whose calcDiff
/// Hessian is not exact (the Gauss-Newton Hessian alone converges only linearly when the
/// multipliers are large: swing-up ~900 iterations; with a nonlinear cost residual it
/// stalls). Central differences of the gradient of the terms that have curvature
/// (linearizeCurvatureTerms: linear terms and exact-Hessian costs are not evaluated),
/// minus the Gauss-Newton Hessian of those terms. On manifolds the Hessian of
/// (dx, du) -> L(x (+) dx, u + du) with x_{k+1} held fixed (the cross terms of the
/// difference with x_{k+1} do not fit the stage structure and are left out).
void Solver::Impl::addCurvature(int k, Node& n) {
  NodeData& d = *n.d;
  LinearizeScratch& sc = scratchOf(k);
  for (int i = 0; i < d.ni; ++i) {
    double d1 = 0.0, d2 = 0.0;
    if (n.kind(i) == kSoft) relaxedLog(n.c(i), d.relaxation(i), d1, d2);
    sc.hcoef(i) = n.kind(i) == kHard ? -n.z(i) : n.kind(i) == kSoft ? d.soft_weight(i) * d1 : 0.0;
  }
  const int nv = ndx + (k < N ? nu : 0);
  const VectorXd& x = xs[static_cast<std::size_t>(k)];
  const VectorXd& u = uOf(k);
  for (int j = 0; j < nv; ++j) {
    const bool in_x = j < ndx;
    const double v = in_x ? (euclid ? x(j) : 0.0) : u(j - ndx);
    const double h = 1e-5 * (1.0 + std::abs(v));
    for (int side = 0; side < 2; ++side) {
      VectorXd& g = side == 0 ? sc.hp : sc.hm;
      const double hs = side == 0 ? h : -h;
      sc.up = u;
      if (in_x && !euclid) {
        sc.dxv.setZero();
        sc.dxv(j) = hs;
        prob->stateSpace().integrate(x, sc.dxv, sc.xp);
      } else {
        sc.xp = x;
        (in_x ? sc.xp(j) : sc.up(j - ndx)) = v + hs;
      }
      prob->linearizeCurvatureTerms(k, sc.xp, sc.up, *sc.dp);
      curvatureGradient(k, n, g);
      if (in_x && !euclid) {
        // Pulled back to the tangent at x by the Jacobian of the retraction.
        prob->stateSpace().integrateJacobians(x, sc.dxv, sc.J0, sc.J1);
        sc.dxv.noalias() = sc.J1.transpose() * g.head(ndx);
        g.head(ndx) = sc.dxv;
      }
    }
    n.H2.col(j).head(nv) = (sc.hp.head(nv) - sc.hm.head(nv)) / (2.0 * h);
  }
  // The differenced costs' Gauss-Newton Hessians are already in d: keep the difference.
  prob->linearizeCurvatureTerms(k, x, u, *sc.dp);
  const NodeData& c = *sc.dp;
  n.H2.topLeftCorner(ndx, ndx) -= c.Lxx;
  if (k < N) {
    n.H2.bottomRightCorner(nu, nu) -= c.Luu;
    n.H2.bottomLeftCorner(nu, ndx) -= c.Lux;
    n.H2.topRightCorner(ndx, nu) -= c.Lux.transpose();
  }
  auto H = n.H2.topLeftCorner(nv, nv);
  for (int i = 0; i < nv; ++i) {
    for (int j = 0; j < i; ++j) H(i, j) = H(j, i) = 0.5 * (H(i, j) + H(j, i));
  }
  if (!H.allFinite()) return;
  shiftHessian(k, n, 1.0);
  n.h2_added = true;
}

/// Gradient of the node's Lagrangian (terms with curvature only) at the point evaluated
/// into sc.dp, with the multipliers of the current iterate; on manifolds the dynamics
/// through the difference Jacobian at x_{k+1}.
void Solver::Impl::curvatureGradient(int k, Node& n, VectorXd& g) {
  LinearizeScratch& sc = scratchOf(k);
  NodeData& dp = *sc.dp;
  if (!euclid && k < N) {
    prob->stateSpace().differenceJacobians(xs[static_cast<std::size_t>(k) + 1], dp.xnext, sc.J0,
                                           sc.J1);
    sc.Ap.noalias() = sc.J1 * dp.Fx;
    dp.Fx = sc.Ap;
    sc.Bp.noalias() = sc.J1 * dp.Fu;
    dp.Fu = sc.Bp;
  }
  constraintGradient(k, n, dp, sc.hcoef, g);
  g.head(ndx) += dp.lx;
  if (k < N) g.segment(ndx, nu) += dp.lu;
}

}  // namespace rollstep::solver
