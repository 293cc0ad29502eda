#include "rollstep/lie/se3.hpp"

#include <cmath>

namespace rollstep::lie {

namespace detail {
Eigen::Matrix3d jacobianQ(const Eigen::Vector3d& rho, const Eigen::Vector3d& theta) {
  const double t2 = theta.squaredNorm();
  const double t = std::sqrt(t2);
  double a;
  double b;
  double c;
  if (t < 0.1) {  // Taylor series; the truncation error is below 1e-13 here.
    const double t4 = t2 * t2;
    const double t6 = t4 * t2;
    a = 1.0 / 6.0 - t2 / 120.0 + t4 / 5040.0 - t6 / 362880.0;
    b = 1.0 / 24.0 - t2 / 720.0 + t4 / 40320.0 - t6 / 3628800.0;
    c = 1.0 / 120.0 - t2 / 2520.0 + t4 / 120960.0 - t6 / 9979200.0;
  } else {
    const double s = std::sin(t);
    const double co = std::cos(t);
    a = (t - s) / (t2 * t);
    b = (t2 + 2.0 * co - 2.0) / (2.0 * t2 * t2);
    c = (2.0 * t - 3.0 * s + t * co) / (2.0 * t2 * t2 * t);
  }
  const Eigen::Matrix3d P = hat(rho);
  const Eigen::Matrix3d T = hat(theta);
  const Eigen::Matrix3d TP = T * P;
  const Eigen::Matrix3d PT = P * T;
  const Eigen::Matrix3d TPT = TP * T;
  const Eigen::Matrix3d TT = T * T;
  return 0.5 * P + a * (TP + PT + TPT) + b * (TT * P + P * TT - 3.0 * TPT) +
         c * (TPT * T + T * TPT);
}
}  // namespace detail

SE3 expSE3(const Vector6d& d) {
  const Eigen::Vector3d rho = d.head<3>();
  const Eigen::Vector3d theta = d.tail<3>();
  return SE3(leftJacobianSO3(theta) * rho, expSO3(theta));
}

Vector6d logSE3(const SE3& x) {
  Vector6d d;
  const Eigen::Vector3d theta = logSO3(x.rotation);
  d.tail<3>() = theta;
  d.head<3>() = leftJacobianInverseSO3(theta) * x.translation;
  return d;
}

Matrix6d adjoint(const SE3& x) {
  Matrix6d m;
  const Eigen::Matrix3d r = x.rotation.toRotationMatrix();
  m.topLeftCorner<3, 3>() = r;
  m.topRightCorner<3, 3>() = hat(x.translation) * r;
  m.bottomLeftCorner<3, 3>().setZero();
  m.bottomRightCorner<3, 3>() = r;
  return m;
}

Matrix6d leftJacobianSE3(const Vector6d& d) {
  Matrix6d m;
  const Eigen::Matrix3d j = leftJacobianSO3(d.tail<3>());
  m.topLeftCorner<3, 3>() = j;
  m.topRightCorner<3, 3>() = detail::jacobianQ(d.head<3>(), d.tail<3>());
  m.bottomLeftCorner<3, 3>().setZero();
  m.bottomRightCorner<3, 3>() = j;
  return m;
}

Matrix6d rightJacobianSE3(const Vector6d& d) { return leftJacobianSE3(-d); }

Matrix6d leftJacobianInverseSE3(const Vector6d& d) {
  Matrix6d m;
  const Eigen::Matrix3d ji = leftJacobianInverseSO3(d.tail<3>());
  const Eigen::Matrix3d q = detail::jacobianQ(d.head<3>(), d.tail<3>());
  m.topLeftCorner<3, 3>() = ji;
  m.topRightCorner<3, 3>() = -ji * q * ji;
  m.bottomLeftCorner<3, 3>().setZero();
  m.bottomRightCorner<3, 3>() = ji;
  return m;
}

Matrix6d rightJacobianInverseSE3(const Vector6d& d) { return leftJacobianInverseSE3(-d); }

SE3 plus(const SE3& x, const Vector6d& d) {
  SE3 y = x * expSE3(d);
  y.rotation.normalize();
  return y;
}

Vector6d minus(const SE3& x1, const SE3& x0) { return logSE3(x0.inverse() * x1); }

void plusJacobians(const SE3& /*x*/, const Vector6d& d, Matrix6d& j_x, Matrix6d& j_d) {
  j_x = adjoint(expSE3(-d));
  j_d = rightJacobianSE3(d);
}

void minusJacobians(const SE3& x1, const SE3& x0, Matrix6d& j_x1, Matrix6d& j_x0) {
  const Vector6d e = minus(x1, x0);
  j_x1 = rightJacobianInverseSE3(e);
  j_x0 = -leftJacobianInverseSE3(e);
}

void integrateSE3(const Eigen::Ref<const Vector7d>& x, const Eigen::Ref<const Vector6d>& d,
                  Eigen::Ref<Vector7d> out) {
  const SE3 y = plus(SE3::fromCoeffs(x), Vector6d(d));
  out = y.coeffs();
}

void differenceSE3(const Eigen::Ref<const Vector7d>& x0, const Eigen::Ref<const Vector7d>& x1,
                   Eigen::Ref<Vector6d> out) {
  out = minus(SE3::fromCoeffs(x1), SE3::fromCoeffs(x0));
}

void integrateSE3Jacobians(const Eigen::Ref<const Vector7d>& x, const Eigen::Ref<const Vector6d>& d,
                           Eigen::Ref<Matrix6d> j_x, Eigen::Ref<Matrix6d> j_d) {
  Matrix6d a;
  Matrix6d b;
  plusJacobians(SE3::fromCoeffs(x), Vector6d(d), a, b);
  j_x = a;
  j_d = b;
}

void differenceSE3Jacobians(const Eigen::Ref<const Vector7d>& x0,
                            const Eigen::Ref<const Vector7d>& x1, Eigen::Ref<Matrix6d> j_x0,
                            Eigen::Ref<Matrix6d> j_x1) {
  Matrix6d a;
  Matrix6d b;
  minusJacobians(SE3::fromCoeffs(x1), SE3::fromCoeffs(x0), a, b);
  j_x1 = a;
  j_x0 = b;
}

}  // namespace rollstep::lie
