#pragma once
// Small models shared by the ocp and solver tests (and the solver benchmark).
#include <cmath>
#include <memory>

#include "rollstep/lie/so3.hpp"
#include "rollstep/ocp/dynamics.hpp"
#include "rollstep/ocp/residual.hpp"
#include "rollstep/ocp/state_space.hpp"

namespace rollstep::testmodels {

using ocp::ConstVecRef;
using ocp::MatRef;
using ocp::MatrixXd;
using ocp::NodeContext;
using ocp::VecRef;
using ocp::VectorXd;

/// Discrete linear dynamics x+ = A x + B u + c (Euclidean).
class LinearDynamics final : public ocp::Dynamics {
 public:
  LinearDynamics(const MatrixXd& A, const MatrixXd& B, const VectorXd& c)
      : Dynamics(std::make_shared<ocp::EuclideanSpace>(static_cast<int>(A.rows())),
                 static_cast<int>(B.cols())),
        A_(A),
        B_(B),
        c_(c) {}
  bool isLinear() const override { return true; }
  std::unique_ptr<ocp::DynamicsData> createData() const override {
    return std::make_unique<ocp::DynamicsData>();
  }
  void calc(const NodeContext&, ConstVecRef x, ConstVecRef u, ocp::DynamicsData&,
            VecRef xnext) const override {
    xnext = c_;
    xnext.noalias() += A_ * x;
    xnext.noalias() += B_ * u;
  }
  void calcDiff(const NodeContext&, ConstVecRef, ConstVecRef, ocp::DynamicsData&, MatRef Fx,
                MatRef Fu) const override {
    Fx = A_;
    Fu = B_;
  }
  MatrixXd A_, B_;
  VectorXd c_;
};

/// Damped pendulum: x = (angle, rate), u = torque. theta'' = -a sin(theta) - b theta' + u.
class Pendulum final : public ocp::ContinuousDynamics {
 public:
  Pendulum() : ContinuousDynamics(std::make_shared<ocp::EuclideanSpace>(2), 1) {}
  std::unique_ptr<ocp::DynamicsData> createData() const override {
    return std::make_unique<ocp::DynamicsData>();
  }
  void calc(const NodeContext&, ConstVecRef x, ConstVecRef u, ocp::DynamicsData&,
            VecRef xdot) const override {
    xdot(0) = x(1);
    xdot(1) = -9.81 * std::sin(x(0)) - 0.1 * x(1) + u(0);
  }
  void calcDiff(const NodeContext&, ConstVecRef x, ConstVecRef, ocp::DynamicsData&, MatRef fx,
                MatRef fu) const override {
    fx << 0.0, 1.0, -9.81 * std::cos(x(0)), -0.1;
    fu << 0.0, 1.0;
  }
};

/// Rigid body on SE(3) x R^6: x = (pose, body twist v), u = body acceleration (6).
/// pose' = v (local), v' = u + [R^T g; 0] (gravity seen in the body frame).
class FloatingBody final : public ocp::ContinuousDynamics {
 public:
  FloatingBody() : ContinuousDynamics(std::make_shared<ocp::SE3xEuclideanSpace>(6), 6) {}
  std::unique_ptr<ocp::DynamicsData> createData() const override {
    return std::make_unique<ocp::DynamicsData>();
  }
  void calc(const NodeContext&, ConstVecRef x, ConstVecRef u, ocp::DynamicsData&,
            VecRef xdot) const override {
    const Eigen::Quaterniond q(x(6), x(3), x(4), x(5));
    xdot.head<6>() = x.segment<6>(7);
    xdot.tail<6>() = u;
    xdot.segment<3>(6) += q.conjugate() * gravity();
  }
  void calcDiff(const NodeContext&, ConstVecRef x, ConstVecRef, ocp::DynamicsData&, MatRef fx,
                MatRef fu) const override {
    const Eigen::Quaterniond q(x(6), x(3), x(4), x(5));
    fx.setZero();
    fx.block<6, 6>(0, 6).setIdentity();
    // d(R^T g)/dtheta for R -> R Exp(theta): hat(R^T g).
    fx.block<3, 3>(6, 3) = lie::hat(q.conjugate() * gravity());
    fu.setZero();
    fu.bottomRows<6>().setIdentity();
  }
  static Eigen::Vector3d gravity() { return Eigen::Vector3d(0.0, 0.0, -9.81); }
};

}  // namespace rollstep::testmodels
