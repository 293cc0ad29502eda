// How is the KKT system reduced and factorised? Each node's barrier terms are condensed
// into its LQ stage and its equality rows projected out (condenseNode), the backward
// Riccati sweep factorises the result (pipelined over the threads), and an Ipopt-style
// inertia correction shifts the Hessian when the exact curvature makes it indefinite.
#include <stdexcept>
#include <utility>

#include "riccati_kernels.hpp"
#include "solver_impl.hpp"

namespace rollstep::solver {

using detail::kHard;
using detail::kInactive;
using detail::relaxedLog;

namespace {

/// a[i] = sum over the n columns of |G(i, c)| for the m rows of the column-major block G
/// (outer stride ld): zero exactly on the rows that are zero (a sum of non-negative terms
/// is zero only if every term is; NaN stays NaN). Down contiguous columns, no branch: it
/// vectorises, where a scan along each row reads one cache line per entry.
void rowAbsSums(const double* G, Eigen::Index ld, int m, Eigen::Index n, double* a) {
  for (int i = 0; i < m; ++i) a[i] = 0.0;
  for (Eigen::Index c = 0; c < n; ++c) {
    const double* g = G + c * ld;
    for (int i = 0; i < m; ++i) a[i] += std::abs(g[i]);
  }
}

/// The columns [first, first + count) of rows [i, i + r) of G between their first and
/// last non-zero column: the terms' rows are sparse (a torque row acts on the base
/// rotation, the leg joints and the contact forces, not on the momentum or the joint
/// velocities; a friction row on the contact forces only).
std::pair<int, int> columnSpan(const MatrixXd& G, int i, int r) {
  const auto zero = [&](int c) {
    // The sum of |entries| down the contiguous segment, without a branch per entry
    // (vectorised); zero only if every entry is (NaN stays NaN).
    const double* g = G.data() + i + c * G.outerStride();
    double a = 0.0;
    for (int j = 0; j < r; ++j) a += std::abs(g[j]);
    return a == 0.0;
  };
  int c0 = 0, c1 = static_cast<int>(G.cols());
  while (c0 < c1 && zero(c0)) ++c0;
  while (c1 > c0 && zero(c1 - 1)) --c1;
  return {c0, c1 - c0};
}

}  // namespace

void Solver::Impl::condenseNode(int k, int thread) {
  withDenseJacobians(k, thread, [this, k, thread] { condenseRows(k, thread); });
  projectNode(k);
}

void Solver::Impl::unpackJacobianBlocks(int k, int thread) {
  const Node& n = node(k);
  const NodeData& d = *n.d;
  SharedDerivatives& sh = shared[static_cast<std::size_t>(thread)];
  const int m = d.ni;
  sh.Gx.topRows(m).setZero();
  sh.Gu.topRows(m).setZero();
  const auto unpack = [](const double* in, const int* blocks, int count, MatrixXd& G) {
    for (int b = 0; b < count; ++b, blocks += 4) {
      const int i = blocks[0], r = blocks[1], a = blocks[2], s = blocks[3];
      for (int c = a; c < a + s; ++c) {
        double* g = G.data() + i + c * G.outerStride();
        for (int j = 0; j < r; ++j) g[j] = in[j];
        in += r;
      }
    }
  };
  unpack(d.Gx.data(), n.gblocks.data(), n.gblocks_x, sh.Gx);
  unpack(d.Gu.data(), n.gblocks.data() + 4 * ni_max, n.gblocks_u, sh.Gu);
}

void Solver::Impl::projectNode(int k) {
  Node& n = node(k);
  n.rank_ok = true;
  n.pivot_ratio = 1.0;
  if (k < N) n.rank_ok = lq.projectStage(k, set.rank_tolerance, &n.pivot_ratio);
}

void Solver::Impl::condenseRows(int k, int thread) {
  Node& n = node(k);
  const NodeData& d = *n.d;
  LqStage& st = lq.stage(k);
  // With one thread, one set of Q, R, S for every stage (shareStageHessians).
  const RiccatiSolver::StageHessian h = lq.hessian(k);
  const bool running = k < N;
  // The Riccati solver reads the lower triangles of Q and R only; whole copies are
  // contiguous (one pass, vectorised) where a triangle is a loop per column. The fused
  // pass evaluated the cost Hessian into Q, R, S already (linearizeNode).
  const bool in_place = condense_in_linearize;
  if (!in_place) h.Q = d.Lxx;
  st.q = d.lx;
  if (running) {
    if (!in_place) {
      h.R = d.Luu;
      h.S = d.Lux;
    }
    st.r = d.lu;
    st.ne = d.ne;
    // Ex and Eu went to the stage in linearizeNode (the node keeps none of its own).
    if (d.ne > 0) st.e.head(d.ne) = d.e.head(d.ne);
  } else {
    st.ne = 0;
  }
  // General rows: Hessian += G^T W G, gradient += G^T gamma.
  for (int i = 0; i < d.ni; ++i) {
    if (n.kind(i) == kHard) {
      n.W(i) = n.z(i) / n.s(i);
      n.gam(i) = hardRowGradient(n, i, n.W(i));
      n.soft_dual(i) = 0.0;
    } else if (n.kind(i) == kInactive) {  // state-only row at node 0
      n.W(i) = 0.0;
      n.gam(i) = 0.0;
      n.soft_dual(i) = 0.0;
    } else {
      double d1 = 0.0, d2 = 0.0;
      relaxedLog(n.c(i), d.relaxation(i), d1, d2);
      n.W(i) = d.soft_weight(i) * d2;
      n.gam(i) = d.soft_weight(i) * d1;
      n.soft_dual(i) = -d.soft_weight(i) * d1;
    }
  }
  n.gblocks_x = n.gblocks_u = 0;
  if (d.ni > 0) {
    const int m = d.ni;
    markRowParts(n, d, running);
    for (int i = 0; i < m; ++i) {
      const int j = d.mirror(i);
      if (j >= 0 && j < i) continue;
      n.Wc(i) = j > i ? n.W(i) + n.W(j) : n.W(i);
      n.gamc(i) = j > i ? n.gam(i) - n.gam(j) : n.gam(i);
    }
    const auto runs = [&n, m](int mask, const auto& f) { forEachRun(n, m, mask, f); };
    // Within a run, only the columns between the first and the last non-zero column of
    // its rows take part (columnSpan).
    // The weighted rows, transposed (W_k G(k, :)^T as column k, in the thread's scratch
    // weighted_gx and weighted_gu), are the left operands of the products: the kernels
    // read them down contiguous columns and the unweighted rows entry by entry.
    const auto W = n.Wc.head(m);
    const int ldtx = static_cast<int>(d.Gx.cols()), ldtu = static_cast<int>(d.Gu.cols());
    // One scratch per thread: it stays in cache from node to node, where one per node
    // would be a fresh 44 kB of the Tachyon 3 OCP at every node.
    double* Tx = weighted_gx[static_cast<std::size_t>(thread)].data();  // ndx x m
    double* Tu = weighted_gu[static_cast<std::size_t>(thread)].data();  // nu x m
    const double* Gx = d.Gx.data();
    const double* Gu = d.Gu.data();
    const Eigen::Index ldx = d.Gx.outerStride(), ldu = d.Gu.outerStride();
    const auto weighted = [&W](double* T, int ld, const double* G, Eigen::Index ldg, int i, int r,
                               int a, int s) {
      for (int row = i; row < i + r; ++row) {
        const double w = W(row);
        double* t = T + row * ld;
        for (int c = a; c < a + s; ++c) t[c] = w * G[row + c * ldg];
      }
    };
    const auto record = [&d](int* out, int& count, int i, int r, int a, int s) {
      recordBlock(d, out, count, i, r, a, s);
    };
    int* blocks_x = n.gblocks.data();
    int* blocks_u = n.gblocks.data() + 4 * ni_max;
    runs(1, [&](int i, int r) {
      const auto [a, s] = columnSpan(d.Gx, i, r);
      record(blocks_x, n.gblocks_x, i, r, a, s);
      weighted(Tx, ldtx, Gx, ldx, i, r, a, s);
      kernels::gemmtLowerAccumulate(s, r, Tx + a + i * ldtx, ldtx, Gx + i + a * ldx, 1, ldx,
                                    h.Q.data() + a + a * h.Q.outerStride(), h.Q.outerStride());
    });
    st.q.noalias() += d.Gx.topRows(m).transpose() * n.gam.head(m);
    runs(2, [&](int i, int r) {
      const auto [a, s] = columnSpan(d.Gu, i, r);
      record(blocks_u, n.gblocks_u, i, r, a, s);
      weighted(Tu, ldtu, Gu, ldu, i, r, a, s);
      kernels::gemmtLowerAccumulate(s, r, Tu + a + i * ldtu, ldtu, Gu + i + a * ldu, 1, ldu,
                                    h.R.data() + a + a * h.R.outerStride(), h.R.outerStride());
      st.r.segment(a, s).noalias() += d.Gu.block(i, a, r, s).transpose() * n.gamc.segment(i, r);
    });
    runs(3, [&](int i, int r) {
      // These rows are within a run of mask 2, whose weighted columns of Tu (a span that
      // holds this one) were written above.
      const auto [a, s] = columnSpan(d.Gx, i, r);
      const auto [b, t] = columnSpan(d.Gu, i, r);
      kernels::gemmAccumulate(t, s, r, Tu + b + i * ldtu, ldtu, Gx + i + a * ldx, 1, ldx,
                              h.S.data() + b + a * h.S.outerStride(), h.S.outerStride());
    });
  }
  // Bounds: diagonal terms only.
  for (int i = ni_max; i < nrows; ++i) {
    if (n.kind(i) == kInactive) continue;
    const auto [input, lower, idx] = bound_rows[static_cast<std::size_t>(i - ni_max)];
    double W = 0.0, gam = 0.0;
    if (n.kind(i) == kHard) {
      W = n.z(i) / n.s(i);
      gam = hardRowGradient(n, i, W);
    } else {
      double d1 = 0.0, d2 = 0.0;
      relaxedLog(n.c(i), relaxation(n, i), d1, d2);
      W = softWeight(n, i) * d2;
      gam = softWeight(n, i) * d1;
      n.soft_dual(i) = -softWeight(n, i) * d1;
    }
    if (input) {
      h.R(idx, idx) += W;
      st.r(idx) += lower ? gam : -gam;
    } else {
      h.Q(idx, idx) += W;
      st.q(idx) += lower ? gam : -gam;
    }
  }
}

void Solver::Impl::markRowParts(Node& n, const NodeData& d, bool running) {
  // A row whose Gx (Gu) is zero adds nothing to Q (R, S): the products run over the
  // contiguous runs of rows with an x (u) part. The terms' rows come in blocks (torque
  // rows act on x and u, friction rows on u only, region rows on x only). Gu is zero on
  // state-only rows, and a node without hard rows has only state-only rows.
  // The two rows of a two-sided limit (NodeData::mirror: Jacobians g and -g) add
  // (W_i + W_j) g g^T: one product with the summed weight on the first row, the second
  // row left out.
  const int m = d.ni;
  rowAbsSums(d.Gx.data(), d.Gx.outerStride(), m, d.Gx.cols(), n.tmp.data());
  for (int i = 0; i < m; ++i) {
    const int j = d.mirror(i);
    if (j >= 0 && j < i) {
      n.row_parts(i) = 0;
      continue;
    }
    const bool on_x = !(n.tmp(i) == 0.0);
    const bool on_u = running && !d.state_only(i);
    n.row_parts(i) = (on_x ? 1 : 0) | (on_u ? 2 : 0);
  }
}

/// The runs of condenseRows (rows with an x part, with a u part) with the second rows of
/// the mirrored pairs (Jacobian -g: the same columns) are the non-zero blocks of Gx and Gu
/// that the node keeps, packed, and recoverNode reads.
void Solver::Impl::recordBlock(const NodeData& d, int* out, int& count, int i, int r, int a,
                               int s) {
  if (s == 0) return;
  const auto add = [&](int row, int rows) {
    int* b = out + 4 * count++;
    b[0] = row;
    b[1] = rows;
    b[2] = a;
    b[3] = s;
  };
  add(i, r);
  for (int q = i; q < i + r;) {
    if (d.mirror(q) <= q) {
      ++q;
      continue;
    }
    int e = q + 1;
    while (e < i + r && d.mirror(e) > e && d.mirror(e) == d.mirror(e - 1) + 1) ++e;
    add(d.mirror(q), e - q);
    q = e;
  }
}

void Solver::Impl::findJacobianBlocks(int k) {
  Node& n = node(k);
  const NodeData& d = *n.d;
  n.gblocks_x = n.gblocks_u = 0;
  const int m = d.ni;
  if (m == 0) return;
  markRowParts(n, d, k < N);
  int* blocks_x = n.gblocks.data();
  int* blocks_u = n.gblocks.data() + 4 * ni_max;
  forEachRun(n, m, 1, [&](int i, int r) {
    const auto [a, s] = columnSpan(d.Gx, i, r);
    recordBlock(d, blocks_x, n.gblocks_x, i, r, a, s);
  });
  forEachRun(n, m, 2, [&](int i, int r) {
    const auto [a, s] = columnSpan(d.Gu, i, r);
    recordBlock(d, blocks_u, n.gblocks_u, i, r, a, s);
  });
}

void Solver::Impl::packJacobianBlocks(int k, int thread) {
  Node& n = node(k);
  const auto pack = [](const MatrixXd& G, const int* blocks, int count, double* out) {
    for (int b = 0; b < count; ++b, blocks += 4) {
      const int i = blocks[0], r = blocks[1], a = blocks[2], s = blocks[3];
      for (int c = a; c < a + s; ++c) {
        const double* g = G.data() + i + c * G.outerStride();
        for (int j = 0; j < r; ++j) out[j] = g[j];
        out += r;
      }
    }
  };
  // The storage holds ni_max rows of the columns the inequality terms declare
  // (Residual::stateColumns, inputColumns): every block must lie within them (the blocks
  // hold each row at most once).
  const auto check = [this, k](const int* blocks, int count, ocp::ColumnRange cols,
                               const char* which) {
    for (int b = 0; b < count; ++b, blocks += 4) {
      if (blocks[2] < cols.first || blocks[2] + blocks[3] > cols.first + cols.count) {
        ROLLSTEP_MSG(
            "node %d: %s of inequality rows %d..%d is non-zero in columns %d..%d, "
            "outside the columns %d..%d the inequality terms declare "
            "(Residual::%s)",
            k, which, blocks[0], blocks[0] + blocks[1] - 1, blocks[2], blocks[2] + blocks[3] - 1,
            cols.first, cols.first + cols.count - 1,
            which[1] == 'x' ? "stateColumns" : "inputColumns");
        throw std::logic_error(message);
      }
    }
  };
  check(n.gblocks.data(), n.gblocks_x, gx_columns, "Gx");
  check(n.gblocks.data() + 4 * ni_max, n.gblocks_u, gu_columns, "Gu");
  const SharedDerivatives& sh = shared[static_cast<std::size_t>(thread)];
  pack(sh.Gx, n.gblocks.data(), n.gblocks_x, n.d->Gx.data());
  pack(sh.Gu, n.gblocks.data() + 4 * ni_max, n.gblocks_u, n.d->Gu.data());
}

/// The gradient part of condenseNode alone, for a new complementarity target (Mehrotra's
/// corrector) or new constraint values c of the hard rows (second-order corrections) with
/// the same Hessian: st.q and st.r of node k. Soft general rows keep the gradient
/// condenseRows gave them; soft bounds are condensed from c again.
void Solver::Impl::condenseGradient(int k) {
  withDenseJacobians(k, chunkOf(k), [this, k] { condenseGradientDense(k); });
}

void Solver::Impl::condenseGradientDense(int k) {
  Node& n = node(k);
  const NodeData& d = *n.d;
  LqStage& st = lq.stage(k);
  const bool running = k < N;
  st.q = d.lx;
  if (running) st.r = d.lu;
  for (int i = 0; i < d.ni; ++i) {
    if (n.kind(i) == kHard) n.gam(i) = hardRowGradient(n, i, n.W(i));
  }
  if (d.ni > 0) {
    st.q.noalias() += d.Gx.topRows(d.ni).transpose() * n.gam.head(d.ni);
    if (running) st.r.noalias() += d.Gu.topRows(d.ni).transpose() * n.gam.head(d.ni);
  }
  for (int i = ni_max; i < nrows; ++i) {
    if (n.kind(i) == kInactive) continue;
    const auto [input, lower, idx] = bound_rows[static_cast<std::size_t>(i - ni_max)];
    double gam = 0.0;
    if (n.kind(i) == kHard) {
      gam = hardRowGradient(n, i, n.z(i) / n.s(i));
    } else {
      double d1 = 0.0, d2 = 0.0;
      relaxedLog(n.c(i), relaxation(n, i), d1, d2);
      gam = softWeight(n, i) * d1;
    }
    (input ? st.r(idx) : st.q(idx)) += lower ? gam : -gam;
  }
}

void Solver::Impl::sweepStage(int k, int& rank_failed, bool& pd) {
  if (!node(k).rank_ok) rank_failed = k;
  if (rank_failed < 0 && pd) pd = lq.backwardStage(k);
}

template <class Prepare>
Solver::Impl::Factorization Solver::Impl::sweepSerially(Prepare prepare) {
  int rank_failed = -1;
  bool pd = true;
  prepare(N);
  lq.beginBackward();
  for (int k = N - 1; k >= 0; --k) {
    prepare(k);
    sweepStage(k, rank_failed, pd);
  }
  return sweepResult(rank_failed, pd);
}

/// Condensing + projection of every node and the backward Riccati sweep. With one
/// thread, node k is condensed right before its backward step (its data still in
/// cache). With more, a pipeline: every thread condenses the nodes it linearised (its
/// chunk, from the top down), then helps with the highest chunks left, while thread 0
/// runs the backward sweep as soon as its next node is ready (condensing a node itself
/// when it would otherwise wait). Each node is
/// condensed by the same arithmetic whichever thread takes it, and the sweep runs in
/// one order, so the results do not depend on the thread count. On a rank failure,
/// failed_node is the first such node.
Solver::Impl::Factorization Solver::Impl::condenseAndFactor() {
  // Nodes factorised by the linearisation are not factorised again (once: the inertia
  // correction shifts the Hessian and condenses again).
  if (std::exchange(condensed_early, false)) return early_factorization;
  if (pool.size() == 1) return sweepSerially([this](int k) { condenseNode(k, 0); });
  int rank_failed = -1;
  bool pd = true;
  const std::uint64_t run = ++pipeline_run;
  for (int t = 0; t < pool.size(); ++t) {
    chunk_next[static_cast<std::size_t>(t)].next.store(chunkBegin(t + 1) - 1,
                                                       std::memory_order_relaxed);
  }
  const auto condenseNext = [this, run](int id) {
    const int j = claimNode(id, true);
    if (j < 0) return false;
    condenseNode(j, id);
    ready[static_cast<std::size_t>(j)].store(run, std::memory_order_release);
    return true;
  };
  const auto waitFor = [this, run, &condenseNext](int k) {
    for (int i = 1; ready[static_cast<std::size_t>(k)].load(std::memory_order_acquire) != run;
         ++i) {
      if (!condenseNext(0)) detail::ThreadPool::pause(i);
    }
  };
  auto body = [&](int id, int) {
    if (id > 0) {
      while (condenseNext(id)) {
      }
      return;
    }
    waitFor(N);
    lq.beginBackward();
    for (int k = N - 1; k >= 0; --k) {
      waitFor(k);
      sweepStage(k, rank_failed, pd);
    }
  };
  pool.run(pool.size(), body);
  return sweepResult(rank_failed, pd);
}

Solver::Impl::Factorization Solver::Impl::sweepResult(int rank_failed, bool pd) {
  if (rank_failed >= 0) {
    failed_node = rank_failed;
    return Factorization::RankDeficient;
  }
  return pd ? Factorization::Ok : Factorization::NotPositiveDefinite;
}

/// From the last node down, each node's linearisation (which condenses it), projection
/// and backward step, while its derivatives and LQ stage are in cache: where linearize
/// then condenseAndFactor write a node's stage in one pass and read it cold in the next.
/// The nodes are evaluated in the opposite order, each by the same arithmetic (their
/// shared workspaces are filled at the start of every evaluation), and the sweep is the
/// one condenseAndFactor runs.
Solver::Impl::Factorization Solver::Impl::linearizeAndFactor() {
  return sweepSerially([this](int k) {
    // The stage's A, B, Ex, Eu: the shared set, for the linearisation and the projection.
    if (k < N) swapSharedStageJacobians(k);
    linearizeNode(k);
    projectNode(k);
    if (k < N) swapSharedStageJacobians(k);
  });
}

/// Each thread linearises, condenses and projects the nodes of its chunk (the partition of
/// forNodes), the node's derivatives and LQ stage still in its cache, where a pass per
/// phase would read them cold. Then the backward sweep, handed down from chunk to chunk:
/// the last chunk's thread starts it at node N, each other thread takes it over at the
/// top of its own chunk (the projected stages it just wrote) when it arrives there and
/// hands it on at the bottom. The chunks shrink towards N (partitionNodes) so that the
/// sweep of the upper chunks runs while the lower ones are still being linearised. The
/// same arithmetic per node and the same sweep as linearize then condenseAndFactor.
Solver::Impl::Factorization Solver::Impl::linearizeProjectAndFactor() {
  int rank_failed = -1;
  bool pd = true;
  sweep_at.store(N + 1, std::memory_order_relaxed);
  sweep_abort.store(false, std::memory_order_relaxed);
  auto body = [&](int t, int) {
    const int lo = chunkBegin(t), hi = chunkBegin(t + 1);
    try {
      for (int k = lo; k < hi; ++k) {
        linearizeNode(k);
        projectNode(k);
      }
    } catch (...) {
      sweep_abort.store(true);  // the threads below would wait for this chunk forever
      throw;
    }
    for (int i = 1; sweep_at.load(std::memory_order_acquire) != hi; ++i) {
      if (sweep_abort.load()) return;
      detail::ThreadPool::pause(i);
    }
    for (int k = hi - 1; k >= lo; --k) {
      if (k == N) {
        lq.beginBackward();
      } else {
        sweepStage(k, rank_failed, pd);
      }
    }
    sweep_at.store(lo, std::memory_order_release);
  };
  pool.run(pool.size(), body);
  return sweepResult(rank_failed, pd);
}

/// Inertia correction (Ipopt), in every mode: when the factorisation failed or needed
/// regularisation, the reduced Hessian is not positive definite (an exact Hessian with
/// negative curvature, a non-convex cost): delta I is added to the Hessian, delta grown
/// until the Riccati factorisation succeeds unregularised. If even a large shift fails
/// and the curvature was added, Gauss-Newton as a last resort. Returns whether the KKT
/// system is factorised; `shifted` tells whether a shift was needed.
bool Solver::Impl::correctInertia(bool factored, bool& shifted) {
  shifted = false;
  if (factored && lq.regularization() == 0.0) {
    last_delta = 0.0;
    return true;
  }
  shifted = true;
  // The shift is added to the nodes' own Hessians, which the fused pass left stale.
  if (std::exchange(derivatives_shared, false)) forNodes([this](int k) { linearizeNode(k); });
  double delta = last_delta > 0.0 ? std::max(1e-8, last_delta / 3.0) : 1e-4;
  delta = std::max(delta, 2.0 * prox);
  factored = false;
  // The equality rows are those that passed condenseAndFactor's rank test before: only
  // the Hessian changes here.
  for (int attempt = 0; attempt < 12 && !factored; ++attempt) {
    forNodes([this, delta](int k) { shiftDiagonal(k, node(k), delta); });
    factored = condenseAndFactor() == Factorization::Ok && lq.regularization() == 0.0;
    if (!factored) delta *= last_delta > 0.0 ? 8.0 : 100.0;
  }
  last_delta = factored ? delta : 0.0;
  if (!factored && use_curvature) {
    forNodes([this](int k) {
      Node& n = node(k);
      shiftDiagonal(k, n, 0.0);
      if (n.h2_added) shiftHessian(k, n, -1.0);
      n.h2_added = false;
    });
    factored = condenseAndFactor() == Factorization::Ok;
  }
  return factored;
}

}  // namespace rollstep::solver
