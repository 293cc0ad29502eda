// Real-time iteration closed loops (issue 4): the "true" system is simulated with a finer
// integrator from the first input of the MPC solution; update(t, x) is called every step
// (shift + one Newton iteration). The loop must reach the target and every constraint
// must hold at every step.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "nonlinear_problems.hpp"
#include "rollstep/solver/solver.hpp"

namespace rollstep::nltest {
namespace {

using solver::Solver;
using solver::SolverMode;
using solver::SolverSettings;
using solver::SolverStatus;

/// One step of the true system: RK4 with `substeps` sub-steps (tangent velocity added in
/// the state space, so it works on manifolds too), zero-order hold on u.
VectorXd simulate(const ocp::ContinuousDynamics& f, const VectorXd& x, ConstVecRef u, double dt,
                  int substeps) {
  const auto& space = f.space();
  auto d = f.createData();
  ocp::NodeContext ctx;
  const double h = dt / substeps;
  VectorXd xk = x, k1(space.ndx()), k2(space.ndx()), k3(space.ndx()), k4(space.ndx()),
           tmp(space.nx());
  for (int i = 0; i < substeps; ++i) {
    f.calc(ctx, xk, u, *d, k1);
    space.integrate(xk, 0.5 * h * k1, tmp);
    f.calc(ctx, tmp, u, *d, k2);
    space.integrate(xk, 0.5 * h * k2, tmp);
    f.calc(ctx, tmp, u, *d, k3);
    space.integrate(xk, h * k3, tmp);
    f.calc(ctx, tmp, u, *d, k4);
    space.integrate(xk, h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4), tmp);
    xk = tmp;
  }
  return xk;
}

bool allFinite(const std::vector<VectorXd>& v) {
  for (const auto& x : v)
    if (!x.allFinite()) return false;
  return true;
}

TEST(NonlinearRealTime, UnicycleClosedLoopAvoidsObstaclesAndReachesGoal) {
  UnicycleOptions o;
  o.horizon = 40;  // 4 s preview
  o.hard_obstacles = {{1.5, -0.15, 0.4}, {3.0, 0.35, 0.3}};
  const auto inst = makeUnicycle(o);
  const double dt = inst.problem->dt();
  UnicycleDynamics truth;
  SpeedProfileResidual profile(o.speed_gain, o.cruise_speed, o.goal_x, o.goal_y);

  // Warm start: a few converging iterations, then real-time iterations.
  SolverSettings conv;
  conv.max_iterations = 30;
  Solver s(inst.problem, conv);
  s.setInitialGuess(inst.xs_guess, inst.us_guess);
  const SolverStatus st0 = s.solve(inst.x0);
  ASSERT_NE(st0, SolverStatus::InvalidInput);
  ASSERT_NE(st0, SolverStatus::Diverged) << s.message();
  SolverSettings rt = s.settings();
  rt.mode = SolverMode::RealTime;
  s.setSettings(rt);

  VectorXd x = inst.x0;
  double t = 0.0, min_clearance = 1e9, max_eq = 0.0, max_bound = 0.0;
  const int steps = 150;
  for (int i = 0; i < steps; ++i) {
    const SolverStatus st = s.update(t, x);
    ASSERT_EQ(st, SolverStatus::IterationDone) << "step " << i << ": " << s.message();
    ASSERT_TRUE(allFinite(s.states()) && allFinite(s.inputs())) << "step " << i;
    const Eigen::Vector2d u = s.inputs()[0];
    // Input bounds and the speed profile (state-input equality) at the applied input.
    max_bound =
        std::max({max_bound, std::abs(u[0]) - o.speed_limit, std::abs(u[1]) - o.turn_rate_limit});
    max_eq = std::max(max_eq, std::abs(u[0] - profile.speed(x)));
    x = simulate(truth, x, u, dt, 10);
    t += dt;
    for (const Circle& c : o.hard_obstacles)
      min_clearance = std::min(min_clearance, std::hypot(x[0] - c.cx, x[1] - c.cy) - c.radius);
  }
  const double dist = std::hypot(x[0] - o.goal_x, x[1] - o.goal_y);
  std::printf(
      "[rti unicycle] final distance %.3e, min clearance %.3e, max |e| %.2e, "
      "max bound violation %.2e\n",
      dist, min_clearance, max_eq, max_bound);
  EXPECT_LT(dist, 0.02);
  EXPECT_GT(min_clearance, 0.0);
  EXPECT_LE(max_bound, 1e-9);
  // The applied input meets the speed profile up to the second-order term of the
  // equality's state dependence (one Newton step from the shifted guess, x_0 changed).
  EXPECT_LT(max_eq, 1e-3);
}

TEST(NonlinearRealTime, RigidBodyClosedLoopReachesTargetPose) {
  RigidBodyOptions o;
  o.horizon = 30;
  const auto inst = makeRigidBody(o);
  const double dt = inst.problem->dt();
  RigidBodyDynamics truth(o.params);
  const auto& space = inst.problem->stateSpace();

  SolverSettings rt;
  rt.mode = SolverMode::RealTime;
  Solver s(inst.problem, rt);
  s.setInitialGuess(inst.xs_guess, inst.us_guess);
  VectorXd x = inst.x0;
  double t = 0.0, max_bound = 0.0;
  VectorXd err(space.ndx());
  for (int i = 0; i < 120; ++i) {
    const SolverStatus st = s.update(t, x);
    ASSERT_EQ(st, SolverStatus::IterationDone) << "step " << i << ": " << s.message();
    ASSERT_TRUE(allFinite(s.states()) && allFinite(s.inputs())) << "step " << i;
    const Eigen::Matrix<double, 6, 1> u = s.inputs()[0];
    max_bound = std::max({max_bound, u.head<3>().lpNorm<Eigen::Infinity>() - o.force_limit,
                          u.tail<3>().lpNorm<Eigen::Infinity>() - o.torque_limit});
    x = simulate(truth, x, u, dt, 10);
    t += dt;
  }
  space.difference(inst.x_goal, x, err);
  std::printf("[rti rigid body] final pose error %.3e, twist %.3e, max bound violation %.2e\n",
              err.head(6).lpNorm<Eigen::Infinity>(), err.tail(6).lpNorm<Eigen::Infinity>(),
              max_bound);
  EXPECT_LT(err.head(6).lpNorm<Eigen::Infinity>(), 1e-2);
  EXPECT_LT(err.tail(6).lpNorm<Eigen::Infinity>(), 1e-2);
  EXPECT_LE(max_bound, 1e-9);
  EXPECT_NEAR(x.segment<4>(3).norm(), 1.0, 1e-9);
}

}  // namespace
}  // namespace rollstep::nltest
