#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "rollstep/lie/so3.hpp"

namespace {
using Eigen::Matrix3d;
using Eigen::Quaterniond;
using Eigen::Vector3d;
using namespace rollstep::lie;

constexpr double kPi = 3.14159265358979323846;

Vector3d randomUnit(std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  Vector3d v(n(rng), n(rng), n(rng));
  return v.normalized();
}

// Rotation vectors: random plus edge-case angles along random axes.
std::vector<Vector3d> testVectors() {
  std::mt19937 rng(42);
  std::uniform_real_distribution<double> u(0.0, kPi);
  std::vector<Vector3d> out{Vector3d::Zero(), Vector3d(1e-9, 0, 0), Vector3d(0, 0, kPi)};
  const double angles[] = {1e-9,   1e-6,   1e-4, 9.99e-3,    1.001e-2,
                           0.0999, 0.1001, 1.0,  kPi - 1e-6, kPi};
  for (double a : angles) out.push_back(a * randomUnit(rng));
  for (int i = 0; i < 40; ++i) out.push_back(u(rng) * randomUnit(rng));
  return out;
}

bool sameRotation(const Quaterniond& a, const Quaterniond& b, double tol) {
  return a.toRotationMatrix().isApprox(b.toRotationMatrix(), tol) ||
         (a.toRotationMatrix() - b.toRotationMatrix()).norm() < tol;
}

TEST(SO3, HatVee) {
  const Vector3d w(0.3, -1.2, 2.0);
  const Vector3d x(-0.5, 0.7, 0.1);
  EXPECT_TRUE((hat(w) * x).isApprox(w.cross(x)));
  EXPECT_TRUE(vee(hat(w)).isApprox(w));
}

TEST(SO3, ExpMatchesAngleAxis) {
  for (const Vector3d& w : testVectors()) {
    const double t = w.norm();
    const Matrix3d ref =
        t > 0 ? Eigen::AngleAxisd(t, w / t).toRotationMatrix() : Matrix3d::Identity();
    EXPECT_LT((expSO3(w).toRotationMatrix() - ref).norm(), 1e-14) << w.transpose();
    EXPECT_NEAR(expSO3(w).norm(), 1.0, 1e-15);
  }
}

TEST(SO3, ExpLogRoundTrip) {
  for (const Vector3d& w : testVectors()) {
    const Quaterniond q = expSO3(w);
    const Vector3d l = logSO3(q);
    EXPECT_LE(l.norm(), kPi + 1e-15);
    if (w.norm() < kPi - 1e-7) {
      EXPECT_LT((l - w).norm(), 1e-13 * std::max(1.0, w.norm())) << w.transpose();
    }
    EXPECT_TRUE(sameRotation(expSO3(l), q, 1e-13)) << w.transpose();
    // Both quaternion signs give the same log.
    const Quaterniond mq(-q.w(), -q.x(), -q.y(), -q.z());
    if (w.norm() < kPi - 1e-7) {
      EXPECT_LT((logSO3(mq) - w).norm(), 1e-13);
    }
  }
  // Tiny angles keep full relative precision.
  const Vector3d tiny(1e-12, -2e-12, 3e-12);
  EXPECT_LT((logSO3(expSO3(tiny)) - tiny).norm(), 1e-26);
}

// Central finite difference of Exp in the local (right) sense: Log(Exp(w)^-1 Exp(w + h e_i)).
Matrix3d fdRightJacobian(const Vector3d& w) {
  const double h = 1e-6;
  Matrix3d j;
  for (int i = 0; i < 3; ++i) {
    const Vector3d e = Vector3d::Unit(i) * h;
    j.col(i) = (minus(expSO3(w + e), expSO3(w)) - minus(expSO3(w - e), expSO3(w))) / (2 * h);
  }
  return j;
}

TEST(SO3, JacobiansMatchFiniteDifferences) {
  for (const Vector3d& w : testVectors()) {
    const Matrix3d jr = rightJacobianSO3(w);
    EXPECT_LT((jr - fdRightJacobian(w)).norm(), 1e-8) << w.transpose();
    EXPECT_LT((leftJacobianSO3(w) - rightJacobianSO3(-w)).norm(), 1e-15);
    EXPECT_LT((leftJacobianSO3(w) - jr.transpose()).norm(), 1e-15);
    // Left Jacobian: Exp(w + dw) = Exp(Jl dw) Exp(w).
    EXPECT_LT((rightJacobianInverseSO3(w) * jr - Matrix3d::Identity()).norm(), 1e-12)
        << w.transpose();
    EXPECT_LT((leftJacobianInverseSO3(w) * leftJacobianSO3(w) - Matrix3d::Identity()).norm(),
              1e-12);
  }
}

TEST(SO3, PlusMinusRoundTrip) {
  std::mt19937 rng(7);
  for (const Vector3d& d : testVectors()) {
    const Quaterniond r = expSO3(2.0 * randomUnit(rng));
    const Quaterniond y = plus(r, d);
    if (d.norm() < kPi - 1e-7) {
      EXPECT_LT((minus(y, r) - d).norm(), 1e-12) << d.transpose();
    }
    EXPECT_TRUE(sameRotation(plus(r, minus(y, r)), y, 1e-12));
  }
}

TEST(SO3, PlusMinusJacobiansMatchFiniteDifferences) {
  std::mt19937 rng(3);
  const double h = 1e-7;
  for (const Vector3d& d : testVectors()) {
    const Quaterniond r = expSO3(1.5 * randomUnit(rng));
    Matrix3d jx;
    Matrix3d jd;
    plusJacobians(r, d, jx, jd);
    const Quaterniond y = plus(r, d);
    Matrix3d fx;
    Matrix3d fd;
    for (int i = 0; i < 3; ++i) {
      const Vector3d e = Vector3d::Unit(i) * h;
      fx.col(i) = (minus(plus(plus(r, e), d), y) - minus(plus(plus(r, -e), d), y)) / (2 * h);
      fd.col(i) = (minus(plus(r, d + e), y) - minus(plus(r, d - e), y)) / (2 * h);
    }
    EXPECT_LT((jx - fx).norm(), 1e-7) << d.transpose();
    EXPECT_LT((jd - fd).norm(), 1e-7) << d.transpose();

    // minus: x1 = r (+) d (angle of the difference = |d|); skip exactly pi (Log jumps).
    if (d.norm() > kPi - 1e-7) continue;
    const double hm = 1e-9;
    Matrix3d j1;
    Matrix3d j0;
    minusJacobians(y, r, j1, j0);
    Matrix3d f1;
    Matrix3d f0;
    for (int i = 0; i < 3; ++i) {
      const Vector3d e = Vector3d::Unit(i) * hm;
      f1.col(i) = (minus(plus(y, e), r) - minus(plus(y, -e), r)) / (2 * hm);
      f0.col(i) = (minus(y, plus(r, e)) - minus(y, plus(r, -e))) / (2 * hm);
    }
    EXPECT_LT((j1 - f1).norm(), 1e-5) << d.transpose();
    EXPECT_LT((j0 - f0).norm(), 1e-5) << d.transpose();
  }
}

}  // namespace
