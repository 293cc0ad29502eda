// Derivatives of the nonlinear test problems against central finite differences on the
// manifold: each ContinuousDynamics and Residual, then every node of the composed
// problems (cost gradient, discrete dynamics, equalities, inequalities).
#include "nonlinear_problems.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <random>

namespace rollstep::nltest {
namespace {

constexpr double kTol = 1e-6;

VectorXd randomState(const ocp::StateSpace& space, std::mt19937& rng, double scale) {
  std::uniform_real_distribution<double> U(-scale, scale);
  VectorXd x(space.nx()), dx(space.ndx());
  space.neutral(x);
  for (int i = 0; i < dx.size(); ++i) dx[i] = U(rng);
  VectorXd out(space.nx());
  space.integrate(x, dx, out);
  return out;
}

VectorXd randomVec(int n, std::mt19937& rng, double scale) {
  std::uniform_real_distribution<double> U(-scale, scale);
  VectorXd v(n);
  for (int i = 0; i < n; ++i) v[i] = U(rng);
  return v;
}

double relErr(const MatrixXd& a, const MatrixXd& b) {
  return (a - b).lpNorm<Eigen::Infinity>() / std::max(1.0, b.lpNorm<Eigen::Infinity>());
}

void checkContinuous(const ocp::ContinuousDynamics& f, std::mt19937& rng, double scale) {
  const auto& space = f.space();
  const int ndx = space.ndx(), nu = f.nu();
  auto d = f.createData();
  ocp::NodeContext ctx;
  ctx.dt = 0.05;
  for (int trial = 0; trial < 10; ++trial) {
    const VectorXd x = randomState(space, rng, scale);
    const VectorXd u = randomVec(nu, rng, scale);
    VectorXd xdot(ndx);
    MatrixXd fx(ndx, ndx), fu(ndx, nu), fxn(ndx, ndx), fun(ndx, nu);
    f.calc(ctx, x, u, *d, xdot);
    f.calcDiff(ctx, x, u, *d, fx, fu);
    finiteDifference(
        space, x, u,
        [&](ConstVecRef xx, ConstVecRef uu, VecRef out) { f.calc(ctx, xx, uu, *d, out); }, ndx, fxn,
        fun);
    EXPECT_LT(relErr(fx, fxn), kTol) << "fx\n" << fx << "\nfd\n" << fxn;
    EXPECT_LT(relErr(fu, fun), kTol) << "fu\n" << fu << "\nfd\n" << fun;
  }
}

void checkResidual(const ocp::Residual& r, const ocp::StateSpace& space, std::mt19937& rng,
                   double scale) {
  const int ndx = space.ndx(), nu = r.nu();
  auto d = r.createData();
  ocp::NodeContext ctx;
  for (int trial = 0; trial < 10; ++trial) {
    const VectorXd x = randomState(space, rng, scale);
    const VectorXd u = randomVec(nu, rng, scale);
    const int rows = r.rows(ctx);
    d->rows = rows;
    r.calc(ctx, x, u, *d);
    r.calcDiff(ctx, x, u, *d);
    const MatrixXd Rx = d->Rx.topRows(rows), Ru = d->Ru.topRows(rows);
    MatrixXd Rxn(rows, ndx), Run(rows, nu);
    finiteDifference(
        space, x, u,
        [&](ConstVecRef xx, ConstVecRef uu, VecRef out) {
          r.calc(ctx, xx, uu, *d);
          out = d->r.head(rows);
        },
        rows, Rxn, Run);
    EXPECT_LT(relErr(Rx, Rxn), kTol) << "Rx\n" << Rx << "\nfd\n" << Rxn;
    EXPECT_LT(relErr(Ru, Run), kTol) << "Ru\n" << Ru << "\nfd\n" << Run;
    if (!r.dependsOnInput()) {
      EXPECT_EQ(Ru.lpNorm<Eigen::Infinity>(), 0.0);
    }
  }
}

/// Every node of the composed problem: cost gradient, F (via the manifold difference),
/// equalities and inequalities.
void checkProblemNodes(const ProblemInstance& inst, std::mt19937& rng, double scale) {
  const auto& pb = *inst.problem;
  const auto& space = pb.stateSpace();
  const int ndx = pb.ndx(), nu = pb.nu();
  auto d = pb.createNodeData();
  auto dp = pb.createNodeData();
  for (int k : {0, pb.horizon() / 2, pb.horizon()}) {
    const bool term = k == pb.horizon();
    VectorXd x = inst.x_goal;
    space.integrate(inst.x_goal, randomVec(ndx, rng, scale), x);
    const VectorXd u = term ? VectorXd::Zero(nu) : randomVec(nu, rng, scale);
    pb.linearize(k, x, u, *d);
    // Cost gradient (1 row).
    MatrixXd gx(1, ndx), gu(1, nu);
    finiteDifference(
        space, x, u,
        [&](ConstVecRef xx, ConstVecRef uu, VecRef out) {
          pb.evaluate(k, xx, uu, *dp);
          out[0] = dp->cost;
        },
        1, gx, gu);
    EXPECT_LT(relErr(d->lx.transpose(), gx), kTol) << inst.name << " node " << k;
    if (!term) {
      EXPECT_LT(relErr(d->lu.transpose(), gu), kTol) << inst.name << " node " << k;
    }
    if (!term) {
      // Fx, Fu: difference from F(x, u) (tangent at F(x, u)).
      const VectorXd F0 = d->xnext;
      MatrixXd Fxn(ndx, ndx), Fun(ndx, nu);
      finiteDifference(
          space, x, u,
          [&](ConstVecRef xx, ConstVecRef uu, VecRef out) {
            pb.evaluate(k, xx, uu, *dp);
            space.difference(F0, dp->xnext, out);
          },
          ndx, Fxn, Fun);
      EXPECT_LT(relErr(d->Fx, Fxn), 1e-5) << inst.name << " Fx\n" << d->Fx << "\nfd\n" << Fxn;
      EXPECT_LT(relErr(d->Fu, Fun), 1e-5) << inst.name << " Fu\n" << d->Fu << "\nfd\n" << Fun;
    }
    if (d->ne > 0) {
      const int ne = d->ne;
      MatrixXd Exn(ne, ndx), Eun(ne, nu);
      finiteDifference(
          space, x, u,
          [&](ConstVecRef xx, ConstVecRef uu, VecRef out) {
            pb.evaluate(k, xx, uu, *dp);
            out = dp->e.head(ne);
          },
          ne, Exn, Eun);
      EXPECT_LT(relErr(d->Ex.topRows(ne), Exn), kTol) << inst.name;
      EXPECT_LT(relErr(d->Eu.topRows(ne), Eun), kTol) << inst.name;
    }
    if (d->ni > 0) {
      const int ni = d->ni;
      MatrixXd Gxn(ni, ndx), Gun(ni, nu);
      finiteDifference(
          space, x, u,
          [&](ConstVecRef xx, ConstVecRef uu, VecRef out) {
            pb.evaluate(k, xx, uu, *dp);
            out = dp->g.head(ni);
          },
          ni, Gxn, Gun);
      EXPECT_LT(relErr(d->Gx.topRows(ni), Gxn), kTol) << inst.name;
      if (!term) {
        EXPECT_LT(relErr(d->Gu.topRows(ni), Gun), kTol) << inst.name;
      }
    }
  }
}

TEST(NonlinearProblems, CartPoleDynamicsDerivatives) {
  std::mt19937 rng(1);
  checkContinuous(CartPoleDynamics(), rng, 3.0);
}

TEST(NonlinearProblems, UnicycleDynamicsDerivatives) {
  std::mt19937 rng(2);
  checkContinuous(UnicycleDynamics(), rng, 3.0);
}

TEST(NonlinearProblems, RigidBodyDynamicsDerivativesWithGravity) {
  std::mt19937 rng(3);
  RigidBodyParams p;
  p.gravity = Eigen::Vector3d(0.3, -1.0, -9.81);
  checkContinuous(RigidBodyDynamics(p), rng, 1.5);
  checkContinuous(RigidBodyDynamics(), rng, 1.5);
}

TEST(NonlinearProblems, RigidBodyHoversAgainstGravityInWorldFrame) {
  // Body rotated: the force that cancels gravity is R^T (-m g), so v' = 0.
  RigidBodyParams p;
  p.gravity = Eigen::Vector3d(0.0, 0.0, -9.81);
  RigidBodyDynamics f(p);
  auto d = f.createData();
  VectorXd x = VectorXd::Zero(13);
  const Eigen::Quaterniond q(Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()));
  x[3] = q.x();
  x[4] = q.y();
  x[5] = q.z();
  x[6] = q.w();
  VectorXd u = VectorXd::Zero(6);
  u.head<3>() = q.toRotationMatrix().transpose() * (-p.mass * p.gravity);
  VectorXd xdot(12);
  f.calc(ocp::NodeContext{}, x, u, *d, xdot);
  EXPECT_LT(xdot.lpNorm<Eigen::Infinity>(), 1e-12);
}

TEST(NonlinearProblems, ResidualDerivatives) {
  std::mt19937 rng(4);
  auto plane = std::make_shared<ocp::EuclideanSpace>(3);
  checkResidual(SpeedProfileResidual(0.7, 1.2, 4.0, 1.0), *plane, rng, 3.0);
  checkResidual(CircleObstacleResidual(plane, 2, {{1.0, 2.0, 0.5}, {-1.0, 0.3, 0.2}}), *plane, rng,
                3.0);
  // Obstacles on the Euclidean part of an SE(3) x R^2 state.
  auto se3 = std::make_shared<ocp::SE3xEuclideanSpace>(2);
  checkResidual(CircleObstacleResidual(se3, 1, {{1.0, 2.0, 0.5}}, 6, 7), *se3, rng, 2.0);
  EXPECT_THROW(CircleObstacleResidual(se3, 1, {{1.0, 2.0, 0.5}}, 0, 1), std::invalid_argument);
}

TEST(NonlinearProblems, SpeedProfileRowRankInInput) {
  SpeedProfileResidual r(0.3, 1.0, 4.0, 0.0);
  auto d = r.createData();
  d->rows = 1;
  VectorXd x(3), u(2);
  x << 1.0, 2.0, 0.3;
  u << 0.5, 0.1;
  r.calc(ocp::NodeContext{}, x, u, *d);
  r.calcDiff(ocp::NodeContext{}, x, u, *d);
  EXPECT_DOUBLE_EQ(d->Ru(0, 0), 1.0);
  EXPECT_NEAR(d->r[0], 0.5 - r.speed(x), 1e-15);
}

TEST(NonlinearProblems, ComposedNodesMatchFiniteDifferences) {
  std::mt19937 rng(5);
  checkProblemNodes(makeCartPole(), rng, 1.0);
  CartPoleOptions euler;
  euler.rk4 = false;
  checkProblemNodes(makeCartPole(euler), rng, 1.0);
  UnicycleOptions uo;
  uo.soft_obstacles = {{3.0, 0.8, 0.3}};
  checkProblemNodes(makeUnicycle(uo), rng, 1.0);
  checkProblemNodes(makeRigidBody(), rng, 0.8);
}

TEST(NonlinearProblems, InstancesAreConsistent) {
  for (const auto& inst : {makeCartPole(), makeUnicycle(), makeRigidBody()}) {
    const auto& pb = *inst.problem;
    EXPECT_EQ(inst.x0.size(), pb.nx()) << inst.name;
    EXPECT_EQ(inst.x_goal.size(), pb.nx()) << inst.name;
    EXPECT_EQ(static_cast<int>(inst.xs_guess.size()), pb.horizon() + 1) << inst.name;
    EXPECT_EQ(static_cast<int>(inst.us_guess.size()), pb.horizon()) << inst.name;
    const auto xs = rollout(pb, inst.x0, inst.us_guess);
    EXPECT_TRUE(std::isfinite(totalCost(pb, xs, inst.us_guess))) << inst.name;
    const double viol = maxViolation(pb, inst.x0, xs, inst.us_guess);
    if (inst.name == "unicycle") {
      // Driving straight on at the profile speed: only the obstacle is violated.
      EXPECT_GT(viol, 0.1);
      for (size_t k = 0; k < xs.size(); ++k) EXPECT_LT((xs[k] - inst.xs_guess[k]).norm(), 1e-12);
    } else {
      EXPECT_LT(viol, 1e-12) << inst.name;
    }
  }
}

}  // namespace
}  // namespace rollstep::nltest
