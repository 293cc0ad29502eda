#include "rollstep/lie/so3.hpp"

#include <cmath>

namespace rollstep::lie {

namespace {
constexpr double kSmallAngle = 1e-2;  // Taylor series below this angle (Jacobians)
constexpr double kTinyAngle = 1e-4;   // Taylor series below this angle (exp/log)
}  // namespace

namespace detail {
void jacobianCoefficientsSO3(double theta, double& alpha, double& beta) {
  const double t2 = theta * theta;
  if (theta < kSmallAngle) {
    alpha = 0.5 - t2 / 24.0 + t2 * t2 / 720.0;
    beta = 1.0 / 6.0 - t2 / 120.0 + t2 * t2 / 5040.0;
  } else {
    const double s = std::sin(0.5 * theta);
    alpha = 2.0 * s * s / t2;  // (1 - cos t) / t^2 without cancellation
    beta = (theta - std::sin(theta)) / (t2 * theta);
  }
}

double inverseJacobianCoefficientSO3(double theta) {
  const double t2 = theta * theta;
  if (theta < kSmallAngle) return 1.0 / 12.0 + t2 / 720.0 + t2 * t2 / 30240.0;
  const double half = 0.5 * theta;
  // (1 + cos t) / sin t = cot(t/2): finite at t = pi.
  return 1.0 / t2 - std::cos(half) / (std::sin(half) * 2.0 * theta);
}
}  // namespace detail

Eigen::Quaterniond expSO3(const Eigen::Vector3d& w) {
  const double t2 = w.squaredNorm();
  const double theta = std::sqrt(t2);
  double k;
  double c;
  if (theta < kTinyAngle) {
    k = 0.5 - t2 / 48.0 + t2 * t2 / 3840.0;
    c = 1.0 - t2 / 8.0 + t2 * t2 / 384.0;
  } else {
    k = std::sin(0.5 * theta) / theta;
    c = std::cos(0.5 * theta);
  }
  return Eigen::Quaterniond(c, k * w.x(), k * w.y(), k * w.z());
}

Eigen::Vector3d logSO3(const Eigen::Quaterniond& q) {
  double w = q.w();
  Eigen::Vector3d v = q.vec();
  if (w < 0.0) {  // the double cover: pick the representative with angle in [0, pi]
    w = -w;
    v = -v;
  }
  const double n2 = v.squaredNorm();
  const double n = std::sqrt(n2);
  if (n < kTinyAngle * std::abs(w)) {
    // theta / n = 2 atan(n / w) / n = (2 / w) (1 - n^2 / (3 w^2) + n^4 / (5 w^4))
    const double r2 = n2 / (w * w);
    return (2.0 / w) * (1.0 - r2 / 3.0 + r2 * r2 / 5.0) * v;
  }
  const double theta = 2.0 * std::atan2(n, w);
  return (theta / n) * v;
}

Eigen::Matrix3d rightJacobianSO3(const Eigen::Vector3d& w) {
  double a;
  double b;
  detail::jacobianCoefficientsSO3(w.norm(), a, b);
  const Eigen::Matrix3d h = hat(w);
  return Eigen::Matrix3d::Identity() - a * h + b * h * h;
}

Eigen::Matrix3d leftJacobianSO3(const Eigen::Vector3d& w) {
  double a;
  double b;
  detail::jacobianCoefficientsSO3(w.norm(), a, b);
  const Eigen::Matrix3d h = hat(w);
  return Eigen::Matrix3d::Identity() + a * h + b * h * h;
}

Eigen::Matrix3d rightJacobianInverseSO3(const Eigen::Vector3d& w) {
  const double g = detail::inverseJacobianCoefficientSO3(w.norm());
  const Eigen::Matrix3d h = hat(w);
  return Eigen::Matrix3d::Identity() + 0.5 * h + g * h * h;
}

Eigen::Matrix3d leftJacobianInverseSO3(const Eigen::Vector3d& w) {
  const double g = detail::inverseJacobianCoefficientSO3(w.norm());
  const Eigen::Matrix3d h = hat(w);
  return Eigen::Matrix3d::Identity() - 0.5 * h + g * h * h;
}

Eigen::Quaterniond plus(const Eigen::Quaterniond& r, const Eigen::Vector3d& d) {
  return (r * expSO3(d)).normalized();
}

Eigen::Vector3d minus(const Eigen::Quaterniond& r1, const Eigen::Quaterniond& r0) {
  return logSO3(r0.conjugate() * r1);
}

void plusJacobians(const Eigen::Quaterniond& /*r*/, const Eigen::Vector3d& d, Eigen::Matrix3d& j_r,
                   Eigen::Matrix3d& j_d) {
  j_r = expSO3(d).toRotationMatrix().transpose();
  j_d = rightJacobianSO3(d);
}

void minusJacobians(const Eigen::Quaterniond& r1, const Eigen::Quaterniond& r0,
                    Eigen::Matrix3d& j_r1, Eigen::Matrix3d& j_r0) {
  const Eigen::Vector3d e = minus(r1, r0);
  j_r1 = rightJacobianInverseSO3(e);
  j_r0 = -leftJacobianInverseSO3(e);
}

}  // namespace rollstep::lie
