#pragma once
// Linear-quadratic test problems for the solver: built with the ocp API, and the same
// problem as one dense stacked QP (Eigen) for independent reference solutions.
#include <Eigen/Dense>
#include <cmath>
#include <limits>
#include <memory>
#include <random>
#include <vector>

#include "rollstep/ocp/cost.hpp"
#include "rollstep/ocp/problem.hpp"
#include "rollstep/ocp/residuals.hpp"
#include "test_models.hpp"

namespace rollstep::lqtest {

using ocp::MatrixXd;
using ocp::VectorXd;
constexpr double kInf = std::numeric_limits<double>::infinity();

/// Time-invariant LQ: x+ = A x + B u + c; running cost dt 0.5 |r|_W^2 with
/// r = Cx x + Cu u + cr; terminal cost 0.5 |Cf x + cf|_Wf^2; running rows
/// Ex x + Eu u + e = 0, Gx x + Gu u + g >= 0; bounds on u (running nodes) and x (nodes 1..N).
struct LqData {
  int nx = 0, nu = 0, N = 0;
  double dt = 0.1;
  MatrixXd A, B, Cx, Cu, Cf, Ex, Eu, Gx, Gu;
  VectorXd c, cr, w, cf, wf, e, g, ulo, uhi, xlo, xhi, x0;
  int ne() const { return static_cast<int>(e.size()); }
  int ni() const { return static_cast<int>(g.size()); }
};

inline MatrixXd randn(int r, int c, std::mt19937& rng, double s = 1.0) {
  std::normal_distribution<double> n(0.0, s);
  MatrixXd m(r, c);
  for (int j = 0; j < c; ++j)
    for (int i = 0; i < r; ++i) m(i, j) = n(rng);
  return m;
}

inline LqData randomLq(unsigned seed, int nx, int nu, int N, int ne, int ni) {
  std::mt19937 rng(seed);
  LqData d;
  d.nx = nx;
  d.nu = nu;
  d.N = N;
  d.A = MatrixXd::Identity(nx, nx) + randn(nx, nx, rng, 0.1);
  d.B = randn(nx, nu, rng, 0.3);
  d.c = randn(nx, 1, rng, 0.05);
  const int nr = nx + nu;
  d.Cx = randn(nr, nx, rng, 0.5);
  d.Cx.topRows(nx) += MatrixXd::Identity(nx, nx);
  d.Cu = randn(nr, nu, rng, 0.2);
  d.Cu.bottomRows(nu) += MatrixXd::Identity(nu, nu);
  d.cr = randn(nr, 1, rng, 0.5);
  d.w = VectorXd::Constant(nr, 1.0) + randn(nr, 1, rng, 0.1).cwiseAbs();
  d.Cf = MatrixXd::Identity(nx, nx) + randn(nx, nx, rng, 0.1);
  d.cf = randn(nx, 1, rng, 0.5);
  d.wf = VectorXd::Constant(nx, 5.0);
  d.Ex = randn(ne, nx, rng, 0.5);
  d.Eu = randn(ne, nu, rng, 1.0);
  d.e = randn(ne, 1, rng, 0.2);
  d.Gx = randn(ni, nx, rng, 0.3);
  d.Gu = randn(ni, nu, rng, 0.5);
  d.g = VectorXd::Constant(ni, 0.3) + randn(ni, 1, rng, 0.1);
  d.ulo = VectorXd::Constant(nu, -kInf);
  d.uhi = VectorXd::Constant(nu, kInf);
  d.xlo = VectorXd::Constant(nx, -kInf);
  d.xhi = VectorXd::Constant(nx, kInf);
  d.x0 = randn(nx, 1, rng, 1.0);
  return d;
}

inline std::shared_ptr<ocp::OptimalControlProblem> buildProblem(const LqData& d) {
  auto dyn = std::make_shared<testmodels::LinearDynamics>(d.A, d.B, d.c);
  auto p = std::make_shared<ocp::OptimalControlProblem>(dyn, d.N, d.dt);
  auto s = dyn->spacePtr();
  const VectorXd zx = VectorXd::Zero(d.nx);
  p->addCost("running", std::make_shared<ocp::LeastSquaresCost>(
                            std::make_shared<ocp::AffineResidual>(s, zx, d.Cx, d.Cu, d.cr), d.w));
  p->addCost(
      "terminal",
      std::make_shared<ocp::LeastSquaresCost>(
          std::make_shared<ocp::AffineResidual>(s, zx, d.Cf, MatrixXd::Zero(d.nx, d.nu), d.cf),
          d.wf),
      ocp::Stage::Terminal);
  if (d.ne() > 0)
    p->addEquality("eq", std::make_shared<ocp::AffineResidual>(s, zx, d.Ex, d.Eu, d.e));
  if (d.ni() > 0)
    p->addInequality("ineq", std::make_shared<ocp::AffineResidual>(s, zx, d.Gx, d.Gu, d.g));
  p->setInputBounds(d.ulo, d.uhi);
  p->setStateBounds(d.xlo, d.xhi);
  return p;
}

/// The stacked QP: z = [x_0 u_0 x_1 u_1 ... x_N]; min 0.5 z'Hz + h'z s.t. Aeq z = beq,
/// Ain z + bin >= 0. Dynamics rows are written as A x_k + B u_k - x_{k+1} = -c and the
/// initial row as -x_0 = -x0, so that the equality multipliers y of "H z + h + Aeq' y = 0"
/// are the solver's costates (lambda_0, lambda_1, ...) and equality multipliers.
struct DenseQp {
  MatrixXd H, Aeq, Ain;
  VectorXd h, beq, bin;
  int nz = 0;
  std::vector<int> row_node, row_index;  // per inequality row: node and solver row index
  int xi(int k, int nx, int nu) const { return k * (nx + nu); }
};

/// Builds the dense QP. Inequality rows follow the solver's layout (general rows, input
/// lower/upper, state lower/upper) so that they can be matched with its slacks and duals.
inline DenseQp denseQp(const LqData& d) {
  const int nx = d.nx, nu = d.nu, N = d.N, ne = d.ne(), ni = d.ni();
  DenseQp q;
  q.nz = N * (nx + nu) + nx;
  q.H = MatrixXd::Zero(q.nz, q.nz);
  q.h = VectorXd::Zero(q.nz);
  const int neq = nx * (N + 1) + ne * N;
  q.Aeq = MatrixXd::Zero(neq, q.nz);
  q.beq = VectorXd::Zero(neq);
  const MatrixXd W = d.w.asDiagonal();
  MatrixXd C(d.Cx.rows(), nx + nu);
  C << d.Cx, d.Cu;
  for (int k = 0; k < N; ++k) {
    const int o = q.xi(k, nx, nu);
    q.H.block(o, o, nx + nu, nx + nu) += d.dt * C.transpose() * W * C;
    q.h.segment(o, nx + nu) += d.dt * C.transpose() * W * d.cr;
  }
  const int oN = q.xi(N, nx, nu);
  q.H.block(oN, oN, nx, nx) += d.Cf.transpose() * d.wf.asDiagonal() * d.Cf;
  q.h.segment(oN, nx) += d.Cf.transpose() * d.wf.asDiagonal() * d.cf;
  // Equalities in the order lambda_0, (lambda_{k+1}, nu_k)_k.
  int r = 0;
  q.Aeq.block(r, 0, nx, nx) = -MatrixXd::Identity(nx, nx);
  q.beq.segment(r, nx) = -d.x0;
  r += nx;
  for (int k = 0; k < N; ++k) {
    const int o = q.xi(k, nx, nu);
    q.Aeq.block(r, o, nx, nx) = d.A;
    q.Aeq.block(r, o + nx, nx, nu) = d.B;
    q.Aeq.block(r, o + nx + nu, nx, nx) = -MatrixXd::Identity(nx, nx);
    q.beq.segment(r, nx) = -d.c;
    r += nx;
    if (ne > 0) {
      q.Aeq.block(r, o, ne, nx) = d.Ex;
      q.Aeq.block(r, o + nx, ne, nu) = d.Eu;
      q.beq.segment(r, ne) = -d.e;
      r += ne;
    }
  }
  // Inequalities.
  std::vector<Eigen::RowVectorXd> rows;
  std::vector<double> consts;
  int nbu = 0, nbx = 0;
  for (int j = 0; j < nu; ++j) nbu += (std::isfinite(d.ulo(j)) || std::isfinite(d.uhi(j))) ? 1 : 0;
  for (int j = 0; j < nx; ++j) nbx += (std::isfinite(d.xlo(j)) || std::isfinite(d.xhi(j))) ? 1 : 0;
  auto add = [&](int k, int index, const Eigen::RowVectorXd& row, double cst) {
    rows.push_back(row);
    consts.push_back(cst);
    q.row_node.push_back(k);
    q.row_index.push_back(index);
  };
  for (int k = 0; k <= N; ++k) {
    const int o = q.xi(k, nx, nu);
    if (k < N) {
      for (int i = 0; i < ni; ++i) {
        Eigen::RowVectorXd row = Eigen::RowVectorXd::Zero(q.nz);
        row.segment(o, nx) = d.Gx.row(i);
        row.segment(o + nx, nu) = d.Gu.row(i);
        add(k, i, row, d.g(i));
      }
      int j = 0;
      for (int c = 0; c < nu; ++c) {
        if (!(std::isfinite(d.ulo(c)) || std::isfinite(d.uhi(c)))) continue;
        Eigen::RowVectorXd row = Eigen::RowVectorXd::Zero(q.nz);
        row(o + nx + c) = 1.0;
        if (std::isfinite(d.ulo(c))) add(k, ni + j, row, -d.ulo(c));
        if (std::isfinite(d.uhi(c))) add(k, ni + nbu + j, -row, d.uhi(c));
        ++j;
      }
    }
    if (k > 0) {
      int j = 0;
      for (int c = 0; c < nx; ++c) {
        if (!(std::isfinite(d.xlo(c)) || std::isfinite(d.xhi(c)))) continue;
        Eigen::RowVectorXd row = Eigen::RowVectorXd::Zero(q.nz);
        row(o + c) = 1.0;
        if (std::isfinite(d.xlo(c))) add(k, ni + 2 * nbu + j, row, -d.xlo(c));
        if (std::isfinite(d.xhi(c))) add(k, ni + 2 * nbu + nbx + j, -row, d.xhi(c));
        ++j;
      }
    }
  }
  q.Ain = MatrixXd::Zero(static_cast<int>(rows.size()), q.nz);
  q.bin = VectorXd::Zero(static_cast<int>(rows.size()));
  for (std::size_t i = 0; i < rows.size(); ++i) {
    q.Ain.row(static_cast<int>(i)) = rows[i];
    q.bin(static_cast<int>(i)) = consts[i];
  }
  return q;
}

struct DenseSolution {
  VectorXd z, y, mu;  // primal, equality multipliers, active-inequality multipliers (>= 0)
};

/// Solves the QP with the given inequality rows imposed as equalities (one dense KKT
/// solve): [H Aeq' -Aa'; Aeq 0 0; Aa 0 0] [z; y; mu] = [-h; beq; -ba].
inline DenseSolution denseKkt(const DenseQp& q, const std::vector<int>& active) {
  const int na = static_cast<int>(active.size());
  const int ne = static_cast<int>(q.Aeq.rows());
  const int n = q.nz + ne + na;
  MatrixXd K = MatrixXd::Zero(n, n);
  VectorXd rhs = VectorXd::Zero(n);
  K.topLeftCorner(q.nz, q.nz) = q.H;
  K.block(0, q.nz, q.nz, ne) = q.Aeq.transpose();
  K.block(q.nz, 0, ne, q.nz) = q.Aeq;
  rhs.head(q.nz) = -q.h;
  rhs.segment(q.nz, ne) = q.beq;
  for (int a = 0; a < na; ++a) {
    const int r = active[static_cast<std::size_t>(a)];
    K.block(0, q.nz + ne + a, q.nz, 1) = -q.Ain.row(r).transpose();
    K.block(q.nz + ne + a, 0, 1, q.nz) = q.Ain.row(r);
    rhs(q.nz + ne + a) = -q.bin(r);
  }
  const VectorXd sol = K.fullPivLu().solve(rhs);
  DenseSolution s;
  s.z = sol.head(q.nz);
  s.y = sol.segment(q.nz, ne);
  s.mu = sol.tail(na);
  return s;
}

}  // namespace rollstep::lqtest
