#include "rollstep/solver/riccati.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <utility>

#include "riccati_kernels.hpp"

namespace rollstep::solver {

using Eigen::MatrixXd;
using Eigen::VectorXd;

RiccatiSolver::RiccatiSolver(int horizon, int nx, int nu, int ne_max)
    : N_(horizon), nx_(nx), nu_(nu), ne_max_(ne_max) {
  if (horizon < 1 || nx < 0 || nu < 0 || ne_max < 0) {
    throw std::invalid_argument("RiccatiSolver: bad dimensions");
  }
  stages_.resize(static_cast<std::size_t>(N_) + 1);
  BAt_ = MatrixXd::Zero(nu + nx + 1, nx);
  Hr_shared_ = MatrixXd::Zero(nu + nx + 1, nu + nx + 1);
  PBAt_ = MatrixXd::Zero(nu + nx + 1, nx);
  M_ = MatrixXd::Zero(nu + nx, nu + nx);
  Q_shared_ = MatrixXd::Zero(nx, nx);
  R_shared_ = MatrixXd::Zero(nu, nu);
  S_shared_ = MatrixXd::Zero(nu, nx);
  work_.resize(static_cast<std::size_t>(N_) + 1);
  const int nz = nu + nx;
  // V and W hold (nz_k + 1) x ng_k with nz_k = nu - ne_k + nx and ng_k <= ne_k <= nu (a stage
  // with ne_k > nu is rejected before): at most (nu + nx + 1 - g) g for some g <= ng_max.
  const int ng_max = std::min(ne_max, nu);
  Eigen::Index vw_size = 0;
  for (int g = 0; g <= ng_max; ++g) {
    vw_size = std::max<Eigen::Index>(vw_size, Eigen::Index{nz + 1 - g} * g);
  }
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
    w.lu = VectorXd::Zero(Eigen::Index{nu} * ng_max);
    w.perm = Eigen::VectorXi::LinSpaced(nu, 0, nu - 1);
    w.rows = Eigen::VectorXi::LinSpaced(ne_max, 0, ne_max - 1);
    w.mark = Eigen::VectorXi::Zero(nu);
    w.col = Eigen::VectorXi::Zero(ne_max);
    w.tf = VectorXd::Zero(ne_max);
    w.reff = VectorXd::Zero(nu);
    w.qeff = VectorXd::Zero(nx);
    w.beff = VectorXd::Zero(nx);
    w.eeff = VectorXd::Zero(ne_max);
    w.RF = MatrixXd::Zero(nu, ne_max);
    w.SF = MatrixXd::Zero(nx, ne_max);
    w.BF = MatrixXd::Zero(nx, ne_max);
    w.EF = MatrixXd::Zero(ne_max, ne_max);
    w.V = VectorXd::Zero(vw_size);
    w.W = VectorXd::Zero(vw_size);
    w.HDD = VectorXd::Zero(Eigen::Index{ng_max} * ng_max);
    w.BD = MatrixXd::Zero(nx, ne_max);
    w.Hr = MatrixXd::Zero(nz + 1, nz + 1);
    w.gr = VectorXd::Zero(nz);
    w.BA = MatrixXd::Zero(nx, nz + 1);
    w.L = MatrixXd::Zero(nz, nu);
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

namespace {

/// P = the symmetric matrix whose lower triangle is that of L (both triangles stored:
/// the backward step's product reads P whole).
template <class Src>
void storeWhole(MatrixXd& P, const Src& L) {
  P.triangularView<Eigen::Lower>() = L;
  P.triangularView<Eigen::StrictlyUpper>() = P.transpose();
}

}  // namespace

bool RiccatiSolver::findFixedInputs(const LqStage& s, Work& w, double rank_tolerance, double scale,
                                    double* ratio) const {
  const int nx = nx_, nu = nu_, ne = s.ne;
  const double* E = s.Eu.data();
  const double* X = s.Ex.data();
  const Eigen::Index ldE = s.Eu.outerStride(), ldX = s.Ex.outerStride();
  w.mark.setZero();
  // Per row: the column of its only non-zero Eu entry, -1 when it has none or more than
  // one (the scan stops at the second: dense rows cost two reads) or when Ex has one.
  int* col = w.col.data();
  for (int i = 0; i < ne; ++i) {
    int c1 = -1;
    for (int c = 0; c < nu; ++c) {
      if (E[i + c * ldE] == 0.0) continue;
      if (c1 >= 0) {
        c1 = -1;
        break;
      }
      c1 = c;
    }
    for (int a = 0; c1 >= 0 && a < nx; ++a) {
      if (X[i + a * ldX] != 0.0) c1 = -1;
    }
    col[i] = c1;
  }
  int ng = 0, nf = 0;
  // Fixing rows go to the end of w.rows (in order), the others to the front.
  for (int i = 0; i < ne; ++i) {
    if (col[i] < 0 || w.mark(col[i]) != 0) {
      w.rows(ng++) = i;
      continue;
    }
    const double r =
        (scale > 0.0 && std::isfinite(scale)) ? std::abs(E[i + col[i] * ldE]) / scale : 0.0;
    *ratio = std::min(*ratio, r);
    if (!(r > rank_tolerance)) {
      *ratio = r;
      return false;
    }
    w.mark(col[i]) = 1;
    ++nf;
    w.rows(ne - nf) = i;
  }
  // The fixing rows were stored from the back: restore their order.
  std::reverse(w.rows.data() + ng, w.rows.data() + ne);
  w.nf = nf;
  // perm: the free inputs in order, then the fixed ones in the order of their rows.
  int free = 0;
  for (int c = 0; c < nu; ++c) {
    if (w.mark(c) == 0) w.perm(free++) = c;
  }
  for (int f = 0; f < nf; ++f) w.perm(nu - nf + f) = col[w.rows(ng + f)];
  return true;
}

void RiccatiSolver::keepFixedColumns(const MatrixXd& R, const MatrixXd& S, const LqStage& s,
                                     Work& w) const {
  const int nf = w.nf, nu = nu_, nx = nx_;
  const int* pF = w.perm.data() + nu - nf;
  const double* Rp = R.data();
  const double* Sp = S.data();
  const Eigen::Index ldR = R.outerStride(), ldS = S.outerStride();
  for (int f = 0; f < nf; ++f) {
    const int c = pF[f];
    double* rf = w.RF.data() + f * w.RF.outerStride();
    double* sf = w.SF.data() + f * w.SF.outerStride();
    // Column c of R from its lower triangle: R(c, 0..c) as a row, R(c..nu, c) as a column.
    for (int j = 0; j < c; ++j) rf[j] = Rp[c + j * ldR];
    for (int j = c; j < nu; ++j) rf[j] = Rp[j + c * ldR];
    for (int a = 0; a < nx; ++a) sf[a] = Sp[c + a * ldS];
    w.BF.col(f) = s.B.col(c);
    w.EF.col(f).head(s.ne) = s.Eu.col(c).head(s.ne);
  }
}

void RiccatiSolver::substituteFixedInputs(const LqStage& s, Work& w) const {
  const int nf = w.nf, ng = s.ne - nf, nu = nu_, nx = nx_;
  if (nf == 0) return;
  w.reff = s.r;
  w.qeff = s.q;
  w.beff = s.b;
  for (int i = 0; i < ng; ++i) w.eeff(i) = s.e(w.rows(i));
  for (int f = 0; f < nf; ++f) {
    const int i = w.rows(ng + f);
    const double t = -s.e(i) / w.EF(i, f);
    w.tf(f) = t;
    const double* rf = w.RF.data() + f * w.RF.outerStride();
    const double* sf = w.SF.data() + f * w.SF.outerStride();
    for (int j = 0; j < nu; ++j) w.reff(j) += rf[j] * t;
    for (int a = 0; a < nx; ++a) w.qeff(a) += sf[a] * t;
    w.beff.noalias() += w.BF.col(f) * t;
    for (int g = 0; g < ng; ++g) w.eeff(g) += w.EF(w.rows(g), f) * t;
  }
}

bool RiccatiSolver::projectStage(int k, double rank_tolerance, double* pivot_ratio) {
  const LqStage& s = stages_[idx(k)];
  Work& w = work_[idx(k)];
  const StageHessian h = hessian(k);
  const int nx = nx_, nu = nu_, ne = s.ne;
  if (pivot_ratio) *pivot_ratio = 1.0;
  if (ne < 0 || ne > ne_max_) throw std::out_of_range("RiccatiSolver::projectStage: bad ne");
  if (ne > nu) {
    if (pivot_ratio) *pivot_ratio = 0.0;
    return false;
  }
  w.nf = 0;
  for (int c = 0; c < nu; ++c) w.perm(c) = c;
  const double scale = ne > 0 ? s.Eu.topRows(ne).cwiseAbs().maxCoeff() : 0.0;
  double min_ratio = 1.0;
  if (ne > 0 && !findFixedInputs(s, w, rank_tolerance, scale, &min_ratio)) {
    if (pivot_ratio) *pivot_ratio = min_ratio;
    return false;
  }
  keepFixedColumns(h.R, h.S, s, w);
  substituteFixedInputs(s, w);
  // The rows left for the LU (ng) and the inputs they act on (nv = ng + nw).
  const int nf = w.nf, ng = ne - nf, nv = nu - nf;
  const int nw = nu - ne, nz = nw + nx;
  const int* rows = w.rows.data();
  const double* rv = nf > 0 ? w.reff.data() : s.r.data();
  const double* bv = nf > 0 ? w.beff.data() : s.b.data();
  const Eigen::Map<const VectorXd> qv(nf > 0 ? w.qeff.data() : s.q.data(), nx);
  const auto ev = [&](int i) { return nf > 0 ? w.eeff(i) : s.e(rows[i]); };

  // LU with partial pivoting of Eu^T (nv x ng, the rows and inputs left): P Eu^T =
  // [L1; L2] U. The row pivots pick the dependent inputs (the first ng of perm), and a
  // pivot that is small against the largest entry of Eu reveals rank deficiency. Raw
  // column loops: the blocks are tiny and every inner loop runs down a contiguous column.
  double* G = w.lu.data();
  const Eigen::Index ldG = nv;
  if (ng > 0) {
    const double* E = s.Eu.data();
    const Eigen::Index ldE = s.Eu.outerStride();
    for (int i = 0; i < ng; ++i) {
      const int row = rows[i];
      if (nf == 0) {
        for (int c = 0; c < nv; ++c) G[c + i * ldG] = E[row + c * ldE];
      } else {
        for (int c = 0; c < nv; ++c) G[c + i * ldG] = E[row + w.perm(c) * ldE];
      }
    }
    for (int j = 0; j < ng; ++j) {
      double* gj = G + j * ldG;
      int p = j;
      double amax = std::abs(gj[j]);
      for (int r = j + 1; r < nv; ++r) {
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
        for (int c = 0; c < ng; ++c) std::swap(G[j + c * ldG], G[p + c * ldG]);
        std::swap(w.perm(j), w.perm(p));
      }
      const double inv = 1.0 / gj[j];
      for (int r = j + 1; r < nv; ++r) gj[r] *= inv;
      for (int c = j + 1; c < ng; ++c) {
        double* gc = G + c * ldG;
        const double f = gc[j];
        for (int r = j + 1; r < nv; ++r) gc[r] -= f * gj[r];
      }
    }
  }
  if (pivot_ratio) *pivot_ratio = min_ratio;
  w.nw = nw;
  const int* pD = w.perm.data();
  const int* pI = w.perm.data() + ng;

  // Dependent inputs du_D = T [w; dx; 1], kept transposed (V = T^T, columns of length
  // nz + 1): Eu_D = U^T L1^T and Eu_I = U^T L2^T give
  //   T = -L1^-T [L2^T | U^-T [Ex e]],  i.e.  V L1 = -[L2; [Ex e]^T U^-1].
  double* V = w.V.data();
  const Eigen::Index ldV = nz + 1;
  if (ng > 0) {
    const double* Ex = s.Ex.data();
    const Eigen::Index ldX = s.Ex.outerStride();
    for (int i = 0; i < ng; ++i) {
      double* vi = V + i * ldV;
      const double* li = G + i * ldG + ng;  // column i of L2
      for (int j = 0; j < nw; ++j) vi[j] = -li[j];
      for (int a = 0; a < nx; ++a) vi[nw + a] = -Ex[rows[i] + a * ldX];
      vi[nz] = -ev(i);
    }
    // [Ex e]^T U^-1 (rows nw.. of V): column i -= U(c, i) column c (c < i), / U(i, i).
    for (int i = 0; i < ng; ++i) {
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
    for (int i = ng - 1; i >= 0; --i) {
      double* vi = V + i * ldV;
      const double* li = G + i * ldG;
      for (int c = i + 1; c < ng; ++c) {
        const double f = li[c];
        const double* vc = V + c * ldV;
        for (int a = 0; a <= nz; ++a) vi[a] -= f * vc[a];
      }
    }
  }

  // Reduced augmented Hessian in [w; dx; 1] (lower triangle): gather the independent
  // part, then add T^T Y + Y^T T with Y = H_Dv + 0.5 H_DD T (kept transposed too,
  // W = Y^T = H_vD + 0.5 V H_DD). Only the lower triangle of R is read.
  const double* Rp = h.R.data();
  const double* Sp = h.S.data();
  const Eigen::Index ldR = h.R.outerStride(), ldS = h.S.outerStride();
  const auto Rsym = [Rp, ldR](int a, int b) { return a >= b ? Rp[a + b * ldR] : Rp[b + a * ldR]; };
  MatrixXd& Hr = reducedHessian(w);
  auto H = Hr.topLeftCorner(nz + 1, nz + 1);
  double* Hp = Hr.data();
  const Eigen::Index ldH = Hr.outerStride();
  for (int j = 0; j < nw; ++j) {
    double* Hc = Hp + j * ldH;
    const int b = pI[j];
    for (int i = j; i < nw; ++i) Hc[i] = Rsym(pI[i], b);
    for (int a = 0; a < nx; ++a) Hc[nw + a] = Sp[b + a * ldS];
    Hc[nz] = rv[b];
  }
  H.block(nw, nw, nx, nx).triangularView<Eigen::Lower>() = h.Q;
  H.row(nz).segment(nw, nx) = qv.transpose();
  H(nz, nz) = 0.0;
  auto BA = w.BA.leftCols(nz + 1);
  for (int j = 0; j < nw; ++j) BA.col(j) = s.B.col(pI[j]);
  BA.middleCols(nw, nx) = s.A;
  BA.col(nz) = Eigen::Map<const VectorXd>(bv, nx);
  if (ng > 0) {
    const auto Vt = packed(w.V, nz + 1, ng);
    auto W = packed(w.W, nz + 1, ng);
    const auto HDD = packed(w.HDD, ng, ng);
    double* Wp = w.W.data();
    double* Dp = w.HDD.data();
    const Eigen::Index ldW = nz + 1, ldD = ng;
    for (int i = 0; i < ng; ++i) {
      double* Wc = Wp + i * ldW;
      const int d = pD[i];
      for (int j = 0; j < nw; ++j) Wc[j] = Rsym(pI[j], d);
      for (int a = 0; a < nx; ++a) Wc[nw + a] = Sp[d + a * ldS];
      Wc[nz] = rv[d];
      double* Dc = Dp + i * ldD;
      for (int j = 0; j < ng; ++j) Dc[j] = Rsym(pD[j], d);
    }
    W.noalias() += 0.5 * Vt * HDD;
    // T^T Y + Y^T T = V W^T + W V^T, on the lower triangle only, both products in the
    // same register accumulators.
    kernels::syr2kLowerAccumulate(nz + 1, ng, V, ldV, Wp, ldW, Hp, ldH);
    auto BD = w.BD.leftCols(ng);
    for (int i = 0; i < ng; ++i) BD.col(i) = s.B.col(pD[i]);
    kernels::gemmAccumulate(nx, nz + 1, ng, w.BD.data(), w.BD.outerStride(), V, ldV, 1, w.BA.data(),
                            w.BA.outerStride());
  }
  w.gr.head(nz) = H.row(nz).head(nz).transpose();
  return true;
}

void RiccatiSolver::beginBackward() {
  failed_stage_ = -1;
  regularization_ = 0.0;
  Work& t = work_[idx(N_)];
  storeWhole(t.P, hessian(N_).Q);
  t.p = stages_[idx(N_)].q;
}

bool RiccatiSolver::backwardStage(int k) {
  const int nx = nx_;
  Work& w = work_[idx(k)];
  const Work& n = work_[idx(k + 1)];
  const int nw = w.nw, nz = nw + nx;
  // [B A b]^T, so that both products read their left operand down contiguous columns:
  // Yn = -[B A b]^T P (P is stored whole, so this is -(P [B A b])^T; its last row is
  // -(P b)^T), then M = H + [B A]^T P [B A] and its factorisation in one fused pass.
  BAt_.topRows(nz + 1) = w.BA.leftCols(nz + 1).transpose();
  const Eigen::Index ldt = BAt_.outerStride(), ldy = PBAt_.outerStride();
  kernels::gemm(nz + 1, nx, nx, BAt_.data(), ldt, n.P.data(), 1, n.P.outerStride(), PBAt_.data(),
                ldy, true);
  w.pb = n.p - PBAt_.row(nz).transpose();
  auto h = w.hm.head(nz);
  h = w.gr.head(nz);
  h.noalias() += BAt_.topRows(nz) * w.pb;

  MatrixXd& Hr = reducedHessian(w);
  bool ok = false;
  double reg = 0.0;
  for (int attempt = 0; attempt < 6 && !ok; ++attempt) {
    if (attempt > 0) {
      // Shift the input block (rare path: singular reduced Hessian).
      const double scale = 1.0 + Hr.topLeftCorner(nw, nw).diagonal().cwiseAbs().maxCoeff();
      reg = (attempt == 1) ? 1e-12 * scale : reg * 100.0;
    }
    ok = kernels::factorSchur(nz, nw, nx, BAt_.data(), ldt, PBAt_.data(), ldy, Hr.data(),
                              Hr.outerStride(), M_.data(), M_.outerStride(), reg);
    if (nw == 0) break;
  }
  if (!ok) {
    failed_stage_ = k;
    return false;
  }
  regularization_ = std::max(regularization_, reg);
  storeWhole(w.P, M_.block(nw, nw, nx, nx));
  w.p = w.hm.segment(nw, nx);
  if (nw > 0) {
    auto v = w.hm.head(nw);
    M_.topLeftCorner(nw, nw).triangularView<Eigen::Lower>().solveInPlace(v);
    w.p.noalias() -= M_.block(nw, 0, nx, nw) * v;
    // The later passes read only M's first nw columns.
    w.L.topLeftCorner(nz, nw) = M_.topLeftCorner(nz, nw);
  }
  return true;
}

void RiccatiSolver::shareReducedHessian(bool on) {
  share_hr_ = on;
  // The stages' own are released while shared (never read then).
  const int n = on ? 0 : nu_ + nx_ + 1;
  for (auto& w : work_) {
    if (w.Hr.rows() != n) w.Hr = MatrixXd::Zero(n, n);
  }
}

void RiccatiSolver::shareStageHessians(bool on) {
  share_h_ = on;
  const int nx = on ? 0 : nx_, nu = on ? 0 : nu_;
  for (auto& s : stages_) {
    if (s.Q.rows() == nx && s.R.rows() == nu) continue;
    s.Q = MatrixXd::Zero(nx, nx);
    s.R = MatrixXd::Zero(nu, nu);
    s.S = MatrixXd::Zero(nu, nx);
  }
}

RiccatiSolver::StageHessian RiccatiSolver::hessian(int k) {
  if (share_h_) return {Q_shared_, R_shared_, S_shared_};
  LqStage& s = stages_[idx(k)];
  return {s.Q, s.R, s.S};
}

bool RiccatiSolver::backward() {
  if (share_h_) {
    throw std::logic_error(
        "RiccatiSolver::backward: the stages share one set of Hessian blocks "
        "(shareStageHessians): run projectStage(k) right after writing stage k's");
  }
  if (share_hr_) {
    throw std::logic_error(
        "RiccatiSolver::backward: the stages share one reduced Hessian (shareReducedHessian): "
        "run backwardStage(k) right after projectStage(k)");
  }
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
    wk.noalias() += w.L.block(nw, 0, nx, nw).transpose() * w.dx;
    w.L.topLeftCorner(nw, nw).transpose().triangularView<Eigen::Upper>().solveInPlace(wk);
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
  const int nx = nx_, nu = nu_, ne = s.ne, nw = w.nw, nz = nw + nx;
  const int nf = w.nf, ng = ne - nf;
  const int* pD = w.perm.data();
  const int* pI = w.perm.data() + ng;
  const int* pF = w.perm.data() + nu - nf;
  for (int j = 0; j < nw; ++j) w.du(pI[j]) = w.w(j);
  for (int f = 0; f < nf; ++f) w.du(pF[f]) = w.tf(f);
  w.mult.setZero();
  if (ne == 0) return;
  const auto& lam_next = work_[idx(k + 1)].lam;
  if (ng > 0) {
    const auto Vt = packed(std::as_const(w.V), nz + 1, ng);
    auto t = w.t.head(ng);
    t = Vt.row(nz).transpose();
    t.noalias() += Vt.topRows(nw).transpose() * w.w.head(nw);
    t.noalias() += Vt.middleRows(nw, nx).transpose() * w.dx;
    for (int i = 0; i < ng; ++i) w.du(pD[i]) = t(i);
    // Stationarity in du: rho + Eu^T nu = 0 with rho = R du + S dx + r + B^T lambda_{k+1}.
    // Its dependent rows come from the projection's own blocks (no pass over R, S, B):
    // rho_D = H_DD t + H_vD^T [w; dx; 1] + B_D^T lambda = 0.5 H_DD t + W^T [w; dx; 1] + ...
    // (W = H_vD + 0.5 V H_DD), and Eu_D^T = L1 U gives nu = -U^-1 L1^-1 rho_D.
    // (The last row of W holds the substituted r, so rho includes R_DF du_F.)
    const auto Wt = packed(std::as_const(w.W), nz + 1, ng);
    auto y = w.t1.head(ng);
    y = Wt.row(nz).transpose();
    y.noalias() += Wt.topRows(nw).transpose() * w.w.head(nw);
    y.noalias() += Wt.middleRows(nw, nx).transpose() * w.dx;
    y.noalias() += 0.5 * packed(std::as_const(w.HDD), ng, ng) * t;
    y.noalias() += w.BD.leftCols(ng).transpose() * lam_next;
    y = -y;
    const auto LU = luFactor(w, nu, ng);
    LU.triangularView<Eigen::UnitLower>().solveInPlace(y);
    LU.triangularView<Eigen::Upper>().solveInPlace(y);
    for (int i = 0; i < ng; ++i) w.mult(w.rows(i)) = y(i);
  }
  // A fixing row's multiplier from the stationarity of its input c (the other fixing
  // rows do not act on c): Eu_ic nu_i = -(rho_c + sum over the LU's rows of Eu_gc nu_g).
  // R's column, S's row, B's and Eu's columns of c are those projectStage kept (RF, SF,
  // BF, EF).
  for (int f = 0; f < nf; ++f) {
    const int i = w.rows(ng + f), c = pF[f];
    const double* rf = w.RF.data() + f * w.RF.outerStride();
    const double* sf = w.SF.data() + f * w.SF.outerStride();
    // S(c, :) dx, summed in index order.
    double sdx = 0.0;
    if (nx > 0) {
      sdx = sf[0] * w.dx(0);
      for (int a = 1; a < nx; ++a) sdx += sf[a] * w.dx(a);
    }
    double rho = s.r(c) + sdx + w.BF.col(f).dot(lam_next);
    for (int j = 0; j < nu; ++j) rho += rf[j] * w.du(j);
    for (int g = 0; g < ng; ++g) rho += w.EF(w.rows(g), f) * w.mult(w.rows(g));
    w.mult(i) = -rho / w.EF(i, f);
  }
}

bool RiccatiSolver::solve(const Eigen::Ref<const VectorXd>& dx0, double rank_tolerance) {
  if (share_hr_ || share_h_) {
    throw std::logic_error(
        "RiccatiSolver::solve: the stages share one reduced Hessian or one set of Hessian "
        "blocks");
  }
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
    const int ne = s.ne, nw = w.nw, nz = nw + nx, nf = w.nf, ng = ne - nf;
    const int* pD = w.perm.data();
    const int* pI = w.perm.data() + ng;
    substituteFixedInputs(s, w);
    const VectorXd& rv = nf > 0 ? w.reff : s.r;
    // Independent part of the reduced gradient and the reduced defect.
    for (int j = 0; j < nw; ++j) w.gr(j) = rv(pI[j]);
    w.gr.segment(nw, nx) = nf > 0 ? w.qeff : s.q;
    w.BA.col(nz) = nf > 0 ? w.beff : s.b;
    if (ng > 0) {
      // T_1 = -R11^-1 Q^T e (last column of T), then the terms of T^T Y + Y^T T in it:
      // gr += Y_v^T T_1 + T_v^T Y_1, Y_1 = r_D + 0.5 H_DD T_1.
      // Last row of V: t1 = -L1^-T U^-T e.
      const auto LU = luFactor(w, nu_, ng);
      auto t1 = w.t1.head(ng);
      for (int i = 0; i < ng; ++i) t1(i) = -(nf > 0 ? w.eeff(i) : s.e(w.rows(i)));
      LU.triangularView<Eigen::Upper>().transpose().solveInPlace(t1);
      LU.triangularView<Eigen::UnitLower>().transpose().solveInPlace(t1);
      auto V = packed(w.V, nz + 1, ng);
      auto W = packed(w.W, nz + 1, ng);
      V.row(nz) = t1.transpose();
      auto y1 = w.t.head(ng);
      for (int i = 0; i < ng; ++i) y1(i) = rv(pD[i]);
      y1.noalias() += 0.5 * packed(std::as_const(w.HDD), ng, ng) * t1;
      W.row(nz) = y1.transpose();
      w.gr.head(nz).noalias() += W.topRows(nz) * t1;
      w.gr.head(nz).noalias() += V.topRows(nz) * y1;
      w.BA.col(nz).noalias() += w.BD.leftCols(ng) * t1;
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
      w.L.topLeftCorner(nw, nw).triangularView<Eigen::Lower>().solveInPlace(v);
      w.p.noalias() -= w.L.block(nw, 0, nx, nw) * v;
    }
  }
  forward(dx0);
  for (int k = 0; k < N_; ++k) recoverStage(k);
}

void RiccatiSolver::feedbackGain(int k, MatrixXd& K) const {
  const Work& w = work_[idx(k)];
  const int nx = nx_, nu = nu_, nw = w.nw, nf = w.nf, ne = stages_[idx(k)].ne - nf;
  auto Kw = w.Kw.topRows(nw);
  if (nw > 0) {
    Kw = -w.L.block(nw, 0, nx, nw).transpose();
    w.L.topLeftCorner(nw, nw).transpose().triangularView<Eigen::Upper>().solveInPlace(Kw);
  }
  const int* pD = w.perm.data();
  const int* pI = w.perm.data() + ne;
  for (int j = 0; j < nw; ++j) K.row(pI[j]) = Kw.row(j);
  for (int f = 0; f < nf; ++f) K.row(w.perm(nu - nf + f)).setZero();  // du_F is constant
  if (ne > 0) {
    auto KD = w.KD.topRows(ne);
    const auto V = packed(w.V, nw + nx + 1, ne);
    KD = V.middleRows(nw, nx).transpose();
    KD.noalias() += V.topRows(nw).transpose() * Kw;
    for (int i = 0; i < ne; ++i) K.row(pD[i]) = KD.row(i);
  }
}

}  // namespace rollstep::solver
