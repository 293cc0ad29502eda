// How is the step found? The Newton direction of the barrier problem: condensing and the
// backward sweep with inertia correction (condensing.cpp), then the forward sweep and, per
// node, the slack and dual steps with their fraction-to-boundary step lengths.
#include <algorithm>
#include <cmath>

#include "solver_impl.hpp"

namespace rollstep::solver {

using detail::kHard;
using detail::kInactive;
using detail::kSoft;
using detail::msSince;
using detail::relaxedLog;

/// The search direction at the current linearisation (dir: step lengths and slope).
/// Returns false when the solve ends here (status set): rank-deficient equalities, a
/// Hessian that is not positive definite, a non-finite direction.
bool Solver::Impl::searchDirection(bool realtime, double primal, IterationStats& it,
                                   Direction& dir) {
  auto t_ric = Clock::now();
  // Mehrotra: the predictor aims at complementarity 0 (affine scaling).
  target_mu = pc_active ? 0.0 : mu;
  corrector = false;
  // Converging mode after short steps: the proximal shift (line_search.cpp).
  if (prox > 0.0 && !realtime) forNodes([this](int k) { shiftDiagonal(k, node(k), prox); });
  const Factorization fac = condenseAndFactor();
  if (fac == Factorization::RankDeficient) {
    const int k = failed_node;
    it.time_riccati_ms = msSince(t_ric);
    stats.push_back(it);
    std::snprintf(message, sizeof(message),
                  "equality rows of node %d are not full row rank in u (relative pivot %.3g, "
                  "%d rows, %d inputs)",
                  k, node(k).pivot_ratio, node(k).d->ne, nu);
    status = SolverStatus::RankDeficientEqualities;
    return false;
  }
  bool shifted = false;
  const bool factored = correctInertia(fac == Factorization::Ok, shifted);
  it.inertia_shift = shifted ? last_delta : 0.0;
  if (!factored) {
    direction_ready = false;
    failed_node = lq.failedStage();
    stats.push_back(it);
    if (!realtime && dualsBlewUp(primal)) {
      ROLLSTEP_MSG("locally infeasible: the duals blew up (> %.3g) with the violation at %.3g",
                   kDualBlowUp, primal);
      status = SolverStatus::Infeasible;
      return false;
    }
    std::snprintf(message, sizeof(message),
                  "the reduced Hessian of node %d is not positive definite", failed_node);
    status = SolverStatus::Diverged;
    return false;
  }
  if (pc_active && shifted) {
    // Not convex: the predictor-corrector is for convex QPs; the monotone barrier and the
    // line search from here on, this direction re-solved for the barrier mu.
    pc_active = false;
    target_mu = mu;
    forNodes([this](int k) { condenseGradient(k); });
    lq.resolveVectors(dx0);
  }
  forwardAndRecover();
  if (pc_active) predictorCorrector();
  direction_ready = true;
  double ap = 1.0, ad = 1.0, dphi = 0.0, step_rel = 0.0;
  bool finite = true;
  for (int k = 0; k <= N; ++k) {
    const Node& n = node(k);
    finite = finite && n.finite;
    ap = std::min(ap, n.alpha_p);
    ad = std::min(ad, n.alpha_d);
    dphi += n.dphi;
    step_rel = std::max(step_rel, n.step_rel);
  }
  dir.tiny = step_rel < 10.0 * std::numeric_limits<double>::epsilon();
  it.time_riccati_ms = msSince(t_ric);
  if (!finite) {
    const bool infeasible = !realtime && dualsBlewUp(primal);
    if (backup_valid) restore();
    stats.push_back(it);
    if (infeasible) {
      ROLLSTEP_MSG("locally infeasible: the duals blew up (> %.3g) with the violation at %.3g",
                   kDualBlowUp, primal);
      status = SolverStatus::Infeasible;
      return false;
    }
    ROLLSTEP_MSG("non-finite search direction; the last good iterate was kept");
    status = SolverStatus::Diverged;
    return false;
  }
  dir.alpha_p = ap;
  dir.alpha_d = ad;
  dir.dphi = dphi;
  return true;
}

/// Mehrotra's corrector, after the predictor (the affine-scaling direction, target 0) is in
/// the nodes: its step lengths give the complementarity mu_aff it would reach, the barrier
/// becomes sigma mu with sigma = (mu_aff / mu)^3 (mu = s^T z / m), and the direction is
/// re-solved through the same factorisation for the target sigma mu - ds_aff dz_aff.
void Solver::Impl::predictorCorrector() {
  double ap = 1.0, ad = 1.0, sz = 0.0;
  int m = 0;
  for (int k = 0; k <= N; ++k) {
    const Node& n = node(k);
    ap = std::min(ap, n.alpha_p);
    ad = std::min(ad, n.alpha_d);
    for (int i = 0; i < nrows; ++i) {
      if (n.kind(i) != kHard) continue;
      sz += n.s(i) * n.z(i);
      ++m;
    }
  }
  if (m == 0) return;  // no inequalities: the predictor is the Newton step
  double sz_aff = 0.0;
  for (int k = 0; k <= N; ++k) {
    Node& n = node(k);
    for (int i = 0; i < nrows; ++i) {
      if (n.kind(i) != kHard) continue;
      sz_aff += (n.s(i) + ap * n.ds(i)) * (n.z(i) + ad * n.dz(i));
    }
    n.ds_aff = n.ds;
    n.dz_aff = n.dz;
  }
  const double mu_now = sz / m;
  const double sigma = std::min(1.0, std::pow(std::max(sz_aff, 0.0) / sz, 3));
  mu = std::max(sigma * mu_now, 0.1 * set.barrier_min);
  target_mu = mu;
  corrector = true;
  forNodes([this](int k) { condenseGradient(k); });
  lq.resolveVectors(dx0);
  forNodes([this](int k) { recoverNode(k); });
  corrector = false;
}

/// Forward Riccati sweep and the step recovery of every node: fused per node with one
/// thread; with more, thread 0 runs the forward sweep while the others recover the
/// nodes of their own chunk as soon as their forward stage is done, then help with the
/// lowest chunks left (thread 0 joins after the sweep, its own chunk first).
void Solver::Impl::forwardAndRecover() {
  if (pool.size() == 1) {
    lq.beginForward(dx0);
    for (int k = 0; k < N; ++k) {
      lq.forwardStage(k);
      recoverNode(k);
    }
    recoverNode(N);
    return;
  }
  for (int t = 0; t < pool.size(); ++t) {
    chunk_next[static_cast<std::size_t>(t)].next.store(chunkBegin(t), std::memory_order_relaxed);
  }
  forward_done.store(0, std::memory_order_relaxed);
  // recoverNode(j) needs forwardStage(j) (j < N), or the whole sweep (j = N).
  const auto recoverClaimed = [this](int id) {
    const int j = claimNode(id, false);
    if (j < 0) return false;
    const int needed = std::min(j + 1, N);
    for (int i = 1; forward_done.load(std::memory_order_acquire) < needed; ++i) {
      detail::ThreadPool::pause(i);
    }
    recoverNode(j);
    return true;
  };
  auto body = [&](int id, int) {
    if (id == 0) {
      lq.beginForward(dx0);
      for (int k = 0; k < N; ++k) {
        lq.forwardStage(k);
        forward_done.store(k + 1, std::memory_order_release);
      }
    }
    while (recoverClaimed(id)) {
    }
  };
  pool.run(pool.size(), body);
}

namespace {

/// t[i] += sum over the block's columns c of G(i, c) v(c) for its rows i (block: first row,
/// rows, first column, columns), each row summed over the columns in order from zero and
/// then added to t[i], as Eigen's column-major matrix-vector product of all the rows
/// [0, fused_rows + 1) does: with multiply-adds (packets of rows), except for the last row of
/// an odd count (rows >= fused_rows), which it sums with separate products and sums.
/// g: the block's first entry, ld: its column stride (the matrix's, or its rows when packed).
void blockTimes(const double* g, Eigen::Index ld, const int* block, const double* v, double* t,
                int fused_rows) {
  namespace ei = Eigen::internal;
  using Packet = ei::packet_traits<double>::type;
  constexpr int P = ei::packet_traits<double>::size;
  const int i0 = block[0], r = block[1], c0 = block[2], s = block[3];
  const double* x = v + c0;
  double* out = t + i0;
  const int rf = std::min(r, std::max(fused_rows - i0, 0));  // rows [0, rf) fused
  int i = 0;
  for (; i + P <= rf; i += P) {
    Packet acc = ei::pset1<Packet>(0.0);
    for (int c = 0; c < s; ++c) {
      acc = ei::pmadd(ei::ploadu<Packet>(g + i + c * ld), ei::pset1<Packet>(x[c]), acc);
    }
    ei::pstoreu(out + i, ei::padd(ei::ploadu<Packet>(out + i), acc));
  }
  for (; i < rf; ++i) {
    double acc = 0.0;
#ifdef __FMA__
    for (int c = 0; c < s; ++c) acc = std::fma(g[i + c * ld], x[c], acc);
#else
    for (int c = 0; c < s; ++c) acc = acc + g[i + c * ld] * x[c];
#endif
    out[i] += acc;
  }
  for (; i < r; ++i) {
    double acc = 0.0;
    for (int c = 0; c < s; ++c) {
      const double p = g[i + c * ld] * x[c];
      acc = acc + p;
    }
    out[i] += acc;
  }
}

}  // namespace

void Solver::Impl::recoverNode(int k) {
  Node& n = node(k);
  const NodeData& d = *n.d;
  lq.recoverStage(k);
  const VectorXd& dx = lq.dx(k);
  const bool running = k < N;
  const VectorXd& du = running ? lq.du(k) : zero_u;
  double dphi = d.lx.dot(dx) + (running ? d.lu.dot(du) : 0.0);
  if (d.ni > 0) {
    // t = Gx dx + Gu du over the non-zero blocks only (condenseRows): the rest of Gx and
    // Gu, mostly zero, is not read (cold memory). Each row is summed as Eigen's product
    // sums it (over the columns in order, from zero, Gx then Gu): the zero terms left out
    // add exactly zero, so the result is the same.
    double* t = n.tmp.data();
    for (int i = 0; i < d.ni; ++i) t[i] = 0.0;
    const int fused_rows = d.ni - d.ni % 2;
    // The blocks packed one after the other (Node::gblocks).
    const auto times = [t, fused_rows](const MatrixXd& G, const int* blocks, int count,
                                       const VectorXd& v) {
      const double* packed = G.data();
      for (int b = 0; b < count; ++b, blocks += 4) {
        const int r = blocks[1];
        blockTimes(packed, r, blocks, v.data(), t, fused_rows);
        packed += r * blocks[3];
      }
    };
    times(d.Gx, n.gblocks.data(), n.gblocks_x, dx);
    if (running) times(d.Gu, n.gblocks.data() + 4 * ni_max, n.gblocks_u, du);
  }
  const double tau = set.fraction_to_boundary;
  double ap = 1.0, ad = 1.0, zmax = 0.0;
  for (int i = 0; i < nrows; ++i) {
    if (n.kind(i) == kInactive) {
      n.ds(i) = 0.0;
      n.dz(i) = 0.0;
      continue;
    }
    double gdv = 0.0;
    if (i < ni_max) {
      gdv = n.tmp(i);
    } else {
      const auto [input, lower, idx] = bound_rows[static_cast<std::size_t>(i - ni_max)];
      gdv = input ? du(idx) : dx(idx);
      if (!lower) gdv = -gdv;
    }
    if (n.kind(i) == kSoft) {
      double d1 = 0.0, d2 = 0.0;
      relaxedLog(n.c(i), relaxation(n, i), d1, d2);
      dphi += softWeight(n, i) * d1 * gdv;
      n.ds(i) = 0.0;
      n.dz(i) = 0.0;
      continue;
    }
    const double s = n.s(i), z = n.z(i);
    const double ds = gdv + (n.c(i) - s);
    const double dz = target(n, i) / s - z - (z / s) * ds;
    n.ds(i) = ds;
    n.dz(i) = dz;
    dphi -= mu / s * ds;
    if (ds < 0.0) ap = std::min(ap, -tau * s / ds);
    if (dz < 0.0) ad = std::min(ad, -tau * z / dz);
    zmax = std::max(zmax, std::abs(z + dz));
  }
  n.alpha_p = ap;
  n.alpha_d = ad;
  n.dphi = dphi;
  n.zmax = zmax;
  // Step size relative to the iterate (Ipopt's tiny-step test).
  const VectorXd& x = xs[static_cast<std::size_t>(k)];
  n.step_rel = dx.lpNorm<Eigen::Infinity>() / (1.0 + x.lpNorm<Eigen::Infinity>());
  if (running) {
    const VectorXd& u = us[static_cast<std::size_t>(k)];
    n.step_rel =
        std::max(n.step_rel, du.lpNorm<Eigen::Infinity>() / (1.0 + u.lpNorm<Eigen::Infinity>()));
  }
  n.finite = std::isfinite(dphi) && dx.allFinite() && du.allFinite() && n.ds.allFinite() &&
             n.dz.allFinite() && lq.costate(k).allFinite() &&
             (!running || lq.equalityMultipliers(k).allFinite());
}

}  // namespace rollstep::solver
