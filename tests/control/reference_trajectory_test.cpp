// Time-lag refinement (ReferenceTrajectory) and the internal state integrator.
#include "rollstep/control/reference_trajectory.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "centroidal/fd_check.hpp"
#include "common/alloc_counter.hpp"
#include "rollstep/control/state_integrator.hpp"
#include "rollstep/model/kinematics.hpp"

namespace rollstep::control {
namespace {

using centroidal::test::nominalState;
using centroidal::test::tachyon3Robot;

/// A hand-made solution: N nodes of dt, inputs that move the joints and push the body.
MpcSolution makeSolution(const centroidal::CentroidalRobot& robot, int N, double dt, double t0,
                         unsigned seed) {
  std::srand(seed);
  MpcSolution s;
  s.sequence = 1;
  s.t0 = t0;
  s.dt = dt;
  s.status = solver::SolverStatus::IterationDone;
  const Eigen::VectorXd x0 = nominalState(robot);
  s.xs.assign(static_cast<size_t>(N + 1), x0);
  s.modes.assign(static_cast<size_t>(N + 1), 63);
  for (int k = 0; k < N; ++k) {
    Eigen::VectorXd u = Eigen::VectorXd::Zero(robot.nu());
    u.head(robot.nj()) = 0.2 * Eigen::VectorXd::Random(robot.nj());
    for (int i = 0; i < robot.nc(); ++i) {
      u.segment<3>(robot.inputForceIndex(i)) =
          Eigen::Vector3d(5.0 * std::sin(k * 0.3), 2.0, robot.mass() * 9.81 / robot.nc() + 3.0);
    }
    s.us.push_back(u);
  }
  return s;
}

// With one substep and the solution's own start, the refined states are the explicit-Euler
// rollout of the inputs: the solution's states when they are dynamically consistent.
TEST(ReferenceTrajectory, RolloutFromTheLatestStateFollowsTheStateEquation) {
  const auto robot = tachyon3Robot();
  auto pre = std::make_shared<const centroidal::CentroidalPrecomputation>(robot);
  const int N = 20;
  const double dt = 0.015;
  MpcSolution s = makeSolution(*robot, N, dt, 1.0, 3);
  RefinementSettings rs;
  rs.horizon = 0.1;
  ReferenceTrajectory ref(pre, rs, N);
  Eigen::VectorXd x_now = nominalState(*robot);
  x_now[2] += 0.01;                  // the latest state differs from the solution's x_0
  x_now.tail<6>()[0] = 0.5;          // moving forward
  const double t_now = 1.0 + 0.004;  // 4 ms after the solution's start
  ASSERT_TRUE(ref.refine(s, t_now, x_now));
  EXPECT_EQ(ref.refinedState(0), x_now);
  EXPECT_GE(ref.refinedUntil(), t_now + rs.horizon - 1e-12);

  // Independent rollout with the OCP's dynamics, input held per solution node.
  centroidal::CentroidalDynamics f(pre);
  auto data = f.createData();
  Eigen::VectorXd x = x_now, xdot(robot->ndx()), next(robot->nx());
  for (int j = 0; j + 1 < ref.refinedNodes(); ++j) {
    const double t = t_now + j * dt;
    const int k = std::min(N - 1, static_cast<int>(std::floor((t - 1.0) / dt + 1e-9)));
    ocp::NodeContext ctx;
    f.calc(ctx, x, s.us[static_cast<size_t>(k)], *data, xdot);
    robot->space()->integrate(x, dt * xdot, next);
    x = next;
    EXPECT_LT((x - ref.refinedState(j + 1)).lpNorm<Eigen::Infinity>(), 1e-12) << "node " << j + 1;
  }

  // Sampling: positions interpolate, the acceleration is the node velocity difference.
  ReferenceSample a = ref.makeSample(), b = ref.makeSample(), mid = ref.makeSample();
  ref.sample(t_now, a);
  ref.sample(t_now + dt, b);
  ref.sample(t_now + 0.5 * dt, mid);
  EXPECT_LT((a.q - x_now.head(robot->nq())).norm(), 1e-12);
  EXPECT_LT((mid.a - (b.v - a.v) / dt).norm(), 1e-9 * (1.0 + mid.a.norm()));
  EXPECT_LT((mid.foot_position - 0.5 * (a.foot_position + b.foot_position)).norm(), 1e-12);
  EXPECT_LT((mid.q.head<3>() - 0.5 * (a.q.head<3>() + b.q.head<3>())).norm(), 1e-4);

  // The joint velocities of the reference are the solution's inputs at that time.
  const int k0 = static_cast<int>(std::floor((t_now - 1.0) / dt));
  EXPECT_LT((a.v.tail(robot->nj()) - s.us[static_cast<size_t>(k0)].head(robot->nj())).norm(),
            1e-12);

  // Lazy extension to the end of the horizon, then held at rest beyond it.
  ReferenceSample late = ref.makeSample();
  ref.sample(1.0 + N * dt + 0.5, late);
  EXPECT_EQ(late.v.norm(), 0.0);
  EXPECT_EQ(late.a.norm(), 0.0);
  EXPECT_GE(ref.refinedUntil(), 1.0 + N * dt - dt - 1e-9);
  EXPECT_TRUE(late.q.allFinite());
}

TEST(ReferenceTrajectory, RejectsWhatDoesNotFitAndKeepsThePreviousReference) {
  const auto robot = tachyon3Robot();
  auto pre = std::make_shared<const centroidal::CentroidalPrecomputation>(robot);
  ReferenceTrajectory ref(pre, RefinementSettings{}, 10);
  MpcSolution s = makeSolution(*robot, 10, 0.015, 0.0, 1);
  const Eigen::VectorXd x = nominalState(*robot);
  EXPECT_FALSE(ref.hasReference());
  ASSERT_TRUE(ref.refine(s, 0.0, x));
  MpcSolution wrong = makeSolution(*robot, 12, 0.015, 0.0, 1);
  EXPECT_FALSE(ref.refine(wrong, 0.01, x));
  MpcSolution nan = s;
  nan.us[3][0] = std::nan("");
  EXPECT_FALSE(ref.refine(nan, 0.01, x));
  Eigen::VectorXd x_nan = x;
  x_nan[0] = std::nan("");
  EXPECT_FALSE(ref.refine(s, 0.01, x_nan));
  EXPECT_TRUE(ref.hasReference());
  EXPECT_EQ(ref.startTime(), 0.0);
  EXPECT_THROW(ReferenceTrajectory(pre, RefinementSettings{}, 0), std::invalid_argument);
  RefinementSettings bad;
  bad.substeps = 0;
  EXPECT_THROW(ReferenceTrajectory(pre, bad, 10), std::invalid_argument);
}

TEST(ReferenceTrajectory, RefineAndSampleDoNotAllocate) {
  const auto robot = tachyon3Robot();
  auto pre = std::make_shared<const centroidal::CentroidalPrecomputation>(robot);
  RefinementSettings rs;
  rs.substeps = 3;
  ReferenceTrajectory ref(pre, rs, 30);
  const MpcSolution s = makeSolution(*robot, 30, 0.015, 0.0, 2);
  const Eigen::VectorXd x = nominalState(*robot);
  ReferenceSample out = ref.makeSample();
  ASSERT_TRUE(ref.refine(s, 0.0, x));
  ref.sample(0.01, out);
  test::AllocationGuard guard;
  for (int i = 0; i < 20; ++i) {
    ref.refine(s, 0.001 * i, x);
    for (int k = 0; k < 30; ++k) ref.sample(0.001 * i + 0.017 * k, out);
  }
  EXPECT_EQ(guard.count(), 0u);
}

TEST(StateIntegrator, NaiveIntegratesOpenLoopInternalBlendsTheMeasurementIn) {
  const auto robot = tachyon3Robot();
  const auto model = robot->modelPtr();
  const double dt = 0.001;
  Eigen::VectorXd q0 = nominalState(*robot).head(robot->nq());
  Eigen::VectorXd v0 = Eigen::VectorXd::Zero(robot->nv());
  Eigen::VectorXd a = Eigen::VectorXd::Random(robot->nv());
  Eigen::VectorXd q_meas = q0, v_meas = Eigen::VectorXd::Random(robot->nv());
  q_meas[0] += 0.01;
  q_meas.tail(robot->nj()).array() += 0.002;

  // Naive: the measurement is not blended in; v = v0 + dt a, q = q0 (+) dt v.
  IntegratorSettings naive;
  naive.mode = IntegratorMode::Naive;
  StateIntegrator n(model, naive, dt);
  n.reset(q0, v0);
  n.step(a, q_meas, v_meas);
  const Eigen::VectorXd v_expect = v0 + dt * a;
  Eigen::VectorXd q_expect(robot->nq());
  model::integrate(*model, q0, dt * v_expect, q_expect);
  EXPECT_LT((n.v() - v_expect).norm(), 1e-14);
  EXPECT_LT((n.q() - q_expect).norm(), 1e-14);

  IntegratorSettings internal;
  internal.position_time_constant = 0.1;
  internal.velocity_time_constant = 0.02;
  StateIntegrator s(model, internal, dt);
  s.reset(q0, v0);
  s.step(Eigen::VectorXd::Zero(robot->nv()), q_meas, v_meas);
  // The velocity moves dt / tau of the way; the joints dt / tau_q of the way, then dt v.
  EXPECT_LT((s.v() - (dt / 0.02) * v_meas).norm(), 1e-14);
  const Eigen::VectorXd joints = q0.tail(robot->nj()) +
                                 (dt / 0.1) * (q_meas - q0).tail(robot->nj()) +
                                 dt * s.v().tail(robot->nj());
  EXPECT_LT((s.q().tail(robot->nj()) - joints).norm(), 1e-14);

  // Held measurement: converges to it (exponentially); a NaN acceleration is ignored.
  Eigen::VectorXd nan_a = Eigen::VectorXd::Zero(robot->nv());
  nan_a[0] = std::nan("");
  const Eigen::VectorXd v_rest = Eigen::VectorXd::Zero(robot->nv());
  for (int k = 0; k < 3000; ++k) s.step(k % 2 ? nan_a : v_rest, q_meas, v_rest);
  Eigen::VectorXd err(robot->nv());
  model::difference(*model, s.q(), q_meas, err);
  EXPECT_LT(err.norm(), 1e-8);
  EXPECT_TRUE(s.q().allFinite());

  test::AllocationGuard guard;
  for (int k = 0; k < 100; ++k) s.step(a, q_meas, v_meas);
  EXPECT_EQ(guard.count(), 0u);
  EXPECT_THROW(StateIntegrator(model, internal, 0.0), std::invalid_argument);
}

}  // namespace
}  // namespace rollstep::control
