#pragma once
// Private to src/solver: the solver's workspace (Solver::Impl) and the declarations of its
// phases. Each phase lives in its own file (linearization, condensing, direction,
// line_search, restoration, barrier, warm_start; workspace.cpp sizes the memory) and
// solver.cpp holds the public API and the main loop (Impl::run).
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <memory>
#include <utility>
#include <vector>

#include "rollstep/solver/riccati.hpp"
#include "rollstep/solver/solver.hpp"
#include "thread_pool.hpp"

namespace rollstep::solver {

using ocp::MatrixXd;
using ocp::NodeData;
using ocp::VectorXd;

#define ROLLSTEP_MSG(...) std::snprintf(message, sizeof(message), __VA_ARGS__)

namespace detail {

using Clock = std::chrono::steady_clock;
inline double msSince(Clock::time_point t) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t).count();
}

constexpr double kInf = std::numeric_limits<double>::infinity();

// Row kinds of the per-node inequality layout.
enum : int { kInactive = 0, kHard = 1, kSoft = 2 };

/// Relaxed logarithmic barrier (Feller and Jones 2016): -log(c) above delta, the
/// quadratic extension (C2 at delta) below. Returns the value; d1, d2 the derivatives.
inline double relaxedLog(double c, double delta, double& d1, double& d2) {
  if (c > delta) {
    d1 = -1.0 / c;
    d2 = 1.0 / (c * c);
    return -std::log(c);
  }
  const double t = (c - 2.0 * delta) / delta;
  d1 = (c - 2.0 * delta) / (delta * delta);
  d2 = 1.0 / (delta * delta);
  return 0.5 * (t * t - 1.0) - std::log(delta);
}

/// A simple-bound row of the per-node inequality layout: after the ni_max general rows
/// come the input bounds (all lower sides, then all upper sides), then the state bounds
/// likewise.
struct BoundRow {
  bool input;  ///< input bound (else state bound)
  bool lower;  ///< lower side (else upper)
  int index;   ///< the bounded coordinate of u or of the tangent of x
};
inline BoundRow boundRow(int i, int ni_max, int nbu, int nbx, const ocp::BoundSet& ub,
                         const ocp::BoundSet& xb) {
  const bool input = i < ni_max + 2 * nbu;
  const int j = input ? (i - ni_max) % std::max(nbu, 1) : (i - ni_max - 2 * nbu) % std::max(nbx, 1);
  const bool lower = input ? (i - ni_max) < nbu : (i - ni_max - 2 * nbu) < nbx;
  const int idx =
      input ? ub.index[static_cast<std::size_t>(j)] : xb.index[static_cast<std::size_t>(j)];
  return {input, lower, idx};
}

}  // namespace detail

// ------------------------------------------------------------------------------------------
struct Solver::Impl {
  using Clock = detail::Clock;
  static constexpr std::size_t kCacheLine = 64;

  struct Node {
    std::unique_ptr<NodeData> d;
    VectorXd s, z, ds, dz, c;  // slacks, duals, steps, constraint values (layout rows)
    VectorXd s_bak, z_bak, s_trial;
    VectorXd ds_aff, dz_aff;  // Mehrotra's affine-scaling (predictor) steps
    Eigen::VectorXi kind;     // kInactive / kHard / kSoft per row
    VectorXd lam, lam_bak;    // costate of the constraint defining x_k (ndx)
    VectorXd mult, mult_bak;  // equality multipliers (ne_max)
    VectorXd defect;          // F(x_k, u_k) (-) x_{k+1}, tangent at x_{k+1}
    // Second-order corrections (line_search.cpp): the iterate's row values, defect and
    // equality values (the trial points overwrite c, defect and the NodeData's), and the
    // accumulated corrected constraint values (hard rows: of c - s).
    VectorXd c_it, defect_it, e_it, soc_rows, soc_defect, soc_e;
    VectorXd rx, ru, tmp;  // dual residual pieces, scratch
    // Per general row: 1 if Gx != 0, | 2 if it acts on u (condensing scratch).
    Eigen::VectorXi row_parts;
    VectorXd W, gam;
    // W and gam with each mirrored pair merged on its first row: W_i + W_j, gam_i - gam_j.
    VectorXd Wc, gamc;
    VectorXd soft_dual;  // -weight beta'(c) of soft rows (reporting)
    // The non-zero blocks of Gx and Gu (found by every linearisation: condenseRows or
    // findJacobianBlocks): per block its first row, rows, first column and columns; Gx's
    // from 0, Gu's from 4 ni_max. The node keeps only the blocks' entries, packed
    // (packJacobianBlocks): block after block, each column-major with its own rows as
    // stride, Gx's blocks in d->Gx's storage and Gu's in d->Gu's, sized for ni_max rows of
    // the columns the inequality terms declare (gx_columns, gu_columns).
    Eigen::VectorXi gblocks;
    int gblocks_x = 0, gblocks_u = 0;
    // Constraint curvature (converging mode with exact_hessian), added to the Hessian and
    // taken out again by the inertia correction. Allocated by reserveCurvature() only for
    // settings that use it (empty otherwise).
    MatrixXd H2;  // (ndx + nu)^2, symmetric
    bool h2_added = false;
    double delta = 0.0;  // diagonal shift of the Hessian (inertia correction)
    int ni_prev = -1;
    /// Contact mode the node was last linearised in (-1: never), moved with the shift:
    /// an input whose node changed mode is refitted (OptimalControlProblem::InputGuess).
    int mode_prev = -1;
    bool fresh = true;  // (re)initialise slacks and duals at next linearisation
    bool finite = true;
    bool rank_ok = true;
    double pivot_ratio = 1.0;
    double primal = 0.0, dual = 0.0, sz_max = 0.0, sz_min = detail::kInf, mult_sum = 0.0;
    int mult_count = 0;
    double z_sum = 0.0;  // duals of the hard rows (complementarity scale)
    int z_count = 0;
    bool soft_rows = false;  // some row of this node is soft
    double alpha_p = 1.0, alpha_d = 1.0, dphi = 0.0, zmax = 0.0, step_rel = 0.0;
    double merit_f = 0.0, merit_theta = 0.0;
  };

  /// KKT measures of one linearisation (fixed-order reduction over the nodes).
  struct Kkt {
    bool finite = true;
    double primal = 0.0, dual = 0.0, sz_max = 0.0, sz_min = detail::kInf;
    double msum = 0.0, cost = 0.0, zsum = 0.0;
    int mcount = 0, zcount = 0;
    double dual_scaled = 0.0;  ///< dual residual over the multiplier scale s_d
    double sz_scaled = 0.0;    ///< max s z over the dual scale s_c
    bool soft_rows = false;    ///< some node has a soft (relaxed-barrier) row
    /// The scaled KKT error of the termination tests (barrier 0).
    double error() const { return std::max({primal, dual_scaled, sz_scaled}); }
    /// max |s z - m| over the hard rows (0 without any).
    double complementarity(double m) const {
      return sz_min == detail::kInf ? 0.0 : std::max(sz_max - m, m - sz_min);
    }
  };
  /// Search direction summary: fraction-to-boundary step lengths, barrier slope.
  struct Direction {
    double alpha_p = 1.0, alpha_d = 1.0, dphi = 0.0;
    bool tiny = false;  ///< tiny relative to the iterate (Ipopt): taken without line search
  };

  // ---- problem, sizes, workspace (workspace.cpp) --------------------------------------------
  std::shared_ptr<ocp::OptimalControlProblem> prob;
  SolverSettings set;
  int N, nx, ndx, nu, ne_max, ni_max, nbu, nbx, nrows, rep_off;
  bool euclid;
  RiccatiSolver lq;
  detail::ThreadPool pool;
  // Multi-thread pipelines (condenseAndFactor, forwardAndRecover): node k was condensed
  // in the pipeline run number ready[k]; claim counters of the nodes still to do.
  std::unique_ptr<std::atomic<std::uint64_t>[]> ready;
  std::uint64_t pipeline_run = 0;
  // The counters one thread writes while the others poll them are each on a cache line of
  // their own (a store invalidates the whole line in the other cores: the node pointers and
  // chunk bounds beside them would be read from memory again at every node), and so are the
  // per-thread claim counters.
  alignas(kCacheLine) std::atomic<int> forward_done{0};
  // Per thread t, the next unclaimed node of its chunk of the linearisation partition
  // (ThreadPool::run's static split of 0..N): a thread condenses and recovers the nodes it
  // linearised first (their data is in its cache), then helps with the others.
  struct alignas(kCacheLine) ChunkCounter {
    std::atomic<int> next{0};
  };
  alignas(kCacheLine) std::unique_ptr<ChunkCounter[]> chunk_next;
  // The nodes' partition into the threads' chunks (partitionNodes): chunk t is
  // [chunk_first[t], chunk_first[t + 1]). Fixed at construction: the nodes of one chunk
  // share their terms' workspaces.
  std::vector<int> chunk_first;
  // linearizeProjectAndFactor: the backward sweep has factorised the stages from sweep_at
  // up (N + 1: none yet); sweep_abort: a chunk threw, nobody waits for the sweep.
  alignas(kCacheLine) std::atomic<int> sweep_at{0};
  std::atomic<bool> sweep_abort{false};
  // Read by every thread at every node: not on the lines of the counters above.
  alignas(kCacheLine) std::vector<Node> nodes;
  // Per thread: the condensing's scratch, the weighted general-row Jacobians (transposed,
  // ndx x ni_max and nu x ni_max); condenseRows(k, t) on thread t.
  std::vector<MatrixXd> weighted_gx, weighted_gu;
  /// Copies the non-zero blocks the linearisation found in the thread's shared inequality
  /// Jacobians (SharedDerivatives) into node k's own Gx and Gu storage, packed
  /// (Node::gblocks): 10.7 kB per node of the Tachyon 3 OCP where the dense rows in use are
  /// 24.6 kB. Throws std::logic_error for a block outside gx_columns, gu_columns (a term
  /// whose Jacobian is non-zero outside the columns it declares).
  void packJacobianBlocks(int k, int thread);
  /// The dense Gx, Gu of node k (rows [0, ni)) from its packed blocks, into the thread's set.
  void unpackJacobianBlocks(int k, int thread);
  /// f() with node k's Gx and Gu dense (unpacked into the thread's set, swapped in): the
  /// condensing's products and sums read them so, the same arithmetic as at linearisation.
  template <class F>
  void withDenseJacobians(int k, int thread, F&& f) {
    unpackJacobianBlocks(k, thread);
    SharedDerivatives& sh = shared[static_cast<std::size_t>(thread)];
    NodeData& d = *node(k).d;
    d.Gx.swap(sh.Gx);
    d.Gu.swap(sh.Gu);
    f();
    d.Gx.swap(sh.Gx);
    d.Gu.swap(sh.Gu);
  }
  /// Node::row_parts of the general rows from the dense d.Gx (and the mirrored pairs).
  void markRowParts(Node& n, const NodeData& d, bool running);
  /// f(first row, rows) for each maximal run of rows whose row_parts hold `mask`.
  template <class F>
  static void forEachRun(const Node& n, int m, int mask, const F& f) {
    for (int i = 0; i < m;) {
      if ((n.row_parts(i) & mask) != mask) {
        ++i;
        continue;
      }
      int j = i + 1;
      while (j < m && (n.row_parts(j) & mask) == mask) ++j;
      f(i, j - i);
      i = j;
    }
  }
  /// Appends the block of rows [i, i + r) x columns [a, a + s) (and the blocks of their
  /// mirrored rows) to the list `out` of `count` blocks; none for s == 0.
  static void recordBlock(const NodeData& d, int* out, int& count, int i, int r, int a, int s);
  /// The blocks condenseRows records, from the dense Jacobians in node k's data, for a
  /// linearisation that does not condense at once.
  void findJacobianBlocks(int k);
  /// The columns the inequality terms can be non-zero in (the hull of their declared
  /// Residual::stateColumns, inputColumns), which the nodes' packed storage holds.
  ocp::ColumnRange gx_columns, gu_columns;
  std::vector<detail::BoundRow> bound_rows;  // decoded layout of rows ni_max.. (fixed)
  std::vector<VectorXd> xs, us, xs_bak, us_bak, xs_trial, us_trial;
  std::vector<VectorXd> scaled;  // per-node scaled tangent steps (manifold states)
  VectorXd x0, dx0, zero_u;
  VectorXd dx0_it, dx0_soc;  // second-order corrections: the iterate's, the corrected
  std::vector<MatrixXd> gains;
  mutable std::vector<bool> gains_valid;
  std::vector<IterationStats> stats;
  SolverStatus status = SolverStatus::MaxIterations;
  int iterations = 0;
  double cost = 0.0;
  double mu = 0.0;
  // Filter of the line search: (theta, f) pairs, sized at construction.
  std::vector<std::pair<double, double>> filter;
  double filter_mu = -1.0, theta_max = detail::kInf, theta_min = 0.0;
  // Filter reset heuristic (SolverSettings::filter_reset_trigger): line searches in a row
  // whose last rejected trial point the filter refused, and the resets of this solve.
  int filter_rejections_in_a_row = 0, filter_resets = 0;
  bool filter_was_reset = false;  // in this iteration (IterationStats::filter_reset)
  bool has_guess = false;
  bool has_curvature = true;   // the problem has terms with curvature (hasCurvature())
  bool reset_slacks = false;   // this iteration's linearisation resets slacks (slack_reset)
  bool use_curvature = false;  // this iteration adds the constraint curvature (H2)
  // Real time: linearizeNode condenses the node's Hessian and gradient while its
  // derivatives are in cache, and the linearisation projects each node right after and
  // factorises (with one thread each node in turn, linearizeAndFactor; with more, the
  // backward sweep after the threads' pass, linearizeProjectAndFactor); the next
  // condenseAndFactor returns its result.
  bool condense_in_linearize = false;
  bool condensed_early = false;
  // Every linearisation evaluates the node's dynamics, equality and inequality Jacobians
  // into one set per thread (the nodes have none of their own but the inequality
  // Jacobians' non-zero blocks, packed), and the fused pass also, straight into the stages' shared
  // Q, R, S (RiccatiSolver:: shareStageHessians: the condensing adds its rows there), its cost
  // Hessian, all swapped in for the evaluation (O(1)) and in cache: they are read only while the
  // node is linearised and condensed (but the inequality Jacobians' non-zero blocks, which
  // packJacobianBlocks keeps for the step recovery), and the nodes' own blocks would be
  // 60-70 kB of cold stores per node of the Tachyon 3 OCP. The nodes' own Hessian and
  // inequality blocks then hold stale values (derivatives_shared): the inertia correction,
  // which condenses again from them, linearises the nodes again first (the same arithmetic,
  // the same values).
  // Per-thread sets (shared, lin_scratch) are each on cache lines of their own: the
  // linearisation swaps their matrices' headers at every node, and neighbouring threads'
  // headers on one line would move that line between the cores at every swap.
  struct alignas(kCacheLine) SharedDerivatives {
    MatrixXd Fx, Fu, Ex, Eu, Gx, Gu;
  };
  std::vector<SharedDerivatives> shared;  // per thread
  /// The scratch of a node's linearisation, one per thread (the thread of the node's chunk,
  /// as for `shared`): read and written only while the node is linearised.
  struct alignas(kCacheLine) LinearizeScratch {
    MatrixXd J0, J1;  // difference Jacobians
    // Constraint curvature (reserveCurvature): central differences of the constraint part
    // of the Lagrangian gradient, evaluated into dp (a whole NodeData: 95 kB of the
    // Tachyon 3 OCP, where one per node was half of a converging solver's memory).
    std::unique_ptr<NodeData> dp;
    VectorXd hp, hm, xp, up, hcoef;  // gradients +-, perturbed point, row coefficients
    VectorXd dxv;                    // tangent perturbation (manifolds)
    MatrixXd Ap, Bp;                 // dynamics Jacobians at the perturbed point (manifolds)
  };
  std::vector<LinearizeScratch> lin_scratch;  // per thread
  LinearizeScratch& scratchOf(int k) { return lin_scratch[static_cast<std::size_t>(chunkOf(k))]; }
  // Likewise the stage's A, B, Ex and Eu (written from Fx, Fu, Ex, Eu, read by the
  // residuals and the projection right after; the Riccati solver keeps the fixed-input
  // columns of B and Eu, BF and EF): one set swapped into the stage for its linearisation
  // and projection (linearizeAndFactor). The stages' own then hold stale values, which
  // only a linearisation (with its condensing) overwrites.
  MatrixXd shared_A, shared_B, shared_stage_Ex, shared_stage_Eu;
  bool derivatives_shared = false;
  /// The fused pass evaluates node k's cost Hessian straight into its stage's Q, R, S
  /// (with one thread the one shared set; with more each stage's own, condensed and
  /// projected right after by the thread that linearised the node).
  void swapStageHessian(int k, NodeData& d) {
    const RiccatiSolver::StageHessian h = lq.hessian(k);
    d.Lxx.swap(h.Q);
    d.Luu.swap(h.R);
    d.Lux.swap(h.S);
  }
  void swapSharedStageJacobians(int k) {
    LqStage& st = lq.stage(k);
    st.A.swap(shared_A);
    st.B.swap(shared_B);
    st.Ex.swap(shared_stage_Ex);
    st.Eu.swap(shared_stage_Eu);
  }
  /// The thread's Fx, Fu, Ex, Eu, Gx, Gu (the nodes hold none: every linearisation
  /// evaluates them here, the stage keeps what it needs, the node the packed blocks of Gx
  /// and Gu).
  void swapSharedJacobians(NodeData& d, int thread) {
    SharedDerivatives& sh = shared[static_cast<std::size_t>(thread)];
    d.Fx.swap(sh.Fx);
    d.Fu.swap(sh.Fu);
    d.Ex.swap(sh.Ex);
    d.Eu.swap(sh.Eu);
    d.Gx.swap(sh.Gx);
    d.Gu.swap(sh.Gu);
  }
  /// Settings whose solve() adds the constraint curvature (converging mode, exact_hessian,
  /// a problem with curvature): they need the curvature workspace.
  bool needsCurvature(const SolverSettings& s) const {
    return s.mode == SolverMode::Converging && s.exact_hessian && has_curvature;
  }
  /// Allocates the curvature workspace of every node (a second NodeData each: half of the
  /// solver's memory), once; called at construction and by setSettings for settings that
  /// need it, so that solve() never allocates and a real-time-only solver never holds it.
  void reserveCurvature();
  bool curvature_reserved = false;
  /// SolverSettings::huge_pages: the advice for the span of the nodes' data and stages;
  /// `collapse`: collapse them now too (real-time solvers only).
  void adviseHugePagesForNodes(bool collapse);
  double last_delta = 0.0;  // last inertia correction
  bool pc_active = false;   // this solve uses Mehrotra's predictor-corrector
  bool tiny_step = false;   // the last step was tiny: decrease the barrier
  // Trial points of this run (line search, restoration) whose evaluation was not finite:
  // named in a failure's message (a model undefined there, such as outside its domain).
  int nonfinite_trials = 0;
  int acceptable_count = 0;  // consecutive acceptable iterations
  double prox = 0.0;         // proximal shift of the Hessian after short steps (line_search.cpp)
  // Complementarity target of the Newton step: s_i z_i -> target_mu (the barrier), minus
  // ds_aff_i dz_aff_i in Mehrotra's corrector.
  double target_mu = 0.0;
  bool corrector = false;
  double target(const Node& n, int i) const {
    return corrector ? target_mu - n.ds_aff(i) * n.dz_aff(i) : target_mu;
  }
  /// Condensed gradient of hard row i (W = z / s): with the slack and dual steps
  /// eliminated, the row adds G^T (W (c - s) - target / s) to the node's gradient.
  double hardRowGradient(const Node& n, int i, double W) const {
    return W * (n.c(i) - n.s(i)) - target(n, i) / n.s(i);
  }
  bool has_solution = false;
  bool direction_ready = false;  // the Riccati workspace holds a valid factorisation
  bool backup_valid = false;     // xs_bak, ... hold the iterate before the last step
  double solution_t0 = 0.0;      // start of the node grid of the stored solution
  int last_shift = 0;            // nodes the last update() shifted the solution by
  int failed_node = -1;
  char message[512] = "";

  Impl(std::shared_ptr<ocp::OptimalControlProblem> p, SolverSettings s);

  // ---- small helpers -------------------------------------------------------------------------
  const VectorXd& uOf(int k) const { return k < N ? us[static_cast<std::size_t>(k)] : zero_u; }
  Node& node(int k) { return nodes[static_cast<std::size_t>(k)]; }
  double relaxation(const Node& n, int i) const {
    return i < ni_max ? n.d->relaxation(i) : boundOptions(i).relaxation;
  }
  /// Fixed weight of a soft row's relaxed barrier (independent of mu).
  double softWeight(const Node& n, int i) const {
    return i < ni_max ? n.d->soft_weight(i) : boundOptions(i).weight;
  }
  /// Options of bound row i >= ni_max: the input bounds' or the state bounds'.
  const ocp::InequalityOptions& boundOptions(int i) const {
    return i < ni_max + 2 * nbu ? prob->inputBounds().options : prob->stateBounds().options;
  }
  /// f(k) for every node k = 0..N, split over the threads (the static partition: thread t
  /// runs the nodes of chunk t in order).
  template <class F>
  void forNodes(F&& f) {
    auto body = [&](int t, int) {
      for (int k = chunkBegin(t); k < chunkBegin(t + 1); ++k) f(k);
    };
    pool.run(pool.size(), body);
  }
  /// First node of thread t's chunk (t = 0..size: chunkBegin(size) = N + 1).
  int chunkBegin(int t) const { return chunk_first[static_cast<std::size_t>(t)]; }
  /// The thread whose chunk holds node k.
  int chunkOf(int k) const {
    int t = 0;
    while (k >= chunkBegin(t + 1)) ++t;
    return t;
  }
  /// The static partition of the nodes 0..N into the threads' chunks (chunk_first).
  void partitionNodes();
  /// Claims the next node of chunk t (downwards or upwards), or returns -1.
  int claimInChunk(int t, bool downwards) {
    auto& next = chunk_next[static_cast<std::size_t>(t)].next;
    const int lo = chunkBegin(t), hi = chunkBegin(t + 1);  // [lo, hi)
    if (downwards ? next.load(std::memory_order_relaxed) < lo
                  : next.load(std::memory_order_relaxed) >= hi) {
      return -1;
    }
    const int j = downwards ? next.fetch_sub(1, std::memory_order_relaxed)
                            : next.fetch_add(1, std::memory_order_relaxed);
    return (j >= lo && j < hi) ? j : -1;
  }
  /// Own chunk first, then the others in the order the sweep needs them.
  int claimNode(int id, bool downwards) {
    int j = claimInChunk(id, downwards);
    const int T = pool.size();
    for (int i = 0; j < 0 && i < T; ++i) {
      const int t = downwards ? T - 1 - i : i;
      if (t != id) j = claimInChunk(t, downwards);
    }
    return j;
  }
  /// Sets the diagonal shift of the node's Hessian to delta (inertia correction).
  void shiftDiagonal(int k, Node& n, double delta) {
    NodeData& d = *n.d;
    d.Lxx.diagonal().array() += delta - n.delta;
    if (k < N) d.Luu.diagonal().array() += delta - n.delta;
    n.delta = delta;
  }
  /// Adds sign * the constraint curvature H2 to the node's Hessian.
  void shiftHessian(int k, Node& n, double sign) {
    NodeData& d = *n.d;
    d.Lxx += sign * n.H2.topLeftCorner(ndx, ndx);
    if (k < N) {
      d.Luu += sign * n.H2.bottomRightCorner(nu, nu);
      d.Lux += sign * n.H2.bottomLeftCorner(nu, ndx);
    }
  }

  // ---- the main loop (solver.cpp) ------------------------------------------------------------
  SolverStatus run(ConstVecRef x_init, bool realtime);
  bool begin(ConstVecRef x_init, bool realtime);
  void pushIntoBounds();
  void pushInputsIntoBounds(std::vector<VectorXd>& inputs) const;
  void moveInsideBound(double& v, const ocp::BoundSet& b, int j) const;
  double rollout();
  bool takeRollout(double theta_limit);
  void centreDuals();

  // ---- linearisation and KKT residuals (linearization.cpp) ------------------------------------
  Kkt linearize(bool realtime, IterationStats& it);
  Kkt residualSummary() const;
  void linearizeNode(int k);
  /// linearizeNode's evaluation, residuals and curvature, with the thread's Jacobians
  /// swapped into the node's data.
  void linearizeWithSharedJacobians(int k, Node& n, const VectorXd& x, const VectorXd& u);
  void rowValues(int k, const VectorXd& x, const VectorXd& u, Node& n) const;
  void initRows(Node& n) const;
  void resetSlacks(Node& n) const;
  void residuals(int k, Node& n);
  void constraintGradient(int k, const Node& n, const NodeData& dd, const VectorXd& coef,
                          VectorXd& out) const;
  void addCurvature(int k, Node& n);
  void curvatureGradient(int k, Node& n, VectorXd& g);

  // ---- condensing, projection, factorisation (condensing.cpp) --------------------------------
  enum class Factorization { Ok, RankDeficient, NotPositiveDefinite };
  /// Condensing of node k (condenseRows) and the projection of its equalities.
  void condenseNode(int k, int thread);
  /// The barrier rows and the node's cost Hessian and gradient into its LQ stage, with
  /// the scratch of the calling thread.
  void condenseRows(int k, int thread);
  void projectNode(int k);
  void condenseGradient(int k);
  void condenseGradientDense(int k);
  Factorization condenseAndFactor();
  /// One thread, real time: linearizeNode(k), projection and backward Riccati step of each
  /// node k = N .. 0 in one pass (the same arithmetic as linearize then condenseAndFactor).
  Factorization linearizeAndFactor();
  /// More threads, real time: linearizeNode(k) and the projection of every node k on the
  /// threads (each node's data in its thread's cache), each thread then continuing the
  /// backward sweep through its own chunk once the sweep has come down to it.
  Factorization linearizeProjectAndFactor();
  /// The backward sweep's bookkeeping: the first node (in the sweep's order) whose
  /// equalities are rank deficient stops it; so does a failed factorisation.
  void sweepStage(int k, int& rank_failed, bool& pd);
  Factorization sweepResult(int rank_failed, bool pd);
  /// The sweep on this thread: prepare(k) makes node k's stage ready (condensed and
  /// projected), for k = N, then N-1 .. 0 each followed by its backward step.
  template <class Prepare>
  Factorization sweepSerially(Prepare prepare);
  Factorization early_factorization = Factorization::Ok;
  bool correctInertia(bool factored, bool& shifted);

  // ---- search direction (direction.cpp) ------------------------------------------------------
  bool searchDirection(bool realtime, double primal, IterationStats& it, Direction& dir);
  void forwardAndRecover();
  void recoverNode(int k);
  void predictorCorrector();

  // ---- step length: filter line search (line_search.cpp) -------------------------------------
  bool filterLineSearch(double dphi, double& alpha, double& alpha_d, double& theta0, double& f0,
                        int& corrections);
  bool acceptableToFilter(double theta, double f, double theta0, double f0, double dphi,
                          double alpha, bool& f_type, bool& filter_refused) const;
  void keepIterateValues(int k);
  int secondOrderCorrection(double alpha0, double theta0, double f0, double dphi, bool& f_type,
                            double& alpha, double& alpha_d);
  void correctionVectors(int k, bool corrected);
  double trialMerit(double alpha, double& f);
  /// Appends the count of non-finite trial points to the message (none: nothing).
  void noteNonFiniteTrials();
  bool stepLengths(double& ap, double& ad) const;
  void noteFilterRefusals(bool refused);
  void takeFullStep(double alpha);
  void updateDuals(double alpha, double alpha_d);
  void trialPoint(int k, double alpha);
  void acceptTrial();
  void evaluateTrial(int k);
  void trialRows(int k, bool slacks_from_rows);
  void meritNode(int k, Node& n, const VectorXd& s) const;
  void addToFilter(double theta, double f);
  void addFilterEntryFor(double theta, double f);
  void adaptProximalShift(double alpha);

  // ---- restoration and infeasibility (restoration.cpp) ---------------------------------------
  /// Infeasibility test when the direction breaks down (non-finite, not factorisable):
  /// some dual above kDualBlowUp while the violation is above the tolerance.
  static constexpr double kDualBlowUp = 1e12;
  bool dualsBlewUp(double primal) const;
  bool stepRejected(const Kkt& kkt, double theta0, double f0, double dphi, Clock::time_point t_upd,
                    IterationStats& it);
  bool restorationPhase(double theta0, double f0, double primal, Clock::time_point t_upd);
  Kkt step_start;  // residuals where the last feasibility step started (its stats entry)
  double feasibilityStep(bool move_slacks, double min_progress, double& theta_start,
                         double& theta_new);

  // ---- termination and barrier (barrier.cpp) -------------------------------------------------
  bool diverged(const Kkt& kkt);
  void recordResiduals(const Kkt& kkt, IterationStats& it) const;
  bool terminated(const Kkt& kkt, int max_it, IterationStats& it);
  void updateBarrier(const Kkt& kkt);
  SolverStatus endRealTimeIteration();

  // ---- warm start, shift, backup (warm_start.cpp) --------------------------------------------
  void shiftToTime(double t0);
  void shiftNodes(int n);
  void backup();
  void restore();
};

}  // namespace rollstep::solver
