#include "runs.hpp"

#include <mujoco/mujoco.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "process.hpp"
#include "rollstep/common/text_file.hpp"
#include "rollstep/sim/plant.hpp"

namespace rollstep::experiments {

namespace fs = std::filesystem;

namespace {

std::string fileText(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

std::string trimmed(std::string s) {
  while (!s.empty() && (s.back() == '\n' || s.back() == ' ')) s.pop_back();
  return s;
}

}  // namespace

std::string RunOutcome::failureText() const {
  if (!error.empty()) return error;
  if (!log) return "no log";
  std::string out;
  for (const std::string& f : assessment.failures) out += (out.empty() ? "" : "; ") + f;
  return out;
}

sim::SceneConfig sceneOf(const Scenario& scenario) {
  return scenario.scene_config.empty() ? sim::loadScene(scenario.scene)
                                       : sim::loadSceneConfig(scenario.scene_config);
}

std::string robotOf(const Scenario& scenario) { return scenario.runSpec("out").robot; }

void setRobot(ExperimentSet& set, const std::string& robot) {
  if (robot.empty()) return;
  for (Scenario& s : set.scenarios) {
    if (!robotOf(s).empty()) {
      throw InputError("--robot " + robot + ": scenario " + s.name + " of " + set.source +
                       " names its own robot (--robot " + robotOf(s) +
                       " in its args); drop one of the two");
    }
    s.args.insert(s.args.end(), {"--robot", robot});
  }
}

sim::PlantOptions plantOptionsOfRobot(const std::string& robot) {
  return sim::plantOptionsFor(robot.empty() ? sim::defaultRobotFolder()
                                            : sim::findRobotFolder(robot));
}

std::vector<JointLimit> jointLimits(const sim::SceneConfig& scene, const std::string& robot) {
  const sim::Plant plant(scene, plantOptionsOfRobot(robot));
  const mjModel* m = plant.mujocoModel();
  std::vector<JointLimit> limits;
  for (const sim::PlantLayout::Joint& joint : plant.layout().joints) {
    const int id = mj_name2id(m, mjOBJ_JOINT, joint.name.c_str());
    if (id < 0 || !m->jnt_limited[id]) continue;
    limits.push_back({joint.name, m->jnt_range[2 * id], m->jnt_range[2 * id + 1]});
  }
  return limits;
}

RunOutcome executeRun(const Scenario& scenario, const sim::RunSpec& run,
                      const sim::SceneConfig& scene, const RunCriteria& criteria,
                      const std::function<void(double, double)>& on_progress) {
  const std::string& dir = run.out;
  fs::create_directories(dir);
  // The child gets the run as a spec file (paths absolute: it reads the same from anywhere).
  const std::string spec_file = dir + "/spec.yaml";
  const std::string spec = sim::toYaml(sim::withAbsolutePaths(run));
  writeFileAtomically(spec_file, spec);
  const std::vector<std::string> args{"sim", "--spec", spec_file};
  const std::string program = selfExecutable();
  const int status = runProcess(
      program, args, dir + "/stdout.txt", dir + "/stderr.txt", [&](const std::string& line) {
        double done = 0.0, total = 0.0;
        if (on_progress &&
            std::sscanf(line.c_str(), "rollstep sim: %lf of %lf s", &done, &total) == 2) {
          on_progress(done, total);
        }
      });
  std::vector<std::string> argv{"rollstep"};
  argv.insert(argv.end(), args.begin(), args.end());
  RunOutcome outcome = judgeRun(scenario, scene, dir, status, criteria);
  outcome.command = shellCommand(argv);
  outcome.spec = spec;
  return outcome;
}

RunOutcome judgeRun(const Scenario& scenario, const sim::SceneConfig& scene, const std::string& dir,
                    int exit_status, const RunCriteria& criteria) {
  RunOutcome o;
  o.name = scenario.name;
  o.dir = dir;
  o.exit_status = exit_status;
  const fs::path d(dir);
  if (exit_status != 0) {
    // The sim's own account first (FAILED), else the end of its standard error.
    std::string reason = trimmed(fileText(d / "FAILED"));
    if (reason.empty()) {
      const std::string err = trimmed(fileText(d / "stderr.txt"));
      std::istringstream lines(err);
      std::string line, last;
      while (std::getline(lines, line)) {
        if (line.rfind("rollstep sim: ", 0) != 0 || line.find("simulated") == std::string::npos) {
          last += (last.empty() ? "" : " ") + line;
        }
      }
      reason = last.empty() ? "no message" : last;
    }
    o.error = "rollstep sim exited with status " + std::to_string(exit_status) + ": " + reason;
    // A run that could not write its outputs says nothing about the controller.
    if (exit_status == kOutputErrorExitStatus) {
      throw OutputError("run '" + scenario.name + "' could not write its outputs: " + reason);
    }
  }
  try {
    if (fs::exists(d / "log.csv")) o.log = LogTable::read((d / "log.csv").string(), "log");
    if (fs::exists(d / "mpc.csv")) o.mpc = LogTable::read((d / "mpc.csv").string(), "MPC log");
  } catch (const std::exception& e) {
    if (o.error.empty()) o.error = e.what();
  }
  o.summary = fileText(d / "summary.txt");
  if (!o.log) {
    if (o.error.empty()) o.error = "the run left no log.csv";
    return o;
  }
  try {
    const sim::Plant plant(scene, plantOptionsOfRobot(robotOf(scenario)));
    o.up_height = plant.wheelRadius(1) + 0.5 * sim::firstRise(sim::resolveScene(scene));
    std::vector<std::string> legs;
    std::vector<double> hip_x, hip_y;
    for (int i = 0; i < plant.layout().numLegs(); ++i) {
      legs.push_back(plant.layout().legs[static_cast<std::size_t>(i)].name);
      hip_x.push_back(plant.hipPosition(i).x());
      hip_y.push_back(plant.hipPosition(i).y());
    }
    o.traverse_legs = traverseLegs(legs, hip_x, hip_y);
    o.assessment = assessRun(*o.log, jointLimits(scene, robotOf(scenario)), criteria,
                             scenario.traverse, o.traverse_legs, o.up_height);
  } catch (const std::exception& e) {
    o.error = std::string("cannot judge the run: ") + e.what();
  }
  return o;
}

}  // namespace rollstep::experiments
