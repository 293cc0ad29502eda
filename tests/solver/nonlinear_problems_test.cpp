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
  auto point = std::make_shared<ocp::EuclideanSpace>(2);
  checkResidual(CircleStepResidual(0.1, 1.0), *point, rng, 2.0);
}

TEST(NonlinearProblems, MaratosCircleGuessLiesOnTheCircle) {
  // The default guess: every next position on the unit circle (the equality holds), the
  // dynamics consistent.
  const ProblemInstance inst = makeMaratosCircle();
  const auto& pb = *inst.problem;
  EXPECT_LT(maxViolation(pb, inst.x0, inst.xs_guess, inst.us_guess), 1e-12);
  EXPECT_NEAR(inst.x0.norm(), 1.0, 1e-15);
  EXPECT_GT(inst.xs_guess.back()[0], inst.x0[0]);  // towards the solution at (1, 0)
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

TEST(NonlinearProblems, TwoLinkArmDynamicsDerivatives) {
  std::mt19937 rng(6);
  checkContinuous(TwoLinkArmDynamics(), rng, 3.0);
  TwoLinkArmParams p;
  p.mass1 = 0.7;
  p.mass2 = 1.3;
  p.length1 = 0.4;
  p.length2 = 0.6;
  p.friction = 0.5;
  checkContinuous(TwoLinkArmDynamics(p), rng, 3.0);
}

TEST(NonlinearProblems, AcrobotDynamicsDerivativesAndFreeShoulder) {
  std::mt19937 rng(9);
  checkContinuous(AcrobotDynamics(), rng, 3.0);
  // The arm with no shoulder torque; hanging straight down at rest it stays there.
  const TwoLinkArmDynamics arm;
  const AcrobotDynamics acrobot;
  auto da = arm.createData();
  auto db = acrobot.createData();
  const ocp::NodeContext ctx;
  const Eigen::Vector4d x(0.3, -0.7, 1.1, -0.4);
  Eigen::Vector4d fa, fb;
  arm.calc(ctx, x, Eigen::Vector2d(0.0, 1.7), *da, fa);
  acrobot.calc(ctx, x, Eigen::VectorXd::Constant(1, 1.7), *db, fb);
  EXPECT_EQ(fa, fb);
  acrobot.calc(ctx, Eigen::Vector4d(-M_PI / 2, 0.0, 0.0, 0.0), Eigen::VectorXd::Zero(1), *db, fb);
  EXPECT_LT(fb.norm(), 1e-12);
}

TEST(NonlinearProblems, TwoLinkArmHoldsStillWithGravityTorqueAndMatchesEnergy) {
  const TwoLinkArmDynamics f;
  auto d = f.createData();
  VectorXd x(4), u(2), xdot(4);
  x << 0.4, -1.1, 0.0, 0.0;
  const Eigen::Vector2d hold = f.gravityTorque(x[0], x[1]);
  u << hold[0], hold[1];  // element-wise: a Vector2d -> VectorXd copy trips -Warray-bounds
  f.calc(ocp::NodeContext{}, x, u, *d, xdot);
  EXPECT_LT(xdot.lpNorm<Eigen::Infinity>(), 1e-12);
  // Without friction and torque, the energy rate vanishes: d/dt (T + V) = 0, with
  // T = 1/2 dq^T M dq from the point masses' velocities and V = g sum m_i y_i.
  TwoLinkArmParams p;
  p.friction = 0.0;
  const TwoLinkArmDynamics free(p);
  x << 0.3, 0.8, 1.5, -2.0;
  u.setZero();
  free.calc(ocp::NodeContext{}, x, u, *d, xdot);
  auto energy = [&](const VectorXd& s) {
    const double l1 = p.length1, l2 = p.length2;
    const Eigen::Vector2d v1(-l1 * std::sin(s[0]) * s[2], l1 * std::cos(s[0]) * s[2]);
    const double w12 = s[2] + s[3];
    const Eigen::Vector2d v2 =
        v1 + Eigen::Vector2d(-l2 * std::sin(s[0] + s[1]) * w12, l2 * std::cos(s[0] + s[1]) * w12);
    const Eigen::Vector2d p2 = free.endEffector(s[0], s[1]);
    return 0.5 * p.mass1 * v1.squaredNorm() + 0.5 * p.mass2 * v2.squaredNorm() +
           p.gravity * (p.mass1 * l1 * std::sin(s[0]) + p.mass2 * p2.y());
  };
  const double h = 1e-6;
  const double rate = (energy(x + h * xdot) - energy(x - h * xdot)) / (2.0 * h);
  EXPECT_NEAR(rate, 0.0, 1e-6);
}

TEST(NonlinearProblems, PlanarQuadrotorDynamicsDerivativesAndHover) {
  std::mt19937 rng(7);
  checkContinuous(PlanarQuadrotorDynamics(), rng, 3.0);
  const PlanarQuadrotorDynamics f;
  auto d = f.createData();
  VectorXd x = VectorXd::Zero(6), u = VectorXd::Constant(2, 0.5 * 9.81), xdot(6);
  f.calc(ocp::NodeContext{}, x, u, *d, xdot);
  EXPECT_LT(xdot.lpNorm<Eigen::Infinity>(), 1e-12);
}

TEST(NonlinearProblems, BicycleDynamicsDerivatives) {
  std::mt19937 rng(8);
  checkContinuous(BicycleDynamics(0.5), rng, 1.2);  // |delta| < pi / 2
}

TEST(NonlinearProblems, ArmKeepOutResidualDerivativesAndValue) {
  std::mt19937 rng(9);
  auto space = std::make_shared<ocp::EuclideanSpace>(4);
  const ArmKeepOutResidual r(4, 2, 0.5, 0.4, {{0.5, 0.3, 0.2}, {-0.2, 0.6, 0.1}});
  checkResidual(r, *space, rng, 3.0);
  // Stretched along +x: the end effector is at (0.9, 0).
  auto d = r.createData();
  d->rows = 2;
  VectorXd x = VectorXd::Zero(4), u = VectorXd::Zero(2);
  r.calc(ocp::NodeContext{}, x, u, *d);
  EXPECT_NEAR(d->r[0], 0.4 * 0.4 + 0.3 * 0.3 - 0.04, 1e-14);
  EXPECT_NEAR(d->r[1], 1.1 * 1.1 + 0.6 * 0.6 - 0.01, 1e-14);
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
  checkProblemNodes(makeTwoLinkArm(), rng, 1.0);
  checkProblemNodes(makePlanarQuadrotor(), rng, 1.0);
  checkProblemNodes(makeBicycle(), rng, 0.5);
  checkProblemNodes(makeMaratosCircle(), rng, 0.5);
}

TEST(NonlinearProblems, InstancesAreConsistent) {
  for (const auto& inst : {makeCartPole(), makeUnicycle(), makeRigidBody(), makeTwoLinkArm(),
                           makePlanarQuadrotor(), makeBicycle(), makeAcrobot()}) {
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
    // The second start: from x0 to x_goal.
    const auto xi = interpolatedStates(inst);
    ASSERT_EQ(static_cast<int>(xi.size()), pb.horizon() + 1) << inst.name;
    VectorXd err(pb.ndx());
    pb.stateSpace().difference(inst.x0, xi.front(), err);
    EXPECT_LT(err.norm(), 1e-12) << inst.name;
    pb.stateSpace().difference(inst.x_goal, xi.back(), err);
    EXPECT_LT(err.norm(), 1e-12) << inst.name;
  }
}

TEST(NonlinearProblems, CountActiveCountsRowsAtTheirBounds) {
  auto inst = makePlanarQuadrotor();
  const auto& pb = *inst.problem;
  auto us = inst.us_guess;
  auto xs = rollout(pb, inst.x0, us);  // hover: nothing active
  EXPECT_EQ(countActive(pb, xs, us).total(), 0);
  us[0].setZero();         // both rotors at the lower bound
  us[3][1] = 7.0;          // one at the upper bound
  xs[5][2] = 0.8;          // tilt at its upper bound
  xs[7][2] = -0.8 + 1e-7;  // within the tolerance
  xs[9][0] = 1.5 - 0.4;    // on the first keep-out disc's boundary
  xs[9][1] = 0.0;
  const ActiveSetCount n = countActive(pb, xs, us);
  EXPECT_EQ(n.input_bounds, 3);
  EXPECT_EQ(n.state_bounds, 2);
  EXPECT_EQ(n.inequalities, 1);
  xs[0][2] = 0.8;  // node 0 is fixed: not counted
  EXPECT_EQ(countActive(pb, xs, us).state_bounds, 2);
}

}  // namespace
}  // namespace rollstep::nltest
