#include "rollstep/ocp/residuals.hpp"

#include <stdexcept>

namespace rollstep::ocp {

namespace {

/// Residual workspace with a reference state and the difference Jacobians.
struct StateDiffData final : ResidualData {
  StateDiffData(int max_rows, int nx, int ndx, int nu)
      : ResidualData(max_rows, ndx, nu),
        xref(VectorXd::Zero(nx)),
        dx(VectorXd::Zero(ndx)),
        J0(MatrixXd::Zero(ndx, ndx)),
        J1(MatrixXd::Zero(ndx, ndx)) {}
  VectorXd xref, dx;
  MatrixXd J0, J1;
};

}  // namespace

// ---- StateErrorResidual --------------------------------------------------------------------

StateErrorResidual::StateErrorResidual(std::shared_ptr<const StateSpace> space, int nu,
                                       const VectorXd& x_ref)
    : Residual(space ? space->ndx() : 0, nu, space ? space->ndx() : 0),
      space_(std::move(space)),
      x_ref_(x_ref) {
  if (!space_) throw std::invalid_argument("StateErrorResidual: null state space");
  if (x_ref.size() != space_->nx()) {
    throw std::invalid_argument("StateErrorResidual: reference has the wrong size");
  }
}

void StateErrorResidual::setReference(const VectorXd& x_ref) {
  if (x_ref.size() != x_ref_.size()) {
    throw std::invalid_argument("StateErrorResidual::setReference: wrong size");
  }
  x_ref_ = x_ref;
}

void StateErrorResidual::reference(const NodeContext& /*ctx*/, VecRef x_ref) const {
  x_ref = x_ref_;
}

std::unique_ptr<ResidualData> StateErrorResidual::createData() const {
  return std::make_unique<StateDiffData>(maxRows(), space_->nx(), ndx(), nu());
}

void StateErrorResidual::calc(const NodeContext& ctx, ConstVecRef x, ConstVecRef /*u*/,
                              ResidualData& d) const {
  auto& s = static_cast<StateDiffData&>(d);
  reference(ctx, s.xref);
  space_->difference(s.xref, x, s.r.head(ndx()));
}

void StateErrorResidual::calcDiff(const NodeContext& /*ctx*/, ConstVecRef x, ConstVecRef /*u*/,
                                  ResidualData& d) const {
  auto& s = static_cast<StateDiffData&>(d);
  if (space_->isEuclidean()) {
    s.Rx.setIdentity();
  } else {
    space_->differenceJacobians(s.xref, x, s.J0, s.Rx);
  }
  s.Ru.setZero();
}

void StateErrorResidual::calcDiffHead(ConstVecRef x, ResidualData& d) const {
  auto& s = static_cast<StateDiffData&>(d);
  const int b = space_->euclideanTangentOffset();
  space_->differenceJacobiansHead(s.xref, x, s.J0.topLeftCorner(b, b), s.Rx.topLeftCorner(b, b));
}

// ---- InputErrorResidual --------------------------------------------------------------------

InputErrorResidual::InputErrorResidual(int ndx, const VectorXd& u_ref)
    : Residual(ndx, static_cast<int>(u_ref.size()), static_cast<int>(u_ref.size())),
      u_ref_(u_ref) {}

void InputErrorResidual::setReference(const VectorXd& u_ref) {
  if (u_ref.size() != u_ref_.size()) {
    throw std::invalid_argument("InputErrorResidual::setReference: wrong size");
  }
  u_ref_ = u_ref;
}

void InputErrorResidual::reference(const NodeContext& /*ctx*/, VecRef u_ref) const {
  u_ref = u_ref_;
}

void InputErrorResidual::calc(const NodeContext& ctx, ConstVecRef /*x*/, ConstVecRef u,
                              ResidualData& d) const {
  auto r = d.r.head(nu());
  reference(ctx, r);
  r = u - r;
}

void InputErrorResidual::calcDiff(const NodeContext& /*ctx*/, ConstVecRef /*x*/, ConstVecRef /*u*/,
                                  ResidualData& d) const {
  d.Rx.setZero();
  d.Ru.setIdentity();
}

// ---- AffineResidual --------------------------------------------------------------------------

AffineResidual::AffineResidual(std::shared_ptr<const StateSpace> space, const VectorXd& x_lin,
                               const MatrixXd& C, const MatrixXd& D, const VectorXd& c)
    : Residual(space ? space->ndx() : 0, static_cast<int>(D.cols()), static_cast<int>(c.size())),
      space_(std::move(space)),
      x_lin_(x_lin),
      C_(C),
      D_(D),
      c_(c) {
  if (!space_) throw std::invalid_argument("AffineResidual: null state space");
  if (x_lin.size() != space_->nx() || C.cols() != space_->ndx() || C.rows() != c.size() ||
      D.rows() != c.size()) {
    throw std::invalid_argument(
        "AffineResidual: inconsistent sizes (need C: m x ndx, D: m x nu, "
        "c: m, x_lin: nx)");
  }
}

std::unique_ptr<ResidualData> AffineResidual::createData() const {
  return std::make_unique<StateDiffData>(maxRows(), space_->nx(), ndx(), nu());
}

void AffineResidual::calc(const NodeContext& /*ctx*/, ConstVecRef x, ConstVecRef u,
                          ResidualData& d) const {
  auto& s = static_cast<StateDiffData&>(d);
  const int m = maxRows();
  space_->difference(x_lin_, x, s.dx);
  s.r.head(m) = c_;
  s.r.head(m).noalias() += C_ * s.dx;
  s.r.head(m).noalias() += D_ * u;
}

void AffineResidual::calcDiff(const NodeContext& /*ctx*/, ConstVecRef x, ConstVecRef /*u*/,
                              ResidualData& d) const {
  auto& s = static_cast<StateDiffData&>(d);
  const int m = maxRows();
  if (space_->isEuclidean()) {
    s.Rx.topRows(m) = C_;
  } else {
    space_->differenceJacobians(x_lin_, x, s.J0, s.J1);
    s.Rx.topRows(m).noalias() = C_ * s.J1;
  }
  s.Ru.topRows(m) = D_;
}

}  // namespace rollstep::ocp
