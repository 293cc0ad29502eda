// What memory does the solver hold? Dimensions first, then every workspace sized from
// them at construction (nodes, trajectories, Riccati stages, thread pool, filter), so
// that solve() and update() only touch memory that already exists.
#include "solver_impl.hpp"

namespace rollstep::solver {

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
      chunk_next(new std::atomic<int>[static_cast<std::size_t>(pool.size())]) {
  has_curvature = prob->hasCurvature();
  for (int k = 0; k <= N; ++k) ready[static_cast<std::size_t>(k)].store(0);
  nodes.resize(static_cast<std::size_t>(N) + 1);
  for (int i = ni_max; i < nrows; ++i) {
    bound_rows.push_back(
        detail::boundRow(i, ni_max, nbu, nbx, prob->inputBounds(), prob->stateBounds()));
  }
  for (auto& n : nodes) {
    n.d = prob->createNodeData();
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
    n.J0 = MatrixXd::Zero(ndx, ndx);
    n.J1 = MatrixXd::Zero(ndx, ndx);
    n.rx = VectorXd::Zero(ndx);
    n.ru = VectorXd::Zero(nu);
    n.tmp = VectorXd::Zero(std::max(ni_max, 1));
    n.WGu = MatrixXd::Zero(ni_max, nu);
    n.WGx = MatrixXd::Zero(ni_max, ndx);
    n.row_parts = Eigen::VectorXi::Zero(ni_max);
    n.W = VectorXd::Zero(ni_max);
    n.Wc = VectorXd::Zero(ni_max);
    n.gamc = VectorXd::Zero(ni_max);
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
  scaled.assign(static_cast<std::size_t>(N) + 1, VectorXd::Zero(ndx));
}

}  // namespace rollstep::solver
