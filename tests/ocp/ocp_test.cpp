// Unit tests of the ocp layer: state spaces, discretisations, residuals, costs, the mode
// schedule and the problem's stacking of rows, against finite differences.
#include <gtest/gtest.h>

#include <limits>
#include <random>
#include <stdexcept>
#include <string>

#include "common/alloc_counter.hpp"
#include "common/malloc_guard.hpp"
#include "common/mirrored_affine.hpp"
#include "rollstep/lie/so3.hpp"
#include "rollstep/ocp/cost.hpp"
#include "rollstep/ocp/problem.hpp"
#include "rollstep/ocp/residuals.hpp"
#include "rollstep/ocp/small_products.hpp"
#include "test_models.hpp"

namespace {

using namespace rollstep;
using ocp::MatrixXd;
using ocp::VectorXd;

VectorXd randomState(const ocp::StateSpace& s, std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  VectorXd x(s.nx()), d(s.ndx());
  s.neutral(x);
  for (int i = 0; i < d.size(); ++i) d(i) = n(rng);
  VectorXd out(s.nx());
  s.integrate(x, d, out);
  return out;
}

VectorXd randomVec(int n, std::mt19937& rng, double scale = 1.0) {
  std::normal_distribution<double> d(0.0, scale);
  VectorXd v(n);
  for (int i = 0; i < n; ++i) v(i) = d(rng);
  return v;
}

/// Central finite difference of a manifold-valued map y(x (+) h e_i), expressed in the
/// tangent at y(x).
template <class F>
MatrixXd fdManifold(const ocp::StateSpace& in, const ocp::StateSpace& out, const VectorXd& x, F f) {
  const double h = 1e-6;
  VectorXd y0(out.nx()), yp(out.nx()), ym(out.nx()), xp(in.nx()), xm(in.nx());
  VectorXd dp(out.ndx()), dm(out.ndx());
  f(x, y0);
  MatrixXd J(out.ndx(), in.ndx());
  for (int i = 0; i < in.ndx(); ++i) {
    VectorXd e = VectorXd::Zero(in.ndx());
    e(i) = h;
    in.integrate(x, e, xp);
    in.integrate(x, -e, xm);
    f(xp, yp);
    f(xm, ym);
    out.difference(y0, yp, dp);
    out.difference(y0, ym, dm);
    J.col(i) = (dp - dm) / (2 * h);
  }
  return J;
}

class SpaceTest : public ::testing::TestWithParam<int> {};

std::shared_ptr<ocp::StateSpace> makeSpace(int which) {
  if (which == 0) return std::make_shared<ocp::EuclideanSpace>(5);
  return std::make_shared<ocp::SE3xEuclideanSpace>(which == 1 ? 0 : 4);
}

TEST_P(SpaceTest, IntegrateDifferenceRoundTripAndJacobians) {
  auto s = makeSpace(GetParam());
  std::mt19937 rng(3);
  for (int trial = 0; trial < 5; ++trial) {
    const VectorXd x = randomState(*s, rng);
    const VectorXd dx = randomVec(s->ndx(), rng, 0.7);
    VectorXd y(s->nx()), back(s->ndx());
    s->integrate(x, dx, y);
    s->difference(x, y, back);
    EXPECT_LT((back - dx).norm(), 1e-10);

    MatrixXd Jx(s->ndx(), s->ndx()), Jd(s->ndx(), s->ndx());
    s->integrateJacobians(x, dx, Jx, Jd);
    const MatrixXd Jx_fd = fdManifold(
        *s, *s, x, [&](const VectorXd& xx, VectorXd& out) { s->integrate(xx, dx, out); });
    EXPECT_LT((Jx - Jx_fd).lpNorm<Eigen::Infinity>(), 1e-6);
    // d/d(dx): perturb dx additively.
    MatrixXd Jd_fd(s->ndx(), s->ndx());
    {
      const double h = 1e-6;
      VectorXd yp(s->nx()), ym(s->nx()), dp(s->ndx()), dm(s->ndx());
      for (int i = 0; i < s->ndx(); ++i) {
        VectorXd e = VectorXd::Zero(s->ndx());
        e(i) = h;
        s->integrate(x, dx + e, yp);
        s->integrate(x, dx - e, ym);
        s->difference(y, yp, dp);
        s->difference(y, ym, dm);
        Jd_fd.col(i) = (dp - dm) / (2 * h);
      }
    }
    EXPECT_LT((Jd - Jd_fd).lpNorm<Eigen::Infinity>(), 1e-6);

    // difference Jacobians (outputs are plain vectors).
    const VectorXd x1 = randomState(*s, rng);
    MatrixXd J0(s->ndx(), s->ndx()), J1(s->ndx(), s->ndx());
    s->differenceJacobians(x, x1, J0, J1);
    const double h = 1e-6;
    MatrixXd J0_fd(s->ndx(), s->ndx()), J1_fd(s->ndx(), s->ndx());
    VectorXd xp(s->nx()), xm(s->nx()), dp(s->ndx()), dm(s->ndx());
    for (int i = 0; i < s->ndx(); ++i) {
      VectorXd e = VectorXd::Zero(s->ndx());
      e(i) = h;
      s->integrate(x, e, xp);
      s->integrate(x, -e, xm);
      s->difference(xp, x1, dp);
      s->difference(xm, x1, dm);
      J0_fd.col(i) = (dp - dm) / (2 * h);
      s->integrate(x1, e, xp);
      s->integrate(x1, -e, xm);
      s->difference(x, xp, dp);
      s->difference(x, xm, dm);
      J1_fd.col(i) = (dp - dm) / (2 * h);
    }
    EXPECT_LT((J0 - J0_fd).lpNorm<Eigen::Infinity>(), 1e-6);
    EXPECT_LT((J1 - J1_fd).lpNorm<Eigen::Infinity>(), 1e-6);

    // Block structure [b x b, 0; 0, +-I] with b = euclideanTangentOffset(), and the head
    // variants give the b x b blocks exactly (callers rely on both).
    const int b = s->euclideanTangentOffset(), m = s->ndx() - b;
    for (const MatrixXd* J : {&Jx, &Jd, &J0, &J1}) {
      const double sign = J == &J0 ? -1.0 : 1.0;
      EXPECT_TRUE((sign * J->bottomRightCorner(m, m)).isIdentity(0.0));
      EXPECT_TRUE(J->topRightCorner(b, m).isZero(0.0));
      EXPECT_TRUE(J->bottomLeftCorner(m, b).isZero(0.0));
    }
    const double nan = std::numeric_limits<double>::quiet_NaN();
    MatrixXd H0 = MatrixXd::Constant(b, b, nan), H1 = H0, Hx = H0, Hd = H0;
    s->differenceJacobiansHead(x, x1, H0, H1);
    s->integrateJacobiansHead(x, dx, Hx, Hd);
    EXPECT_TRUE(H0 == J0.topLeftCorner(b, b));
    EXPECT_TRUE(H1 == J1.topLeftCorner(b, b));
    EXPECT_TRUE(Hx == Jx.topLeftCorner(b, b));
    EXPECT_TRUE(Hd == Jd.topLeftCorner(b, b));
  }
}

INSTANTIATE_TEST_SUITE_P(Spaces, SpaceTest, ::testing::Values(0, 1, 2));

TEST(StateSpace, Se3NeutralAndSizes) {
  ocp::SE3xEuclideanSpace s(6);
  EXPECT_EQ(s.nx(), 13);
  EXPECT_EQ(s.ndx(), 12);
  EXPECT_FALSE(s.isEuclidean());
  EXPECT_EQ(s.euclideanTangentOffset(), 6);
  VectorXd x(13);
  s.neutral(x);
  EXPECT_DOUBLE_EQ(x(6), 1.0);
  EXPECT_DOUBLE_EQ(x.head<6>().norm(), 0.0);
}

// ---- discretisations ----------------------------------------------------------------------

template <class Disc>
void checkDiscreteJacobians(std::shared_ptr<const ocp::ContinuousDynamics> f, double tol) {
  const Disc F(f);
  const auto& s = F.space();
  std::mt19937 rng(11);
  auto data = F.createData();
  ocp::NodeContext ctx;
  ctx.dt = 0.05;
  for (int trial = 0; trial < 4; ++trial) {
    const VectorXd x = randomState(s, rng);
    const VectorXd u = randomVec(F.nu(), rng);
    VectorXd xn(s.nx());
    MatrixXd Fx(s.ndx(), s.ndx()), Fu(s.ndx(), F.nu());
    F.calc(ctx, x, u, *data, xn);
    F.calcDiff(ctx, x, u, *data, Fx, Fu);
    const MatrixXd Fx_fd = fdManifold(
        s, s, x, [&](const VectorXd& xx, VectorXd& out) { F.calc(ctx, xx, u, *data, out); });
    MatrixXd Fu_fd(s.ndx(), F.nu());
    const double h = 1e-6;
    VectorXd yp(s.nx()), ym(s.nx()), dp(s.ndx()), dm(s.ndx());
    for (int i = 0; i < F.nu(); ++i) {
      VectorXd e = VectorXd::Zero(F.nu());
      e(i) = h;
      F.calc(ctx, x, u + e, *data, yp);
      F.calc(ctx, x, u - e, *data, ym);
      s.difference(xn, yp, dp);
      s.difference(xn, ym, dm);
      Fu_fd.col(i) = (dp - dm) / (2 * h);
    }
    EXPECT_LT((Fx - Fx_fd).lpNorm<Eigen::Infinity>(), tol);
    EXPECT_LT((Fu - Fu_fd).lpNorm<Eigen::Infinity>(), tol);
  }
}

TEST(Dynamics, ExplicitEulerJacobiansEuclidean) {
  checkDiscreteJacobians<ocp::ExplicitEuler>(std::make_shared<testmodels::Pendulum>(), 1e-7);
}

TEST(Dynamics, ExplicitEulerJacobiansOnSe3) {
  checkDiscreteJacobians<ocp::ExplicitEuler>(std::make_shared<testmodels::FloatingBody>(), 1e-6);
}

TEST(Dynamics, RungeKutta4Jacobians) {
  checkDiscreteJacobians<ocp::RungeKutta4>(std::make_shared<testmodels::Pendulum>(), 1e-7);
}

TEST(Dynamics, RungeKutta4IsFourthOrder) {
  // Linear system x' = -x: one RK4 step equals the degree-4 Taylor polynomial of exp(-h).
  class Decay final : public ocp::ContinuousDynamics {
   public:
    Decay() : ContinuousDynamics(std::make_shared<ocp::EuclideanSpace>(1), 1) {}
    std::unique_ptr<ocp::DynamicsData> createData() const override {
      return std::make_unique<ocp::DynamicsData>();
    }
    void calc(const ocp::NodeContext&, ocp::ConstVecRef x, ocp::ConstVecRef, ocp::DynamicsData&,
              ocp::VecRef xdot) const override {
      xdot = -x;
    }
    void calcDiff(const ocp::NodeContext&, ocp::ConstVecRef, ocp::ConstVecRef, ocp::DynamicsData&,
                  ocp::MatRef fx, ocp::MatRef fu) const override {
      fx(0, 0) = -1.0;
      fu(0, 0) = 0.0;
    }
  };
  ocp::RungeKutta4 F(std::make_shared<Decay>());
  auto d = F.createData();
  ocp::NodeContext ctx;
  ctx.dt = 0.1;
  VectorXd x(1), u(1), xn(1);
  x << 1.0;
  u << 0.0;
  F.calc(ctx, x, u, *d, xn);
  const double h = 0.1;
  EXPECT_NEAR(xn(0), 1 - h + h * h / 2 - h * h * h / 6 + h * h * h * h / 24, 1e-15);
}

TEST(Dynamics, RungeKutta4RejectsManifolds) {
  EXPECT_THROW(ocp::RungeKutta4(std::make_shared<testmodels::FloatingBody>()),
               std::invalid_argument);
}

// ---- residuals and costs ------------------------------------------------------------------

TEST(Residuals, StateErrorOnSe3MatchesFiniteDifferences) {
  auto s = std::make_shared<ocp::SE3xEuclideanSpace>(3);
  std::mt19937 rng(5);
  const VectorXd xref = randomState(*s, rng);
  ocp::StateErrorResidual r(s, 2, xref);
  auto d = r.createData();
  ocp::NodeContext ctx;
  const VectorXd x = randomState(*s, rng);
  const VectorXd u = VectorXd::Zero(2);
  r.calc(ctx, x, u, *d);
  r.calcDiff(ctx, x, u, *d);
  VectorXd expect(s->ndx());
  s->difference(xref, x, expect);
  EXPECT_LT((d->r.head(s->ndx()) - expect).norm(), 1e-14);
  const double h = 1e-6;
  VectorXd xp(s->nx()), xm(s->nx()), rp(s->ndx()), rm(s->ndx());
  for (int i = 0; i < s->ndx(); ++i) {
    VectorXd e = VectorXd::Zero(s->ndx());
    e(i) = h;
    s->integrate(x, e, xp);
    s->integrate(x, -e, xm);
    s->difference(xref, xp, rp);
    s->difference(xref, xm, rm);
    EXPECT_LT(((rp - rm) / (2 * h) - d->Rx.col(i)).lpNorm<Eigen::Infinity>(), 1e-6);
  }
  EXPECT_TRUE(d->Ru.isZero());
  EXPECT_FALSE(r.dependsOnInput());
}

TEST(Residuals, InputAndAffine) {
  std::mt19937 rng(7);
  ocp::InputErrorResidual ui(3, (VectorXd(2) << 1.0, -2.0).finished());
  auto d = ui.createData();
  ocp::NodeContext ctx;
  const VectorXd x = randomVec(3, rng), u = randomVec(2, rng);
  ui.calc(ctx, x, u, *d);
  ui.calcDiff(ctx, x, u, *d);
  EXPECT_NEAR(d->r(0), u(0) - 1.0, 1e-15);
  EXPECT_NEAR(d->r(1), u(1) + 2.0, 1e-15);
  EXPECT_TRUE(d->Ru.isIdentity());

  auto s = std::make_shared<ocp::EuclideanSpace>(3);
  const MatrixXd C = MatrixXd::Random(4, 3), D = MatrixXd::Random(4, 2);
  const VectorXd c = VectorXd::Random(4), xl = VectorXd::Random(3);
  ocp::AffineResidual ar(s, xl, C, D, c);
  auto ad = ar.createData();
  ar.calc(ctx, x, u, *ad);
  ar.calcDiff(ctx, x, u, *ad);
  EXPECT_LT((ad->r - (C * (x - xl) + D * u + c)).norm(), 1e-14);
  EXPECT_TRUE(ad->Rx.isApprox(C));
  EXPECT_TRUE(ad->Ru.isApprox(D));
  EXPECT_TRUE(ar.dependsOnInput());
  ocp::AffineResidual state_only(s, xl, C, MatrixXd::Zero(4, 2), c);
  EXPECT_FALSE(state_only.dependsOnInput());
}

TEST(Cost, LeastSquaresGradientAndGaussNewtonHessian) {
  auto s = std::make_shared<ocp::SE3xEuclideanSpace>(2);
  std::mt19937 rng(9);
  const int nu = 3;
  const MatrixXd C = MatrixXd::Random(5, s->ndx()), D = MatrixXd::Random(5, nu);
  const VectorXd c = VectorXd::Random(5);
  const VectorXd xl = randomState(*s, rng);
  auto res = std::make_shared<ocp::AffineResidual>(s, xl, C, D, c);
  const VectorXd w = (VectorXd(5) << 1.0, 2.0, 0.5, 3.0, 0.0).finished();
  ocp::LeastSquaresCost cost(res, w);
  auto cd = cost.createData();
  auto rd = res->createData();
  ocp::NodeContext ctx;
  const VectorXd x = randomState(*s, rng), u = randomVec(nu, rng);
  const int n = s->ndx();
  VectorXd lx = VectorXd::Zero(n), lu = VectorXd::Zero(nu);
  MatrixXd Lxx = MatrixXd::Zero(n, n), Luu = MatrixXd::Zero(nu, nu), Lux = MatrixXd::Zero(nu, n);
  const double l = cost.calc(ctx, x, u, *cd);
  cost.calcDiff(ctx, x, u, *cd, 2.0, lx, lu, Lxx, Luu, Lux);
  res->calc(ctx, x, u, *rd);
  res->calcDiff(ctx, x, u, *rd);
  EXPECT_NEAR(l, 0.5 * rd->r.dot(w.asDiagonal() * rd->r), 1e-13);
  // Gauss-Newton Hessian and gradient (scale 2).
  EXPECT_LT((Lxx - 2.0 * rd->Rx.transpose() * w.asDiagonal() * rd->Rx).norm(), 1e-12);
  EXPECT_LT((Luu - 2.0 * rd->Ru.transpose() * w.asDiagonal() * rd->Ru).norm(), 1e-12);
  EXPECT_LT((Lux - 2.0 * rd->Ru.transpose() * w.asDiagonal() * rd->Rx).norm(), 1e-12);
  // Gradient against finite differences of the value.
  const double h = 1e-6;
  VectorXd xp(s->nx()), xm(s->nx());
  for (int i = 0; i < n; ++i) {
    VectorXd e = VectorXd::Zero(n);
    e(i) = h;
    s->integrate(x, e, xp);
    s->integrate(x, -e, xm);
    const double fd = (cost.calc(ctx, xp, u, *cd) - cost.calc(ctx, xm, u, *cd)) / (2 * h);
    EXPECT_NEAR(2.0 * fd, lx(i), 1e-6);
  }
  for (int i = 0; i < nu; ++i) {
    VectorXd e = VectorXd::Zero(nu);
    e(i) = h;
    const double fd = (cost.calc(ctx, x, u + e, *cd) - cost.calc(ctx, x, u - e, *cd)) / (2 * h);
    EXPECT_NEAR(2.0 * fd, lu(i), 1e-6);
  }
  EXPECT_THROW(ocp::LeastSquaresCost(res, VectorXd::Ones(4)), std::invalid_argument);
  EXPECT_THROW(ocp::LeastSquaresCost(res, -VectorXd::Ones(5)), std::invalid_argument);
}

TEST(Cost, StructuredTrackingPathsMatchTheGenericProducts) {
  std::mt19937 rng(21);
  const int nu = 4;
  for (int which = 0; which < 2; ++which) {
    std::shared_ptr<ocp::StateSpace> s;
    if (which == 0) {
      s = std::make_shared<ocp::EuclideanSpace>(5);
    } else {
      s = std::make_shared<ocp::SE3xEuclideanSpace>(3);
    }
    const int n = s->ndx();
    const VectorXd xr = randomState(*s, rng), x = randomState(*s, rng), u = randomVec(nu, rng);
    const VectorXd ur = randomVec(nu, rng);
    std::vector<std::shared_ptr<const ocp::Residual>> residuals{
        std::make_shared<ocp::StateErrorResidual>(s, nu, xr),
        std::make_shared<ocp::InputErrorResidual>(n, ur)};
    for (const auto& res : residuals) {
      const VectorXd w = randomVec(res->maxRows(), rng).cwiseAbs();
      ocp::LeastSquaresCost cost(res, w);
      auto cd = cost.createData();
      auto rd = res->createData();
      ocp::NodeContext ctx;
      VectorXd lx = VectorXd::Ones(n), lu = VectorXd::Ones(nu);  // accumulates on top
      MatrixXd Lxx = MatrixXd::Ones(n, n), Luu = MatrixXd::Ones(nu, nu),
               Lux = MatrixXd::Ones(nu, n);
      cost.calc(ctx, x, u, *cd);
      cost.calcDiff(ctx, x, u, *cd, 0.5, lx, lu, Lxx, Luu, Lux);
      rd->rows = res->maxRows();
      res->calc(ctx, x, u, *rd);
      res->calcDiff(ctx, x, u, *rd);
      const MatrixXd W = w.asDiagonal();
      EXPECT_LT((lx - VectorXd::Ones(n) - 0.5 * rd->Rx.transpose() * W * rd->r).norm(), 1e-12);
      EXPECT_LT((lu - VectorXd::Ones(nu) - 0.5 * rd->Ru.transpose() * W * rd->r).norm(), 1e-12);
      EXPECT_LT((Lxx - MatrixXd::Ones(n, n) - 0.5 * rd->Rx.transpose() * W * rd->Rx).norm(), 1e-12);
      EXPECT_LT((Luu - MatrixXd::Ones(nu, nu) - 0.5 * rd->Ru.transpose() * W * rd->Ru).norm(),
                1e-12);
      EXPECT_LT((Lux - MatrixXd::Ones(nu, n) - 0.5 * rd->Ru.transpose() * W * rd->Rx).norm(),
                1e-12);
    }
  }
}

TEST(Cost, GenericPathMatchesTheDenseProductsForSmallAndLargeResiduals) {
  // Residuals of up to 8 rows take the small-depth products, larger ones Eigen's; both
  // with trailing zero input columns (left out) and on accumulators that are not zero.
  std::mt19937 rng(33);
  auto s = std::make_shared<ocp::SE3xEuclideanSpace>(5);
  const int n = s->ndx(), nu = 9;
  for (int rows : {1, 3, 6, 8, 9, 14}) {
    const MatrixXd C = MatrixXd::Random(rows, n);
    MatrixXd D = MatrixXd::Random(rows, nu);
    D.rightCols(3).setZero();
    auto res = std::make_shared<ocp::AffineResidual>(s, randomState(*s, rng), C, D,
                                                     VectorXd::Random(rows));
    const VectorXd w = randomVec(rows, rng).cwiseAbs();
    ocp::LeastSquaresCost cost(res, w);
    auto cd = cost.createData();
    auto rd = res->createData();
    ocp::NodeContext ctx;
    const VectorXd x = randomState(*s, rng), u = randomVec(nu, rng);
    const VectorXd lx0 = VectorXd::Random(n), lu0 = VectorXd::Random(nu);
    const MatrixXd Lxx0 = MatrixXd::Random(n, n), Luu0 = MatrixXd::Random(nu, nu),
                   Lux0 = MatrixXd::Random(nu, n);
    VectorXd lx = lx0, lu = lu0;
    MatrixXd Lxx = Lxx0, Luu = Luu0, Lux = Lux0;
    cost.calc(ctx, x, u, *cd);
    cost.calcDiff(ctx, x, u, *cd, 0.25, lx, lu, Lxx, Luu, Lux);
    rd->rows = rows;
    res->calc(ctx, x, u, *rd);
    res->calcDiff(ctx, x, u, *rd);
    const MatrixXd W = 0.25 * MatrixXd(w.asDiagonal());
    EXPECT_LT((lx - lx0 - rd->Rx.transpose() * W * rd->r).norm(), 1e-12) << rows;
    EXPECT_LT((lu - lu0 - rd->Ru.transpose() * W * rd->r).norm(), 1e-12) << rows;
    EXPECT_LT((Lxx - Lxx0 - rd->Rx.transpose() * W * rd->Rx).norm(), 1e-12) << rows;
    EXPECT_LT((Luu - Luu0 - rd->Ru.transpose() * W * rd->Ru).norm(), 1e-12) << rows;
    EXPECT_LT((Lux - Lux0 - rd->Ru.transpose() * W * rd->Rx).norm(), 1e-12) << rows;
  }
}

TEST(SmallProducts, EqualEigensProductOnBlocksWithoutTouchingTheRest) {
  std::mt19937 rng(5);
  for (int rows : {1, 2, 3, 4, 5, 6, 7, 8, 9, 13, 24, 30}) {
    for (int depth : {0, 1, 2, 3, 4, 5, 6, 7, 9, 12}) {
      for (int cols : {1, 2, 7, 24}) {
        for (bool accumulate : {false, true}) {
          // Operands as blocks of larger matrices (outer stride > rows).
          const MatrixXd Abig = MatrixXd::Random(rows + 3, depth + 2);
          const MatrixXd Bbig = MatrixXd::Random(depth + 4, cols + 1);
          const MatrixXd C0 = MatrixXd::Random(rows + 5, cols + 2);
          const auto A = Abig.block(1, 1, rows, depth);
          const auto B = Bbig.block(2, 0, depth, cols);
          MatrixXd C = C0;
          const double alpha = -0.7;
          {
            test::MallocGuard mguard;
            ocp::smallDepthProduct(C.block(2, 1, rows, cols), A, B, alpha, accumulate);
            EXPECT_EQ(mguard.count(), 0u);
          }
          MatrixXd expected = C0;
          expected.block(2, 1, rows, cols) =
              (accumulate ? MatrixXd(C0.block(2, 1, rows, cols)) : MatrixXd::Zero(rows, cols)) +
              alpha * A * B;
          EXPECT_LT((C - expected).cwiseAbs().maxCoeff(), 1e-12)
              << rows << " x " << depth << " x " << cols << " accumulate " << accumulate;
        }
      }
    }
  }
  // A vector right-hand side (a gradient: C += A^T r with A^T stored).
  const MatrixXd At = MatrixXd::Random(11, 6);
  const VectorXd r = VectorXd::Random(8);
  VectorXd g = VectorXd::Random(11);
  const VectorXd g0 = g;
  ocp::smallDepthProduct(g, At, r.segment(1, 6), 2.0, true);
  EXPECT_LT((g - g0 - 2.0 * At * r.segment(1, 6)).norm(), 1e-12);
}

// ---- mode schedule ---------------------------------------------------------------------------

TEST(ModeSchedule, PhasesAndModes) {
  ocp::ModeSchedule m(4, 7);
  EXPECT_EQ(m.modeAt(-1.0), 7);
  EXPECT_EQ(m.modeAt(100.0), 7);
  m.set({0.5, 1.0}, {1, 2, 3});
  EXPECT_EQ(m.switches(), 2);
  EXPECT_EQ(m.modeAt(0.0), 1);
  EXPECT_EQ(m.modeAt(0.5), 2);  // [t_0, t_1) belongs to m_1
  EXPECT_EQ(m.modeAt(0.99), 2);
  EXPECT_EQ(m.modeAt(1.0), 3);
  EXPECT_EQ(m.phaseAt(0.2), 0);
  EXPECT_EQ(m.phaseAt(2.0), 2);
  EXPECT_THROW(m.set({1.0, 0.5}, {1, 2, 3}), std::invalid_argument);
  EXPECT_THROW(m.set({0.5}, {1, 2, 3}), std::invalid_argument);
  EXPECT_THROW(m.set({0.1, 0.2, 0.3, 0.4, 0.5}, {1, 2, 3, 4, 5, 6}), std::invalid_argument);
  m.setConstant(4);
  EXPECT_EQ(m.modeAt(0.7), 4);
  // Within capacity, set() does not allocate.
  const std::vector<double> t{0.1, 0.2, 0.3, 0.4};
  const std::vector<int> md{0, 1, 0, 1, 0};
  test::AllocationGuard guard;
  m.set(t, md);
  EXPECT_EQ(guard.count(), 0u);
}

TEST(ModeSchedule, SplitAndSetModeInPlace) {
  ocp::ModeSchedule m(3, 0);
  m.set({0.5, 1.0}, {1, 2, 3});
  {
    test::AllocationGuard guard;
    EXPECT_TRUE(m.split(0.75));  // new switch, same mode on both sides
    EXPECT_EQ(guard.count(), 0u);
  }
  EXPECT_EQ(m.switches(), 3);
  EXPECT_EQ(m.modeAt(0.6), 2);
  EXPECT_EQ(m.modeAt(0.8), 2);
  EXPECT_EQ(m.phaseAt(0.8), 2);
  m.setMode(1, 5);  // [0.5, 0.75)
  EXPECT_EQ(m.modeAt(0.6), 5);
  EXPECT_EQ(m.modeAt(0.8), 2);
  EXPECT_EQ(m.modeAt(1.2), 3);
  EXPECT_TRUE(m.split(1.0));  // already a switch: nothing to insert
  EXPECT_TRUE(m.split(1.0 + 1e-12));
  EXPECT_EQ(m.switches(), 3);
  EXPECT_FALSE(m.split(2.0));  // capacity 3 is full
  EXPECT_FALSE(m.split(std::numeric_limits<double>::quiet_NaN()));
  EXPECT_EQ(m.switches(), 3);
  m.setMode(7, 9);  // out of range: nothing
  m.setMode(-1, 9);
  EXPECT_EQ(m.modes(), (std::vector<int>{1, 5, 2, 3}));
  // Before the first switch.
  ocp::ModeSchedule n(2, 4);
  EXPECT_TRUE(n.split(-1.0));
  n.setMode(0, 6);
  EXPECT_EQ(n.modeAt(-2.0), 6);
  EXPECT_EQ(n.modeAt(0.0), 4);
}

// ---- problem -------------------------------------------------------------------------------

/// Rows depend on the mode: `rows_in_mode1` rows in mode 1, none otherwise. r = u(0) + k x(0).
class ModeResidual final : public ocp::Residual {
 public:
  ModeResidual(int ndx, int nu, int rows, double k) : Residual(ndx, nu, rows), k_(k) {}
  int rows(const ocp::NodeContext& ctx) const override { return ctx.mode == 1 ? maxRows() : 0; }
  void calc(const ocp::NodeContext&, ocp::ConstVecRef x, ocp::ConstVecRef u,
            ocp::ResidualData& d) const override {
    for (int i = 0; i < d.rows; ++i) d.r(i) = u(0) + k_ * x(0) + i;
  }
  void calcDiff(const ocp::NodeContext&, ocp::ConstVecRef, ocp::ConstVecRef,
                ocp::ResidualData& d) const override {
    d.Rx.setZero();
    d.Ru.setZero();
    for (int i = 0; i < d.rows; ++i) {
      d.Rx(i, 0) = k_;
      d.Ru(i, 0) = 1.0;
    }
  }

 private:
  double k_;
};

std::shared_ptr<ocp::OptimalControlProblem> stackingProblem() {
  auto dyn = std::make_shared<ocp::ExplicitEuler>(std::make_shared<testmodels::Pendulum>());
  auto p = std::make_shared<ocp::OptimalControlProblem>(dyn, 10, 0.1);
  auto s = dyn->spacePtr();
  p->addCost(
      "state",
      std::make_shared<ocp::LeastSquaresCost>(
          std::make_shared<ocp::StateErrorResidual>(s, 1, VectorXd::Zero(2)), VectorXd::Ones(2)),
      ocp::Stage::All);
  p->addCost("input", std::make_shared<ocp::LeastSquaresCost>(
                          std::make_shared<ocp::InputErrorResidual>(2, VectorXd::Zero(1)),
                          VectorXd::Ones(1)));
  p->addEquality("always", std::make_shared<ModeResidual>(2, 1, 1, 0.0));  // only in mode 1
  p->addEquality("mode1", std::make_shared<ModeResidual>(2, 1, 2, 2.0));
  p->addInequality("ineq", std::make_shared<ModeResidual>(2, 1, 3, -1.0));
  p->addInequality(
      "terminal",
      std::make_shared<ocp::AffineResidual>(s, VectorXd::Zero(2), MatrixXd::Identity(2, 2),
                                            MatrixXd::Zero(2, 1), VectorXd::Ones(2)),
      ocp::Stage::Terminal);
  return p;
}

TEST(Problem, StacksActiveRowsByMode) {
  auto p = stackingProblem();
  EXPECT_EQ(p->maxEqualities(), 3);
  EXPECT_EQ(p->maxInequalities(), 5);
  p->modeSchedule().set({0.45}, {0, 1});  // nodes 0..4 in mode 0, 5..10 in mode 1
  p->setInitialTime(0.0);
  auto d = p->createNodeData();
  const VectorXd x = (VectorXd(2) << 0.3, -0.2).finished();
  const VectorXd u = (VectorXd(1) << 0.7).finished();
  p->linearize(2, x, u, *d);
  EXPECT_EQ(d->context.mode, 0);
  EXPECT_EQ(d->ne, 0);
  EXPECT_EQ(d->ni, 0);
  p->linearize(6, x, u, *d);
  EXPECT_EQ(d->context.mode, 1);
  ASSERT_EQ(d->ne, 3);
  EXPECT_NEAR(d->e(0), 0.7, 1e-15);        // "always" row
  EXPECT_NEAR(d->e(1), 0.7 + 0.6, 1e-15);  // "mode1" rows follow in order
  EXPECT_NEAR(d->e(2), 0.7 + 0.6 + 1.0, 1e-15);
  EXPECT_DOUBLE_EQ(d->Ex(1, 0), 2.0);
  EXPECT_DOUBLE_EQ(d->Eu(2, 0), 1.0);
  ASSERT_EQ(d->ni, 3);
  EXPECT_NEAR(d->g(2), 0.7 - 0.3 + 2.0, 1e-15);
  // Dynamics: explicit Euler.
  EXPECT_NEAR(d->xnext(0), 0.3 + 0.1 * -0.2, 1e-15);
  // Cost: dt * 0.5 (|x|^2 + u^2).
  EXPECT_NEAR(d->cost, 0.1 * 0.5 * (0.09 + 0.04 + 0.49), 1e-15);
  EXPECT_NEAR(d->lu(0), 0.1 * 0.7, 1e-15);
  // Terminal node: only terminal terms, no input, no equalities.
  p->linearize(10, x, u, *d);
  EXPECT_TRUE(d->context.terminal);
  EXPECT_EQ(d->ne, 0);
  ASSERT_EQ(d->ni, 2);
  EXPECT_NEAR(d->g(0), 1.3, 1e-15);
  EXPECT_NEAR(d->cost, 0.5 * 0.13, 1e-15);  // terminal cost is not scaled by dt
  EXPECT_EQ(p->equalityNames()[1], "mode1");
}

using test::MirroredAffine;

TEST(Problem, MirroredRowsAreMarkedAtTheirStackedPositions) {
  auto p = stackingProblem();
  auto s = p->dynamics().spacePtr();
  const auto mirror = [](const ocp::NodeData& nd) {
    return std::vector<int>(nd.mirror.data(), nd.mirror.data() + nd.ni);
  };
  MatrixXd C(5, 2), D(5, 1);
  C << 1, 2, 3, 4, -1, -2, -3, -4, 5, 6;
  D << 1, -1, -1, 1, 0;
  p->addInequality("two-sided", std::make_shared<MirroredAffine>(s, C, D, VectorXd::Ones(5), 2));
  p->modeSchedule().set({0.45}, {0, 1});
  auto d = p->createNodeData();
  const VectorXd x = (VectorXd(2) << 0.3, -0.2).finished();
  const VectorXd u = (VectorXd(1) << 0.7).finished();
  p->linearize(2, x, u, *d);  // mode 0: the ModeResidual has no rows, the pairs come first
  ASSERT_EQ(d->ni, 5);
  EXPECT_EQ(mirror(*d), (std::vector<int>{2, 3, 0, 1, -1}));
  p->linearize(6, x, u, *d);  // mode 1: after the 3 rows of the ModeResidual
  ASSERT_EQ(d->ni, 8);
  EXPECT_EQ(mirror(*d), (std::vector<int>{-1, -1, -1, 5, 6, 3, 4, -1}));
  for (int j = 3; j < 5; ++j) {
    EXPECT_TRUE(d->Gx.row(j + 2) == -d->Gx.row(j));
    EXPECT_TRUE(d->Gu.row(j + 2) == -d->Gu.row(j));
  }
}

TEST(Problem, CurvaturePassKeepsOnlyTermsWithSecondDerivatives) {
  // Pendulum (nonlinear dynamics), quadratic state/input costs (exact Hessians), an
  // affine inequality (linear) and ModeResidual (linear in fact, but not declared so).
  auto p = stackingProblem();
  EXPECT_TRUE(p->hasCurvature());
  p->modeSchedule().set({0.45}, {0, 1});
  auto d = p->createNodeData();
  auto c = p->createNodeData();
  const VectorXd x = (VectorXd(2) << 0.3, -0.2).finished();
  const VectorXd u = (VectorXd(1) << 0.7).finished();
  for (int k : {2, 6, 10}) {
    p->linearize(k, x, u, *d);
    p->linearizeCurvatureTerms(k, x, u, *c);
    // Same rows; exact-Hessian costs contribute nothing.
    ASSERT_EQ(c->ne, d->ne);
    ASSERT_EQ(c->ni, d->ni);
    EXPECT_EQ(c->cost, 0.0);
    EXPECT_TRUE(c->lx.isZero(0.0));
    EXPECT_TRUE(c->Lxx.isZero(0.0));
    if (k < p->horizon()) {
      EXPECT_TRUE(c->Fx.isApprox(d->Fx));  // the pendulum is nonlinear: kept
      EXPECT_TRUE(c->Ex.topRows(c->ne).isApprox(d->Ex.topRows(d->ne)));
    } else {
      // Terminal: the affine inequality is declared linear: zero rows.
      EXPECT_TRUE(c->Gx.topRows(c->ni).isZero(0.0));
      EXPECT_TRUE(c->state_only.head(c->ni).all());
    }
  }
  // Row flags: ModeResidual depends on u (not state-only) at running nodes.
  p->linearize(6, x, u, *d);
  EXPECT_FALSE(d->state_only.head(d->ni).any());
}

TEST(Problem, LinearQuadraticProblemHasNoCurvature) {
  const MatrixXd A = MatrixXd::Identity(2, 2), B = MatrixXd::Ones(2, 1);
  auto dyn = std::make_shared<testmodels::LinearDynamics>(A, B, VectorXd::Zero(2));
  auto p = std::make_shared<ocp::OptimalControlProblem>(dyn, 5, 0.1);
  auto s = dyn->spacePtr();
  p->addCost("state", std::make_shared<ocp::LeastSquaresCost>(
                          std::make_shared<ocp::StateErrorResidual>(s, 1, VectorXd::Zero(2)),
                          VectorXd::Ones(2)));
  p->addInequality(
      "box", std::make_shared<ocp::AffineResidual>(s, VectorXd::Zero(2), MatrixXd::Identity(2, 2),
                                                   MatrixXd::Ones(2, 1), VectorXd::Ones(2)));
  EXPECT_FALSE(p->hasCurvature());
  // A nonlinear residual anywhere brings curvature back.
  p->addEquality("mode", std::make_shared<ModeResidual>(2, 1, 1, 1.0));
  EXPECT_TRUE(p->hasCurvature());
  // Lie-group states always have curvature (the retraction).
  auto se3 = std::make_shared<ocp::ExplicitEuler>(std::make_shared<testmodels::FloatingBody>());
  ocp::OptimalControlProblem q(se3, 5, 0.1);
  EXPECT_TRUE(q.hasCurvature());
}

TEST(Problem, CoordinateNamesForDiagnostics) {
  const MatrixXd A = MatrixXd::Identity(2, 2), B = MatrixXd::Ones(2, 1);
  auto dyn = std::make_shared<testmodels::LinearDynamics>(A, B, VectorXd::Zero(2));
  ocp::OptimalControlProblem p(dyn, 5, 0.1);
  EXPECT_EQ(p.tangentName(1), "tangent 1");
  EXPECT_EQ(p.inputName(0), "input 0");
  p.setCoordinateNames({"cart", "pole"}, {});
  EXPECT_EQ(p.tangentName(1), "pole");
  EXPECT_EQ(p.inputName(0), "input 0");
  EXPECT_EQ(p.tangentName(7), "tangent 7");  // out of range: generated, no throw
  p.setCoordinateNames({}, {"force"});
  EXPECT_EQ(p.tangentName(0), "tangent 0");
  EXPECT_EQ(p.inputName(0), "force");
  try {
    p.setCoordinateNames({"cart"}, {"force"});
    ADD_FAILURE() << "a wrong count must throw";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("1 tangent names for 2 coordinates"), std::string::npos)
        << e.what();
  }
  EXPECT_THROW(p.setCoordinateNames({}, {"a", "b"}), std::invalid_argument);
  EXPECT_EQ(p.inputName(0), "force");  // a refused call changes nothing
}

TEST(Problem, EvaluateAndLinearizeDoNotAllocate) {
  auto p = stackingProblem();
  p->modeSchedule().set({0.45}, {0, 1});
  auto d = p->createNodeData();
  const VectorXd x = (VectorXd(2) << 0.3, -0.2).finished();
  const VectorXd u = (VectorXd(1) << 0.7).finished();
  test::AllocationGuard guard;
  test::MallocGuard mguard;
  for (int k = 0; k <= p->horizon(); ++k) {
    p->evaluate(k, x, u, *d);
    p->linearize(k, x, u, *d);
  }
  EXPECT_EQ(guard.count(), 0u);
  EXPECT_EQ(mguard.count(), 0u);
}

TEST(Problem, Se3ProblemDoesNotAllocate) {
  auto f = std::make_shared<testmodels::FloatingBody>();
  auto dyn = std::make_shared<ocp::ExplicitEuler>(f);
  auto p = std::make_shared<ocp::OptimalControlProblem>(dyn, 5, 0.05);
  auto s = dyn->spacePtr();
  VectorXd xr(13);
  s->neutral(xr);
  p->addCost("x",
             std::make_shared<ocp::LeastSquaresCost>(
                 std::make_shared<ocp::StateErrorResidual>(s, 6, xr), VectorXd::Ones(12)),
             ocp::Stage::All);
  auto d = p->createNodeData();
  std::mt19937 rng(1);
  const VectorXd x = randomState(*s, rng), u = randomVec(6, rng);
  test::AllocationGuard guard;
  test::MallocGuard mguard;
  p->linearize(0, x, u, *d);
  p->linearize(5, x, u, *d);
  EXPECT_EQ(guard.count(), 0u);
  EXPECT_EQ(mguard.count(), 0u);
}

// ---- workspaces for nodes with a shared cache -------------------------------------------

/// The shared work of a node: s = x(0)^2.
struct SquareCache final : ocp::NodeCache {
  double s = 0.0;
};
class SquarePrecomputation final : public ocp::NodePrecomputation {
 public:
  std::unique_ptr<ocp::NodeCache> createCache() const override {
    return std::make_unique<SquareCache>();
  }
  void compute(const ocp::NodeContext&, ocp::ConstVecRef x, ocp::ConstVecRef, bool,
               ocp::NodeCache& cache) const override {
    static_cast<SquareCache&>(cache).s = x(0) * x(0);
  }
};

/// A workspace with its own SquareCache for calls without a node cache, or none.
struct SquareData final : ocp::ResidualData {
  SquareData(int ndx, int nu, bool own_cache)
      : ResidualData(1, ndx, nu), own(own_cache ? std::make_unique<SquareCache>() : nullptr) {}
  std::unique_ptr<SquareCache> own;
};
/// The cache a Square term reads: the node's, else its own (computed here), else an error.
const SquareCache& squareCache(const ocp::NodeContext& ctx, ocp::ConstVecRef x, SquareCache* own) {
  if (ctx.cache != nullptr) return static_cast<const SquareCache&>(*ctx.cache);
  if (own == nullptr) throw std::logic_error("no node cache and none of its own");
  own->s = x(0) * x(0);
  return *own;
}

/// r = x(0)^2 + u(0), read from the node cache when the call has one. Counts the
/// workspaces made by each factory.
class SquareResidual final : public ocp::Residual {
 public:
  SquareResidual() : Residual(2, 1, 1) {}
  std::unique_ptr<ocp::ResidualData> createData() const override {
    ++alone;
    return std::make_unique<SquareData>(ndx(), nu(), true);
  }
  std::unique_ptr<ocp::ResidualData> createDataWithNodeCache() const override {
    ++with_cache;
    return std::make_unique<SquareData>(ndx(), nu(), false);
  }
  void calc(const ocp::NodeContext& ctx, ocp::ConstVecRef x, ocp::ConstVecRef u,
            ocp::ResidualData& d) const override {
    d.r(0) = squareCache(ctx, x, static_cast<SquareData&>(d).own.get()).s + u(0);
  }
  void calcDiff(const ocp::NodeContext&, ocp::ConstVecRef x, ocp::ConstVecRef,
                ocp::ResidualData& d) const override {
    d.Rx(0, 0) = 2.0 * x(0);
    d.Rx(0, 1) = 0.0;
    d.Ru(0, 0) = 1.0;
  }
  mutable int alone = 0, with_cache = 0;
};

/// The pendulum, its sin(x(0)) replaced by x(0)^2 read like SquareResidual does.
class SquarePendulum final : public ocp::ContinuousDynamics {
 public:
  struct Data final : ocp::DynamicsData {
    explicit Data(bool own_cache) : own(own_cache ? std::make_unique<SquareCache>() : nullptr) {}
    std::unique_ptr<SquareCache> own;
  };
  SquarePendulum() : ContinuousDynamics(std::make_shared<ocp::EuclideanSpace>(2), 1) {}
  std::unique_ptr<ocp::DynamicsData> createData() const override {
    ++alone;
    return std::make_unique<Data>(true);
  }
  std::unique_ptr<ocp::DynamicsData> createDataWithNodeCache() const override {
    ++with_cache;
    return std::make_unique<Data>(false);
  }
  void calc(const ocp::NodeContext& ctx, ocp::ConstVecRef x, ocp::ConstVecRef u,
            ocp::DynamicsData& d, ocp::VecRef xdot) const override {
    xdot(0) = x(1);
    xdot(1) = -squareCache(ctx, x, static_cast<Data&>(d).own.get()).s + u(0);
  }
  void calcDiff(const ocp::NodeContext&, ocp::ConstVecRef x, ocp::ConstVecRef, ocp::DynamicsData&,
                ocp::MatRef fx, ocp::MatRef fu) const override {
    fx << 0.0, 1.0, -2.0 * x(0), 0.0;
    fu << 0.0, 1.0;
  }
  mutable int alone = 0, with_cache = 0;
};

// A problem with a precomputation passes its node cache to every call: the terms' workspaces
// come from createDataWithNodeCache (through LeastSquaresCost and ExplicitEuler too), and
// evaluate the same as those of createData without a precomputation.
TEST(Problem, TermWorkspacesOfNodesWithACacheComeFromCreateDataWithNodeCache) {
  auto f = std::make_shared<SquarePendulum>();
  auto res = std::make_shared<SquareResidual>();
  auto make = [&](bool with_pre) {
    auto p = std::make_shared<ocp::OptimalControlProblem>(std::make_shared<ocp::ExplicitEuler>(f),
                                                          4, 0.1);
    p->addCost("square", std::make_shared<ocp::LeastSquaresCost>(res, VectorXd::Ones(1)));
    p->addEquality("square", res);
    p->addInequality("square", res);
    if (with_pre) p->setPrecomputation(std::make_shared<SquarePrecomputation>());
    return p;
  };
  const VectorXd x = (VectorXd(2) << 0.3, -0.2).finished();
  const VectorXd u = (VectorXd(1) << 0.7).finished();
  auto alone = make(false);
  auto da = alone->createNodeData();
  EXPECT_EQ(res->alone, 3);
  EXPECT_EQ(f->alone, 1);
  EXPECT_EQ(res->with_cache + f->with_cache, 0);
  auto shared = make(true);
  auto ds = shared->createNodeData();
  EXPECT_EQ(res->alone, 3);
  EXPECT_EQ(f->alone, 1);
  EXPECT_EQ(res->with_cache, 3);
  EXPECT_EQ(f->with_cache, 1);
  for (int k : {0, 4}) {
    alone->linearize(k, x, u, *da);
    shared->linearize(k, x, u, *ds);
    EXPECT_EQ(ds->cost, da->cost) << k;
    EXPECT_EQ(ds->lx, da->lx) << k;
    EXPECT_EQ(ds->Lxx, da->Lxx) << k;
    EXPECT_EQ(ds->xnext, da->xnext) << k;
    EXPECT_EQ(ds->Fx, da->Fx) << k;
    EXPECT_EQ(ds->e, da->e) << k;
    EXPECT_EQ(ds->g, da->g) << k;
    EXPECT_EQ(ds->Gx, da->Gx) << k;
  }
  EXPECT_NEAR(ds->e(0), 0.09 + 0.7, 1e-15);
  // Such a workspace used without the node cache has nothing to fall back on.
  ocp::NodeContext bare = shared->context(0);
  ASSERT_EQ(bare.cache, nullptr);
  EXPECT_THROW(res->calc(bare, x, u, *ds->equality_data[0]), std::logic_error);
  EXPECT_NO_THROW(res->calc(bare, x, u, *da->equality_data[0]));
}

TEST(Problem, RejectsInvalidComposition) {
  auto p = stackingProblem();
  auto s = p->dynamics().spacePtr();
  // Terminal cost / inequality depending on the input.
  EXPECT_THROW(p->addCost("u",
                          std::make_shared<ocp::LeastSquaresCost>(
                              std::make_shared<ocp::InputErrorResidual>(2, VectorXd::Zero(1)),
                              VectorXd::Ones(1)),
                          ocp::Stage::Terminal),
               std::invalid_argument);
  EXPECT_THROW(p->addInequality("soft-u", std::make_shared<ModeResidual>(2, 1, 1, 1.0),
                                ocp::Stage::Running, {true, 0.1}),
               std::invalid_argument);
  // Wrong dimensions.
  EXPECT_THROW(p->addEquality("bad", std::make_shared<ModeResidual>(3, 1, 1, 1.0)),
               std::invalid_argument);
  // Bounds: lower > upper, sizes, non-Euclidean part.
  const double inf = ocp::OptimalControlProblem::kInfinity;
  EXPECT_THROW(p->setInputBounds(VectorXd::Constant(1, 1.0), VectorXd::Constant(1, 0.0)),
               std::invalid_argument);
  EXPECT_THROW(p->setInputBounds(VectorXd::Zero(2), VectorXd::Ones(2)), std::invalid_argument);
  p->setInputBounds(VectorXd::Constant(1, -inf), VectorXd::Constant(1, 2.0));
  ASSERT_EQ(p->inputBounds().size(), 1);
  EXPECT_FALSE(p->inputBounds().has_lower[0]);
  EXPECT_TRUE(p->inputBounds().has_upper[0]);
  p->setStateBounds(VectorXd::Constant(2, -inf), VectorXd::Constant(2, inf));
  EXPECT_EQ(p->stateBounds().size(), 0);

  auto dyn = std::make_shared<ocp::ExplicitEuler>(std::make_shared<testmodels::FloatingBody>());
  ocp::OptimalControlProblem q(dyn, 3, 0.1);
  VectorXd lo = VectorXd::Constant(12, -inf), hi = VectorXd::Constant(12, inf);
  lo(8) = -1.0;
  q.setStateBounds(lo, hi);
  EXPECT_EQ(q.stateBounds().index[0], 8);
  lo(2) = -1.0;  // translation tangent: not Euclidean
  EXPECT_THROW(q.setStateBounds(lo, hi), std::invalid_argument);
}

}  // namespace
