// The centroidal terms assembled into an ocp::OptimalControlProblem and solved by the
// interior-point solver: standing still and a short trot converge, with the equalities
// satisfied (no inequalities here: those are tested with their own terms).
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <memory>
#include <set>

#include "centroidal/assembly.hpp"
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

// Nodes that one thread linearises in turn share one precomputation cache (the solver
// gives each thread's nodes one): every derivative must be bit for bit that of a node
// with a cache of its own, whichever node the shared cache held before.
TEST(CentroidalProblem, NodesSharingACacheLinearizeAsWithTheirOwn) {
  Assembly a("trot", 0.15, 20);
  std::vector<Eigen::VectorXd> xs, us;
  nominalGuess(*a.robot, a.problem->horizon(), xs, us);
  // Different points at each node, so that a stale cache would show.
  for (std::size_t k = 0; k < us.size(); ++k) {
    xs[k](0) += 0.01 * static_cast<double>(k);
    us[k] += 0.05 * std::sin(static_cast<double>(k)) * Eigen::VectorXd::Ones(us[k].size());
  }
  const auto shared = a.problem->createNodeCache();
  ASSERT_NE(shared, nullptr);
  const int N = a.problem->horizon();
  std::vector<std::unique_ptr<ocp::NodeData>> sharing, own;
  for (int k = 0; k <= N; ++k) {
    sharing.push_back(a.problem->createNodeData(shared));
    own.push_back(a.problem->createNodeData());
    EXPECT_EQ(sharing.back()->cache, shared);
  }
  EXPECT_NE(own[0]->cache, own[1]->cache);
  const auto at = [&](const std::vector<Eigen::VectorXd>& v, int k) -> const Eigen::VectorXd& {
    return v[static_cast<std::size_t>(std::min(k, static_cast<int>(v.size()) - 1))];
  };
  // Forwards, then backwards (the cache holds node k + 1's data when node k runs).
  for (const bool forwards : {true, false}) {
    for (int i = 0; i <= N; ++i) {
      const int k = forwards ? i : N - i;
      const auto ku = static_cast<std::size_t>(k);
      a.problem->linearize(k, at(xs, k), at(us, k), *sharing[ku]);
      a.problem->linearize(k, at(xs, k), at(us, k), *own[ku]);
      const ocp::NodeData& s = *sharing[ku];
      const ocp::NodeData& o = *own[ku];
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
    }
  }
  // The comparison above saw nodes of more than one kind (trot: the equality rows of
  // the stance and swing feet differ in number between the modes).
  std::set<int> rows;
  for (const auto& d : own) rows.insert(d->ne);
  EXPECT_GT(rows.size(), 1u);
}

}  // namespace
}  // namespace rollstep::centroidal::test
