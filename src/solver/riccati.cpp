#include "rollstep/solver/riccati.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Householder>
#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace rollstep::solver {

using Eigen::MatrixXd;
using Eigen::VectorXd;

RiccatiSolver::RiccatiSolver(int horizon, int nx, int nu, int ne_max)
    : N_(horizon), nx_(nx), nu_(nu), ne_max_(ne_max) {
  if (horizon < 1 || nx < 0 || nu < 0 || ne_max < 0) {
    throw std::invalid_argument("RiccatiSolver: bad dimensions");
  }
  stages_.resize(static_cast<std::size_t>(N_) + 1);
  work_.resize(static_cast<std::size_t>(N_) + 1);
  const int nz = nu + nx;
  for (auto& s : stages_) {
    s.Q = MatrixXd::Zero(nx, nx);
    s.S = MatrixXd::Zero(nu, nx);
    s.R = MatrixXd::Zero(nu, nu);
    s.q = VectorXd::Zero(nx);
    s.r = VectorXd::Zero(nu);
    s.A = MatrixXd::Zero(nx, nx);
    s.B = MatrixXd::Zero(nx, nu);
    s.b = VectorXd::Zero(nx);
    s.Ex = MatrixXd::Zero(ne_max, nx);
    s.Eu = MatrixXd::Zero(ne_max, nu);
    s.e = VectorXd::Zero(ne_max);
  }
  for (auto& w : work_) {
    w.qr = MatrixXd::Zero(nu, ne_max);
    w.tau = VectorXd::Zero(ne_max);
    w.perm = Eigen::VectorXi::Zero(ne_max);
    w.Qm = MatrixXd::Zero(nu, nu);
    w.hh = VectorXd::Zero(nz + 2);
    w.T = MatrixXd::Zero(nu, nz + 1);
    w.Y = MatrixXd::Zero(ne_max, nx + 1);
    w.RT = MatrixXd::Zero(nu, nz + 1);
    w.Hr = MatrixXd::Zero(nz, nz);
    w.gr = VectorXd::Zero(nz);
    w.BA = MatrixXd::Zero(nx, nz + 1);
    w.PBA = MatrixXd::Zero(nx, nz);
    w.M = MatrixXd::Zero(nz, nz);
    w.hm = VectorXd::Zero(nz);
    w.pb = VectorXd::Zero(nx);
    w.P = MatrixXd::Zero(nx, nx);
    w.p = VectorXd::Zero(nx);
    w.dx = VectorXd::Zero(nx);
    w.w = VectorXd::Zero(nu);
    w.du = VectorXd::Zero(nu);
    w.lam = VectorXd::Zero(nx);
    w.mult = VectorXd::Zero(ne_max);
    w.rho = VectorXd::Zero(nu);
    w.t = VectorXd::Zero(nu);
    w.Kw = MatrixXd::Zero(nu, nx);
    w.nw = nu;
  }
}

bool RiccatiSolver::projectStage(int k, double rank_tolerance, double* pivot_ratio) {
  const LqStage& s = stages_[idx(k)];
  Work& w = work_[idx(k)];
  const int nx = nx_, nu = nu_, ne = s.ne;
  if (pivot_ratio) *pivot_ratio = 1.0;
  if (ne < 0 || ne > ne_max_) throw std::out_of_range("RiccatiSolver::projectStage: bad ne");

  if (ne == 0) {
    // No equalities: the reduced problem is the stage itself (w = du).
    w.nw = nu;
    w.Hr.topLeftCorner(nu, nu) = s.R;
    w.Hr.block(0, nu, nu, nx) = s.S;
    w.Hr.block(nu, 0, nx, nu) = s.S.transpose();
    w.Hr.block(nu, nu, nx, nx) = s.Q;
    w.gr.head(nu) = s.r;
    w.gr.tail(nx) = s.q;
    w.BA.leftCols(nu) = s.B;
    w.BA.middleCols(nu, nx) = s.A;
    w.BA.col(nu + nx) = s.b;
    w.mult.setZero();
    return true;
  }
  if (ne > nu) {
    if (pivot_ratio) *pivot_ratio = 0.0;
    return false;
  }

  // Householder QR with column pivoting of Eu^T (nu x ne): Eu^T P = Q [R; 0].
  auto A = w.qr.leftCols(ne);
  A = s.Eu.topRows(ne).transpose();
  for (int j = 0; j < ne; ++j) w.perm(j) = j;
  double r00 = 0.0, min_ratio = 1.0;
  for (int j = 0; j < ne; ++j) {
    int best = j;
    double best_norm = A.col(j).tail(nu - j).squaredNorm();
    for (int c = j + 1; c < ne; ++c) {
      const double n = A.col(c).tail(nu - j).squaredNorm();
      if (n > best_norm) {
        best_norm = n;
        best = c;
      }
    }
    if (best != j) {
      A.col(j).swap(A.col(best));
      std::swap(w.perm(j), w.perm(best));
    }
    double beta = 0.0;
    A.col(j).tail(nu - j).makeHouseholderInPlace(w.tau(j), beta);
    A(j, j) = beta;
    if (j == 0) r00 = std::abs(beta);
    const double ratio = (r00 > 0.0 && std::isfinite(r00)) ? std::abs(beta) / r00 : 0.0;
    min_ratio = std::min(min_ratio, ratio);
    if (!(ratio > rank_tolerance)) {
      if (pivot_ratio) *pivot_ratio = ratio;
      return false;
    }
    if (j + 1 < ne) {
      A.block(j, j + 1, nu - j, ne - j - 1)
          .applyHouseholderOnTheLeft(A.col(j).tail(nu - j - 1), w.tau(j), w.hh.data());
    }
  }
  if (pivot_ratio) *pivot_ratio = min_ratio;

  // Explicit Q = H_0 ... H_{ne-1} (backward accumulation).
  w.Qm.setIdentity();
  for (int j = ne - 1; j >= 0; --j) {
    w.Qm.bottomRightCorner(nu - j, nu - j)
        .applyHouseholderOnTheLeft(A.col(j).tail(nu - j - 1), w.tau(j), w.hh.data());
  }

  // Particular solution: Eu du = -(e + Ex dx)  =>  du_p = -Q1 R^-T P^T [Ex e] [dx; 1].
  const int nw = nu - ne;
  w.nw = nw;
  auto Y = w.Y.topRows(ne);
  for (int j = 0; j < ne; ++j) {
    const int row = w.perm(j);
    Y.row(j).head(nx) = s.Ex.row(row);
    Y(j, nx) = s.e(row);
  }
  A.topRows(ne).triangularView<Eigen::Upper>().transpose().solveInPlace(Y);
  auto T = w.T.leftCols(nw + nx + 1);
  T.leftCols(nw) = w.Qm.rightCols(nw);
  T.rightCols(nx + 1).noalias() = -w.Qm.leftCols(ne) * Y;
  const auto Z = T.leftCols(nw);
  const auto Dx = T.middleCols(nw, nx);
  const auto d0 = T.col(nw + nx);

  // Reduced Hessian and gradient in [w; dx].
  auto RT = w.RT.leftCols(nw + nx + 1);
  RT.noalias() = s.R * T;
  RT.middleCols(nw, nx) += s.S;
  RT.col(nw + nx) += s.r;
  w.Hr.topLeftCorner(nw, nw + nx).noalias() = Z.transpose() * RT.leftCols(nw + nx);
  w.gr.head(nw).noalias() = Z.transpose() * RT.col(nw + nx);
  w.Hr.block(nw, 0, nx, nw) = w.Hr.block(0, nw, nw, nx).transpose();
  auto Hxx = w.Hr.block(nw, nw, nx, nx);
  Hxx = s.Q;
  Hxx.noalias() += Dx.transpose() * RT.middleCols(nw, nx);
  Hxx.noalias() += s.S.transpose() * Dx;
  auto gx = w.gr.segment(nw, nx);
  gx = s.q;
  gx.noalias() += s.S.transpose() * d0;
  gx.noalias() += Dx.transpose() * RT.col(nw + nx);

  // Reduced dynamics [B Z, A + B Dx | b + B d0].
  auto BA = w.BA.leftCols(nw + nx + 1);
  BA.noalias() = s.B * T;
  BA.middleCols(nw, nx) += s.A;
  BA.col(nw + nx) += s.b;
  return true;
}

bool RiccatiSolver::backward() {
  const int nx = nx_;
  failed_stage_ = -1;
  regularization_ = 0.0;
  {
    Work& t = work_[idx(N_)];
    t.P.triangularView<Eigen::Lower>() = stages_[idx(N_)].Q;
    t.p = stages_[idx(N_)].q;
  }
  for (int k = N_ - 1; k >= 0; --k) {
    Work& w = work_[idx(k)];
    const Work& n = work_[idx(k + 1)];
    const int nw = w.nw, nz = nw + nx;
    const auto BA = w.BA.leftCols(nz);
    const auto br = w.BA.col(nz);
    auto PBA = w.PBA.leftCols(nz);
    PBA.noalias() = n.P.selfadjointView<Eigen::Lower>() * BA;
    auto M = w.M.topLeftCorner(nz, nz);
    M.triangularView<Eigen::Lower>() = w.Hr.topLeftCorner(nz, nz);
    M.triangularView<Eigen::Lower>() += BA.transpose() * PBA;
    w.pb = n.p;
    w.pb.noalias() += n.P.selfadjointView<Eigen::Lower>() * br;
    auto h = w.hm.head(nz);
    h = w.gr.head(nz);
    h.noalias() += BA.transpose() * w.pb;

    if (nw > 0) {
      Eigen::Ref<MatrixXd> Mww(w.M.topLeftCorner(nw, nw));
      bool ok = false;
      double reg = 0.0;
      for (int attempt = 0; attempt < 6 && !ok; ++attempt) {
        if (attempt > 0) {
          // Rebuild the block and shift it (rare path: singular reduced Hessian).
          const double scale = 1.0 + w.Hr.topLeftCorner(nw, nw).diagonal().cwiseAbs().maxCoeff();
          reg = (attempt == 1) ? 1e-12 * scale : reg * 100.0;
          Mww.triangularView<Eigen::Lower>() = w.Hr.topLeftCorner(nw, nw);
          Mww.triangularView<Eigen::Lower>() +=
              BA.leftCols(nw).transpose() * PBA.leftCols(nw);
          Mww.diagonal().array() += reg;
        }
        Eigen::LLT<Eigen::Ref<MatrixXd>> llt(Mww);
        ok = llt.info() == Eigen::Success && std::isfinite(Mww.diagonal().sum());
      }
      if (!ok) {
        failed_stage_ = k;
        return false;
      }
      regularization_ = std::max(regularization_, reg);
      auto Lxw = w.M.block(nw, 0, nx, nw);
      Mww.transpose().triangularView<Eigen::Upper>().solveInPlace<Eigen::OnTheRight>(Lxw);
      auto v = w.hm.head(nw);
      Mww.triangularView<Eigen::Lower>().solveInPlace(v);
      w.P.triangularView<Eigen::Lower>() = w.M.block(nw, nw, nx, nx);
      w.P.selfadjointView<Eigen::Lower>().rankUpdate(Lxw, -1.0);
      w.p = w.hm.segment(nw, nx);
      w.p.noalias() -= Lxw * v;
    } else {
      w.P.triangularView<Eigen::Lower>() = w.M.block(0, 0, nx, nx);
      w.p = w.hm.head(nx);
    }
  }
  return true;
}

void RiccatiSolver::forward(const Eigen::Ref<const VectorXd>& dx0) {
  const int nx = nx_;
  work_[0].dx = dx0;
  for (int k = 0; k < N_; ++k) {
    Work& w = work_[idx(k)];
    const int nw = w.nw, nz = nw + nx;
    auto wk = w.w.head(nw);
    if (nw > 0) {
      wk = w.hm.head(nw);
      wk.noalias() += w.M.block(nw, 0, nx, nw).transpose() * w.dx;
      w.M.topLeftCorner(nw, nw).transpose().triangularView<Eigen::Upper>().solveInPlace(wk);
      wk = -wk;
    }
    w.lam = w.p;
    w.lam.noalias() += w.P.selfadjointView<Eigen::Lower>() * w.dx;
    VectorXd& next = work_[idx(k + 1)].dx;
    next = w.BA.col(nz);
    next.noalias() += w.BA.leftCols(nw) * wk;
    next.noalias() += w.BA.middleCols(nw, nx) * w.dx;
  }
  Work& t = work_[idx(N_)];
  t.lam = t.p;
  t.lam.noalias() += t.P.selfadjointView<Eigen::Lower>() * t.dx;
}

void RiccatiSolver::recoverStage(int k) {
  if (k >= N_) return;
  const LqStage& s = stages_[idx(k)];
  Work& w = work_[idx(k)];
  const int nx = nx_, nu = nu_, ne = s.ne, nw = w.nw;
  if (ne == 0) {
    w.du = w.w;
    return;
  }
  w.du = w.T.col(nw + nx);
  w.du.noalias() += w.T.leftCols(nw) * w.w.head(nw);
  w.du.noalias() += w.T.middleCols(nw, nx) * w.dx;
  // Stationarity in du: rho + Eu^T nu = 0 with rho = R du + S dx + r + B^T lambda_{k+1};
  // Eu^T = Q1 R P^T  =>  nu = -P R^-1 Q1^T rho.
  w.rho = s.r;
  w.rho.noalias() += s.R * w.du;
  w.rho.noalias() += s.S * w.dx;
  w.rho.noalias() += s.B.transpose() * work_[idx(k + 1)].lam;
  auto y = w.t.head(ne);
  y.noalias() = w.Qm.leftCols(ne).transpose() * w.rho;
  w.qr.topLeftCorner(ne, ne).triangularView<Eigen::Upper>().solveInPlace(y);
  w.mult.setZero();
  for (int j = 0; j < ne; ++j) w.mult(w.perm(j)) = -y(j);
  (void)nu;
}

bool RiccatiSolver::solve(const Eigen::Ref<const VectorXd>& dx0, double rank_tolerance) {
  for (int k = 0; k < N_; ++k) {
    if (!projectStage(k, rank_tolerance)) {
      failed_stage_ = k;
      return false;
    }
  }
  if (!backward()) return false;
  forward(dx0);
  for (int k = 0; k < N_; ++k) recoverStage(k);
  return true;
}

void RiccatiSolver::feedbackGain(int k, MatrixXd& K) const {
  const Work& w = work_[idx(k)];
  const int nx = nx_, nw = w.nw;
  auto Kw = w.Kw.topRows(nw);
  if (nw > 0) {
    Kw = -w.M.block(nw, 0, nx, nw).transpose();
    w.M.topLeftCorner(nw, nw).transpose().triangularView<Eigen::Upper>().solveInPlace(Kw);
  }
  if (stages_[idx(k)].ne == 0) {
    K = Kw;
  } else {
    K = w.T.middleCols(nw, nx);
    K.noalias() += w.T.leftCols(nw) * Kw;
  }
}

}  // namespace rollstep::solver
