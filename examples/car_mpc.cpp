// A complete use of the ocp and solver layers on a problem small enough to read in one
// sitting: a car (kinematic bicycle) parks 10 m ahead after driving around a round
// obstacle in its way, its speed, lateral acceleration and inputs limited.
//
//   1. Compose the optimal control problem from small terms: dynamics, least-squares
//      costs, a state-only and a state-input inequality, simple bounds.
//   2. Solve it to convergence (the offline plan, and the warm start of the MPC).
//   3. Run it as a model predictive controller: one real-time iteration per control
//      period on the measured state, the first input applied to a simulated car.
//
// Run: build/examples/car_mpc [--quiet]. Exit status 0 when the car parks within 5 cm of
// the goal, never touches the obstacle and never exceeds a limit; 1 otherwise.
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <vector>

#include "rollstep/ocp/cost.hpp"
#include "rollstep/ocp/dynamics.hpp"
#include "rollstep/ocp/problem.hpp"
#include "rollstep/ocp/residuals.hpp"
#include "rollstep/solver/solver.hpp"

namespace {

using rollstep::ocp::ConstVecRef;
using rollstep::ocp::MatRef;
using rollstep::ocp::VecRef;
using rollstep::ocp::VectorXd;
namespace ocp = rollstep::ocp;
namespace solver = rollstep::solver;

constexpr double kWheelbase = 2.5;        // [m]
constexpr double kMaxLateralAccel = 1.0;  // [m/s^2]
constexpr double kObstacleX = 5.0, kObstacleY = 0.3, kObstacleRadius = 1.0;
// The controller keeps this much more room: its constraint holds at the nodes only, and
// the path between two nodes may cut a corner.
constexpr double kSafetyMargin = 0.1;

// ---- 1. the model: x = [px, py, yaw, speed], u = [acceleration, steering angle] -------
// Continuous dynamics with analytic derivatives; RungeKutta4 discretises it (and
// differentiates through its stages).
class KinematicBicycle final : public ocp::ContinuousDynamics {
 public:
  KinematicBicycle() : ContinuousDynamics(std::make_shared<ocp::EuclideanSpace>(4), 2) {}
  std::unique_ptr<ocp::DynamicsData> createData() const override {
    return std::make_unique<ocp::DynamicsData>();
  }
  void calc(const ocp::NodeContext&, ConstVecRef x, ConstVecRef u, ocp::DynamicsData&,
            VecRef xdot) const override {
    xdot << x[3] * std::cos(x[2]), x[3] * std::sin(x[2]), x[3] * std::tan(u[1]) / kWheelbase, u[0];
  }
  void calcDiff(const ocp::NodeContext&, ConstVecRef x, ConstVecRef u, ocp::DynamicsData&,
                MatRef fx, MatRef fu) const override {
    const double c = std::cos(x[2]), s = std::sin(x[2]), t = std::tan(u[1]);
    fx.setZero();
    fu.setZero();
    fx(0, 2) = -x[3] * s;
    fx(0, 3) = c;
    fx(1, 2) = x[3] * c;
    fx(1, 3) = s;
    fx(2, 3) = t / kWheelbase;
    fu(2, 1) = x[3] * (1.0 + t * t) / kWheelbase;
    fu(3, 0) = 1.0;
  }
};

// Keep-out disc, state only: |p - centre|^2 - (radius + margin)^2 >= 0 (one row).
class OutsideDisc final : public ocp::Residual {
 public:
  OutsideDisc() : Residual(4, 2, 1) {}
  bool dependsOnInput() const override { return false; }
  void calc(const ocp::NodeContext&, ConstVecRef x, ConstVecRef,
            ocp::ResidualData& d) const override {
    const double dx = x[0] - kObstacleX, dy = x[1] - kObstacleY;
    const double keep_out = kObstacleRadius + kSafetyMargin;
    d.r[0] = dx * dx + dy * dy - keep_out * keep_out;
  }
  void calcDiff(const ocp::NodeContext&, ConstVecRef x, ConstVecRef,
                ocp::ResidualData& d) const override {
    d.Rx.row(0) << 2.0 * (x[0] - kObstacleX), 2.0 * (x[1] - kObstacleY), 0.0, 0.0;
    d.Ru.row(0).setZero();
  }
};

// Lateral acceleration v^2 tan(steer) / L within +-a_max: a state-input inequality,
// two rows a_max -+ v^2 tan(steer) / L >= 0.
class LateralAcceleration final : public ocp::Residual {
 public:
  LateralAcceleration() : Residual(4, 2, 2) {}
  static double value(ConstVecRef x, ConstVecRef u) {
    return x[3] * x[3] * std::tan(u[1]) / kWheelbase;
  }
  void calc(const ocp::NodeContext&, ConstVecRef x, ConstVecRef u,
            ocp::ResidualData& d) const override {
    const double a = value(x, u);
    d.r[0] = kMaxLateralAccel - a;
    d.r[1] = kMaxLateralAccel + a;
  }
  void calcDiff(const ocp::NodeContext&, ConstVecRef x, ConstVecRef u,
                ocp::ResidualData& d) const override {
    const double t = std::tan(u[1]);
    const double da_dv = 2.0 * x[3] * t / kWheelbase;
    const double da_ds = x[3] * x[3] * (1.0 + t * t) / kWheelbase;
    d.Rx.topRows(2).setZero();
    d.Ru.topRows(2).setZero();
    d.Rx(0, 3) = -da_dv;
    d.Rx(1, 3) = da_dv;
    d.Ru(0, 1) = -da_ds;
    d.Ru(1, 1) = da_ds;
  }
};

VectorXd vec(std::initializer_list<double> v) {
  VectorXd out(static_cast<Eigen::Index>(v.size()));
  Eigen::Index i = 0;
  for (double e : v) out[i++] = e;
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  const bool quiet = argc > 1 && std::strcmp(argv[1], "--quiet") == 0;
  const int N = 50;
  const double dt = 0.1;
  const VectorXd goal = vec({10.0, 0.0, 0.0, 0.0});
  const VectorXd start = vec({0.0, 0.0, 0.0, 0.0});
  const VectorXd input_lo = vec({-3.0, -0.5}), input_hi = vec({3.0, 0.5});
  const double inf = ocp::OptimalControlProblem::kInfinity;
  const VectorXd state_lo = vec({-inf, -inf, -inf, -0.5});  // speed only: reverse slowly,
  const VectorXd state_hi = vec({inf, inf, inf, 2.5});      // drive at most 2.5 m/s

  // ---- 1. compose the problem ------------------------------------------------------------
  auto car = std::make_shared<KinematicBicycle>();
  auto problem =
      std::make_shared<ocp::OptimalControlProblem>(std::make_shared<ocp::RungeKutta4>(car), N, dt);
  auto to_goal = std::make_shared<ocp::StateErrorResidual>(car->spacePtr(), 2, goal);
  auto effort = std::make_shared<ocp::InputErrorResidual>(4, VectorXd::Zero(2));
  problem->addCost("to_goal",
                   std::make_shared<ocp::LeastSquaresCost>(to_goal, vec({0.2, 0.2, 0.5, 0.1})));
  problem->addCost("effort", std::make_shared<ocp::LeastSquaresCost>(effort, vec({0.1, 1.0})));
  problem->addCost("parked",
                   std::make_shared<ocp::LeastSquaresCost>(to_goal, vec({100, 100, 100, 100})),
                   ocp::Stage::Terminal);
  problem->addInequality("obstacle", std::make_shared<OutsideDisc>(), ocp::Stage::All);
  problem->addInequality("lateral_acceleration", std::make_shared<LateralAcceleration>());
  problem->setInputBounds(input_lo, input_hi);
  problem->setStateBounds(state_lo, state_hi);

  // ---- 2. converging solve: the plan, from a guess that waits in place ------------------
  solver::SolverSettings settings;  // Converging mode by default
  solver::Solver nmpc(problem, settings);
  nmpc.setInitialGuess(std::vector<VectorXd>(N + 1, start),
                       std::vector<VectorXd>(N, VectorXd::Zero(2)));
  const solver::SolverStatus status = nmpc.solve(start);
  const solver::IterationStats& last = nmpc.stats().back();
  std::printf("plan: %s after %d iterations, cost %.6f, KKT residuals primal %.1e dual %.1e\n",
              solver::toString(status), nmpc.iterations(), nmpc.cost(), last.primal_residual,
              last.dual_residual);
  if (status != solver::SolverStatus::Converged) return 1;

  // ---- 3. MPC: one real-time iteration per period, first input to a simulated car --------
  // The simulated car integrates the same continuous model with 10 RK4 substeps per
  // period (finer than the controller's model).
  auto sim_data = car->createData();
  const auto simulate = [&](VectorXd& x, const VectorXd& u) {
    const int substeps = 10;
    const double h = dt / substeps;
    ocp::NodeContext ctx;
    VectorXd k1(4), k2(4), k3(4), k4(4);
    for (int i = 0; i < substeps; ++i) {
      car->calc(ctx, x, u, *sim_data, k1);
      car->calc(ctx, x + 0.5 * h * k1, u, *sim_data, k2);
      car->calc(ctx, x + 0.5 * h * k2, u, *sim_data, k3);
      car->calc(ctx, x + h * k3, u, *sim_data, k4);
      x += (h / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
    }
  };
  VectorXd x = start;
  double min_clearance = 1e9, max_lateral = 0.0, max_rti_ms = 0.0;
  bool limits_ok = true;
  if (!quiet)
    std::printf("%6s %8s %8s %8s %8s %8s %8s %10s\n", "t [s]", "px", "py", "yaw", "speed", "accel",
                "steer", "rti [ms]");
  for (int step = 0; step <= 150; ++step) {
    const double t = step * dt;
    const solver::SolverStatus s = nmpc.update(t, x);  // shift, then one Newton step
    if (s != solver::SolverStatus::IterationDone) {
      std::printf("MPC: real-time iteration failed at t = %.1f s: %s (%s)\n", t,
                  solver::toString(s), nmpc.message());
      return 1;
    }
    const VectorXd u = nmpc.inputs()[0];
    const auto& it = nmpc.stats().back();
    max_rti_ms =
        std::max(max_rti_ms, it.time_linearize_ms + it.time_riccati_ms + it.time_update_ms);
    if (!quiet && step % 10 == 0) {
      std::printf("%6.1f %8.3f %8.3f %8.3f %8.3f %8.3f %8.3f %10.3f\n", t, x[0], x[1], x[2], x[3],
                  u[0], u[1], it.time_linearize_ms + it.time_riccati_ms + it.time_update_ms);
    }
    limits_ok = limits_ok && (u.array() >= input_lo.array() - 1e-9).all() &&
                (u.array() <= input_hi.array() + 1e-9).all() && x[3] >= state_lo[3] - 1e-3 &&
                x[3] <= state_hi[3] + 1e-3;
    max_lateral = std::max(max_lateral, std::abs(LateralAcceleration::value(x, u)));
    simulate(x, u);
    min_clearance =
        std::min(min_clearance, std::hypot(x[0] - kObstacleX, x[1] - kObstacleY) - kObstacleRadius);
  }
  const double miss = (x.head<2>() - goal.head<2>()).norm();
  std::printf(
      "MPC: parked %.3f m from the goal at %.3f m/s; closest approach to the obstacle "
      "%.3f m; max |lateral acceleration| %.2f m/s^2 (limit %.1f); slowest real-time "
      "iteration %.3f ms\n",
      miss, x[3], min_clearance, max_lateral, kMaxLateralAccel, max_rti_ms);
  const bool ok = miss < 0.05 && std::abs(x[3]) < 0.05 && min_clearance > 0.0 && limits_ok &&
                  max_lateral <= kMaxLateralAccel + 1e-3;
  std::printf("%s\n", ok ? "car_mpc: OK" : "car_mpc: FAILED");
  return ok ? 0 : 1;
}
