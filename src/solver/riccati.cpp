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
  PBA_ = MatrixXd::Zero(nx, nu + nx);
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
    w.qr = MatrixXd::Zero(ne_max, nz + 1);
    w.tau = VectorXd::Zero(ne_max);
    w.perm = Eigen::VectorXi::LinSpaced(nu, 0, nu - 1);
    w.hh = VectorXd::Zero(nz + 2);
    w.T = MatrixXd::Zero(ne_max, nz + 1);
    w.HD = MatrixXd::Zero(ne_max, nz + 1);
    w.HDD = MatrixXd::Zero(ne_max, ne_max);
    w.BD = MatrixXd::Zero(nx, ne_max);
    w.Hr = MatrixXd::Zero(nz + 1, nz + 1);
    w.cn = VectorXd::Zero(nu);
    w.gr = VectorXd::Zero(nz);
    w.BA = MatrixXd::Zero(nx, nz + 1);
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
    w.KD = MatrixXd::Zero(ne_max, nx);
    w.nw = nu;
  }
}

namespace {
/// Applies H = I - tau v v^T, v = [1; F(j+1:ne, j)], to F(j:ne, c0:c1) (raw loops: the
/// blocks are tiny and Eigen's generic path costs more than the arithmetic).
template <class Mat>
void applyReflector(Mat& F, int j, int ne, int c0, int c1, double tau) {
  if (tau == 0.0) return;
  const Eigen::Index ld = F.outerStride();
  double* base = F.data();
  const double* v = base + j * ld + j;  // v[0] is R(j, j); the essential part follows
  const int m = ne - j;
  for (int c = c0; c < c1; ++c) {
    double* col = base + c * ld + j;
    double dot = col[0];
    for (int i = 1; i < m; ++i) dot += v[i] * col[i];
    dot *= tau;
    col[0] -= dot;
    for (int i = 1; i < m; ++i) col[i] -= dot * v[i];
  }
}
}  // namespace

bool RiccatiSolver::projectStage(int k, double rank_tolerance, double* pivot_ratio) {
  const LqStage& s = stages_[idx(k)];
  Work& w = work_[idx(k)];
  const int nx = nx_, nu = nu_, ne = s.ne;
  if (pivot_ratio) *pivot_ratio = 1.0;
  if (ne < 0 || ne > ne_max_) throw std::out_of_range("RiccatiSolver::projectStage: bad ne");
  if (ne > nu) {
    if (pivot_ratio) *pivot_ratio = 0.0;
    return false;
  }
  for (int c = 0; c < nu; ++c) w.perm(c) = c;

  // Householder QR with column pivoting of Eu (ne x nu): Eu P = Q [R11 R12], applied to
  // the augmented [Eu | Ex | e] so that Q^T [Ex e] comes out of the same sweep.
  auto F = w.qr.topRows(ne);
  if (ne > 0) {
    F.leftCols(nu) = s.Eu.topRows(ne);
    F.middleCols(nu, nx) = s.Ex.topRows(ne);
    F.col(nu + nx) = s.e.head(ne);
    double r00 = 0.0, min_ratio = 1.0;
    auto norms = w.cn.head(nu);
    norms = F.leftCols(nu).colwise().squaredNorm().transpose();
    for (int j = 0; j < ne; ++j) {
      if (j > 0) {
        // Downdate the remaining column norms by the row just eliminated (LAPACK xGEQPF);
        // recompute exactly when cancellation makes the downdate unreliable.
        for (int c = j; c < nu; ++c) {
          norms(c) -= F(j - 1, c) * F(j - 1, c);
          if (norms(c) < 1e-3 * std::abs(F(j - 1, c) * F(j - 1, c)) || norms(c) < 0.0) {
            norms(c) = F.col(c).segment(j, ne - j).squaredNorm();
          }
        }
      }
      int best = j;
      for (int c = j + 1; c < nu; ++c) {
        if (norms(c) > norms(best)) best = c;
      }
      if (best != j) {
        F.col(j).swap(F.col(best));
        std::swap(w.perm(j), w.perm(best));
        std::swap(norms(j), norms(best));
      }
      double beta = 0.0;
      F.col(j).segment(j, ne - j).makeHouseholderInPlace(w.tau(j), beta);
      F(j, j) = beta;
      if (j == 0) r00 = std::abs(beta);
      const double ratio = (r00 > 0.0 && std::isfinite(r00)) ? std::abs(beta) / r00 : 0.0;
      min_ratio = std::min(min_ratio, ratio);
      if (!(ratio > rank_tolerance)) {
        if (pivot_ratio) *pivot_ratio = ratio;
        return false;
      }
      applyReflector(F, j, ne, j + 1, nu + nx + 1, w.tau(j));
    }
    if (pivot_ratio) *pivot_ratio = min_ratio;
  }

  const int nw = nu - ne, nz = nw + nx;
  w.nw = nw;
  const int* pD = w.perm.data();
  const int* pI = w.perm.data() + ne;

  // Dependent inputs: du_D = T [w; dx; 1] with T = -R11^-1 [R12 | Q^T Ex | Q^T e].
  auto T = w.T.topLeftCorner(ne, nz + 1);
  if (ne > 0) {
    T = F.rightCols(nz + 1);  // [R12 | Q^T Ex | Q^T e]
    F.leftCols(ne).triangularView<Eigen::Upper>().solveInPlace(T);
    T = -T;
  }

  // Reduced augmented Hessian in [w; dx; 1] (lower triangle): gather the independent
  // part, then add T^T Y + Y^T T with Y = H_Dv + 0.5 H_DD T.
  auto H = w.Hr.topLeftCorner(nz + 1, nz + 1);
  // Raw column-major gathers (contiguous writes, reads within one column of R or S).
  const double* Rp = s.R.data();
  const double* Sp = s.S.data();
  const Eigen::Index ldR = s.R.outerStride(), ldS = s.S.outerStride();
  double* Hp = w.Hr.data();
  const Eigen::Index ldH = w.Hr.outerStride();
  for (int j = 0; j < nw; ++j) {
    const double* Rc = Rp + pI[j] * ldR;
    double* Hc = Hp + j * ldH;
    for (int i = j; i < nw; ++i) Hc[i] = Rc[pI[i]];
    for (int a = 0; a < nx; ++a) Hc[nw + a] = Sp[pI[j] + a * ldS];
    Hc[nz] = s.r(pI[j]);
  }
  H.block(nw, nw, nx, nx).triangularView<Eigen::Lower>() = s.Q;
  H.row(nz).segment(nw, nx) = s.q.transpose();
  H(nz, nz) = 0.0;
  auto BA = w.BA.leftCols(nz + 1);
  for (int j = 0; j < nw; ++j) BA.col(j) = s.B.col(pI[j]);
  BA.middleCols(nw, nx) = s.A;
  BA.col(nz) = s.b;
  if (ne > 0) {
    auto Y = w.HD.topLeftCorner(ne, nz + 1);
    auto HDD = w.HDD.topLeftCorner(ne, ne);
    double* Yp = w.HD.data();
    double* Dp = w.HDD.data();
    const Eigen::Index ldY = w.HD.outerStride(), ldD = w.HDD.outerStride();
    for (int j = 0; j < nw; ++j) {
      const double* Rc = Rp + pI[j] * ldR;
      double* Yc = Yp + j * ldY;
      for (int i = 0; i < ne; ++i) Yc[i] = Rc[pD[i]];
    }
    for (int a = 0; a < nx; ++a) {
      const double* Sc = Sp + a * ldS;
      double* Yc = Yp + (nw + a) * ldY;
      for (int i = 0; i < ne; ++i) Yc[i] = Sc[pD[i]];
    }
    for (int i = 0; i < ne; ++i) Yp[i + nz * ldY] = s.r(pD[i]);
    for (int j = 0; j < ne; ++j) {
      const double* Rc = Rp + pD[j] * ldR;
      double* Dc = Dp + j * ldD;
      for (int i = 0; i < ne; ++i) Dc[i] = Rc[pD[i]];
    }
    Y.noalias() += 0.5 * HDD * T;
    // T^T Y goes into M (free until backward(); nz + 1 <= nu + nx when ne > 0).
    auto TY = w.M.topLeftCorner(nz + 1, nz + 1);
    TY.noalias() = T.transpose() * Y;
    const double* TYp = w.M.data();
    const Eigen::Index ldT = w.M.outerStride();
    for (int j = 0; j <= nz; ++j) {
      double* Hc = Hp + j * ldH;
      const double* Tc = TYp + j * ldT;
      for (int i = j; i <= nz; ++i) Hc[i] += Tc[i] + TYp[j + i * ldT];
    }
    auto BD = w.BD.leftCols(ne);
    for (int i = 0; i < ne; ++i) BD.col(i) = s.B.col(pD[i]);
    BA.noalias() += BD * T;
  }
  w.gr.head(nz) = H.row(nz).head(nz).transpose();
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
    auto PBA = PBA_.leftCols(nz);
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
          Mww.triangularView<Eigen::Lower>() += BA.leftCols(nw).transpose() * PBA.leftCols(nw);
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
  const int nx = nx_, ne = s.ne, nw = w.nw, nz = nw + nx;
  const int* pD = w.perm.data();
  const int* pI = w.perm.data() + ne;
  for (int j = 0; j < nw; ++j) w.du(pI[j]) = w.w(j);
  w.mult.setZero();
  if (ne == 0) return;
  const auto T = w.T.topLeftCorner(ne, nz + 1);
  auto t = w.t.head(ne);
  t = T.col(nz);
  t.noalias() += T.leftCols(nw) * w.w.head(nw);
  t.noalias() += T.middleCols(nw, nx) * w.dx;
  for (int i = 0; i < ne; ++i) w.du(pD[i]) = t(i);
  // Stationarity in du: rho + Eu^T nu = 0 with rho = R du + S dx + r + B^T lambda_{k+1};
  // Eu = Q [R11 R12] P^T  =>  nu = -Q R11^-T rho_D.
  w.rho = s.r;
  w.rho.noalias() += s.R * w.du;
  w.rho.noalias() += s.S * w.dx;
  w.rho.noalias() += s.B.transpose() * work_[idx(k + 1)].lam;
  auto y = w.mult.head(ne);
  for (int i = 0; i < ne; ++i) y(i) = -w.rho(pD[i]);
  const auto F = w.qr.topRows(ne);
  F.leftCols(ne).triangularView<Eigen::Upper>().transpose().solveInPlace(y);
  for (int j = ne - 1; j >= 0; --j) {
    y.segment(j, ne - j).applyHouseholderOnTheLeft(F.col(j).segment(j + 1, ne - j - 1), w.tau(j),
                                                   w.hh.data());
  }
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

void RiccatiSolver::resolveVectors(const Eigen::Ref<const VectorXd>& dx0) {
  const int nx = nx_;
  for (int k = 0; k < N_; ++k) {
    const LqStage& s = stages_[idx(k)];
    Work& w = work_[idx(k)];
    const int ne = s.ne, nw = w.nw, nz = nw + nx;
    const int* pD = w.perm.data();
    const int* pI = w.perm.data() + ne;
    // Independent part of the reduced gradient and the reduced defect.
    for (int j = 0; j < nw; ++j) w.gr(j) = s.r(pI[j]);
    w.gr.segment(nw, nx) = s.q;
    w.BA.col(nz) = s.b;
    if (ne > 0) {
      // T_1 = -R11^-1 Q^T e (last column of T), then the terms of T^T Y + Y^T T in it:
      // gr += Y_v^T T_1 + T_v^T Y_1, Y_1 = r_D + 0.5 H_DD T_1.
      const auto F = w.qr.topRows(ne);
      auto t1 = w.T.col(nz).head(ne);
      t1 = s.e.head(ne);
      for (int j = 0; j < ne; ++j) {
        t1.segment(j, ne - j).applyHouseholderOnTheLeft(F.col(j).segment(j + 1, ne - j - 1),
                                                        w.tau(j), w.hh.data());
      }
      F.leftCols(ne).triangularView<Eigen::Upper>().solveInPlace(t1);
      t1 = -t1;
      auto y1 = w.t.head(ne);
      for (int i = 0; i < ne; ++i) y1(i) = s.r(pD[i]);
      y1.noalias() += 0.5 * w.HDD.topLeftCorner(ne, ne) * t1;
      w.HD.col(nz).head(ne) = y1;
      w.gr.head(nz).noalias() += w.HD.topLeftCorner(ne, nz).transpose() * t1;
      w.gr.head(nz).noalias() += w.T.topLeftCorner(ne, nz).transpose() * y1;
      w.BA.col(nz).noalias() += w.BD.leftCols(ne) * t1;
    }
  }
  work_[idx(N_)].p = stages_[idx(N_)].q;
  for (int k = N_ - 1; k >= 0; --k) {
    Work& w = work_[idx(k)];
    const Work& n = work_[idx(k + 1)];
    const int nw = w.nw, nz = nw + nx;
    w.pb = n.p;
    w.pb.noalias() += n.P.selfadjointView<Eigen::Lower>() * w.BA.col(nz);
    auto h = w.hm.head(nz);
    h = w.gr.head(nz);
    h.noalias() += w.BA.leftCols(nz).transpose() * w.pb;
    w.p = h.segment(nw, nx);
    if (nw > 0) {
      auto v = w.hm.head(nw);
      w.M.topLeftCorner(nw, nw).triangularView<Eigen::Lower>().solveInPlace(v);
      w.p.noalias() -= w.M.block(nw, 0, nx, nw) * v;
    }
  }
  forward(dx0);
  for (int k = 0; k < N_; ++k) recoverStage(k);
}

void RiccatiSolver::feedbackGain(int k, MatrixXd& K) const {
  const Work& w = work_[idx(k)];
  const int nx = nx_, nw = w.nw, ne = stages_[idx(k)].ne;
  auto Kw = w.Kw.topRows(nw);
  if (nw > 0) {
    Kw = -w.M.block(nw, 0, nx, nw).transpose();
    w.M.topLeftCorner(nw, nw).transpose().triangularView<Eigen::Upper>().solveInPlace(Kw);
  }
  const int* pD = w.perm.data();
  const int* pI = w.perm.data() + ne;
  for (int j = 0; j < nw; ++j) K.row(pI[j]) = Kw.row(j);
  if (ne > 0) {
    auto KD = w.KD.topRows(ne);
    KD = w.T.block(0, nw, ne, nx);
    KD.noalias() += w.T.topLeftCorner(ne, nw) * Kw;
    for (int i = 0; i < ne; ++i) K.row(pD[i]) = KD.row(i);
  }
}

}  // namespace rollstep::solver
