// What memory does the solver hold? Dimensions first, then every workspace sized from
// them at construction (nodes, trajectories, Riccati stages, thread pool, filter), so
// that solve() and update() only touch memory that already exists.
#include <stdexcept>

#include "solver_impl.hpp"

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace rollstep::solver {

namespace {

#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
constexpr bool kSanitizer = true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer)
constexpr bool kSanitizer = true;
#else
constexpr bool kSanitizer = false;
#endif
#else
constexpr bool kSanitizer = false;
#endif

/// SolverSettings::huge_pages: asks Linux to back the 2 MB-aligned cover of [lo, hi) with
/// transparent huge pages, and with `collapse` to collapse the pages already there now
/// (MADV_COLLAPSE, Linux 6.1; older kernels ignore it). The collapse is only for a solver
/// built for real-time iterations: it can take seconds on a busy machine, in the kernel,
/// where a signal waits for it (a converging solve, as `rollstep plan` runs, must end within
/// a second of Ctrl-C); without it the kernel's background thread collapses them later. Advice
/// only: the memory's contents never change, and every failure leaves things as they were. Skipped
/// for spans under 4 MB (few TLB entries anyway) or over 1 GB (not one heap region), and in
/// sanitizer builds (whose allocators spread small blocks over large sparse regions that a collapse
/// would fill).
void adviseHugePages(std::uintptr_t lo, std::uintptr_t hi, bool collapse) {
#if defined(__linux__) && defined(MADV_HUGEPAGE)
  constexpr std::uintptr_t kHuge = std::uintptr_t{1} << 21;
  if (kSanitizer || hi <= lo || hi - lo < 2 * kHuge || hi - lo > (std::uintptr_t{1} << 30)) {
    return;
  }
  lo &= ~(kHuge - 1);
  hi = (hi + kHuge - 1) & ~(kHuge - 1);
  void* p = reinterpret_cast<void*>(lo);
  const std::size_t len = hi - lo;
  if (madvise(p, len, MADV_HUGEPAGE) != 0 || !collapse) return;
#ifdef MADV_COLLAPSE
  (void)madvise(p, len, MADV_COLLAPSE);
#else
  (void)madvise(p, len, 25);  // MADV_COLLAPSE, headers older than Linux 6.1
#endif
#else
  (void)lo;
  (void)hi;
  (void)collapse;
#endif
}

}  // namespace

Solver::Impl::Impl(std::shared_ptr<ocp::OptimalControlProblem> p, SolverSettings s)
    : prob(std::move(p)),
      set(s),
      N(prob->horizon()),
      nx(prob->nx()),
      ndx(prob->ndx()),
      nu(prob->nu()),
      ne_max(prob->maxEqualities()),
      ni_max(prob->maxInequalities()),
      nbu(prob->inputBounds().size()),
      nbx(prob->stateBounds().size()),
      nrows(ni_max + 2 * nbu + 2 * nbx),
      rep_off(nx - ndx),
      euclid(prob->stateSpace().isEuclidean()),
      lq(N, ndx, nu, ne_max),
      pool(s.num_threads, std::chrono::microseconds(s.thread_spin_us)),
      ready(new std::atomic<std::uint64_t>[static_cast<std::size_t>(N) + 1]),
      chunk_next(new ChunkCounter[static_cast<std::size_t>(pool.size())]) {
  has_curvature = prob->hasCurvature();
  // One thread condenses, projects and factorises each stage in turn (condenseAndFactor,
  // linearizeAndFactor).
  lq.shareReducedHessian(pool.size() == 1);
  lq.shareStageHessians(pool.size() == 1);
  for (int k = 0; k <= N; ++k) ready[static_cast<std::size_t>(k)].store(0);
  partitionNodes();
  nodes.resize(static_cast<std::size_t>(N) + 1);
  for (int i = ni_max; i < nrows; ++i) {
    bound_rows.push_back(
        detail::boundRow(i, ni_max, nbu, nbx, prob->inputBounds(), prob->stateBounds()));
  }
  // Of the inequality Jacobians the nodes keep the non-zero blocks, packed
  // (packJacobianBlocks): at most ni_max rows of the columns the terms can be non-zero in
  // (for the Tachyon 3 OCP the configuration's 18 of 24 state columns and the contact
  // forces' 18 of 30 input columns: 29 kB per node instead of 44 kB).
  {
    const auto hull = [](ocp::ColumnRange& h, ocp::ColumnRange c) {
      if (c.count <= 0) return;
      const int end =
          h.count > 0 ? std::max(h.first + h.count, c.first + c.count) : c.first + c.count;
      h.first = h.count > 0 ? std::min(h.first, c.first) : c.first;
      h.count = end - h.first;
    };
    gx_columns = gu_columns = ocp::ColumnRange{};
    for (std::size_t j = 0; j < prob->inequalityNames().size(); ++j) {
      const ocp::Residual& r = prob->inequality(j);
      const ocp::ColumnRange cx = r.stateColumns(), cu = r.inputColumns();
      if (cx.first < 0 || cx.count < 0 || cx.first + cx.count > ndx || cu.first < 0 ||
          cu.count < 0 || cu.first + cu.count > nu) {
        throw std::invalid_argument("Solver: inequality '" + prob->inequalityNames()[j] +
                                    "' declares Jacobian columns outside the state's tangent "
                                    "or the input");
      }
      hull(gx_columns, cx);
      hull(gu_columns, cu);
    }
  }
  // The dynamics and equality Jacobians are read only while the node is linearised (the
  // stage keeps A, B, Ex and Eu): every linearisation evaluates them into the thread's set
  // (the real-time pass's derivatives, per thread, in the first node's shapes), and the
  // nodes' own (25 kB per node of the Tachyon 3 OCP) are released, as are their dense
  // inequality Jacobians, each node's right after it is created (the next one reuses the
  // memory: the process never holds them all at once).
  const auto releaseDenseJacobians = [this](NodeData& d) {
    if (shared.empty()) {
      shared.assign(static_cast<std::size_t>(pool.size()),
                    SharedDerivatives{d.Fx, d.Fu, d.Ex, d.Eu, d.Gx, d.Gu});
    }
    for (MatrixXd* m : {&d.Fx, &d.Fu, &d.Ex, &d.Eu}) *m = MatrixXd();
    d.Gx = MatrixXd::Zero(static_cast<Eigen::Index>(ni_max) * gx_columns.count, 1);
    d.Gu = MatrixXd::Zero(static_cast<Eigen::Index>(ni_max) * gu_columns.count, 1);
  };
  // The nodes of one thread's chunk (forNodes' static partition) are evaluated one after
  // the other and share their terms' workspaces and precomputation cache: one set stays
  // in cache from node to node, where one per node is cold memory at every node.
  for (int t = 0; t < pool.size(); ++t) {
    const int first = chunkBegin(t);
    for (int k = first; k < chunkBegin(t + 1); ++k) {
      node(k).d = k == first ? prob->createNodeData()
                             : prob->createNodeDataSharingWorkspaces(*node(first).d);
      releaseDenseJacobians(*node(k).d);
    }
  }
  for (auto& n : nodes) {
    for (VectorXd* v :
         {&n.s, &n.z, &n.ds, &n.dz, &n.c, &n.s_bak, &n.z_bak, &n.s_trial, &n.ds_aff, &n.dz_aff}) {
      *v = VectorXd::Zero(nrows);
    }
    n.kind = Eigen::VectorXi::Zero(nrows);
    n.lam = VectorXd::Zero(ndx);
    n.lam_bak = VectorXd::Zero(ndx);
    n.mult = VectorXd::Zero(ne_max);
    n.mult_bak = VectorXd::Zero(ne_max);
    n.defect = VectorXd::Zero(ndx);
    n.c_it = VectorXd::Zero(nrows);
    n.soc_rows = VectorXd::Zero(nrows);
    n.defect_it = VectorXd::Zero(ndx);
    n.soc_defect = VectorXd::Zero(ndx);
    n.e_it = VectorXd::Zero(ne_max);
    n.soc_e = VectorXd::Zero(ne_max);
    n.rx = VectorXd::Zero(ndx);
    n.ru = VectorXd::Zero(nu);
    n.tmp = VectorXd::Zero(std::max(ni_max, 1));
    n.row_parts = Eigen::VectorXi::Zero(ni_max);
    n.W = VectorXd::Zero(ni_max);
    n.Wc = VectorXd::Zero(ni_max);
    n.gamc = VectorXd::Zero(ni_max);
    n.gam = VectorXd::Zero(ni_max);
    n.soft_dual = VectorXd::Zero(nrows);
    n.gblocks = Eigen::VectorXi::Zero(8 * std::max(ni_max, 1));
  }
  lin_scratch.resize(static_cast<std::size_t>(pool.size()));
  for (auto& sc : lin_scratch) {
    sc.J0 = MatrixXd::Zero(ndx, ndx);
    sc.J1 = MatrixXd::Zero(ndx, ndx);
  }
  weighted_gx.assign(static_cast<std::size_t>(pool.size()), MatrixXd::Zero(ndx, ni_max));
  weighted_gu.assign(static_cast<std::size_t>(pool.size()), MatrixXd::Zero(nu, ni_max));
  if (pool.size() == 1) {  // linearizeAndFactor's shared stage Jacobians (same shapes)
    shared_A = lq.stage(0).A;
    shared_B = lq.stage(0).B;
    shared_stage_Ex = lq.stage(0).Ex;
    shared_stage_Eu = lq.stage(0).Eu;
  }
  xs.assign(static_cast<std::size_t>(N) + 1, VectorXd::Zero(nx));
  for (auto& x : xs) prob->stateSpace().neutral(x);
  us.assign(static_cast<std::size_t>(N), VectorXd::Zero(nu));
  xs_bak = xs_trial = xs;
  us_bak = us_trial = us;
  x0 = VectorXd::Zero(nx);
  dx0 = VectorXd::Zero(ndx);
  dx0_it = VectorXd::Zero(ndx);
  dx0_soc = VectorXd::Zero(ndx);
  zero_u = VectorXd::Zero(nu);
  gains.assign(static_cast<std::size_t>(N), MatrixXd::Zero(nu, ndx));
  gains_valid.assign(static_cast<std::size_t>(N), false);
  stats.reserve(static_cast<std::size_t>(std::max(set.max_iterations, 1)) + 2);
  filter.reserve(static_cast<std::size_t>(std::max(set.max_iterations, 1)) + 2);
  scaled.assign(static_cast<std::size_t>(N) + 1, VectorXd::Zero(ndx));
  if (set.huge_pages) adviseHugePagesForNodes(set.mode == SolverMode::RealTime);
  // After all that an iteration touches, outside the span advised to huge pages.
  if (needsCurvature(set)) reserveCurvature();
}

/// Chunk sizes shrinking geometrically towards the last node, by 1 + kSweepShare from one
/// thread's chunk to the next: in a real-time iteration (linearizeProjectAndFactor) the
/// last chunk's thread starts the backward sweep through its own nodes while the others
/// still linearise theirs, and each thread takes the sweep over as it arrives at its chunk:
/// with a chunk n_t (1 + kSweepShare) = n_{t - 1} they finish together. kSweepShare: a
/// node's backward step against its linearisation, condensing and projection, about 3 us
/// against 25-30 us on the Tachyon 3 OCP (bench_centroidal, bench_solver).
void Solver::Impl::partitionNodes() {
  constexpr double kSweepShare = 0.12;
  const int T = pool.size();
  std::vector<double> weight(static_cast<std::size_t>(T));
  double total = 0.0;
  for (int t = T - 1; t >= 0; --t) {
    weight[static_cast<std::size_t>(t)] =
        t == T - 1 ? 1.0 : weight[static_cast<std::size_t>(t) + 1] * (1.0 + kSweepShare);
    total += weight[static_cast<std::size_t>(t)];
  }
  chunk_first.assign(static_cast<std::size_t>(T) + 1, N + 1);
  double before = 0.0;
  for (int t = 0; t < T; ++t) {
    chunk_first[static_cast<std::size_t>(t)] =
        static_cast<int>(std::lround((N + 1) * before / total));
    before += weight[static_cast<std::size_t>(t)];
  }
}

void Solver::Impl::reserveCurvature() {
  if (curvature_reserved) return;
  for (auto& n : nodes) n.H2 = MatrixXd::Zero(ndx + nu, ndx + nu);
  for (auto& sc : lin_scratch) {
    sc.dp = prob->createNodeData();
    sc.hp = VectorXd::Zero(ndx + nu);
    sc.hm = VectorXd::Zero(ndx + nu);
    sc.xp = VectorXd::Zero(nx);
    sc.up = VectorXd::Zero(nu);
    sc.hcoef = VectorXd::Zero(std::max(ni_max, 1));
    sc.dxv = VectorXd::Zero(ndx);
    sc.Ap = MatrixXd::Zero(ndx, ndx);
    sc.Bp = MatrixXd::Zero(ndx, nu);
  }
  curvature_reserved = true;
}

void Solver::Impl::adviseHugePagesForNodes(bool collapse) {
  // The span of the heap that holds the Riccati stages and the nodes' data.
  std::uintptr_t lo = ~std::uintptr_t{0}, hi = 0;
  const auto span = [&lo, &hi](const void* ptr) {
    if (ptr == nullptr) return;  // released (shared) blocks
    const auto a = reinterpret_cast<std::uintptr_t>(ptr);
    lo = std::min(lo, a);
    hi = std::max(hi, a + 1);
  };
  for (int k = 0; k <= N; ++k) {
    const Node& n = node(k);
    span(n.d.get());
    span(n.d->Lxx.data());
    span(n.d->Gx.data());
    span(n.d->Gu.data());
    if (n.d->cache) span(n.d->cache.get());
    for (const auto& c : n.d->cost_data) span(c.get());
    for (const auto& r : n.d->equality_data) span(r.get());
    for (const auto& r : n.d->inequality_data) span(r.get());
    span(n.s.data());
    span(lq.stage(k).Q.data());
    span(lq.stage(k).Eu.data());
  }
  adviseHugePages(lo, hi, collapse);
}

}  // namespace rollstep::solver
