#pragma once
// SO(3) with unit-quaternion storage.
//
// Conventions (binding for the whole project):
//  - Quaternions are Eigen::Quaterniond; inside plain vectors they are stored as
//    (x, y, z, w), the order of Eigen's coeffs().
//  - Tangent vectors are rotation vectors theta (axis * angle, rad).
//  - Right-plus: R (+) d = R * Exp(d)  (local perturbation).
//    Minus:      R1 (-) R0 = Log(R0^-1 * R1).
//  - Right Jacobian Jr(w): Exp(w + dw) ~= Exp(w) * Exp(Jr(w) dw).
//    Left Jacobian  Jl(w): Exp(w + dw) ~= Exp(Jl(w) dw) * Exp(w).   Jl(w) = Jr(-w) = Jr(w)^T.
// Everything is fixed-size, allocation-free and numerically stable near zero angle
// (Taylor series) and near pi (Log returns an angle in [0, pi]).
#include <Eigen/Core>
#include <Eigen/Geometry>

namespace rollstep::lie {

/// Skew-symmetric matrix: hat(w) * x = w.cross(x).
inline Eigen::Matrix3d hat(const Eigen::Vector3d& w) {
  Eigen::Matrix3d m;
  m << 0.0, -w.z(), w.y(), w.z(), 0.0, -w.x(), -w.y(), w.x(), 0.0;
  return m;
}

/// Inverse of hat (reads the skew-symmetric part).
inline Eigen::Vector3d vee(const Eigen::Matrix3d& m) {
  return Eigen::Vector3d(0.5 * (m(2, 1) - m(1, 2)), 0.5 * (m(0, 2) - m(2, 0)),
                         0.5 * (m(1, 0) - m(0, 1)));
}

/// Exponential map: rotation vector -> unit quaternion.
Eigen::Quaterniond expSO3(const Eigen::Vector3d& w);
/// Logarithm: unit quaternion -> rotation vector with angle in [0, pi].
/// The quaternion need not be exactly normalised.
Eigen::Vector3d logSO3(const Eigen::Quaterniond& q);

Eigen::Matrix3d rightJacobianSO3(const Eigen::Vector3d& w);
Eigen::Matrix3d rightJacobianInverseSO3(const Eigen::Vector3d& w);
Eigen::Matrix3d leftJacobianSO3(const Eigen::Vector3d& w);
Eigen::Matrix3d leftJacobianInverseSO3(const Eigen::Vector3d& w);

/// R (+) d = R * Exp(d).
Eigen::Quaterniond plus(const Eigen::Quaterniond& r, const Eigen::Vector3d& d);
/// R1 (-) R0 = Log(R0^-1 * R1).
Eigen::Vector3d minus(const Eigen::Quaterniond& r1, const Eigen::Quaterniond& r0);

/// Derivatives of R (+) d: d/dR = Exp(d)^T (= Ad(Exp(-d))), d/dd = Jr(d).
void plusJacobians(const Eigen::Quaterniond& r, const Eigen::Vector3d& d, Eigen::Matrix3d& j_r,
                   Eigen::Matrix3d& j_d);
/// Derivatives of e = R1 (-) R0: d/dR1 = Jr^-1(e), d/dR0 = -Jl^-1(e).
void minusJacobians(const Eigen::Quaterniond& r1, const Eigen::Quaterniond& r0,
                    Eigen::Matrix3d& j_r1, Eigen::Matrix3d& j_r0);

namespace detail {
/// Coefficients of Jr/Jl: alpha = (1 - cos t)/t^2, beta = (t - sin t)/t^3.
void jacobianCoefficientsSO3(double theta, double& alpha, double& beta);
/// Coefficient of Jr^-1/Jl^-1: gamma = 1/t^2 - (1 + cos t)/(2 t sin t).
double inverseJacobianCoefficientSO3(double theta);
}  // namespace detail

}  // namespace rollstep::lie
