#pragma once
// The centroidal terms of this layer assembled into an ocp::OptimalControlProblem for
// Tachyon 3 (dynamics, equalities, costs; no inequalities), with test weights. Shared by
// the problem test and bench/centroidal.
#include <string>

#include "centroidal/fd_check.hpp"
#include "rollstep/centroidal/contact_equalities.hpp"
#include "rollstep/centroidal/costs.hpp"
#include "rollstep/centroidal/dynamics.hpp"
#include "rollstep/centroidal/swing_height.hpp"
#include "rollstep/ocp/problem.hpp"

namespace rollstep::centroidal::test {

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

/// x0 = nominal standing state; initial guess: x0 everywhere, weight / 6 on each wheel.
inline void nominalGuess(const CentroidalRobot& robot, int horizon,
                         std::vector<Eigen::VectorXd>& xs, std::vector<Eigen::VectorXd>& us) {
  const Eigen::VectorXd x0 = nominalState(robot);
  xs.assign(static_cast<size_t>(horizon + 1), x0);
  Eigen::VectorXd u0 = Eigen::VectorXd::Zero(robot.nu());
  for (int i = 0; i < robot.nc(); ++i) {
    u0[robot.inputForceIndex(i) + 2] = robot.mass() * 9.81 / robot.nc();
  }
  us.assign(static_cast<size_t>(horizon), u0);
}

}  // namespace rollstep::centroidal::test
