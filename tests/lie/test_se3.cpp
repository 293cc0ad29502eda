#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "rollstep/lie/se3.hpp"

namespace {
using Eigen::Matrix3d;
using Eigen::Quaterniond;
using Eigen::Vector3d;
using namespace rollstep::lie;

constexpr double kPi = 3.14159265358979323846;

Vector3d randomUnit(std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  return Vector3d(n(rng), n(rng), n(rng)).normalized();
}

std::vector<Vector6d> testTangents() {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(0.0, kPi);
  std::normal_distribution<double> n(0.0, 1.0);
  std::vector<Vector6d> out;
  out.push_back(Vector6d::Zero());
  const double angles[] = {0.0,    1e-9,   1e-6, 1e-4,       9.99e-3, 1.001e-2,
                           0.0999, 0.1001, 1.0,  kPi - 1e-6, kPi};
  for (double a : angles) {
    Vector6d d;
    d.head<3>() = Vector3d(n(rng), n(rng), n(rng));
    d.tail<3>() = a * randomUnit(rng);
    out.push_back(d);
  }
  for (int i = 0; i < 40; ++i) {
    Vector6d d;
    d.head<3>() = 2.0 * Vector3d(n(rng), n(rng), n(rng));
    d.tail<3>() = u(rng) * randomUnit(rng);
    out.push_back(d);
  }
  return out;
}

SE3 randomPose(std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  return SE3(Vector3d(n(rng), n(rng), n(rng)), expSO3(2.5 * randomUnit(rng)));
}

TEST(SE3, GroupOperations) {
  std::mt19937 rng(1);
  const SE3 a = randomPose(rng);
  const SE3 b = randomPose(rng);
  const Vector3d p(0.3, -0.2, 1.1);
  EXPECT_TRUE((a * b).toMatrix().isApprox(a.toMatrix() * b.toMatrix(), 1e-14));
  EXPECT_TRUE((a * a.inverse()).isApprox(SE3::Identity(), 1e-14));
  EXPECT_TRUE((a * b).act(p).isApprox(a.act(b.act(p)), 1e-14));
  EXPECT_TRUE(SE3::fromCoeffs(a.coeffs()).isApprox(a, 1e-15));
  // The adjoint maps local twists to the parent frame: x Exp(d) x^-1 = Exp(Ad(x) d).
  Vector6d d;
  d << 0.1, -0.3, 0.2, 0.4, 0.1, -0.2;
  EXPECT_TRUE((a * expSE3(d) * a.inverse()).isApprox(expSE3(adjoint(a) * d), 1e-13));
}

TEST(SE3, ExpMatchesMatrixExponentialSeries) {
  for (const Vector6d& d : testTangents()) {
    // exp of the 4x4 twist matrix by scaling and squaring of a Taylor series
    Eigen::Matrix4d x = Eigen::Matrix4d::Zero();
    x.topLeftCorner<3, 3>() = hat(d.tail<3>());
    x.topRightCorner<3, 1>() = d.head<3>();
    const Eigen::Matrix4d s = x / 1024.0;
    Eigen::Matrix4d e = Eigen::Matrix4d::Identity();
    Eigen::Matrix4d term = Eigen::Matrix4d::Identity();
    for (int k = 1; k < 20; ++k) {
      term = term * s / k;
      e += term;
    }
    for (int k = 0; k < 10; ++k) e = e * e;
    EXPECT_LT((expSE3(d).toMatrix() - e).norm(), 1e-11) << d.transpose();
  }
}

TEST(SE3, ExpLogRoundTrip) {
  for (const Vector6d& d : testTangents()) {
    const SE3 x = expSE3(d);
    const Vector6d l = logSE3(x);
    if (d.tail<3>().norm() < kPi - 1e-7) {
      EXPECT_LT((l - d).norm(), 1e-12 * std::max(1.0, d.norm())) << d.transpose();
    }
    EXPECT_TRUE(expSE3(l).isApprox(x, 1e-12)) << d.transpose();
  }
}

// Central finite differences on the manifold of a map f: SE3 tangent -> SE3,
// measured as (f(+h e_i) (-) y - f(-h e_i) (-) y) / 2h.
template <class F>
Matrix6d fdJacobian(const F& f, const SE3& y, double h) {
  Matrix6d j;
  for (int i = 0; i < 6; ++i) {
    const Vector6d e = Vector6d::Unit(i) * h;
    j.col(i) = (minus(f(e), y) - minus(f(Vector6d(-e)), y)) / (2 * h);
  }
  return j;
}

TEST(SE3, JacobiansMatchFiniteDifferences) {
  for (const Vector6d& d : testTangents()) {
    const SE3 y = expSE3(d);
    const Matrix6d fr = fdJacobian([&](const Vector6d& e) { return expSE3(d + e); }, y, 1e-6);
    const Matrix6d jr = rightJacobianSE3(d);
    EXPECT_LT((jr - fr).norm(), 1e-8) << d.transpose();
    // Left Jacobian: Exp(d + e) = Exp(Jl e) Exp(d)  <=>  Jl = Ad(Exp(d)) Jr.
    EXPECT_LT((leftJacobianSE3(d) - adjoint(y) * jr).norm(), 1e-12) << d.transpose();
    EXPECT_LT((rightJacobianInverseSE3(d) * jr - Matrix6d::Identity()).norm(), 1e-11);
    EXPECT_LT((leftJacobianInverseSE3(d) * leftJacobianSE3(d) - Matrix6d::Identity()).norm(),
              1e-11);
  }
}

TEST(SE3, PlusMinusJacobiansMatchFiniteDifferences) {
  std::mt19937 rng(5);
  for (const Vector6d& d : testTangents()) {
    const SE3 x = randomPose(rng);
    const SE3 y = plus(x, d);
    Matrix6d jx;
    Matrix6d jd;
    plusJacobians(x, d, jx, jd);
    const Matrix6d fx = fdJacobian([&](const Vector6d& e) { return plus(plus(x, e), d); }, y, 1e-7);
    const Matrix6d fd = fdJacobian([&](const Vector6d& e) { return plus(x, d + e); }, y, 1e-7);
    EXPECT_LT((jx - fx).norm(), 1e-6) << d.transpose();
    EXPECT_LT((jd - fd).norm(), 1e-6) << d.transpose();

    if (d.tail<3>().norm() > kPi - 1e-7) continue;  // Log jumps at exactly pi
    EXPECT_LT((minus(y, x) - d).norm(), 1e-11 * std::max(1.0, d.norm()));
    Matrix6d j1;
    Matrix6d j0;
    minusJacobians(y, x, j1, j0);
    const double h = 1e-9;
    Matrix6d f1;
    Matrix6d f0;
    for (int i = 0; i < 6; ++i) {
      const Vector6d e = Vector6d::Unit(i) * h;
      f1.col(i) = (minus(plus(y, e), x) - minus(plus(y, Vector6d(-e)), x)) / (2 * h);
      f0.col(i) = (minus(y, plus(x, e)) - minus(y, plus(x, Vector6d(-e)))) / (2 * h);
    }
    EXPECT_LT((j1 - f1).norm(), 1e-5 * std::max(1.0, j1.norm())) << d.transpose();
    EXPECT_LT((j0 - f0).norm(), 1e-5 * std::max(1.0, j0.norm())) << d.transpose();
  }
}

TEST(SE3, RawVectorHelpers) {
  std::mt19937 rng(9);
  Eigen::VectorXd state(20);
  state.setZero();
  const SE3 x0 = randomPose(rng);
  const SE3 x1 = randomPose(rng);
  state.segment<7>(3) = x0.coeffs();
  state.segment(10, 7) = x1.coeffs();
  Vector6d diff;
  differenceSE3(state.segment<7>(3), state.segment(10, 7), diff);
  EXPECT_TRUE(diff.isApprox(minus(x1, x0), 1e-14));
  Eigen::VectorXd out(7);
  integrateSE3(state.segment<7>(3), diff, out);
  EXPECT_TRUE(SE3::fromCoeffs(out).isApprox(x1, 1e-12));
  EXPECT_NEAR(out.tail<4>().norm(), 1.0, 1e-15);
  // In place.
  integrateSE3(state.segment<7>(3), diff, state.segment<7>(3));
  EXPECT_TRUE(SE3::fromCoeffs(state.segment<7>(3)).isApprox(x1, 1e-12));

  Matrix6d a;
  Matrix6d b;
  Matrix6d ra;
  Matrix6d rb;
  Eigen::Matrix<double, 6, 12> both;
  integrateSE3Jacobians(x0.coeffs(), diff, both.leftCols<6>(), both.rightCols<6>());
  plusJacobians(x0, diff, ra, rb);
  EXPECT_TRUE(both.leftCols<6>().isApprox(ra));
  EXPECT_TRUE(both.rightCols<6>().isApprox(rb));
  differenceSE3Jacobians(x0.coeffs(), x1.coeffs(), a, b);
  minusJacobians(x1, x0, rb, ra);
  EXPECT_TRUE(a.isApprox(ra));
  EXPECT_TRUE(b.isApprox(rb));
}

}  // namespace

#include "common/alloc_counter.hpp"

namespace {
TEST(Lie, NoAllocation) {
  using namespace rollstep::lie;
  Eigen::Matrix<double, 7, 1> x =
      SE3(Eigen::Vector3d(1, 2, 3), expSO3(Eigen::Vector3d(0.1, 0.2, 0.3))).coeffs();
  Vector6d d;
  d << 0.1, 0.2, 0.3, -0.4, 0.5, 0.6;
  Eigen::Matrix<double, 7, 1> y;
  Vector6d e;
  Matrix6d a;
  Matrix6d b;
  rollstep::test::AllocationGuard guard;
  integrateSE3(x, d, y);
  differenceSE3(x, y, e);
  integrateSE3Jacobians(x, d, a, b);
  differenceSE3Jacobians(x, y, a, b);
  const SE3 p = expSE3(d);
  e = logSE3(p * p.inverse());
  a = rightJacobianInverseSE3(d) * leftJacobianSE3(d) * adjoint(p);
  EXPECT_EQ(guard.count(), 0u);
  EXPECT_LT(e.norm(), 1e-12);
}
}  // namespace
