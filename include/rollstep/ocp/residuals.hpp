#pragma once
// Ready-made residuals used by most problems.
#include <memory>

#include "rollstep/ocp/residual.hpp"
#include "rollstep/ocp/state_space.hpp"

namespace rollstep::ocp {

/// r = x (-) x_ref(t) (tangent size). The reference is constant unless a derived class
/// overrides reference(). State-only.
class StateErrorResidual : public Residual {
 public:
  StateErrorResidual(std::shared_ptr<const StateSpace> space, int nu, const VectorXd& x_ref);
  bool dependsOnInput() const override { return false; }
  /// On a Euclidean space x - x_ref is affine; on a Lie group the log is not.
  bool isLinear() const override { return space_->isEuclidean(); }
  void setReference(const VectorXd& x_ref);  ///< must have size nx; does not allocate
  /// The reference at this node; default: the constant one.
  virtual void reference(const NodeContext& ctx, VecRef x_ref) const;
  std::unique_ptr<ResidualData> createData() const override;
  void calc(const NodeContext& ctx, ConstVecRef x, ConstVecRef u, ResidualData& d) const override;
  void calcDiff(const NodeContext& ctx, ConstVecRef x, ConstVecRef u,
                ResidualData& d) const override;
  /// calcDiff restricted to the leading b x b block of Rx, b =
  /// space().euclideanTangentOffset() (the rest of Rx is the identity and Ru is zero,
  /// left as they are), for callers that exploit that structure. Needs calc() first.
  void calcDiffHead(ConstVecRef x, ResidualData& d) const;
  const StateSpace& space() const { return *space_; }

 protected:
  std::shared_ptr<const StateSpace> space_;
  VectorXd x_ref_;
};

/// r = u - u_ref(t) (size nu). The reference is constant unless reference() is overridden.
class InputErrorResidual : public Residual {
 public:
  InputErrorResidual(int ndx, const VectorXd& u_ref);
  bool dependsOnState() const override { return false; }
  bool isLinear() const override { return true; }
  void setReference(const VectorXd& u_ref);
  virtual void reference(const NodeContext& ctx, VecRef u_ref) const;
  void calc(const NodeContext& ctx, ConstVecRef x, ConstVecRef u, ResidualData& d) const override;
  void calcDiff(const NodeContext& ctx, ConstVecRef x, ConstVecRef u,
                ResidualData& d) const override;

 protected:
  VectorXd u_ref_;
};

/// r = S_x (x (-) x0)_sel + S_u u + c: a linear (affine) residual in the tangent
/// coordinates around a fixed linearisation point; r = C dx + D u + c where
/// dx = x (-) x_lin. Useful for linear constraints and linear-quadratic tests.
class AffineResidual : public Residual {
 public:
  AffineResidual(std::shared_ptr<const StateSpace> space, const VectorXd& x_lin, const MatrixXd& C,
                 const MatrixXd& D, const VectorXd& c);
  bool dependsOnInput() const override { return !D_.isZero(0.0); }
  /// Affine in (x (-) x_lin, u): linear in the tangent coordinates on Euclidean spaces only.
  bool isLinear() const override { return space_->isEuclidean(); }
  std::unique_ptr<ResidualData> createData() const override;
  void calc(const NodeContext& ctx, ConstVecRef x, ConstVecRef u, ResidualData& d) const override;
  void calcDiff(const NodeContext& ctx, ConstVecRef x, ConstVecRef u,
                ResidualData& d) const override;

 private:
  std::shared_ptr<const StateSpace> space_;
  VectorXd x_lin_;
  MatrixXd C_, D_;
  VectorXd c_;
};

}  // namespace rollstep::ocp
