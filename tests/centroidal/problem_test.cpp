// The centroidal terms assembled into an ocp::OptimalControlProblem and solved by the
// interior-point solver: standing still and a short trot converge, with the equalities
// satisfied (no inequalities here: those are tested with their own terms).
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <memory>
#include <set>
#include <string>

#include "centroidal/assembly.hpp"
#include "centroidal/plan_fixture.hpp"
#include "rollstep/solver/solver.hpp"

namespace rollstep::centroidal::test {
namespace {

solver::SolverStatus solveFromNominal(Assembly& a, solver::Solver& s) {
  std::vector<Eigen::VectorXd> xs, us;
  nominalGuess(*a.robot, a.problem->horizon(), xs, us);
  s.setInitialGuess(xs, us);
  return s.solve(xs[0]);
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
  // Gauss-Newton, as the OCP's defaults (config/ocp.yaml): the exact Hessian's differences
  // of 54 gradient columns per node took 45 s in the AddressSanitizer tree.
  settings.exact_hessian = false;
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

// SolverSettings::huge_pages is advice to the kernel about the solver's memory: the
// iterates must be bit for bit those of a solver without it (N = 100, a span of memory
// above the 4 MB below which the advice is skipped).
TEST(CentroidalProblem, HugePageAdviceLeavesEveryIterateAsItWas) {
  Assembly a("trot", 0.15, 100);
  std::vector<Eigen::VectorXd> xs, us;
  nominalGuess(*a.robot, a.problem->horizon(), xs, us);
  std::vector<std::vector<Eigen::VectorXd>> states, inputs;
  for (const bool huge : {true, false}) {
    solver::SolverSettings settings;
    settings.max_iterations = 4;
    settings.exact_hessian = false;
    settings.huge_pages = huge;
    solver::Solver s(a.problem, settings);
    s.setInitialGuess(xs, us);
    s.solve(xs[0]);
    states.push_back(s.states());
    inputs.push_back(s.inputs());
  }
  for (std::size_t k = 0; k < states[0].size(); ++k) EXPECT_EQ(states[0][k], states[1][k]) << k;
  for (std::size_t k = 0; k < inputs[0].size(); ++k) EXPECT_EQ(inputs[0][k], inputs[1][k]) << k;
}

// Nodes that one thread linearises in turn share their terms' workspaces and cache (the
// solver gives each thread's nodes one set): every value and derivative must be bit for
// bit that of a node with workspaces of its own, whichever node (stance or swing, running
// or terminal) the shared ones served before. The OCP of `rollstep plan`: every term.
// Which rows are relaxed-barrier rows: none by default; soft_region_constraints the stance
// and swing region rows alone (the joint position bounds stay hard); soft_state_constraints
// both.
TEST(CentroidalProblem, SoftRegionConstraintsRelaxTheFootholdRowsAlone) {
  const RobotOcpDescription robot = test::tachyon3Description();
  struct Case {
    bool state, region, regions_soft, bounds_soft;
  };
  for (const Case c : {Case{false, false, false, false}, Case{false, true, true, false},
                       Case{true, false, true, true}, Case{true, true, true, true}}) {
    OcpSettings settings;
    settings.horizon = 30;
    settings.soft_state_constraints = c.state;
    settings.soft_region_constraints = c.region;
    CentroidalOcp ocp(robot, settings,
                      planning::terrainFromBoxes({-20, 20, -5, 5, 0}, 0.0, {{0.1, 2, -5, 5, 0.2}}),
                      planning::GaitKind::Trot);
    ocp.reset(0.0, lie::SE3::Identity(), planning::BaseVelocityCommand{0.3, 0.0, 0.0});
    const ocp::OptimalControlProblem& p = *ocp.problem();
    EXPECT_EQ(p.stateBounds().options.soft, c.bounds_soft);
    std::vector<Eigen::VectorXd> xs, us;
    ocp.initialGuess(xs, us);
    auto data = p.createNodeData();
    int region_rows = 0, other_rows = 0;
    for (int k = 1; k < p.horizon(); ++k) {
      p.evaluate(k, xs[static_cast<std::size_t>(k)], us[static_cast<std::size_t>(k)], *data);
      int offset = 0;
      for (std::size_t j = 0; j < data->inequality_data.size(); ++j) {
        const int rows = data->inequality_data[j]->rows;
        const std::string& name = p.inequalityNames()[j];
        const bool region = name == "stance_region" || name == "swing_region";
        for (int i = offset; i < offset + rows; ++i) {
          EXPECT_EQ(data->soft[i], region && c.regions_soft) << name << " node " << k;
          ++(region ? region_rows : other_rows);
        }
        offset += rows;
      }
    }
    EXPECT_GT(region_rows, 0);
    EXPECT_GT(other_rows, 0);
  }
}

TEST(CentroidalProblem, NodesSharingWorkspacesLinearizeAsWithTheirOwn) {
  const RobotOcpDescription robot = test::tachyon3Description();
  OcpSettings settings;
  settings.horizon = 40;
  CentroidalOcp ocp(robot, settings,
                    planning::terrainFromBoxes({-20, 20, -5, 5, 0}, 0.0, {{0.1, 2, -5, 5, 0.2}}),
                    planning::GaitKind::Trot);
  ocp.reset(0.0, lie::SE3::Identity(), planning::BaseVelocityCommand{0.3, 0.0, 0.0});
  const ocp::OptimalControlProblem& p = *ocp.problem();
  std::vector<Eigen::VectorXd> xs, us;
  ocp.initialGuess(xs, us);
  // Different points at each node, so that anything stale would show.
  for (std::size_t k = 0; k < us.size(); ++k) {
    xs[k](0) += 0.02 * static_cast<double>(k);
    us[k] += 0.05 * std::sin(static_cast<double>(k)) * Eigen::VectorXd::Ones(us[k].size());
  }
  const int N = p.horizon();
  std::vector<std::unique_ptr<ocp::NodeData>> sharing, own;
  for (int k = 0; k <= N; ++k) {
    sharing.push_back(k == 0 ? p.createNodeData() : p.createNodeDataSharingWorkspaces(*sharing[0]));
    own.push_back(p.createNodeData());
  }
  ASSERT_NE(sharing[0]->cache, nullptr);
  EXPECT_EQ(sharing[N]->cache, sharing[0]->cache);
  EXPECT_EQ(sharing[N]->inequality_data[0], sharing[0]->inequality_data[0]);
  EXPECT_NE(sharing[N]->Gx.data(), sharing[0]->Gx.data());
  EXPECT_NE(own[0]->cache, own[1]->cache);
  const Eigen::VectorXd zero_u = Eigen::VectorXd::Zero(p.nu());
  std::set<int> rows;
  // Forwards, then backwards: the shared workspaces hold another node's data each time.
  for (const bool forwards : {true, false}) {
    for (int i = 0; i <= N; ++i) {
      const int k = forwards ? i : N - i;
      const auto kk = static_cast<std::size_t>(k);
      const Eigen::VectorXd& u = k < N ? us[kk] : zero_u;
      p.linearize(k, xs[kk], u, *sharing[kk]);
      p.linearize(k, xs[kk], u, *own[kk]);
      const ocp::NodeData& s = *sharing[kk];
      const ocp::NodeData& o = *own[kk];
      EXPECT_EQ(s.cost, o.cost) << k;
      EXPECT_EQ(s.lx, o.lx) << k;
      EXPECT_EQ(s.lu, o.lu) << k;
      EXPECT_EQ(s.Lxx, o.Lxx) << k;
      EXPECT_EQ(s.Luu, o.Luu) << k;
      EXPECT_EQ(s.Lux, o.Lux) << k;
      EXPECT_EQ(s.xnext, o.xnext) << k;
      EXPECT_EQ(s.Fx, o.Fx) << k;
      EXPECT_EQ(s.Fu, o.Fu) << k;
      ASSERT_EQ(s.ne, o.ne) << k;
      ASSERT_EQ(s.ni, o.ni) << k;
      EXPECT_EQ(s.e, o.e) << k;
      EXPECT_EQ(s.Ex, o.Ex) << k;
      EXPECT_EQ(s.Eu, o.Eu) << k;
      EXPECT_EQ(s.g, o.g) << k;
      EXPECT_EQ(s.Gx, o.Gx) << k;
      EXPECT_EQ(s.Gu, o.Gu) << k;
      rows.insert(o.ni);
    }
  }
  // Nodes of more than one kind took part (the trot's stance and swing feet have
  // different inequality rows: friction on stance feet, regions).
  EXPECT_GT(rows.size(), 1u);
  // Workspaces of another problem are refused.
  Assembly other("stand", 0.0, 4);
  EXPECT_THROW(p.createNodeDataSharingWorkspaces(*other.problem->createNodeData()),
               std::invalid_argument);
}

// Real-time iterations on the OCP of `rollstep plan` (every term): one thread shares the
// workspaces of all nodes, condenses each node inside the linearisation and keeps one
// reduced Hessian; two threads do none of that. Every iterate must be bit for bit the same.
TEST(CentroidalProblem, RealTimeIterationsAreTheSameWithOneAndTwoThreads) {
  const RobotOcpDescription robot = test::tachyon3Description();
  std::vector<std::vector<Eigen::VectorXd>> states, inputs;
  for (const int threads : {1, 2}) {
    OcpSettings settings;
    settings.horizon = 40;
    settings.solver.num_threads = threads;
    settings.solver.max_iterations = 3;
    CentroidalOcp ocp(robot, settings,
                      planning::terrainFromBoxes({-20, 20, -5, 5, 0}, 0.0, {{0.3, 2, -5, 5, 0.2}}),
                      planning::GaitKind::Trot);
    ocp.reset(0.0, lie::SE3::Identity(), planning::BaseVelocityCommand{0.3, 0.0, 0.0});
    solver::Solver s(ocp.problem(), settings.solver);
    std::vector<Eigen::VectorXd> xs, us;
    ocp.initialGuess(xs, us);
    s.setInitialGuess(xs, us);
    const Eigen::VectorXd x0 = ocp.standingState(0.0, 0.0, 0.0);
    s.solve(x0);
    solver::SolverSettings rt = s.settings();
    rt.mode = solver::SolverMode::RealTime;
    s.setSettings(rt);
    for (int i = 1; i <= 3; ++i) {
      ASSERT_EQ(s.update(0.0, s.states()[1]), solver::SolverStatus::IterationDone) << s.message();
    }
    states.push_back(s.states());
    inputs.push_back(s.inputs());
  }
  for (std::size_t k = 0; k < states[0].size(); ++k) EXPECT_EQ(states[0][k], states[1][k]) << k;
  for (std::size_t k = 0; k < inputs[0].size(); ++k) EXPECT_EQ(inputs[0][k], inputs[1][k]) << k;
}

}  // namespace
}  // namespace rollstep::centroidal::test
