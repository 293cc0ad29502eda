#pragma once
// Dynamics of the discretised system: x_{k+1} = F(x_k, u_k) over one node step dt.
// Jacobians are in tangent coordinates: F(x (+) dx, u + du) ~= F(x, u) (+) (Fx dx + Fu du).
#include <memory>

#include "rollstep/ocp/state_space.hpp"

namespace rollstep::ocp {

struct DynamicsData {
  virtual ~DynamicsData() = default;
};

/// Discrete-time dynamics (what the multiple-shooting solver uses).
class Dynamics {
 public:
  Dynamics(std::shared_ptr<const StateSpace> space, int nu) : space_(std::move(space)), nu_(nu) {}
  virtual ~Dynamics() = default;
  const StateSpace& space() const { return *space_; }
  const std::shared_ptr<const StateSpace>& spacePtr() const { return space_; }
  int nu() const { return nu_; }
  /// True when F is affine in the tangent coordinates on a Euclidean space
  /// (F(x + dx, u + du) = F(x, u) + Fx dx + Fu du): no curvature is computed for it.
  virtual bool isLinear() const { return false; }
  virtual std::unique_ptr<DynamicsData> createData() const = 0;
  /// Workspace for a node whose every call carries the problem's node cache (see
  /// Residual::createDataWithNodeCache). Default: createData().
  virtual std::unique_ptr<DynamicsData> createDataWithNodeCache() const { return createData(); }
  /// xnext = F(x, u) over ctx.dt.
  virtual void calc(const NodeContext& ctx, ConstVecRef x, ConstVecRef u, DynamicsData& d,
                    VecRef xnext) const = 0;
  /// Fx (ndx x ndx), Fu (ndx x nu). Called right after calc with the same arguments.
  virtual void calcDiff(const NodeContext& ctx, ConstVecRef x, ConstVecRef u, DynamicsData& d,
                        MatRef Fx, MatRef Fu) const = 0;

 private:
  std::shared_ptr<const StateSpace> space_;
  int nu_;
};

/// Continuous-time dynamics: the tangent velocity xdot = f(x, u) (size ndx).
class ContinuousDynamics {
 public:
  ContinuousDynamics(std::shared_ptr<const StateSpace> space, int nu)
      : space_(std::move(space)), nu_(nu) {}
  virtual ~ContinuousDynamics() = default;
  const StateSpace& space() const { return *space_; }
  const std::shared_ptr<const StateSpace>& spacePtr() const { return space_; }
  int nu() const { return nu_; }
  /// True when f is affine in (x, u) on a Euclidean space; the integrators below are
  /// then affine too.
  virtual bool isLinear() const { return false; }
  virtual std::unique_ptr<DynamicsData> createData() const = 0;
  /// Workspace for calls that all carry the node cache of the point (x, u) they evaluate
  /// (see Residual::createDataWithNodeCache). Default: createData().
  virtual std::unique_ptr<DynamicsData> createDataWithNodeCache() const { return createData(); }
  virtual void calc(const NodeContext& ctx, ConstVecRef x, ConstVecRef u, DynamicsData& d,
                    VecRef xdot) const = 0;
  /// fx = d f / d x (tangent), fu = d f / d u. Called right after calc.
  virtual void calcDiff(const NodeContext& ctx, ConstVecRef x, ConstVecRef u, DynamicsData& d,
                        MatRef fx, MatRef fu) const = 0;

 private:
  std::shared_ptr<const StateSpace> space_;
  int nu_;
};

/// Explicit Euler on the manifold: F(x, u) = x (+) dt f(x, u). Works on any StateSpace.
class ExplicitEuler final : public Dynamics {
 public:
  explicit ExplicitEuler(std::shared_ptr<const ContinuousDynamics> f);
  bool isLinear() const override { return f_->isLinear() && f_->space().isEuclidean(); }
  std::unique_ptr<DynamicsData> createData() const override;
  /// f evaluates at the node's own (x, u): its createDataWithNodeCache() workspace.
  std::unique_ptr<DynamicsData> createDataWithNodeCache() const override;
  void calc(const NodeContext& ctx, ConstVecRef x, ConstVecRef u, DynamicsData& d,
            VecRef xnext) const override;
  void calcDiff(const NodeContext& ctx, ConstVecRef x, ConstVecRef u, DynamicsData& d, MatRef Fx,
                MatRef Fu) const override;
  const ContinuousDynamics& continuous() const { return *f_; }

 private:
  std::shared_ptr<const ContinuousDynamics> f_;
};

/// Classic 4th-order Runge-Kutta with zero-order-hold input. Euclidean spaces only
/// (the constructor throws std::invalid_argument otherwise).
class RungeKutta4 final : public Dynamics {
 public:
  explicit RungeKutta4(std::shared_ptr<const ContinuousDynamics> f);
  bool isLinear() const override { return f_->isLinear(); }
  std::unique_ptr<DynamicsData> createData() const override;
  void calc(const NodeContext& ctx, ConstVecRef x, ConstVecRef u, DynamicsData& d,
            VecRef xnext) const override;
  void calcDiff(const NodeContext& ctx, ConstVecRef x, ConstVecRef u, DynamicsData& d, MatRef Fx,
                MatRef Fu) const override;

 private:
  std::shared_ptr<const ContinuousDynamics> f_;
};

}  // namespace rollstep::ocp
