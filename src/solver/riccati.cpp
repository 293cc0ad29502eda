#include "rollstep/solver/riccati.hpp"

#include <Eigen/Cholesky>
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
  PBA_ = MatrixXd::Zero(nx, nu + nx + 1);
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
    w.lu = MatrixXd::Zero(nu, ne_max);
    w.perm = Eigen::VectorXi::LinSpaced(nu, 0, nu - 1);
    w.V = MatrixXd::Zero(nz + 1, ne_max);
    w.W = MatrixXd::Zero(nz + 1, ne_max);
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
    w.t = VectorXd::Zero(nu);
    w.t1 = VectorXd::Zero(ne_max);
    w.Kw = MatrixXd::Zero(nu, nx);
    w.KD = MatrixXd::Zero(ne_max, nx);
    w.nw = nu;
  }
}

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
  const int nw = nu - ne, nz = nw + nx;

  // LU with partial pivoting of Eu^T (nu x ne): P Eu^T = [L1; L2] U. The row pivots pick
  // the dependent inputs (the first ne of perm), and a pivot that is small against the
  // largest entry of Eu reveals rank deficiency. Raw column loops: the blocks are tiny
  // and every inner loop runs down a contiguous column.
  double* G = w.lu.data();
  const Eigen::Index ldG = w.lu.outerStride();
  if (ne > 0) {
    const double* E = s.Eu.data();
    const Eigen::Index ldE = s.Eu.outerStride();
    for (int i = 0; i < ne; ++i) {
      for (int c = 0; c < nu; ++c) G[c + i * ldG] = E[i + c * ldE];
    }
    const double scale = s.Eu.topRows(ne).cwiseAbs().maxCoeff();
    double min_ratio = 1.0;
    for (int j = 0; j < ne; ++j) {
      double* gj = G + j * ldG;
      int p = j;
      double amax = std::abs(gj[j]);
      for (int r = j + 1; r < nu; ++r) {
        const double a = std::abs(gj[r]);
        if (a > amax) {
          amax = a;
          p = r;
        }
      }
      const double ratio = (scale > 0.0 && std::isfinite(scale)) ? amax / scale : 0.0;
      min_ratio = std::min(min_ratio, ratio);
      if (!(ratio > rank_tolerance)) {
        if (pivot_ratio) *pivot_ratio = ratio;
        return false;
      }
      if (p != j) {
        for (int c = 0; c < ne; ++c) std::swap(G[j + c * ldG], G[p + c * ldG]);
        std::swap(w.perm(j), w.perm(p));
      }
      const double inv = 1.0 / gj[j];
      for (int r = j + 1; r < nu; ++r) gj[r] *= inv;
      for (int c = j + 1; c < ne; ++c) {
        double* gc = G + c * ldG;
        const double f = gc[j];
        for (int r = j + 1; r < nu; ++r) gc[r] -= f * gj[r];
      }
    }
    if (pivot_ratio) *pivot_ratio = min_ratio;
  }
  w.nw = nw;
  const int* pD = w.perm.data();
  const int* pI = w.perm.data() + ne;

  // Dependent inputs du_D = T [w; dx; 1], kept transposed (V = T^T, columns of length
  // nz + 1): Eu_D = U^T L1^T and Eu_I = U^T L2^T give
  //   T = -L1^-T [L2^T | U^-T [Ex e]],  i.e.  V L1 = -[L2; [Ex e]^T U^-1].
  double* V = w.V.data();
  const Eigen::Index ldV = w.V.outerStride();
  if (ne > 0) {
    const double* Ex = s.Ex.data();
    const Eigen::Index ldX = s.Ex.outerStride();
    for (int i = 0; i < ne; ++i) {
      double* vi = V + i * ldV;
      const double* li = G + i * ldG + ne;  // column i of L2
      for (int j = 0; j < nw; ++j) vi[j] = -li[j];
      for (int a = 0; a < nx; ++a) vi[nw + a] = -Ex[i + a * ldX];
      vi[nz] = -s.e(i);
    }
    // [Ex e]^T U^-1 (rows nw.. of V): column i -= U(c, i) column c (c < i), / U(i, i).
    for (int i = 0; i < ne; ++i) {
      double* vi = V + i * ldV + nw;
      const double* ui = G + i * ldG;
      for (int c = 0; c < i; ++c) {
        const double f = ui[c];
        const double* vc = V + c * ldV + nw;
        for (int a = 0; a <= nx; ++a) vi[a] -= f * vc[a];
      }
      const double inv = 1.0 / ui[i];
      for (int a = 0; a <= nx; ++a) vi[a] *= inv;
    }
    // V L1 = Z: column i -= L1(c, i) column c (c > i), from the last column.
    for (int i = ne - 1; i >= 0; --i) {
      double* vi = V + i * ldV;
      const double* li = G + i * ldG;
      for (int c = i + 1; c < ne; ++c) {
        const double f = li[c];
        const double* vc = V + c * ldV;
        for (int a = 0; a <= nz; ++a) vi[a] -= f * vc[a];
      }
    }
  }

  // Reduced augmented Hessian in [w; dx; 1] (lower triangle): gather the independent
  // part, then add T^T Y + Y^T T with Y = H_Dv + 0.5 H_DD T (kept transposed too,
  // W = Y^T = H_vD + 0.5 V H_DD). Only the lower triangle of R is read.
  const double* Rp = s.R.data();
  const double* Sp = s.S.data();
  const Eigen::Index ldR = s.R.outerStride(), ldS = s.S.outerStride();
  const auto Rsym = [Rp, ldR](int a, int b) { return a >= b ? Rp[a + b * ldR] : Rp[b + a * ldR]; };
  auto H = w.Hr.topLeftCorner(nz + 1, nz + 1);
  double* Hp = w.Hr.data();
  const Eigen::Index ldH = w.Hr.outerStride();
  for (int j = 0; j < nw; ++j) {
    double* Hc = Hp + j * ldH;
    const int b = pI[j];
    for (int i = j; i < nw; ++i) Hc[i] = Rsym(pI[i], b);
    for (int a = 0; a < nx; ++a) Hc[nw + a] = Sp[b + a * ldS];
    Hc[nz] = s.r(b);
  }
  H.block(nw, nw, nx, nx).triangularView<Eigen::Lower>() = s.Q;
  H.row(nz).segment(nw, nx) = s.q.transpose();
  H(nz, nz) = 0.0;
  auto BA = w.BA.leftCols(nz + 1);
  for (int j = 0; j < nw; ++j) BA.col(j) = s.B.col(pI[j]);
  BA.middleCols(nw, nx) = s.A;
  BA.col(nz) = s.b;
  if (ne > 0) {
    const auto Vt = w.V.topLeftCorner(nz + 1, ne);
    auto W = w.W.topLeftCorner(nz + 1, ne);
    auto HDD = w.HDD.topLeftCorner(ne, ne);
    double* Wp = w.W.data();
    double* Dp = w.HDD.data();
    const Eigen::Index ldW = w.W.outerStride(), ldD = w.HDD.outerStride();
    for (int i = 0; i < ne; ++i) {
      double* Wc = Wp + i * ldW;
      const int d = pD[i];
      for (int j = 0; j < nw; ++j) Wc[j] = Rsym(pI[j], d);
      for (int a = 0; a < nx; ++a) Wc[nw + a] = Sp[d + a * ldS];
      Wc[nz] = s.r(d);
      double* Dc = Dp + i * ldD;
      for (int j = 0; j < ne; ++j) Dc[j] = Rsym(pD[j], d);
    }
    W.noalias() += 0.5 * Vt * HDD;
    // T^T Y = V W^T; its transpose is added too, on the lower triangle only.
    auto TY = w.M.topLeftCorner(nz + 1, nz + 1);  // free until backward()
    TY.noalias() = Vt * W.transpose();
    const double* TYp = w.M.data();
    const Eigen::Index ldT = w.M.outerStride();
    for (int j = 0; j <= nz; ++j) {
      double* Hc = Hp + j * ldH;
      const double* Tc = TYp + j * ldT;
      for (int i = j; i <= nz; ++i) Hc[i] += Tc[i] + TYp[j + i * ldT];
    }
    auto BD = w.BD.leftCols(ne);
    for (int i = 0; i < ne; ++i) BD.col(i) = s.B.col(pD[i]);
    BA.noalias() += BD * Vt.transpose();
  }
  w.gr.head(nz) = H.row(nz).head(nz).transpose();
  return true;
}

void RiccatiSolver::beginBackward() {
  failed_stage_ = -1;
  regularization_ = 0.0;
  Work& t = work_[idx(N_)];
  t.P.triangularView<Eigen::Lower>() = stages_[idx(N_)].Q;
  t.p = stages_[idx(N_)].q;
}

bool RiccatiSolver::backwardStage(int k) {
  const int nx = nx_;
  Work& w = work_[idx(k)];
  const Work& n = work_[idx(k + 1)];
  const int nw = w.nw, nz = nw + nx;
  const auto BA = w.BA.leftCols(nz);
  // P [B A b] in one product; its last column gives P b.
  PBA_.leftCols(nz + 1).noalias() = n.P.selfadjointView<Eigen::Lower>() * w.BA.leftCols(nz + 1);
  const auto PBA = PBA_.leftCols(nz);
  auto M = w.M.topLeftCorner(nz, nz);
  M.triangularView<Eigen::Lower>() = w.Hr.topLeftCorner(nz, nz);
  M.triangularView<Eigen::Lower>() += BA.transpose() * PBA;
  w.pb = n.p + PBA_.col(nz);
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
  return true;
}

bool RiccatiSolver::backward() {
  beginBackward();
  for (int k = N_ - 1; k >= 0; --k) {
    if (!backwardStage(k)) return false;
  }
  return true;
}

void RiccatiSolver::beginForward(const Eigen::Ref<const VectorXd>& dx0) {
  Work& w = work_[0];
  w.dx = dx0;
  w.lam = w.p;
  w.lam.noalias() += w.P.selfadjointView<Eigen::Lower>() * w.dx;
}

void RiccatiSolver::forwardStage(int k) {
  const int nx = nx_;
  Work& w = work_[idx(k)];
  Work& n = work_[idx(k + 1)];
  const int nw = w.nw, nz = nw + nx;
  auto wk = w.w.head(nw);
  if (nw > 0) {
    wk = w.hm.head(nw);
    wk.noalias() += w.M.block(nw, 0, nx, nw).transpose() * w.dx;
    w.M.topLeftCorner(nw, nw).transpose().triangularView<Eigen::Upper>().solveInPlace(wk);
    wk = -wk;
  }
  n.dx = w.BA.col(nz);
  n.dx.noalias() += w.BA.leftCols(nw) * wk;
  n.dx.noalias() += w.BA.middleCols(nw, nx) * w.dx;
  n.lam = n.p;
  n.lam.noalias() += n.P.selfadjointView<Eigen::Lower>() * n.dx;
}

void RiccatiSolver::forward(const Eigen::Ref<const VectorXd>& dx0) {
  beginForward(dx0);
  for (int k = 0; k < N_; ++k) forwardStage(k);
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
  const auto Vt = w.V.topLeftCorner(nz + 1, ne);
  auto t = w.t.head(ne);
  t = Vt.row(nz).transpose();
  t.noalias() += Vt.topRows(nw).transpose() * w.w.head(nw);
  t.noalias() += Vt.middleRows(nw, nx).transpose() * w.dx;
  for (int i = 0; i < ne; ++i) w.du(pD[i]) = t(i);
  // Stationarity in du: rho + Eu^T nu = 0 with rho = R du + S dx + r + B^T lambda_{k+1}.
  // Its dependent rows come from the projection's own blocks (no pass over R, S, B):
  // rho_D = H_DD t + H_vD^T [w; dx; 1] + B_D^T lambda = 0.5 H_DD t + W^T [w; dx; 1] + ...
  // (W = H_vD + 0.5 V H_DD), and Eu_D^T = L1 U gives nu = -U^-1 L1^-1 rho_D.
  const auto Wt = w.W.topLeftCorner(nz + 1, ne);
  auto y = w.mult.head(ne);
  y = Wt.row(nz).transpose();
  y.noalias() += Wt.topRows(nw).transpose() * w.w.head(nw);
  y.noalias() += Wt.middleRows(nw, nx).transpose() * w.dx;
  y.noalias() += 0.5 * w.HDD.topLeftCorner(ne, ne) * t;
  y.noalias() += w.BD.leftCols(ne).transpose() * work_[idx(k + 1)].lam;
  y = -y;
  const auto LU = w.lu.topLeftCorner(ne, ne);
  LU.triangularView<Eigen::UnitLower>().solveInPlace(y);
  LU.triangularView<Eigen::Upper>().solveInPlace(y);
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
      // Last row of V: t1 = -L1^-T U^-T e.
      const auto LU = w.lu.topLeftCorner(ne, ne);
      auto t1 = w.t1.head(ne);
      t1 = -s.e.head(ne);
      LU.triangularView<Eigen::Upper>().transpose().solveInPlace(t1);
      LU.triangularView<Eigen::UnitLower>().transpose().solveInPlace(t1);
      w.V.row(nz).head(ne) = t1.transpose();
      auto y1 = w.t.head(ne);
      for (int i = 0; i < ne; ++i) y1(i) = s.r(pD[i]);
      y1.noalias() += 0.5 * w.HDD.topLeftCorner(ne, ne) * t1;
      w.W.row(nz).head(ne) = y1.transpose();
      w.gr.head(nz).noalias() += w.W.topLeftCorner(nz, ne) * t1;
      w.gr.head(nz).noalias() += w.V.topLeftCorner(nz, ne) * y1;
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
    KD = w.V.block(nw, 0, nx, ne).transpose();
    KD.noalias() += w.V.topLeftCorner(nw, ne).transpose() * Kw;
    for (int i = 0; i < ne; ++i) K.row(pD[i]) = KD.row(i);
  }
}

}  // namespace rollstep::solver
