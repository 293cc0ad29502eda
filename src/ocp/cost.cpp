#include "rollstep/ocp/cost.hpp"

#include <stdexcept>

#include "rollstep/ocp/residuals.hpp"
#include "rollstep/ocp/small_products.hpp"

namespace rollstep::ocp {

namespace {
// Residuals with at most this many rows take the small-depth products (small_products.hpp)
// for R^T W R; larger ones Eigen's general product.
constexpr int kSmallDepth = 8;

/// Which scratch of LsqData a cost's path uses (calcDiff).
struct LsqScratch {
  bool general;  // wr, WRx, WRu: the generic path with more than kSmallDepth rows
  bool small;    // RxT, RuT: the generic path with at most kSmallDepth rows
  bool block;    // RxT: the pose block of a state error on SE(3) x R^n
};

struct LsqData final : CostData {
  // Only the scratch the cost's path uses: the rest, in the middle of the node's data,
  // would spread what an iteration touches over more pages (tens of kB per node).
  LsqData(std::unique_ptr<ResidualData> r, int max_rows, int ndx, int nu, LsqScratch use)
      : res(std::move(r)),
        wr(VectorXd::Zero(use.general ? max_rows : 0)),
        WRx(MatrixXd::Zero(use.general ? max_rows : 0, ndx)),
        WRu(MatrixXd::Zero(use.general ? max_rows : 0, nu)),
        RxT(MatrixXd::Zero(ndx, use.small || use.block ? max_rows : 0)),
        RuT(MatrixXd::Zero(nu, use.small ? max_rows : 0)) {}
  std::unique_ptr<ResidualData> res;
  VectorXd wr;        // W r
  MatrixXd WRx, WRu;  // W Rx, W Ru
  MatrixXd RxT, RuT;  // (W Rx)^T, (W Ru)^T: the left operands of the small-depth products
};
}  // namespace

LeastSquaresCost::LeastSquaresCost(std::shared_ptr<const Residual> residual,
                                   const VectorXd& weights)
    : CostTerm(residual ? residual->ndx() : 0, residual ? residual->nu() : 0),
      residual_(std::move(residual)),
      weights_(weights) {
  if (!residual_) throw std::invalid_argument("LeastSquaresCost: null residual");
  if (weights.size() != residual_->maxRows()) {
    throw std::invalid_argument("LeastSquaresCost: weights must have maxRows() entries");
  }
  if ((weights.array() < 0.0).any() || !weights.allFinite()) {
    throw std::invalid_argument("LeastSquaresCost: weights must be finite and nonnegative");
  }
  if (dynamic_cast<const InputErrorResidual*>(residual_.get()) != nullptr) {
    structure_ = Structure::InputIdentity;
  } else if (const auto* se = dynamic_cast<const StateErrorResidual*>(residual_.get())) {
    if (se->space().isEuclidean()) {
      structure_ = Structure::StateIdentity;
    } else {
      structure_ = Structure::StateBlock;
      block_ = se->space().euclideanTangentOffset();
    }
  }
}

void LeastSquaresCost::setWeights(const VectorXd& weights) {
  if (weights.size() != weights_.size() || (weights.array() < 0.0).any() || !weights.allFinite()) {
    throw std::invalid_argument("LeastSquaresCost::setWeights: wrong size or negative weight");
  }
  weights_ = weights;
}

namespace {
LsqScratch scratchOf(bool generic, bool block, int max_rows) {
  return {generic && max_rows > kSmallDepth, generic, block};
}
}  // namespace

std::unique_ptr<CostData> LeastSquaresCost::createData() const {
  return std::make_unique<LsqData>(
      residual_->createData(), residual_->maxRows(), ndx(), nu(),
      scratchOf(structure_ == Structure::Generic, structure_ == Structure::StateBlock,
                residual_->maxRows()));
}

std::unique_ptr<CostData> LeastSquaresCost::createDataWithNodeCache() const {
  return std::make_unique<LsqData>(
      residual_->createDataWithNodeCache(), residual_->maxRows(), ndx(), nu(),
      scratchOf(structure_ == Structure::Generic, structure_ == Structure::StateBlock,
                residual_->maxRows()));
}

double LeastSquaresCost::calc(const NodeContext& ctx, ConstVecRef x, ConstVecRef u,
                              CostData& d) const {
  auto& s = static_cast<LsqData&>(d);
  const int m = residual_->rows(ctx);
  s.res->rows = m;
  if (m == 0) return 0.0;
  residual_->calc(ctx, x, u, *s.res);
  const auto r = s.res->r.head(m);
  return 0.5 * r.dot(weights_.head(m).cwiseProduct(r));
}

void LeastSquaresCost::calcDiff(const NodeContext& ctx, ConstVecRef x, ConstVecRef u, CostData& d,
                                double scale, VecRef lx, VecRef lu, MatRef Lxx, MatRef Luu,
                                MatRef Lux) const {
  auto& s = static_cast<LsqData&>(d);
  const int m = s.res->rows;
  if (m == 0) return;
  if (structure_ == Structure::InputIdentity || structure_ == Structure::StateIdentity) {
    // r = u - u_ref or x - x_ref: gradient scale W r, Hessian scale W (diagonal).
    const bool input = structure_ == Structure::InputIdentity;
    auto g = input ? lu : lx;
    auto H = input ? Luu : Lxx;
    g.head(m) += scale * weights_.head(m).cwiseProduct(s.res->r.head(m));
    H.diagonal().head(m) += scale * weights_.head(m);
    return;
  }
  if (structure_ == Structure::StateBlock) {
    static_cast<const StateErrorResidual&>(*residual_).calcDiffHead(x, *s.res);
    // Rx = blockdiag(J, I) with J = d(x_ref (-) x)/dx on the pose (block_ x block_).
    const int b = block_, n = m - b;
    const auto J = s.res->Rx.topLeftCorner(b, b);
    const auto r = s.res->r.head(m);
    // (W J)^T once; the right operands are J and r themselves.
    auto WJT = s.RxT.topLeftCorner(b, b);
    WJT.noalias() = J.transpose() * (scale * weights_.head(b)).asDiagonal();
    smallDepthProduct(lx.head(b), WJT, r.head(b), 1.0, true);
    lx.tail(n) += scale * weights_.tail(n).cwiseProduct(r.tail(n));
    smallDepthProduct(Lxx.topLeftCorner(b, b), WJT, J, 1.0, true);
    Lxx.diagonal().tail(n) += scale * weights_.tail(n);
    return;
  }
  residual_->calcDiff(ctx, x, u, *s.res);
  const auto w = weights_.head(m);
  const auto Rx = s.res->Rx.topRows(m);
  const bool on_x = residual_->dependsOnState(), on_u = residual_->dependsOnInput();
  // Trailing input columns of Ru that are exactly zero (e.g. a base velocity residual
  // does not depend on the contact forces) add exactly zero: they are left out.
  int cu = 0;
  if (on_u) {
    cu = nu();
    while (cu > 0 && s.res->Ru.col(cu - 1).head(m).isZero(0.0)) --cu;
  }
  const auto Ru = s.res->Ru.topLeftCorner(m, cu);
  if (m <= kSmallDepth) {
    // (W R)^T formed once per block (the left operands); the right operands are R and r
    // themselves.
    const auto r = s.res->r.head(m);
    if (on_x) {
      auto WRxT = s.RxT.leftCols(m);
      WRxT.noalias() = Rx.transpose() * (scale * w).asDiagonal();
      smallDepthProduct(lx, WRxT, r, 1.0, true);
      smallDepthProduct(Lxx, WRxT, Rx, 1.0, true);
    }
    if (cu > 0) {
      auto WRuT = s.RuT.topLeftCorner(cu, m);
      WRuT.noalias() = Ru.transpose() * (scale * w).asDiagonal();
      smallDepthProduct(lu.head(cu), WRuT, r, 1.0, true);
      smallDepthProduct(Luu.topLeftCorner(cu, cu), WRuT, Ru, 1.0, true);
      if (on_x) smallDepthProduct(Lux.topRows(cu), WRuT, Rx, 1.0, true);
    }
    return;
  }
  s.wr.head(m) = scale * w.cwiseProduct(s.res->r.head(m));
  if (on_x) {
    s.WRx.topRows(m).noalias() = (scale * w).asDiagonal() * Rx;
    lx.noalias() += Rx.transpose() * s.wr.head(m);
    Lxx.noalias() += Rx.transpose() * s.WRx.topRows(m);
  }
  if (cu > 0) {
    s.WRu.topLeftCorner(m, cu).noalias() = (scale * w).asDiagonal() * Ru;
    lu.head(cu).noalias() += Ru.transpose() * s.wr.head(m);
    Luu.topLeftCorner(cu, cu).noalias() += Ru.transpose() * s.WRu.topLeftCorner(m, cu);
    if (on_x) Lux.topRows(cu).noalias() += Ru.transpose() * s.WRx.topRows(m);
  }
}

}  // namespace rollstep::ocp
