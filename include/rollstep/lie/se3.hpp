#pragma once
// SE(3) with (translation, unit quaternion) storage.
//
// Conventions (binding for the whole project):
//  - Tangent vectors are ordered [rho (translation part, 3); theta (rotation, 3)], i.e.
//    linear first, like Pinocchio's Motion. A body twist is expressed in the LOCAL frame.
//  - Exp([rho; theta]) = (Jl_SO3(theta) rho, Exp_SO3(theta)).
//  - Right-plus: x (+) d = x * Exp(d) (local perturbation).
//    Minus:      x1 (-) x0 = Log(x0^-1 * x1).
//  - Right Jacobian Jr(d): Exp(d + dd) ~= Exp(d) * Exp(Jr(d) dd); Jl(d) = Jr(-d).
//  - Adjoint Ad(x) = [[R, hat(t) R], [0, R]] maps local twists to the parent frame.
//  - In plain vectors (solver states) a pose is 7 numbers [p(3); quat (x, y, z, w)].
// Everything is fixed-size and allocation-free, stable near zero angle and near pi.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>

#include "rollstep/lie/so3.hpp"

namespace rollstep::lie {

using Vector6d = Eigen::Matrix<double, 6, 1>;
using Matrix6d = Eigen::Matrix<double, 6, 6>;
using Vector7d = Eigen::Matrix<double, 7, 1>;

/// Rigid transform x = (R, t): x.act(p) = R p + t.
struct SE3 {
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();

  SE3() = default;
  SE3(const Eigen::Vector3d& t, const Eigen::Quaterniond& r) : translation(t), rotation(r) {}

  static SE3 Identity() { return SE3(); }

  /// Composition (this * other).
  SE3 operator*(const SE3& other) const {
    return SE3(translation + rotation * other.translation, rotation * other.rotation);
  }
  /// Inverse (assumes a unit quaternion).
  SE3 inverse() const {
    const Eigen::Quaterniond ri = rotation.conjugate();
    return SE3(-(ri * translation), ri);
  }
  /// Transforms a point: R p + t.
  Eigen::Vector3d act(const Eigen::Vector3d& p) const { return rotation * p + translation; }
  /// Homogeneous 4x4 matrix.
  Eigen::Matrix4d toMatrix() const {
    Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
    m.topLeftCorner<3, 3>() = rotation.toRotationMatrix();
    m.topRightCorner<3, 1>() = translation;
    return m;
  }
  /// [p; quat (x, y, z, w)].
  Vector7d coeffs() const {
    Vector7d c;
    c.head<3>() = translation;
    c.tail<4>() = rotation.coeffs();
    return c;
  }
  /// From [p; quat (x, y, z, w)]; the quaternion is used as given (not normalised).
  static SE3 fromCoeffs(const Eigen::Ref<const Vector7d>& c) {
    return SE3(c.head<3>(), Eigen::Quaterniond(c(6), c(3), c(4), c(5)));
  }
  /// Approximate equality of transforms (quaternion sign ignored).
  bool isApprox(const SE3& other, double tol = 1e-12) const {
    return (translation - other.translation).norm() <= tol &&
           std::abs(std::abs(rotation.dot(other.rotation)) - 1.0) <= tol;
  }
};

SE3 expSE3(const Vector6d& d);
Vector6d logSE3(const SE3& x);

/// Ad(x) = [[R, hat(t) R], [0, R]].
Matrix6d adjoint(const SE3& x);

Matrix6d rightJacobianSE3(const Vector6d& d);
Matrix6d rightJacobianInverseSE3(const Vector6d& d);
Matrix6d leftJacobianSE3(const Vector6d& d);
Matrix6d leftJacobianInverseSE3(const Vector6d& d);

/// x (+) d = x * Exp(d).
SE3 plus(const SE3& x, const Vector6d& d);
/// x1 (-) x0 = Log(x0^-1 * x1).
Vector6d minus(const SE3& x1, const SE3& x0);

/// Derivatives of x (+) d: d/dx = Ad(Exp(-d)), d/dd = Jr(d).
void plusJacobians(const SE3& x, const Vector6d& d, Matrix6d& j_x, Matrix6d& j_d);
/// Derivatives of e = x1 (-) x0: d/dx1 = Jr^-1(e), d/dx0 = -Jl^-1(e).
void minusJacobians(const SE3& x1, const SE3& x0, Matrix6d& j_x1, Matrix6d& j_x0);

// ---- Helpers on raw 7-vectors [p; quat (x, y, z, w)] (Eigen::Ref / Map / segment friendly).

/// out = x (+) d. `out` may alias `x`. The output quaternion is normalised.
void integrateSE3(const Eigen::Ref<const Vector7d>& x, const Eigen::Ref<const Vector6d>& d,
                  Eigen::Ref<Vector7d> out);
/// out = x1 (-) x0 (Pinocchio's difference(x0, x1)).
void differenceSE3(const Eigen::Ref<const Vector7d>& x0, const Eigen::Ref<const Vector7d>& x1,
                   Eigen::Ref<Vector6d> out);
/// Derivatives of x (+) d w.r.t. x (tangent) and d.
void integrateSE3Jacobians(const Eigen::Ref<const Vector7d>& x, const Eigen::Ref<const Vector6d>& d,
                           Eigen::Ref<Matrix6d> j_x, Eigen::Ref<Matrix6d> j_d);
/// Derivatives of x1 (-) x0 w.r.t. x0 and x1 (tangent).
void differenceSE3Jacobians(const Eigen::Ref<const Vector7d>& x0,
                            const Eigen::Ref<const Vector7d>& x1, Eigen::Ref<Matrix6d> j_x0,
                            Eigen::Ref<Matrix6d> j_x1);

namespace detail {
/// Barfoot's Q(rho, theta): the top-right block of the left Jacobian of SE(3).
Eigen::Matrix3d jacobianQ(const Eigen::Vector3d& rho, const Eigen::Vector3d& theta);
}  // namespace detail

}  // namespace rollstep::lie
