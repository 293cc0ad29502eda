#pragma once
// Cost terms. Running costs are densities: the node's cost is dt * l(x, u); terminal
// costs are taken as they are.
#include <memory>

#include "rollstep/ocp/residual.hpp"

namespace rollstep::ocp {

struct CostData {
  virtual ~CostData() = default;
};

class CostTerm {
 public:
  CostTerm(int ndx, int nu) : ndx_(ndx), nu_(nu) {}
  virtual ~CostTerm() = default;
  int ndx() const { return ndx_; }
  int nu() const { return nu_; }
  /// False for state-only costs (required for terminal costs).
  virtual bool dependsOnInput() const { return true; }
  virtual bool active(const NodeContext& /*ctx*/) const { return true; }
  /// True when the Hessian calcDiff adds is the exact second derivative of l in the
  /// tangent coordinates (l(x (+) dx, u + du) to second order), not a Gauss-Newton
  /// approximation. The solver then computes no curvature for this term when it forms
  /// the Lagrangian's Hessian (SolverSettings::exact_hessian); otherwise the missing
  /// curvature is found by central differences of calcDiff's gradient. An exact Hessian
  /// may be indefinite: the solver's inertia correction handles it.
  virtual bool hessianIsExact() const { return false; }
  virtual std::unique_ptr<CostData> createData() const = 0;
  /// Workspace for a node whose every call carries the problem's node cache (see
  /// Residual::createDataWithNodeCache). Default: createData().
  virtual std::unique_ptr<CostData> createDataWithNodeCache() const { return createData(); }
  /// Value l(x, u).
  virtual double calc(const NodeContext& ctx, ConstVecRef x, ConstVecRef u, CostData& d) const = 0;
  /// ADDS scale * (gradient, Gauss-Newton Hessian) to the given accumulators (the
  /// caller passes scale = dt for running nodes). Called right after calc.
  virtual void calcDiff(const NodeContext& ctx, ConstVecRef x, ConstVecRef u, CostData& d,
                        double scale, VecRef lx, VecRef lu, MatRef Lxx, MatRef Luu,
                        MatRef Lux) const = 0;

 private:
  int ndx_, nu_;
};

/// l = 0.5 * sum_i w_i r_i(x, u)^2 with a nonnegative diagonal weight; Gauss-Newton
/// Hessian R^T W R. Tracking residuals (InputErrorResidual, StateErrorResidual and classes
/// derived from them that only override reference()) take a structured path: identity
/// Jacobians, and on SE(3) x R^n only the 6 x 6 pose block is dense.
class LeastSquaresCost final : public CostTerm {
 public:
  LeastSquaresCost(std::shared_ptr<const Residual> residual, const VectorXd& weights);
  bool dependsOnInput() const override { return residual_->dependsOnInput(); }
  bool active(const NodeContext& ctx) const override { return residual_->rows(ctx) > 0; }
  /// R^T W R is exact when the residual is linear.
  bool hessianIsExact() const override { return residual_->isLinear(); }
  std::unique_ptr<CostData> createData() const override;
  /// The residual's createDataWithNodeCache() workspace.
  std::unique_ptr<CostData> createDataWithNodeCache() const override;
  double calc(const NodeContext& ctx, ConstVecRef x, ConstVecRef u, CostData& d) const override;
  void calcDiff(const NodeContext& ctx, ConstVecRef x, ConstVecRef u, CostData& d, double scale,
                VecRef lx, VecRef lu, MatRef Lxx, MatRef Luu, MatRef Lux) const override;
  void setWeights(const VectorXd& weights);  ///< same size as before; does not allocate
  const Residual& residual() const { return *residual_; }

 private:
  enum class Structure { Generic, InputIdentity, StateIdentity, StateBlock };
  std::shared_ptr<const Residual> residual_;
  VectorXd weights_;
  Structure structure_ = Structure::Generic;
  int block_ = 0;  ///< StateBlock: size of the dense leading block (6 on SE(3) x R^n)
};

}  // namespace rollstep::ocp
