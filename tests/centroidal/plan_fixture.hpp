#pragma once
// Shared by the proof tests of issue 11 (plan_test.cpp, plan_step_test.cpp): the Tachyon 3
// OCP built by CentroidalOcp, solved in converging mode from a cold start (the standing
// posture along the base reference), with convergence and every constraint group checked.
#include <gtest/gtest.h>

#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "rollstep/centroidal/centroidal_ocp.hpp"
#include "rollstep/solver/solver.hpp"

namespace rollstep::centroidal::test {

/// Every constraint group must hold to this at the solution.
constexpr double kConstraintTolerance = 1e-4;

inline RobotOcpDescription tachyon3Description() {
  return loadRobotOcpDescription(std::string(ROLLSTEP_ROBOTS_DIR) + "/tachyon3/centroidal.yaml");
}

/// Solves from the cold start and checks convergence and every constraint group.
inline void solveAndCheck(CentroidalOcp& ocp, solver::Solver& s, const Eigen::VectorXd& x0) {
  std::vector<Eigen::VectorXd> xs, us;
  ocp.initialGuess(xs, us);
  xs[0] = x0;
  s.setInitialGuess(xs, us);
  const solver::SolverStatus status = s.solve(x0);
  ASSERT_FALSE(s.stats().empty());
  std::printf("status %s after %d iterations, KKT error %.2e\n",
              status == solver::SolverStatus::Converged ? "Converged" : s.message(), s.iterations(),
              s.stats().back().kkt_error);
  // Converged (KKT error below kkt_tolerance, 1e-8), or stopped where the line search
  // finds no better point within acceptable_tolerance (1e-6): the step-down plan ends at
  // 6e-8 in the AddressSanitizer build (-O1) and at 7e-9 in Release, the rounding differs.
  EXPECT_TRUE(status == solver::SolverStatus::Converged ||
              status == solver::SolverStatus::Acceptable)
      << s.message();
  EXPECT_LE(s.stats().back().kkt_error, s.settings().acceptable_tolerance);
  for (const ConstraintViolation& v :
       constraintViolations(*ocp.problem(), s.states(), s.inputs())) {
    EXPECT_LE(v.value, kConstraintTolerance) << v.group << " at node " << v.node;
  }
}

/// The OCP settings without the climbing rules and the speed rule (the values the library
/// had before they became its defaults): level costs, a fixed 0.8 s trot, mid-swing apex,
/// no body-height ramp, no gap rule, no waits at edges, no late touch-downs, one
/// iteration per real-time update. For the plans written for that OCP (the paper's).
inline OcpSettings withoutClimbingRules() {
  OcpSettings s;
  s.base_velocity_weight << 10, 10, 10, 5, 5, 5;
  s.base_position_weight = Eigen::Vector3d(100, 100, 200);
  s.joint_position_weight = 20;
  s.swing_height_max_correction = 0;
  s.joint_limit_margin = 0;
  s.swing_clearance = 0.04;
  s.swing_apex_margin = 0.5;
  s.base_height_reach = 0;
  s.base_height_slope = 0;
  s.base_height_rate = false;
  s.late_touchdown_tolerance = 0;
  s.foothold_gap_reach = 0;
  s.step_down_max_hold = 0;
  s.step_up_max_hold = 0;
  s.gait_period = 0.8;
  s.speed_adaptation = false;
  s.solver.realtime_iterations = 1;
  return s;
}

/// One solved plan: the OCP on `terrain` with `gait` and forward command vx, from the
/// standing posture at x = x_start.
struct PlanRun {
  RobotOcpDescription robot = tachyon3Description();
  OcpSettings settings;
  std::unique_ptr<CentroidalOcp> ocp;
  std::unique_ptr<solver::Solver> solver;

  PlanRun(planning::TerrainModel terrain, planning::GaitKind gait, double vx, double x_start = 0.0,
          const OcpSettings& custom = OcpSettings{})
      : settings(custom) {
    ocp = std::make_unique<CentroidalOcp>(robot, settings, std::move(terrain), gait);
    lie::SE3 start = lie::SE3::Identity();
    start.translation.x() = x_start;
    ocp->reset(0.0, start, planning::BaseVelocityCommand{vx, 0.0, 0.0});
    solver = std::make_unique<solver::Solver>(ocp->problem(), settings.solver);
    solveAndCheck(*ocp, *solver, ocp->standingState(x_start, 0.0, 0.0));
  }
  const Eigen::VectorXd& x(int k) const { return solver->states()[static_cast<std::size_t>(k)]; }
  const Eigen::VectorXd& u(int k) const { return solver->inputs()[static_cast<std::size_t>(k)]; }
  int N() const { return ocp->problem()->horizon(); }
  int mode(int k) const { return ocp->problem()->context(k).mode; }
  double force(int k, int foot, int axis) const {
    return u(k)[ocp->robot().inputForceIndex(foot) + axis];
  }
};

}  // namespace rollstep::centroidal::test
