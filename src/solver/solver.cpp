#include "rollstep/solver/solver.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>

#include "rollstep/solver/riccati.hpp"
#include "thread_pool.hpp"

namespace rollstep::solver {

using ocp::MatrixXd;
using ocp::NodeData;
using ocp::VectorXd;

const char* toString(SolverStatus s) {
  switch (s) {
    case SolverStatus::Converged:
      return "Converged";
    case SolverStatus::IterationDone:
      return "IterationDone";
    case SolverStatus::MaxIterations:
      return "MaxIterations";
    case SolverStatus::LineSearchFailed:
      return "LineSearchFailed";
    case SolverStatus::RankDeficientEqualities:
      return "RankDeficientEqualities";
    case SolverStatus::Diverged:
      return "Diverged";
    case SolverStatus::InvalidInput:
      return "InvalidInput";
    case SolverStatus::Infeasible:
      return "Infeasible";
  }
  return "Unknown";
}

#define ROLLSTEP_MSG(...) std::snprintf(message, sizeof(message), __VA_ARGS__)

namespace {

using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t).count();
}

constexpr double kInf = std::numeric_limits<double>::infinity();

// Row kinds of the per-node inequality layout.
enum : int { kInactive = 0, kHard = 1, kSoft = 2 };

/// Relaxed logarithmic barrier (Feller and Jones 2016): -log(c) above delta, the
/// quadratic extension (C2 at delta) below. Returns the value; d1, d2 the derivatives.
double relaxedLog(double c, double delta, double& d1, double& d2) {
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
BoundRow boundRow(int i, int ni_max, int nbu, int nbx, const ocp::BoundSet& ub,
                  const ocp::BoundSet& xb) {
  const bool input = i < ni_max + 2 * nbu;
  const int j = input ? (i - ni_max) % std::max(nbu, 1) : (i - ni_max - 2 * nbu) % std::max(nbx, 1);
  const bool lower = input ? (i - ni_max) < nbu : (i - ni_max - 2 * nbu) < nbx;
  const int idx =
      input ? ub.index[static_cast<std::size_t>(j)] : xb.index[static_cast<std::size_t>(j)];
  return {input, lower, idx};
}

}  // namespace

// ------------------------------------------------------------------------------------------
struct Solver::Impl {
  struct Node {
    std::unique_ptr<NodeData> d;
    VectorXd s, z, ds, dz, c;  // slacks, duals, steps, constraint values (layout rows)
    VectorXd s_bak, z_bak, s_trial;
    Eigen::VectorXi kind;     // kInactive / kHard / kSoft per row
    VectorXd lam, lam_bak;    // costate of the constraint defining x_k (ndx)
    VectorXd mult, mult_bak;  // equality multipliers (ne_max)
    VectorXd defect;          // F(x_k, u_k) (-) x_{k+1}, tangent at x_{k+1}
    MatrixXd J0, J1;          // difference Jacobians
    VectorXd rx, ru, tmp;     // dual residual pieces, scratch
    MatrixXd WGu, WGx;        // weighted general-row Jacobians
    VectorXd W, gam;
    VectorXd soft_dual;  // -weight beta'(c) of soft rows (reporting)
    // Constraint curvature (converging mode, Euclidean): central differences of the
    // constraint part of the Lagrangian gradient, evaluated into dp.
    std::unique_ptr<NodeData> dp;
    MatrixXd H2;                     // (ndx + nu)^2, symmetric
    VectorXd hp, hm, xp, up, hcoef;  // gradients +-, perturbed point, row coefficients
    VectorXd dxv;                    // tangent perturbation (manifolds)
    MatrixXd Ap, Bp;                 // dynamics Jacobians at the perturbed point (manifolds)
    bool h2_added = false;
    double delta = 0.0;  // diagonal shift of the Hessian (inertia correction)
    int ni_prev = -1;
    bool fresh = true;  // (re)initialise slacks and duals at next linearisation
    bool finite = true;
    bool rank_ok = true;
    double pivot_ratio = 1.0;
    double primal = 0.0, dual = 0.0, sz_max = 0.0, sz_min = kInf, mult_sum = 0.0;
    int mult_count = 0;
    double alpha_p = 1.0, alpha_d = 1.0, dphi = 0.0, zmax = 0.0;
    double merit_f = 0.0, merit_theta = 0.0;
  };

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
  std::atomic<int> forward_done{0};
  // Per thread t, the next unclaimed node of its chunk of the linearisation partition
  // (ThreadPool::run's static split of 0..N): a thread condenses and recovers the nodes it
  // linearised first (their data is in its cache), then helps with the others.
  std::unique_ptr<std::atomic<int>[]> chunk_next;
  int chunkBegin(int t) const { return pool.chunkBegin(N + 1, t); }
  /// Claims the next node of chunk t (downwards or upwards), or returns -1.
  int claimInChunk(int t, bool downwards) {
    auto& next = chunk_next[static_cast<std::size_t>(t)];
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
  std::vector<Node> nodes;
  std::vector<BoundRow> bound_rows;  // decoded layout of rows ni_max.. (fixed at construction)
  std::vector<VectorXd> xs, us, xs_bak, us_bak, xs_trial, us_trial;
  VectorXd x0, dx0, zero_u;
  std::vector<MatrixXd> gains;
  mutable std::vector<bool> gains_valid;
  std::vector<IterationStats> stats;
  SolverStatus status = SolverStatus::MaxIterations;
  int iterations = 0;
  double cost = 0.0;
  double mu = 0.0;
  // Filter of the line search: (theta, f) pairs, sized at construction.
  std::vector<std::pair<double, double>> filter;
  double filter_mu = -1.0, theta_max = kInf, theta_min = 0.0;
  void addToFilter(double theta, double f) {
    // Drop the entries the new one dominates, then append (never beyond the capacity).
    std::size_t m = 0;
    for (std::size_t j = 0; j < filter.size(); ++j) {
      if (!(filter[j].first >= theta && filter[j].second >= f)) filter[m++] = filter[j];
    }
    filter.resize(m);
    if (filter.size() < filter.capacity()) filter.emplace_back(theta, f);
  }
  bool has_guess = false;
  bool use_curvature = false;  // this iteration adds the constraint curvature (H2)
  double last_delta = 0.0;     // last inertia correction
  bool has_solution = false;
  bool direction_ready = false;  // the Riccati workspace holds a valid factorisation
  bool backup_valid = false;     // xs_bak, ... hold the iterate before the last step
  double solution_t0 = 0.0;      // start of the node grid of the stored solution
  int last_shift = 0;            // nodes the last update() shifted the solution by
  int failed_node = -1;
  char message[256] = "";

  Impl(std::shared_ptr<ocp::OptimalControlProblem> p, SolverSettings s)
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
        chunk_next(new std::atomic<int>[static_cast<std::size_t>(pool.size())]) {
    for (int k = 0; k <= N; ++k) ready[static_cast<std::size_t>(k)].store(0);
    nodes.resize(static_cast<std::size_t>(N) + 1);
    for (int i = ni_max; i < nrows; ++i) {
      bound_rows.push_back(boundRow(i, ni_max, nbu, nbx, prob->inputBounds(), prob->stateBounds()));
    }
    for (auto& n : nodes) {
      n.d = prob->createNodeData();
      for (VectorXd* v : {&n.s, &n.z, &n.ds, &n.dz, &n.c, &n.s_bak, &n.z_bak, &n.s_trial}) {
        *v = VectorXd::Zero(nrows);
      }
      n.kind = Eigen::VectorXi::Zero(nrows);
      n.lam = VectorXd::Zero(ndx);
      n.lam_bak = VectorXd::Zero(ndx);
      n.mult = VectorXd::Zero(ne_max);
      n.mult_bak = VectorXd::Zero(ne_max);
      n.defect = VectorXd::Zero(ndx);
      n.J0 = MatrixXd::Zero(ndx, ndx);
      n.J1 = MatrixXd::Zero(ndx, ndx);
      n.rx = VectorXd::Zero(ndx);
      n.ru = VectorXd::Zero(nu);
      n.tmp = VectorXd::Zero(std::max(ni_max, 1));
      n.WGu = MatrixXd::Zero(ni_max, nu);
      n.WGx = MatrixXd::Zero(ni_max, ndx);
      n.W = VectorXd::Zero(ni_max);
      n.gam = VectorXd::Zero(ni_max);
      n.soft_dual = VectorXd::Zero(nrows);
      n.dp = prob->createNodeData();
      n.H2 = MatrixXd::Zero(ndx + nu, ndx + nu);
      n.hp = VectorXd::Zero(ndx + nu);
      n.hm = VectorXd::Zero(ndx + nu);
      n.xp = VectorXd::Zero(nx);
      n.up = VectorXd::Zero(nu);
      n.hcoef = VectorXd::Zero(std::max(ni_max, 1));
      n.dxv = VectorXd::Zero(ndx);
      n.Ap = MatrixXd::Zero(ndx, ndx);
      n.Bp = MatrixXd::Zero(ndx, nu);
    }
    xs.assign(static_cast<std::size_t>(N) + 1, VectorXd::Zero(nx));
    for (auto& x : xs) prob->stateSpace().neutral(x);
    us.assign(static_cast<std::size_t>(N), VectorXd::Zero(nu));
    xs_bak = xs_trial = xs;
    us_bak = us_trial = us;
    x0 = VectorXd::Zero(nx);
    dx0 = VectorXd::Zero(ndx);
    zero_u = VectorXd::Zero(nu);
    gains.assign(static_cast<std::size_t>(N), MatrixXd::Zero(nu, ndx));
    gains_valid.assign(static_cast<std::size_t>(N), false);
    stats.reserve(static_cast<std::size_t>(std::max(set.max_iterations, 1)) + 2);
    filter.reserve(static_cast<std::size_t>(std::max(set.max_iterations, 1)) + 2);
  }

  const VectorXd& uOf(int k) const { return k < N ? us[static_cast<std::size_t>(k)] : zero_u; }
  Node& node(int k) { return nodes[static_cast<std::size_t>(k)]; }

  // ---- rows ---------------------------------------------------------------------------------
  /// Sets kind and value c of every row of node k from d (general rows) and (x, u).
  void rowValues(int k, const VectorXd& x, const VectorXd& u, Node& n) const {
    const NodeData& d = *n.d;
    const bool terminal = (k == N);
    n.kind.setZero();
    for (int i = 0; i < d.ni; ++i) {
      n.kind(i) = d.soft(i) ? kSoft : kHard;
      n.c(i) = d.g(i);
    }
    for (int i = d.ni; i < ni_max; ++i) n.c(i) = 0.0;
    const auto& ub = prob->inputBounds();
    for (int j = 0; j < nbu; ++j) {
      const int lo = ni_max + j, hi = ni_max + nbu + j;
      const double v = terminal ? 0.0 : u(ub.index[static_cast<std::size_t>(j)]);
      n.c(lo) = v - ub.lower(j);
      n.c(hi) = ub.upper(j) - v;
      if (!terminal) {
        if (ub.has_lower[static_cast<std::size_t>(j)]) n.kind(lo) = kHard;
        if (ub.has_upper[static_cast<std::size_t>(j)]) n.kind(hi) = kHard;
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

  double relaxation(const Node& n, int i) const {
    return i < ni_max ? n.d->relaxation(i) : prob->stateBounds().options.relaxation;
  }
  /// Fixed weight of a soft row's relaxed barrier (independent of mu).
  double softWeight(const Node& n, int i) const {
    return i < ni_max ? n.d->soft_weight(i) : prob->stateBounds().options.weight;
  }

  // ---- phase 1: linearisation and residuals --------------------------------------------------
  void linearizeNode(int k) {
    Node& n = node(k);
    NodeData& d = *n.d;
    const VectorXd& x = xs[static_cast<std::size_t>(k)];
    const VectorXd& u = uOf(k);
    prob->linearize(k, x, u, d);
    LqStage& st = lq.stage(k);
    if (k < N) {
      const VectorXd& xn = xs[static_cast<std::size_t>(k) + 1];
      prob->stateSpace().difference(xn, d.xnext, n.defect);
      if (euclid) {
        st.A = d.Fx;
        st.B = d.Fu;
      } else {
        prob->stateSpace().differenceJacobians(xn, d.xnext, n.J0, n.J1);
        st.A.noalias() = n.J1 * d.Fx;
        st.B.noalias() = n.J1 * d.Fu;
      }
      st.b = n.defect;
    }
    rowValues(k, x, u, n);
    if (n.fresh || d.ni != n.ni_prev) initRows(n);
    n.ni_prev = d.ni;
    n.fresh = false;
    residuals(k, n);
    n.h2_added = false;
    n.delta = 0.0;
    if (use_curvature && n.finite) addCurvature(k, n);
  }

  /// Constraint part of the Lagrangian gradient at the point evaluated in dd, with the
  /// multipliers of the current iterate: [Fx; Fu]^T lam_{k+1} + E^T nu + G^T hcoef.
  void constraintGradient(int k, const Node& n, const NodeData& dd, VectorXd& out) const {
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
      ox.noalias() += dd.Gx.topRows(dd.ni).transpose() * n.hcoef.head(dd.ni);
      if (k < N) ou.noalias() += dd.Gu.topRows(dd.ni).transpose() * n.hcoef.head(dd.ni);
    }
  }

  /// Adds the constraint curvature (second derivatives of dynamics, equalities and
  /// general inequalities times their multipliers) to the node's Gauss-Newton Hessian:
  /// the Gauss-Newton Hessian alone converges only linearly when the multipliers are
  /// large (swing-up: ~900 iterations). Central differences of Jacobians. On manifolds
  /// the node's Hessian in (x_k, u_k) with x_{k+1} held fixed (the cross terms of the
  /// difference with x_{k+1} do not fit the stage structure and are left out).
  void addCurvature(int k, Node& n) {
    NodeData& d = *n.d;
    for (int i = 0; i < d.ni; ++i) {
      double d1 = 0.0, d2 = 0.0;
      if (n.kind(i) == kSoft) relaxedLog(n.c(i), d.relaxation(i), d1, d2);
      n.hcoef(i) = n.kind(i) == kHard ? -n.z(i) : d.soft_weight(i) * d1;
    }
    const int nv = ndx + (k < N ? nu : 0);
    const VectorXd& x = xs[static_cast<std::size_t>(k)];
    const VectorXd& u = uOf(k);
    for (int j = 0; j < nv; ++j) {
      const bool in_x = j < ndx;
      const double v = in_x ? (euclid ? x(j) : 0.0) : u(j - ndx);
      const double h = 1e-5 * (1.0 + std::abs(v));
      for (int side = 0; side < 2; ++side) {
        VectorXd& g = side == 0 ? n.hp : n.hm;
        const double hs = side == 0 ? h : -h;
        n.up = u;
        if (in_x && !euclid) {
          n.dxv.setZero();
          n.dxv(j) = hs;
          prob->stateSpace().integrate(x, n.dxv, n.xp);
        } else {
          n.xp = x;
          (in_x ? n.xp(j) : n.up(j - ndx)) = v + hs;
        }
        prob->linearize(k, n.xp, n.up, *n.dp);
        if (euclid) {
          constraintGradient(k, n, *n.dp, g);
          continue;
        }
        // Manifold: the whole node gradient (cost included, its Gauss-Newton Hessian is
        // not exact either), dynamics through the difference Jacobian, pulled back to the
        // tangent at x by the Jacobian of the retraction.
        NodeData& dp = *n.dp;
        if (k < N) {
          prob->stateSpace().differenceJacobians(xs[static_cast<std::size_t>(k) + 1], dp.xnext,
                                                 n.J0, n.J1);
          n.Ap.noalias() = n.J1 * dp.Fx;
          dp.Fx = n.Ap;
          n.Bp.noalias() = n.J1 * dp.Fu;
          dp.Fu = n.Bp;
        }
        constraintGradient(k, n, dp, g);
        g.head(ndx) += dp.lx;
        if (k < N) g.segment(ndx, nu) += dp.lu;
        if (in_x) {
          prob->stateSpace().integrateJacobians(x, n.dxv, n.J0, n.J1);
          n.dxv.noalias() = n.J1.transpose() * g.head(ndx);
          g.head(ndx) = n.dxv;
        }
      }
      n.H2.col(j).head(nv) = (n.hp.head(nv) - n.hm.head(nv)) / (2.0 * h);
    }
    if (!euclid) {  // H2 holds the full Hessian: keep the difference to Gauss-Newton
      n.H2.topLeftCorner(ndx, ndx) -= d.Lxx;
      if (k < N) {
        n.H2.bottomRightCorner(nu, nu) -= d.Luu;
        n.H2.bottomLeftCorner(nu, ndx) -= d.Lux;
        n.H2.topRightCorner(ndx, nu) -= d.Lux.transpose();
      }
    }
    auto H = n.H2.topLeftCorner(nv, nv);
    for (int i = 0; i < nv; ++i) {
      for (int j = 0; j < i; ++j) H(i, j) = H(j, i) = 0.5 * (H(i, j) + H(j, i));
    }
    if (!H.allFinite()) return;
    shiftHessian(k, n, 1.0);
    n.h2_added = true;
  }
  /// Sets the diagonal shift of the node's Hessian to delta (inertia correction).
  void shiftDiagonal(int k, Node& n, double delta) {
    NodeData& d = *n.d;
    d.Lxx.diagonal().array() += delta - n.delta;
    if (k < N) d.Luu.diagonal().array() += delta - n.delta;
    n.delta = delta;
  }
  void shiftHessian(int k, Node& n, double sign) {
    NodeData& d = *n.d;
    d.Lxx += sign * n.H2.topLeftCorner(ndx, ndx);
    if (k < N) {
      d.Luu += sign * n.H2.bottomRightCorner(nu, nu);
      d.Lux += sign * n.H2.bottomLeftCorner(nu, ndx);
    }
  }

  void initRows(Node& n) const {
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

  /// KKT residuals of node k at the current linearisation and multipliers.
  void residuals(int k, Node& n) {
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
    const auto rowCoefficient = [&](int i, double relax) {
      if (n.kind(i) == kHard) {
        primal = std::max(primal, std::abs(n.c(i) - n.s(i)));
        const double sz = n.s(i) * n.z(i);
        sz_max = std::max(sz_max, sz);
        sz_min = std::min(sz_min, sz);
        msum += n.z(i);
        ++mcount;
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
  }

  // ---- phase 2: condensing and projection ------------------------------------------------
  void condenseNode(int k) {
    Node& n = node(k);
    const NodeData& d = *n.d;
    LqStage& st = lq.stage(k);
    const bool running = k < N;
    // The Riccati solver reads the lower triangles of Q and R only.
    st.Q.triangularView<Eigen::Lower>() = d.Lxx;
    st.q = d.lx;
    if (running) {
      st.R.triangularView<Eigen::Lower>() = d.Luu;
      st.S = d.Lux;
      st.r = d.lu;
      st.ne = d.ne;
      if (d.ne > 0) {
        st.Ex.topRows(d.ne) = d.Ex.topRows(d.ne);
        st.Eu.topRows(d.ne) = d.Eu.topRows(d.ne);
        st.e.head(d.ne) = d.e.head(d.ne);
      }
    } else {
      st.ne = 0;
    }
    // General rows: Hessian += G^T W G, gradient += G^T gamma.
    for (int i = 0; i < d.ni; ++i) {
      if (n.kind(i) == kHard) {
        n.W(i) = n.z(i) / n.s(i);
        n.gam(i) = n.W(i) * (n.c(i) - n.s(i)) - mu / n.s(i);
        n.soft_dual(i) = 0.0;
      } else {
        double d1 = 0.0, d2 = 0.0;
        relaxedLog(n.c(i), d.relaxation(i), d1, d2);
        n.W(i) = d.soft_weight(i) * d2;
        n.gam(i) = d.soft_weight(i) * d1;
        n.soft_dual(i) = -d.soft_weight(i) * d1;
      }
    }
    if (d.ni > 0) {
      const int m = d.ni;
      const auto Gx = d.Gx.topRows(m);
      const auto W = n.W.head(m);
      n.WGx.topRows(m).noalias() = W.asDiagonal() * Gx;
      st.Q.triangularView<Eigen::Lower>() += Gx.transpose() * n.WGx.topRows(m);
      st.q.noalias() += Gx.transpose() * n.gam.head(m);
      bool has_u = false;
      if (running) {
        for (int i = 0; i < m; ++i) has_u = has_u || (n.kind(i) == kHard);
      }
      if (has_u) {
        const auto Gu = d.Gu.topRows(m);
        n.WGu.topRows(m).noalias() = W.asDiagonal() * Gu;
        st.R.triangularView<Eigen::Lower>() += Gu.transpose() * n.WGu.topRows(m);
        st.S.noalias() += Gu.transpose() * n.WGx.topRows(m);
        st.r.noalias() += Gu.transpose() * n.gam.head(m);
      }
    }
    // Bounds: diagonal terms only.
    for (int i = ni_max; i < nrows; ++i) {
      if (n.kind(i) == kInactive) continue;
      const auto [input, lower, idx] = bound_rows[static_cast<std::size_t>(i - ni_max)];
      double W = 0.0, gam = 0.0;
      if (n.kind(i) == kHard) {
        W = n.z(i) / n.s(i);
        gam = W * (n.c(i) - n.s(i)) - mu / n.s(i);
      } else {
        double d1 = 0.0, d2 = 0.0;
        relaxedLog(n.c(i), relaxation(n, i), d1, d2);
        W = softWeight(n, i) * d2;
        gam = softWeight(n, i) * d1;
        n.soft_dual(i) = -softWeight(n, i) * d1;
      }
      if (input) {
        st.R(idx, idx) += W;
        st.r(idx) += lower ? gam : -gam;
      } else {
        st.Q(idx, idx) += W;
        st.q(idx) += lower ? gam : -gam;
      }
    }
    n.rank_ok = true;
    n.pivot_ratio = 1.0;
    if (running) n.rank_ok = lq.projectStage(k, set.rank_tolerance, &n.pivot_ratio);
  }

  enum class Factorization { Ok, RankDeficient, NotPositiveDefinite };
  /// Condensing + projection of every node and the backward Riccati sweep. With one
  /// thread, node k is condensed right before its backward step (its data still in
  /// cache). With more, a pipeline: every thread condenses the nodes it linearised (its
  /// chunk, from the top down), then helps with the highest chunks left, while thread 0
  /// runs the backward sweep as soon as its next node is ready (condensing a node itself
  /// when it would otherwise wait). Each node is
  /// condensed by the same arithmetic whichever thread takes it, and the sweep runs in
  /// one order, so the results do not depend on the thread count. On a rank failure,
  /// failed_node is the first such node.
  Factorization condenseAndFactor() {
    int rank_failed = -1;
    bool pd = true;
    const auto sweep = [&](int k) {
      if (!node(k).rank_ok) rank_failed = k;
      if (rank_failed < 0 && pd) pd = lq.backwardStage(k);
    };
    if (pool.size() == 1) {
      condenseNode(N);
      lq.beginBackward();
      for (int k = N - 1; k >= 0; --k) {
        condenseNode(k);
        sweep(k);
      }
    } else {
      const std::uint64_t run = ++pipeline_run;
      for (int t = 0; t < pool.size(); ++t) {
        chunk_next[static_cast<std::size_t>(t)].store(chunkBegin(t + 1) - 1,
                                                      std::memory_order_relaxed);
      }
      const auto condenseNext = [this, run](int id) {
        const int j = claimNode(id, true);
        if (j < 0) return false;
        condenseNode(j);
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
          sweep(k);
        }
      };
      pool.run(pool.size(), body);
    }
    if (rank_failed >= 0) {
      failed_node = rank_failed;
      return Factorization::RankDeficient;
    }
    return pd ? Factorization::Ok : Factorization::NotPositiveDefinite;
  }
  /// Forward Riccati sweep and the step recovery of every node: fused per node with one
  /// thread; with more, thread 0 runs the forward sweep while the others recover the
  /// nodes of their own chunk as soon as their forward stage is done, then help with the
  /// lowest chunks left (thread 0 joins after the sweep, its own chunk first).
  void forwardAndRecover() {
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
      chunk_next[static_cast<std::size_t>(t)].store(chunkBegin(t), std::memory_order_relaxed);
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

  // ---- phase 3: step recovery --------------------------------------------------------------
  void recoverNode(int k) {
    Node& n = node(k);
    const NodeData& d = *n.d;
    lq.recoverStage(k);
    const VectorXd& dx = lq.dx(k);
    const bool running = k < N;
    const VectorXd& du = running ? lq.du(k) : zero_u;
    double dphi = d.lx.dot(dx) + (running ? d.lu.dot(du) : 0.0);
    if (d.ni > 0) {
      auto t = n.tmp.head(d.ni);
      t.noalias() = d.Gx.topRows(d.ni) * dx;
      if (running) t.noalias() += d.Gu.topRows(d.ni) * du;
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
      const double dz = mu / s - z - (z / s) * ds;
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
    n.finite = std::isfinite(dphi) && dx.allFinite() && du.allFinite() && n.ds.allFinite() &&
               n.dz.allFinite() && lq.costate(k).allFinite() &&
               (!running || lq.equalityMultipliers(k).allFinite());
  }

  // ---- line search ---------------------------------------------------------------------------
  std::vector<VectorXd> scaled;  // per-node scaled tangent steps (manifold states)
  void trialPoint(int k, double alpha) {
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

  void evaluateTrial(int k) {
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
  void meritNode(int k, Node& n, const VectorXd& s) const {
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

  // ---- helpers --------------------------------------------------------------------------------
  template <class F>
  void forNodes(F&& f) {
    auto body = [&](int b, int e) {
      for (int k = b; k < e; ++k) f(k);
    };
    pool.run(N + 1, body);
  }

  void backup() {
    for (int k = 0; k <= N; ++k) {
      const auto kk = static_cast<std::size_t>(k);
      Node& n = node(k);
      xs_bak[kk] = xs[kk];
      if (k < N) us_bak[kk] = us[kk];
      n.s_bak = n.s;
      n.z_bak = n.z;
      n.lam_bak = n.lam;
      n.mult_bak = n.mult;
    }
  }
  void restore() {
    for (int k = 0; k <= N; ++k) {
      const auto kk = static_cast<std::size_t>(k);
      Node& n = node(k);
      xs[kk] = xs_bak[kk];
      if (k < N) us[kk] = us_bak[kk];
      n.s = n.s_bak;
      n.z = n.z_bak;
      n.lam = n.lam_bak;
      n.mult = n.mult_bak;
    }
  }

  /// Moves the solution n whole nodes earlier (warm start of a real-time update): node k
  /// takes node k + n; the tail repeats the old last state and input, its slacks and duals
  /// are reinitialised. The backup iterate is shifted the same way.
  void shiftNodes(int n) {
    auto shiftStates = [&](std::vector<VectorXd>& v) {
      for (int k = 0; k + n <= N; ++k)
        v[static_cast<std::size_t>(k)].swap(v[static_cast<std::size_t>(k + n)]);
      const auto last = static_cast<std::size_t>(N - n);
      for (int k = N - n + 1; k <= N; ++k) v[static_cast<std::size_t>(k)] = v[last];
    };
    auto shiftInputs = [&](std::vector<VectorXd>& v) {
      for (int k = 0; k + n < N; ++k)
        v[static_cast<std::size_t>(k)].swap(v[static_cast<std::size_t>(k + n)]);
      const auto last = static_cast<std::size_t>(N - 1 - n >= 0 ? N - 1 - n : N - 1);
      for (int k = std::max(N - n, 0); k < N; ++k) v[static_cast<std::size_t>(k)] = v[last];
    };
    shiftStates(xs);
    shiftStates(xs_bak);
    shiftInputs(us);
    shiftInputs(us_bak);
    for (int k = 0; k + n <= N; ++k) {
      Node& a = node(k);
      Node& b = node(k + n);
      a.s.swap(b.s);
      a.z.swap(b.z);
      a.lam.swap(b.lam);
      a.mult.swap(b.mult);
      a.s_bak.swap(b.s_bak);
      a.z_bak.swap(b.z_bak);
      a.lam_bak.swap(b.lam_bak);
      a.mult_bak.swap(b.mult_bak);
      std::swap(a.ni_prev, b.ni_prev);
    }
    for (int k = std::max(N - n, 0); k <= N; ++k) {
      Node& t = node(k);
      t.fresh = true;
      t.lam.setZero();
      t.lam_bak.setZero();
      // The backup tail keeps slacks/duals that are reinitialised at the next
      // linearisation anyway (fresh); mark them consistent with the primary ones.
      t.s_bak = t.s;
      t.z_bak = t.z;
    }
  }

  /// Infeasibility test at the iteration limit: the violation stays above the tolerance
  /// and did not halve over the last kStallWindow iterations.
  static constexpr int kStallWindow = 10;
  /// Infeasibility test when the direction breaks down (non-finite, not factorisable):
  /// some dual above kDualBlowUp while the violation is above the tolerance.
  static constexpr double kDualBlowUp = 1e12;
  bool dualsBlewUp(double primal) const {
    if (!(primal > set.infeasibility_tolerance)) return false;
    for (const Node& n : nodes) {
      for (int i = 0; i < nrows; ++i) {
        if (n.kind(i) == kHard && !(n.z(i) <= kDualBlowUp)) return true;
      }
    }
    return false;
  }
  bool violationStalled(double primal) const {
    const auto n = static_cast<int>(stats.size());
    if (!(primal > set.infeasibility_tolerance) || n <= kStallWindow) return false;
    return primal >= 0.5 * stats[static_cast<std::size_t>(n - 1 - kStallWindow)].primal_residual;
  }

  /// Restoration probe at the current iterate: one step of the minimum-norm problem
  /// (Hessian I, no cost gradient, same linearised constraints and barrier), backtracked
  /// on the violation alone. Takes the step and returns its length when it reduces the l1
  /// violation theta0 by at least 0.1 %, else keeps the iterate and returns 0.
  double feasibilityStep(double theta0) {
    use_curvature = false;
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
      condenseNode(k);
    });
    prob->stateSpace().difference(xs[0], x0, dx0);
    if (!lq.backward()) return 0.0;
    lq.forward(dx0);
    forNodes([this](int k) { recoverNode(k); });
    double alpha = 1.0;
    for (int k = 0; k <= N; ++k) {
      if (!node(k).finite) return 0.0;
      alpha = std::min(alpha, node(k).alpha_p);
    }
    for (int ls = 0; ls < std::max(set.max_line_search_steps, 1); ++ls) {
      forNodes([this, alpha](int k) { trialPoint(k, alpha); });
      forNodes([this](int k) { evaluateTrial(k); });
      double theta = 0.0;
      for (int k = 0; k <= N; ++k) theta += node(k).merit_theta;
      prob->stateSpace().difference(xs_trial[0], x0, dx0);
      theta += dx0.lpNorm<1>();
      if (std::isfinite(theta) && theta <= (1.0 - 1e-4 * alpha) * theta0) {
        if (theta > (1.0 - 1e-3) * theta0) return 0.0;  // stationary for the violation
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

  // ---- one full run --------------------------------------------------------------------------
  SolverStatus run(ConstVecRef x_init, bool realtime);
};

SolverStatus Solver::Impl::run(ConstVecRef x_init, bool realtime) {
  stats.clear();
  iterations = 0;
  failed_node = -1;
  message[0] = '\0';
  gains_valid.assign(gains_valid.size(), false);
  if (x_init.size() != nx || !x_init.allFinite()) {
    ROLLSTEP_MSG("initial state has the wrong size or non-finite entries");
    return status = SolverStatus::InvalidInput;
  }
  x0 = x_init;
  if (!has_guess) {
    for (auto& x : xs) x = x0;
    has_guess = true;
  }
  if (realtime) {
    mu = set.barrier_realtime;
  } else {
    mu = set.barrier_initial;
    for (auto& n : nodes) {
      n.fresh = true;
      n.lam.setZero();
    }
    filter.clear();
    filter_mu = -1.0;
    last_delta = 0.0;
  }
  const int max_it = realtime ? 1 : std::max(set.max_iterations, 0);

  for (;;) {
    IterationStats it;
    it.iteration = iterations;
    auto t_lin = Clock::now();
    use_curvature = !realtime && set.exact_hessian;
    forNodes([this](int k) { linearizeNode(k); });
    prob->stateSpace().difference(xs[0], x0, dx0);
    // Residuals (fixed order reduction).
    bool finite = dx0.allFinite();
    double primal = dx0.lpNorm<Eigen::Infinity>(), dual = 0.0, sz_max = 0.0, sz_min = kInf;
    double msum = 0.0, total_cost = 0.0;
    int mcount = 0;
    for (int k = 0; k <= N; ++k) {
      const Node& n = node(k);
      finite = finite && n.finite;
      primal = std::max(primal, n.primal);
      dual = std::max(dual, n.dual);
      sz_max = std::max(sz_max, n.sz_max);
      sz_min = std::min(sz_min, n.sz_min);
      msum += n.mult_sum;
      mcount += n.mult_count;
      total_cost += n.d->cost;
    }
    it.time_linearize_ms = msSince(t_lin);
    if (!finite || !std::isfinite(primal) || primal > set.divergence_threshold) {
      if (backup_valid) {
        restore();
        ROLLSTEP_MSG(
            "the iterate diverged (primal residual %.3g); the last good iterate was restored",
            primal);
        return status = SolverStatus::Diverged;
      }
      ROLLSTEP_MSG("the problem evaluates to non-finite values at the initial guess");
      return status = SolverStatus::InvalidInput;
    }
    const double sd = std::max(100.0, msum / std::max(mcount, 1)) / 100.0;
    const double dual_scaled = dual / sd;
    auto complMu = [&](double m) {
      return sz_min == kInf ? 0.0 : std::max(sz_max - m, m - sz_min);
    };
    cost = total_cost;
    it.cost = total_cost;
    it.primal_residual = primal;
    it.dual_residual = dual;
    it.complementarity = complMu(mu);

    if (!realtime) {
      const double e0 = std::max({primal, dual_scaled, sz_max});
      if (e0 <= set.kkt_tolerance) {
        it.barrier = mu;
        stats.push_back(it);
        has_solution = true;
        return status = SolverStatus::Converged;
      }
      if (iterations >= max_it) {
        it.barrier = mu;
        stats.push_back(it);
        has_solution = true;
        if (violationStalled(primal)) {
          ROLLSTEP_MSG(
              "locally infeasible: the constraint violation %.3g did not halve in the last %d "
              "of %d iterations",
              primal, kStallWindow, max_it);
          return status = SolverStatus::Infeasible;
        }
        ROLLSTEP_MSG("no convergence in %d iterations (KKT error %.3g)", max_it, e0);
        return status = SolverStatus::MaxIterations;
      }
      // Monotone (Fiacco-McCormick) barrier update.
      while (mu > set.barrier_min && std::max({primal, dual_scaled, complMu(mu)}) <= 10.0 * mu) {
        mu = std::max(set.barrier_min, std::min(set.barrier_decrease * mu, std::pow(mu, 1.5)));
      }
    }
    it.barrier = mu;

    // Search direction.
    auto t_ric = Clock::now();
    const Factorization fac = condenseAndFactor();
    if (fac == Factorization::RankDeficient) {
      const int k = failed_node;
      it.time_riccati_ms = msSince(t_ric);
      stats.push_back(it);
      std::snprintf(message, sizeof(message),
                    "equality rows of node %d are not full row rank in u (relative pivot %.3g, "
                    "%d rows, %d inputs)",
                    k, node(k).pivot_ratio, node(k).d->ne, nu);
      return status = SolverStatus::RankDeficientEqualities;
    }
    bool factored = fac == Factorization::Ok;
    if (use_curvature && (!factored || lq.regularization() > 0.0)) {
      // Not convex on the null space with the curvature: inertia correction as in Ipopt
      // (delta I added to the Hessian, delta grown until the Riccati factorisation
      // succeeds unregularised); Gauss-Newton if even a large shift fails.
      double delta = last_delta > 0.0 ? std::max(1e-8, last_delta / 3.0) : 1e-4;
      factored = false;
      for (int attempt = 0; attempt < 12 && !factored; ++attempt) {
        forNodes([this, delta](int k) {
          shiftDiagonal(k, node(k), delta);
          condenseNode(k);
        });
        factored = lq.backward() && lq.regularization() == 0.0;
        if (!factored) delta *= last_delta > 0.0 ? 8.0 : 100.0;
      }
      last_delta = factored ? delta : 0.0;
      if (!factored) {
        forNodes([this](int k) {
          Node& n = node(k);
          shiftDiagonal(k, n, 0.0);
          if (n.h2_added) shiftHessian(k, n, -1.0);
          n.h2_added = false;
          condenseNode(k);
        });
        factored = lq.backward();
      }
    } else if (use_curvature) {
      last_delta = 0.0;
    }
    if (!factored) {
      direction_ready = false;
      failed_node = lq.failedStage();
      stats.push_back(it);
      if (!realtime && dualsBlewUp(primal)) {
        ROLLSTEP_MSG("locally infeasible: the duals blew up (> %.3g) with the violation at %.3g",
                     kDualBlowUp, primal);
        return status = SolverStatus::Infeasible;
      }
      std::snprintf(message, sizeof(message),
                    "the reduced Hessian of node %d is not positive definite", failed_node);
      return status = SolverStatus::Diverged;
    }
    forwardAndRecover();
    direction_ready = true;
    double ap = 1.0, ad = 1.0, dphi = 0.0;
    finite = true;
    for (int k = 0; k <= N; ++k) {
      const Node& n = node(k);
      finite = finite && n.finite;
      ap = std::min(ap, n.alpha_p);
      ad = std::min(ad, n.alpha_d);
      dphi += n.dphi;
    }
    it.time_riccati_ms = msSince(t_ric);
    if (!finite) {
      const bool infeasible = !realtime && dualsBlewUp(primal);
      if (backup_valid) restore();
      stats.push_back(it);
      if (infeasible) {
        ROLLSTEP_MSG("locally infeasible: the duals blew up (> %.3g) with the violation at %.3g",
                     kDualBlowUp, primal);
        return status = SolverStatus::Infeasible;
      }
      ROLLSTEP_MSG("non-finite search direction; the last good iterate was kept");
      return status = SolverStatus::Diverged;
    }

    // Step length.
    auto t_upd = Clock::now();
    backup();
    backup_valid = true;
    double alpha = ap;
    if (!realtime && set.line_search) {
      double f0 = 0.0, theta0 = 0.0;
      for (int k = 0; k <= N; ++k) {
        Node& n = node(k);
        // Values of the current iterate: recompute rows from the linearisation.
        meritNode(k, n, n.s);
        f0 += n.merit_f;
        theta0 += n.merit_theta;
      }
      theta0 += dx0.lpNorm<1>();
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
      constexpr double kGammaTheta = 1e-5, kGammaF = 1e-8, kEta = 1e-4;
      const double f_tol = 1e-13 * (1.0 + std::abs(f0));  // round-off of the sums
      bool accepted = false;
      bool f_type = false;
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
        bool ok = std::isfinite(f) && std::isfinite(theta) && theta <= theta_max;
        for (std::size_t j = 0; ok && j < filter.size(); ++j) {
          ok = theta < filter[j].first || f < filter[j].second;
        }
        if (ok) {
          // Switching condition: the step promises an objective decrease that dominates
          // the (small) violation: then require Armijo on f, else decrease of theta or f.
          const bool switching = dphi < 0.0 && alpha * std::pow(-dphi, 2.3) > std::pow(theta0, 1.1);
          f_type = switching && theta0 <= theta_min;
          if (f_type) {
            ok = f <= f0 + kEta * alpha * dphi + f_tol;
          } else {
            ok = theta <= (1.0 - kGammaTheta) * theta0 || f <= f0 - kGammaF * theta0 + f_tol;
          }
        }
        if (ok) {
          accepted = true;
          break;
        }
        alpha *= 0.5;
      }
      if (accepted && !f_type) addToFilter((1.0 - kGammaTheta) * theta0, f0 - kGammaF * theta0);
      if (!accepted) {
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
            // One entry per iteration (stats is reserved for max_iterations + 2 entries).
            IterationStats& last = stats.back();
            last.primal_step = alpha_r;
            last.restoration = true;
            last.time_update_ms = msSince(t_upd);
            ++iterations;
            continue;
          }
          forNodes([this](int k) { linearizeNode(k); });  // outputs of the kept iterate
          ROLLSTEP_MSG(
              "locally infeasible: neither the Newton step nor a minimum-norm feasibility "
              "step reduces the constraint violation (max %.3g, l1 %.3g)",
              primal, theta0);
          return status = SolverStatus::Infeasible;
        }
        ROLLSTEP_MSG(
            "line search failed after %d backtracking steps (objective slope %.3g, "
            "violation %.3g)",
            set.max_line_search_steps, dphi, theta0);
        return status = SolverStatus::LineSearchFailed;
      }
      for (int k = 0; k <= N; ++k) {
        const auto kk = static_cast<std::size_t>(k);
        xs[kk] = xs_trial[kk];
        if (k < N) us[kk] = us_trial[kk];
        node(k).s = node(k).s_trial;
      }
    } else {
      forNodes([this, alpha](int k) {
        trialPoint(k, alpha);
        const auto kk = static_cast<std::size_t>(k);
        xs[kk] = xs_trial[kk];
        if (k < N) us[kk] = us_trial[kk];
        node(k).s = node(k).s_trial;
      });
    }
    // Duals and multipliers.
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
    it.primal_step = alpha;
    it.dual_step = ad;

    it.time_update_ms = msSince(t_upd);
    stats.push_back(it);
    ++iterations;
    has_solution = true;
    if (realtime) {
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
  }
}

// ------------------------------------------------------------------------------------------
void checkSettings(const SolverSettings& s) {
  const auto require = [](bool ok, const char* what) {
    if (!ok) throw std::invalid_argument(std::string("SolverSettings: ") + what);
  };
  const auto positive = [](double v) { return std::isfinite(v) && v > 0.0; };
  require(s.max_iterations >= 1, "max_iterations must be >= 1");
  require(positive(s.kkt_tolerance), "kkt_tolerance must be finite and > 0");
  require(positive(s.barrier_initial), "barrier_initial must be finite and > 0");
  require(positive(s.barrier_min), "barrier_min must be finite and > 0");
  require(s.barrier_min <= s.barrier_initial, "barrier_min must be <= barrier_initial");
  require(s.barrier_decrease > 0.0 && s.barrier_decrease < 1.0,
          "barrier_decrease must be in (0, 1)");
  require(positive(s.barrier_realtime), "barrier_realtime must be finite and > 0");
  require(s.fraction_to_boundary > 0.0 && s.fraction_to_boundary < 1.0,
          "fraction_to_boundary must be in (0, 1)");
  require(s.max_line_search_steps >= 1, "max_line_search_steps must be >= 1");
  require(s.rank_tolerance >= 0.0 && s.rank_tolerance < 1.0, "rank_tolerance must be in [0, 1)");
  require(s.num_threads >= 1, "num_threads must be >= 1");
  require(s.thread_spin_us >= 0, "thread_spin_us must be >= 0");
  require(s.divergence_threshold > 0.0, "divergence_threshold must be > 0 (inf: never)");
  require(s.infeasibility_tolerance >= 0.0, "infeasibility_tolerance must be >= 0 (inf: never)");
}

Solver::Solver(std::shared_ptr<ocp::OptimalControlProblem> problem, SolverSettings settings) {
  if (!problem) throw std::invalid_argument("Solver: null problem");
  checkSettings(settings);
  impl_ = std::make_unique<Impl>(std::move(problem), settings);
  impl_->scaled.assign(static_cast<std::size_t>(impl_->N) + 1, VectorXd::Zero(impl_->ndx));
}

Solver::~Solver() = default;

void Solver::setInitialGuess(const std::vector<VectorXd>& xs, const std::vector<VectorXd>& us) {
  Impl& m = *impl_;
  if (xs.size() != static_cast<std::size_t>(m.N) + 1 ||
      us.size() != static_cast<std::size_t>(m.N)) {
    throw std::invalid_argument("Solver::setInitialGuess: need N+1 states and N inputs");
  }
  for (const auto& x : xs) {
    if (x.size() != m.nx || !x.allFinite()) {
      throw std::invalid_argument(
          "Solver::setInitialGuess: a state has the wrong size or is not finite");
    }
  }
  for (const auto& u : us) {
    if (u.size() != m.nu || !u.allFinite()) {
      throw std::invalid_argument(
          "Solver::setInitialGuess: an input has the wrong size or is not finite");
    }
  }
  for (std::size_t k = 0; k < xs.size(); ++k) m.xs[k] = xs[k];
  m.backup_valid = false;
  for (std::size_t k = 0; k < us.size(); ++k) m.us[k] = us[k];
  for (auto& n : m.nodes) {
    n.fresh = true;
    n.lam.setZero();
  }
  m.has_guess = true;
}

SolverStatus Solver::solve(ConstVecRef x0) {
  Impl& m = *impl_;
  m.solution_t0 = m.prob->initialTime();
  m.last_shift = 0;
  return m.run(x0, m.set.mode == SolverMode::RealTime);
}

SolverStatus Solver::update(double t0, ConstVecRef x0) {
  Impl& m = *impl_;
  if (!std::isfinite(t0)) {
    m.stats.clear();
    std::snprintf(m.message, sizeof(m.message), "non-finite time");
    return m.status = SolverStatus::InvalidInput;
  }
  // The stored solution lives on the node grid that starts at solution_t0; it moves by
  // whole nodes only, so that updates faster than dt add up to a shift when they cover
  // one (the problem itself starts at t0, less than one node later).
  const double dt = m.prob->dt();
  m.last_shift = 0;
  const double nodes_moved = (t0 - m.solution_t0) / dt;
  if (!m.has_solution || !(nodes_moved > -1e-6) || nodes_moved >= 1e9) {
    m.solution_t0 = t0;  // nothing to shift, time went backwards, or a jump of ages
  } else {
    const int shift = static_cast<int>(std::floor(nodes_moved + 1e-6));
    if (shift > 0) {
      m.shiftNodes(std::min(shift, m.N));
      m.last_shift = shift;
      m.solution_t0 += shift * dt;
    }
  }
  m.prob->setInitialTime(t0);
  return m.run(x0, true);
}

const std::vector<VectorXd>& Solver::states() const { return impl_->xs; }
const std::vector<VectorXd>& Solver::inputs() const { return impl_->us; }
const VectorXd& Solver::equalityMultipliers(int k) const {
  return impl_->nodes.at(static_cast<std::size_t>(k)).mult;
}
const VectorXd& Solver::inequalityDuals(int k) const {
  return impl_->nodes.at(static_cast<std::size_t>(k)).z;
}
const VectorXd& Solver::slacks(int k) const {
  return impl_->nodes.at(static_cast<std::size_t>(k)).s;
}
const MatrixXd& Solver::feedbackGain(int k) const {
  Impl& m = *impl_;
  const auto kk = static_cast<std::size_t>(k);
  if (k < 0 || k >= m.N) throw std::out_of_range("Solver::feedbackGain: node out of range");
  if (!m.gains_valid[kk]) {
    if (m.direction_ready) {
      m.lq.feedbackGain(k, m.gains[kk]);
    } else {
      m.gains[kk].setZero();  // no factorisation yet
    }
    m.gains_valid[kk] = true;
  }
  return m.gains[kk];
}
const ocp::NodeData& Solver::nodeData(int k) const {
  return *impl_->nodes.at(static_cast<std::size_t>(k)).d;
}
const std::vector<IterationStats>& Solver::stats() const { return impl_->stats; }
int Solver::iterations() const { return impl_->iterations; }
int Solver::lastShift() const { return impl_->last_shift; }
SolverStatus Solver::status() const { return impl_->status; }
double Solver::cost() const { return impl_->cost; }
double Solver::barrier() const { return impl_->mu; }
int Solver::failedNode() const { return impl_->failed_node; }
const char* Solver::message() const { return impl_->message; }
const SolverSettings& Solver::settings() const { return impl_->set; }
void Solver::setSettings(const SolverSettings& s) {
  checkSettings(s);
  if (s.num_threads != impl_->set.num_threads || s.thread_spin_us != impl_->set.thread_spin_us) {
    throw std::invalid_argument(
        "Solver::setSettings: num_threads and thread_spin_us cannot change after construction");
  }
  impl_->set = s;
  impl_->stats.reserve(static_cast<std::size_t>(std::max(s.max_iterations, 1)) + 2);
  impl_->filter.reserve(static_cast<std::size_t>(std::max(s.max_iterations, 1)) + 2);
}
ocp::OptimalControlProblem& Solver::problem() { return *impl_->prob; }
const RiccatiSolver& Solver::riccati() const { return impl_->lq; }

}  // namespace rollstep::solver
