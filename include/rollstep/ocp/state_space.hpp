#pragma once
// The manifold a state lives on. States are stored as plain vectors of size nx() (the
// representation); perturbations live in the tangent space of size ndx().
#include "rollstep/ocp/types.hpp"

namespace rollstep::ocp {

class StateSpace {
 public:
  virtual ~StateSpace() = default;
  virtual int nx() const = 0;   ///< representation size
  virtual int ndx() const = 0;  ///< tangent size
  /// The neutral element (zero for R^n, identity pose for SE(3)).
  virtual void neutral(VecRef x) const = 0;
  /// out = x (+) dx (right/local perturbation on Lie groups).
  virtual void integrate(ConstVecRef x, ConstVecRef dx, VecRef out) const = 0;
  /// out = x1 (-) x0, so that x0 (+) out = x1.
  virtual void difference(ConstVecRef x0, ConstVecRef x1, VecRef out) const = 0;
  /// Jacobians of integrate(x, dx) w.r.t. x (tangent at x) and dx. ndx x ndx each.
  virtual void integrateJacobians(ConstVecRef x, ConstVecRef dx, MatRef Jx, MatRef Jdx) const = 0;
  /// Jacobians of difference(x0, x1) w.r.t. x0 and x1 (tangent perturbations). ndx x ndx each.
  virtual void differenceJacobians(ConstVecRef x0, ConstVecRef x1, MatRef J0, MatRef J1) const = 0;
  /// The same Jacobians restricted to their leading b x b blocks, b =
  /// euclideanTangentOffset() (the rest is the identity, -I for J0 of the difference):
  /// for callers that exploit this block structure. Each argument is b x b.
  virtual void integrateJacobiansHead(ConstVecRef /*x*/, ConstVecRef /*dx*/, MatRef /*Jx*/,
                                      MatRef /*Jdx*/) const {}
  virtual void differenceJacobiansHead(ConstVecRef /*x0*/, ConstVecRef /*x1*/, MatRef /*J0*/,
                                       MatRef /*J1*/) const {}
  /// True when nx() == ndx() and integrate is plain addition.
  virtual bool isEuclidean() const = 0;
  /// Offset of the Euclidean tail of the tangent (components that are plain coordinates);
  /// the representation index of tangent index i >= euclideanTangentOffset() is
  /// i + nx() - ndx().
  virtual int euclideanTangentOffset() const = 0;
};

/// R^n.
class EuclideanSpace final : public StateSpace {
 public:
  explicit EuclideanSpace(int n);
  int nx() const override { return n_; }
  int ndx() const override { return n_; }
  void neutral(VecRef x) const override;
  void integrate(ConstVecRef x, ConstVecRef dx, VecRef out) const override;
  void difference(ConstVecRef x0, ConstVecRef x1, VecRef out) const override;
  void integrateJacobians(ConstVecRef x, ConstVecRef dx, MatRef Jx, MatRef Jdx) const override;
  void differenceJacobians(ConstVecRef x0, ConstVecRef x1, MatRef J0, MatRef J1) const override;
  bool isEuclidean() const override { return true; }
  int euclideanTangentOffset() const override { return 0; }

 private:
  int n_;
};

/// SE(3) x R^n: x = [p (3), quaternion (x, y, z, w) (4), z (n)],
/// dx = [rho (3, local translation), theta (3, local rotation), dz (n)].
/// Uses the SE(3) exponential (rollstep::lie), right perturbation x (+) d = x Exp(d).
class SE3xEuclideanSpace final : public StateSpace {
 public:
  explicit SE3xEuclideanSpace(int n);
  int nx() const override { return 7 + n_; }
  int ndx() const override { return 6 + n_; }
  void neutral(VecRef x) const override;
  void integrate(ConstVecRef x, ConstVecRef dx, VecRef out) const override;
  void difference(ConstVecRef x0, ConstVecRef x1, VecRef out) const override;
  void integrateJacobians(ConstVecRef x, ConstVecRef dx, MatRef Jx, MatRef Jdx) const override;
  void differenceJacobians(ConstVecRef x0, ConstVecRef x1, MatRef J0, MatRef J1) const override;
  void integrateJacobiansHead(ConstVecRef x, ConstVecRef dx, MatRef Jx, MatRef Jdx) const override;
  void differenceJacobiansHead(ConstVecRef x0, ConstVecRef x1, MatRef J0, MatRef J1) const override;
  bool isEuclidean() const override { return false; }
  int euclideanTangentOffset() const override { return 6; }

 private:
  int n_;
};

}  // namespace rollstep::ocp
