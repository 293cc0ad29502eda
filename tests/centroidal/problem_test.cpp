// The centroidal terms assembled into an ocp::OptimalControlProblem and solved by the
// interior-point solver: standing still and a short trot converge, with the equalities
// satisfied (no inequalities here: those are tested with their own terms).
#include <gtest/gtest.h>

#include <iostream>

#include "centroidal/fd_check.hpp"
#include "rollstep/centroidal/costs.hpp"
#include "rollstep/centroidal/dynamics.hpp"
#include "rollstep/centroidal/equalities.hpp"
#include "rollstep/solver/solver.hpp"

namespace rollstep::centroidal::test {
namespace {

struct Assembly {
  std::shared_ptr<const CentroidalRobot> robot = tachyon3Robot();
  std::shared_ptr<const CentroidalPrecomputation> pre =
      std::make_shared<const CentroidalPrecomputation>(robot);
  Tachyon3Scene scene;
  std::shared_ptr<ocp::OptimalControlProblem> problem;

  Assembly(const std::string& gait, double speed, int horizon)
      : scene(makeTachyon3Scene(gait, speed)) {
    auto f = std::make_shared<const CentroidalDynamics>(pre);
    problem = std::make_shared<ocp::OptimalControlProblem>(
        std::make_shared<const ocp::ExplicitEuler>(f), horizon, 0.015,
        scene.scheduler->requiredCapacity());
    problem->setPrecomputation(pre);
    const int nj = robot->nj(), nu = robot->nu();
    const Eigen::VectorXd q_j_ref = nominalState(*robot).segment(7, nj);
    Eigen::VectorXd w_state(robot->ndx());
    w_state << Eigen::VectorXd::Constant(6, 50.0), Eigen::VectorXd::Constant(nj, 5.0),
        Eigen::VectorXd::Constant(6, 1e-3);
    Eigen::VectorXd w_input(nu);
    w_input << Eigen::VectorXd::Constant(nj, 0.1), Eigen::VectorXd::Constant(nu - nj, 1e-4);
    problem->addCost("base_velocity",
                     std::make_shared<const ocp::LeastSquaresCost>(
                         std::make_shared<const BaseVelocityResidual>(pre, scene.base),
                         Eigen::VectorXd::Constant(6, 5.0)));
    problem->addCost(
        "state",
        std::make_shared<const ocp::LeastSquaresCost>(
            std::make_shared<const StateTrackingResidual>(robot, q_j_ref, scene.base), w_state),
        ocp::Stage::All);
    problem->addCost("input", std::make_shared<const ocp::LeastSquaresCost>(
                                  std::make_shared<const InputTrackingResidual>(robot), w_input));
    problem->addEquality("swing_force", std::make_shared<const SwingForceResidual>(robot));
    problem->addEquality("stance_velocity", std::make_shared<const StanceVelocityResidual>(pre));
    problem->addEquality("swing_height",
                         std::make_shared<const SwingHeightResidual>(pre, scene.feet, 10.0));
    scene.scheduler->fill(0.0, horizon * 0.015, problem->modeSchedule());
  }
};

solver::SolverStatus solveFromNominal(Assembly& a, solver::Solver& s) {
  const Eigen::VectorXd x0 = nominalState(*a.robot);
  const int n = a.problem->horizon();
  std::vector<Eigen::VectorXd> xs(static_cast<size_t>(n + 1), x0);
  Eigen::VectorXd u0 = Eigen::VectorXd::Zero(a.robot->nu());
  for (int i = 0; i < 6; ++i) u0[a.robot->inputForceIndex(i) + 2] = a.robot->mass() * 9.81 / 6;
  std::vector<Eigen::VectorXd> us(static_cast<size_t>(n), u0);
  s.setInitialGuess(xs, us);
  return s.solve(x0);
}

TEST(CentroidalProblem, StandingStillConverges) {
  Assembly a("stand", 0.0, 20);
  solver::Solver s(a.problem);
  const auto status = solveFromNominal(a, s);
  EXPECT_EQ(status, solver::SolverStatus::Converged) << s.message();
  // Stays put, carrying the weight on the six wheels.
  for (int k = 0; k < 20; ++k) {
    const Eigen::VectorXd& u = s.inputs()[static_cast<size_t>(k)];
    double fz = 0.0;
    for (int i = 0; i < 6; ++i) fz += u[a.robot->inputForceIndex(i) + 2];
    EXPECT_NEAR(fz, a.robot->mass() * 9.81, 1e-3 * a.robot->mass() * 9.81) << k;
  }
  EXPECT_LT((s.states().back().head(3) - nominalState(*a.robot).head(3)).norm(), 1e-3);
}

TEST(CentroidalProblem, ShortTrotConvergesWithTheEqualitiesSatisfied) {
  Assembly a("trot", 0.3, 40);
  solver::SolverSettings settings;
  settings.max_iterations = 200;
  solver::Solver s(a.problem, settings);
  const auto status = solveFromNominal(a, s);
  EXPECT_TRUE(status == solver::SolverStatus::Converged ||
              status == solver::SolverStatus::Acceptable)
      << solver::toString(status) << ": " << s.message();
  std::cout << "trot N=40: " << solver::toString(status) << " in " << s.iterations()
            << " iterations\n";
  // Swing feet carry nothing, stance wheels do not sink.
  auto ev = a.problem->createNodeData();
  for (int k = 0; k < 40; ++k) {
    a.problem->evaluate(k, s.states()[static_cast<size_t>(k)], s.inputs()[static_cast<size_t>(k)],
                        *ev);
    const int mode = a.problem->context(k).mode;
    const Eigen::VectorXd& u = s.inputs()[static_cast<size_t>(k)];
    for (int i = 0; i < 6; ++i) {
      if (!CentroidalRobot::inStance(mode, i)) {
        EXPECT_LT(u.segment<3>(a.robot->inputForceIndex(i)).norm(), 1e-6) << k;
      }
    }
  }
  // The base moved forward at about the commanded 0.3 m/s (h_lin ~ m v mid-horizon; the
  // terminal cost's h = 0 reference slows it down at the end of the horizon).
  EXPECT_GT(s.states().back()[0], 0.1);
  EXPECT_NEAR(s.states()[16][a.robot->stateMomentumIndex()] / a.robot->mass(), 0.3, 0.1);
}

}  // namespace
}  // namespace rollstep::centroidal::test
