// `rollstep plan`: builds the full-centroidal OCP for a scene and a behaviour, solves it in
// converging mode from a cold start (the standing posture along the base reference), and
// writes the trajectory, the solver's iteration statistics and a summary.
//
// Outputs (docs/USER_GUIDE.md): DIR/trajectory.csv, DIR/iterations.csv and DIR/summary.txt,
// each written under a temporary name and renamed into place complete. Inputs are all
// loaded before anything is written. Exit status 0 when the solve converged (or stopped at
// an acceptable point: KKT error below acceptable_tolerance), 3 when it ended otherwise (the
// files are written all the same: the summary says why), 1 on errors.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <string>
#include <system_error>

#include "cli_util.hpp"
#include "commands.hpp"
#include "output_folder.hpp"
#include "rollstep/centroidal/centroidal_ocp.hpp"
#include "rollstep/common/interrupt.hpp"
#include "rollstep/common/text_file.hpp"
#include "rollstep/sim/scene.hpp"
#include "rollstep/sim/scene_terrain.hpp"
#include "rollstep/solver/solver.hpp"

namespace rollstep::apps {

namespace {

namespace fs = std::filesystem;

struct PlanOptions {
  std::string scene = "flat";
  std::string scene_config;
  std::string gait = "trot";
  double vx = 0.0, vy = 0.0, yaw_rate = 0.0;
  double duration = 1.5;
  double start_x = 0.0;
  std::string config;
  std::string robot;
  std::string out = "out/plan";
};

std::string trajectoryCsv(const centroidal::CentroidalOcp& ocp, const solver::Solver& s) {
  const centroidal::CentroidalRobot& robot = ocp.robot();
  const model::Model& model = robot.model();
  const int N = ocp.problem()->horizon(), nj = robot.nj(), nc = robot.nc();
  std::string out =
      "time_s,x_m,y_m,z_m,qx,qy,qz,qw,vx_mps,vy_mps,vz_mps,wx_radps,wy_radps,wz_radps";
  for (int j = 0; j < nj; ++j) out += ",q_" + model.jointNames[static_cast<std::size_t>(j)];
  for (int j = 0; j < nj; ++j) out += ",v_" + model.jointNames[static_cast<std::size_t>(j)];
  const char* axes[] = {"x", "y", "z"};
  for (int i = 0; i < nc; ++i) {
    for (const char* a : axes)
      out += ",f" + std::string(a) + "_" + ocp.contactNames()[static_cast<std::size_t>(i)] + "_N";
  }
  for (int i = 0; i < nc; ++i) {
    for (const char* a : axes)
      out += ",p" + std::string(a) + "_" + ocp.contactNames()[static_cast<std::size_t>(i)] + "_m";
  }
  out += ",mode\n";
  const Eigen::VectorXd zero_u = Eigen::VectorXd::Zero(robot.nu());
  for (int k = 0; k <= N; ++k) {
    const ocp::NodeContext ctx = ocp.problem()->context(k);
    const Eigen::VectorXd& x = s.states()[static_cast<std::size_t>(k)];
    // The last node has no input: its velocities and forces repeat the last input's.
    const Eigen::VectorXd& u = s.inputs()[static_cast<std::size_t>(std::min(k, N - 1))];
    const lie::Vector6d twist = ocp.baseTwist(x, u);
    const Eigen::Matrix3Xd feet = ocp.footPositions(x);
    out += numberText(ctx.time);
    for (int i = 0; i < 7; ++i) out += "," + numberText(x[i]);
    for (int i = 0; i < 6; ++i) out += "," + numberText(twist[i]);
    for (int j = 0; j < nj; ++j) out += "," + numberText(x[robot.stateJointIndex() + j]);
    for (int j = 0; j < nj; ++j) out += "," + numberText(u[j]);
    for (int i = 0; i < 3 * nc; ++i) out += "," + numberText(u[nj + i]);
    for (int i = 0; i < nc; ++i) {
      for (int a = 0; a < 3; ++a) out += "," + numberText(feet(a, i));
    }
    out += "," + std::to_string(ctx.mode) + "\n";
  }
  return out;
}

std::string iterationsCsv(const solver::Solver& s) {
  std::string out =
      "iteration,cost,primal_residual,dual_residual,complementarity,kkt_error,barrier,"
      "primal_step,dual_step,inertia_shift,restoration,linearize_ms,riccati_ms,update_ms\n";
  for (const solver::IterationStats& st : s.stats()) {
    out += formatText(
        "%d,%s,%s,%s,%s,%s,%s,%s,%s,%s,%d,%s,%s,%s\n", st.iteration, numberText(st.cost).c_str(),
        numberText(st.primal_residual).c_str(), numberText(st.dual_residual).c_str(),
        numberText(st.complementarity).c_str(), numberText(st.kkt_error).c_str(),
        numberText(st.barrier).c_str(), numberText(st.primal_step).c_str(),
        numberText(st.dual_step).c_str(), numberText(st.inertia_shift).c_str(),
        st.restoration ? 1 : 0, numberText(st.time_linearize_ms).c_str(),
        numberText(st.time_riccati_ms).c_str(), numberText(st.time_update_ms).c_str());
  }
  return out;
}

int runPlan(const PlanOptions& o) {
  // Inputs: everything loads before anything is written.
  const sim::SceneConfig scene =
      o.scene_config.empty() ? sim::loadScene(o.scene) : sim::loadSceneConfig(o.scene_config);
  const std::string robot_file = robotFolderOption(o.robot).description;
  const centroidal::RobotOcpDescription robot = centroidal::loadRobotOcpDescription(robot_file);
  centroidal::OcpSettings settings;
  if (!o.config.empty()) settings = centroidal::loadOcpSettings(o.config);
  const long steps = std::lround(o.duration / settings.dt);
  if (steps < 1 || steps > 10000) {
    throw CLI::ValidationError(
        "--duration",
        formatText("%s s is %ld steps of dt = %s s; valid: 1 to 10000 steps",
                   numberText(o.duration).c_str(), steps, numberText(settings.dt).c_str()));
  }
  settings.horizon = static_cast<int>(steps);
  settings.solver.mode = solver::SolverMode::Converging;
  centroidal::CentroidalOcp ocp(
      robot, settings,
      sim::terrainFromScene(scene, centroidal::footholdRegionMargin(robot, settings)),
      centroidal::gaitKindFromString(o.gait));
  lie::SE3 start = lie::SE3::Identity();
  start.translation.x() = o.start_x;
  ocp.reset(0.0, start, planning::BaseVelocityCommand{o.vx, o.vy, o.yaw_rate});
  solver::Solver solver(ocp.problem(), settings.solver);
  const Eigen::VectorXd x0 = ocp.standingState(o.start_x, 0.0, 0.0);
  std::vector<Eigen::VectorXd> xs, us;
  ocp.initialGuess(xs, us);
  xs[0] = x0;
  solver.setInitialGuess(xs, us);

  const auto t0 = std::chrono::steady_clock::now();
  const solver::SolverStatus status = solver.solve(x0);
  const double solve_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

  std::string summary = formatText(
      "rollstep plan: scene %s, gait %s, command (%s m/s, %s m/s, %s rad/s), horizon %s s "
      "(N = %d, dt = %s s)\n"
      "  robot      %s (%s)\n"
      "  solver     %s after %d iterations in %.3f s; KKT error %.3g (tolerance %.3g); cost %.6g\n"
      "%s"
      "  largest violation per constraint group (at node):\n",
      scene.name.c_str(), o.gait.c_str(), numberText(o.vx).c_str(), numberText(o.vy).c_str(),
      numberText(o.yaw_rate).c_str(), numberText(o.duration).c_str(), settings.horizon,
      numberText(settings.dt).c_str(), robot_file.c_str(), robot.urdf.c_str(),
      solver::toString(status), solver.iterations(), solve_s,
      solver.stats().empty() ? 0.0 : solver.stats().back().kkt_error, settings.solver.kkt_tolerance,
      solver.cost(),
      *solver.message() != '\0' ? formatText("  message    %s\n", solver.message()).c_str() : "");
  for (const centroidal::ConstraintViolation& v :
       centroidal::constraintViolations(*ocp.problem(), solver.states(), solver.inputs())) {
    summary += formatText("    %-24s %.3g%s\n", v.group.c_str(), v.value,
                          v.node >= 0 ? formatText(" (node %d)", v.node).c_str() : "");
  }
  const Eigen::VectorXd& xN = solver.states().back();
  summary += formatText("  base       (%.3f, %.3f, %.3f) m -> (%.3f, %.3f, %.3f) m\n", x0[0], x0[1],
                        x0[2], xN[0], xN[1], xN[2]);

  // Outputs: the three files as a whole. The previous ones are removed only now (the solve
  // above wrote nothing, and an interrupt during it ends the process with nothing touched);
  // each file goes to a temporary first and all three are renamed into place only when all
  // are written; on any failure (a full disk, an interrupt) only DIR/FAILED is left.
  const OutputFolder folder("plan", o.out, {"trajectory.csv", "iterations.csv", "summary.txt"});
  folder.create();
  const fs::path dir(o.out);
  summary += "  outputs    " + (dir / "trajectory.csv").string() + ", " +
             (dir / "iterations.csv").string() + ", " + (dir / "summary.txt").string() + "\n";
  folder.begin();
  try {
    AtomicFileWriter trajectory((dir / "trajectory.csv").string());
    AtomicFileWriter iterations((dir / "iterations.csv").string());
    AtomicFileWriter summary_file((dir / "summary.txt").string());
    trajectory.write(trajectoryCsv(ocp, solver));
    iterations.write(iterationsCsv(solver));
    summary_file.write(summary);
    throwIfInterrupted();
    trajectory.commit();
    iterations.commit();
    summary_file.commit();
  } catch (const std::exception& e) {
    const bool marked = folder.fail(e.what());
    if (dynamic_cast<const Interrupted*>(&e) != nullptr) throw;
    throw OutputError(std::string(e.what()) + "\n  the plan's outputs were not written" +
                      (marked ? "; the error is in " + folder.failedPath() : ""));
  }
  std::fputs(summary.c_str(), stdout);
  std::fflush(stdout);
  return status == solver::SolverStatus::Converged || status == solver::SolverStatus::Acceptable
             ? 0
             : 3;
}

}  // namespace

void registerPlanCommand(CLI::App& app, int& exit_status) {
  auto options = std::make_shared<PlanOptions>();
  CLI::App* cmd = app.add_subcommand(
      "plan",
      "Build the full-centroidal OCP for a scene and a behaviour, solve it in converging "
      "mode from a cold start, and write DIR/trajectory.csv (time, base pose and twist, "
      "joint positions and velocities, contact forces, foot positions, mode), "
      "DIR/iterations.csv (the solver's statistics) and DIR/summary.txt (status, KKT error, "
      "largest violation of each constraint group, solve time).");
  cmd->footer(
      "Exit status: 0 converged (or acceptable: KKT error below the solver's "
      "acceptable_tolerance), 3 not converged (files written, the summary says why), 1 on "
      "bad options or inputs.\n"
      "Example: rollstep plan --scene step20 --gait trot --vx 0.15 --duration 1.5 --out out/plan");
  CLI::Option* scene =
      cmd->add_option("--scene", options->scene,
                      "Scene: a name (" + sim::sceneNamesText() + ") or a scene file (as for sim)")
          ->capture_default_str();
  CLI::Option* scene_config =
      cmd->add_option("--scene-config", options->scene_config, "Scene file (as for sim)")
          ->check(kNotEmpty);
  scene->excludes(scene_config);
  cmd->add_option("--gait", options->gait, "standing, rolling, trot or static_walk")
      ->check(CLI::IsMember({"standing", "rolling", "trot", "static_walk"}))
      ->capture_default_str();
  cmd->add_option("--vx", options->vx, "Forward base velocity command [m/s] (base frame)")
      ->check(numberIn(-2.0, 2.0, "m/s"))
      ->capture_default_str();
  cmd->add_option("--vy", options->vy, "Lateral base velocity command [m/s] (base frame)")
      ->check(numberIn(-1.0, 1.0, "m/s"))
      ->capture_default_str();
  cmd->add_option("--yaw-rate", options->yaw_rate, "Yaw rate command [rad/s]")
      ->check(numberIn(-2.0, 2.0, "rad/s"))
      ->capture_default_str();
  cmd->add_option("--duration", options->duration,
                  "Horizon length [s]; N = duration / dt (dt from --config)")
      ->check(numberIn(0.001, 150.0, "s"))
      ->capture_default_str();
  cmd->add_option("--start-x", options->start_x, "Start position of the base along x [m]")
      ->check(numberIn(-50.0, 50.0, "m"))
      ->capture_default_str();
  cmd->add_option("--config", options->config,
                  "OCP settings YAML (config/ocp.yaml lists every key; default: its defaults)")
      ->check(kNotEmpty);
  cmd->add_option("--robot", options->robot, kRobotOptionHelp)->check(kNotEmpty);
  cmd->add_option("--out", options->out, "Output directory (created if needed)")
      ->check(kNotEmpty)
      ->capture_default_str();
  cmd->final_callback([options, &exit_status] { exit_status = runPlan(*options); });
}

}  // namespace rollstep::apps
