// `rollstep trials`: randomized trials of one scenario of config/experiments.yaml (step
// height, friction, start offset, sensor noise: all drawn from the seed), one result file
// per trial, an aggregate; --jobs local processes; --print-commands for GNU parallel or a
// Slurm job array, --collect to aggregate result files written anywhere. No scheduler of its
// own beyond --jobs.
#include <sys/wait.h>

#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "cli_util.hpp"
#include "commands.hpp"
#include "experiments/document.hpp"
#include "experiments/process.hpp"
#include "experiments/runs.hpp"
#include "experiments/scenarios.hpp"
#include "experiments/trials.hpp"
#include "output_folder.hpp"
#include "rollstep/common/interrupt.hpp"
#include "rollstep/common/number_text.hpp"
#include "rollstep/common/text_file.hpp"
#include "rollstep/sim/plant.hpp"
#include "rollstep/sim/scene.hpp"

namespace rollstep::apps {

namespace {

namespace fs = std::filesystem;
using namespace rollstep::experiments;

struct TrialsOptions {
  std::string scenario, controller, seeds, out, experiments, robot;
  int jobs = 1;
  bool print_commands = false, no_aggregate = false;
  std::vector<std::string> collect;
};

std::string trialDir(const std::string& out, const Scenario& s, std::uint64_t seed) {
  char name[64];
  std::snprintf(name, sizeof name, "_seed%04llu", static_cast<unsigned long long>(seed));
  return out + "/" + s.name + name;
}

std::vector<std::string> trialCommand(const TrialsOptions& o, std::uint64_t seed) {
  std::vector<std::string> command = {selfExecutable(), "trials",
                                      "--experiments",  fs::absolute(o.experiments).string(),
                                      "--scenario",     o.scenario};
  if (!o.controller.empty()) command.insert(command.end(), {"--controller", o.controller});
  if (!o.robot.empty()) {
    // A folder path as absolute as the others; a robot name as it is.
    const bool path = o.robot.find('/') != std::string::npos || o.robot == "." || o.robot == "..";
    command.insert(command.end(), {"--robot", path ? fs::absolute(o.robot).string() : o.robot});
  }
  command.insert(command.end(), {"--seeds", std::to_string(seed), "--no-aggregate", "--out",
                                 fs::absolute(o.out).string()});
  return command;
}

/// The scenario --scenario and --controller pick: a scene (the first scenario of that scene
/// with the controller) or a scenario's name (the controller, when given, must be its own).
const Scenario& selectScenario(const ExperimentSet& set, const std::string& scenario,
                               const std::string& controller) {
  std::string have;
  for (const Scenario& s : set.scenarios) {
    have += (have.empty() ? "" : ", ") + s.name + " (" + s.scene + " with " + s.controller + ")";
  }
  if (sim::isSceneName(scenario)) {
    if (controller.empty()) {
      throw CLI::ValidationError("--controller", "needed with the scene " + scenario +
                                                     " (or name a scenario: " + have + ")");
    }
    for (const Scenario& s : set.scenarios) {
      if (s.scene == scenario && s.controller == controller) return s;
    }
    throw CLI::ValidationError("--scenario", "no scenario of scene " + scenario +
                                                 " with controller " + controller + " in " +
                                                 set.source + " (it has: " + have + ")");
  }
  for (const Scenario& s : set.scenarios) {
    if (s.name != scenario) continue;
    if (!controller.empty() && controller != s.controller) {
      throw CLI::ValidationError("--controller", "scenario " + scenario + " runs controller " +
                                                     s.controller + ", not " + controller);
    }
    return s;
  }
  throw CLI::ValidationError("--scenario", "'" + scenario + "' is neither a scene (" +
                                               sim::sceneNamesText() + ") nor a scenario of " +
                                               set.source + " (it has: " + have + ")");
}

/// A trial's folder: its files replaced as a whole (a run that does not end leaves FAILED
/// with the reason and no result.yaml; --collect then says it is unfinished). scene.yaml is
/// listed so that the scene file an older trial wrote there is removed (the run spec now
/// carries the drawn scene numbers).
OutputFolder trialFolder(const std::string& dir) {
  return OutputFolder("trials", dir, {"result.yaml", "scene.yaml", "sensors.yaml"});
}

/// Runs one trial in this process (its sim as a child) and writes its result.yaml.
TrialResult runTrial(const TrialsOptions& o, const ExperimentSet& set, const Scenario& s,
                     std::uint64_t seed) {
  const TrialParameters p = drawTrial(seed, set.trials);
  const std::string dir = trialDir(fs::absolute(o.out).string(), s, seed);
  const OutputFolder folder = trialFolder(dir);
  folder.create();
  folder.begin();
  try {
    fs::create_directories(dir + "/sim");
    writeFileAtomically(dir + "/sensors.yaml", trialSensorNoise(p).toYaml());
    // The drawn speed and scene numbers are the run spec's (the child reads them there).
    const Scenario trial = trialScenario(s, p);
    sim::RunSpec spec = trial.runSpec(dir + "/sim");
    spec.scene_parameters = trialSceneNumbers(sceneOf(s), p);
    spec.sensor_config = dir + "/sensors.yaml";
    const sim::SceneConfig scene = sim::sceneOf(spec);
    const RunOutcome run = executeRun(trial, spec, scene, set.criteria);
    throwIfInterrupted();  // the sim was interrupted with us: not a result
    TrialResult r;
    r.scenario = s.name;
    r.controller = s.controller;
    r.parameters = p;
    r.sensor_noise_applied = readsSensors(s);
    r.passed = run.passed();
    r.failure = run.passed() ? "" : run.failureText();
    if (run.assessment.metrics) {
      r.traverse_time = run.assessment.metrics->traverse_time;
      r.mean_abs_vz = run.assessment.metrics->mean_abs_vz;
      r.mean_abs_wy = run.assessment.metrics->mean_abs_wy;
    }
    std::vector<std::string> command = trialCommand(o, seed);
    command[0] = "rollstep";
    r.command = shellCommand(command);
    writeFileAtomically(dir + "/result.yaml", toYaml(r));
    return r;
  } catch (const std::exception& e) {
    folder.fail(e.what());
    throw;
  }
}

/// The aggregate's text: the results, and the trial folders found without one.
std::string aggregateText(const std::vector<TrialResult>& results,
                          const std::vector<UncountedTrial>& uncounted, const std::string& how) {
  std::string text =
      "# rollstep trials: aggregate\n\n" + how + "\n\n" + aggregateMarkdown(aggregate(results));
  if (!uncounted.empty()) {
    text += "\nNot counted: " + std::to_string(uncounted.size()) + " of " +
            std::to_string(uncounted.size() + results.size()) +
            " trial folders hold no result that can be counted:\n\n";
    for (const UncountedTrial& u : uncounted) {
      text += "- " + literalText(u.dir) + ": " + literalText(u.reason) + "\n";
    }
  }
  return text;
}

void writeAggregate(const std::string& text, std::size_t results, std::size_t uncounted,
                    const std::string& out_dir) {
  const OutputFolder folder("trials", out_dir, {"aggregate.md"});
  folder.create();
  folder.begin();
  try {
    writeFileAtomically(out_dir + "/aggregate.md", text);
  } catch (const std::exception& e) {
    folder.fail(e.what());
    throw;
  }
  std::fputs(text.c_str(), stdout);
  std::printf("\nrollstep trials: %zu results", results);
  if (uncounted > 0) {
    std::printf("; %zu trial folders not counted (unfinished or unreadable: listed)", uncounted);
  }
  std::printf("; aggregate in %s/aggregate.md\n", out_dir.c_str());
}

/// Options that --collect does not use: refused rather than ignored.
void refuseWithCollect(const CLI::App& cmd) {
  for (const char* option : {"--scenario", "--controller", "--seeds", "--jobs", "--print-commands",
                             "--no-aggregate", "--experiments"}) {
    if (cmd.count(option) > 0) {
      throw CLI::ValidationError(option,
                                 "is not used by --collect (it aggregates the result "
                                 "files found; no trial is run)");
    }
  }
}

int collectTrialResults(const TrialsOptions& o) {
  const TrialCollection c = collectTrials(o.collect);
  std::string from;
  for (const std::string& d : o.collect) from += " " + literalText(d);
  if (c.folders == 0) {
    throw InputError("--collect: no result.yaml found under" + from +
                     " (no trial folder: none holds a result.yaml or is named "
                     "<scenario>_seed<N>)");
  }
  // The text first (a seed in two files is an error): nothing is replaced before.
  const std::string text = aggregateText(c.results, c.uncounted, "Collected from:" + from);
  for (const UncountedTrial& u : c.uncounted) {
    std::fprintf(stderr, "rollstep trials: not counted: %s: %s\n", u.dir.c_str(), u.reason.c_str());
  }
  writeAggregate(text, c.results.size(), c.uncounted.size(),
                 o.out.empty() ? o.collect.front() : o.out);
  return c.uncounted.empty() ? 0 : 3;
}

/// Waits for the trial processes still running after an interrupt (each got it and ends
/// within a second; after two, they are killed) and leaves FAILED in the folders of those
/// that did not write it.
void endRunningTrials(const std::map<pid_t, std::string>& running) {
  for (const auto& [pid, dir] : running) {
    int status = 0;
    const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(2);
    pid_t r = 0;
    while ((r = ::waitpid(pid, &status, WNOHANG)) == 0 && std::chrono::steady_clock::now() < until)
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    if (r == 0) status = endProcess(pid, 0.0);
    unregisterChild(pid);
    std::error_code ec;
    if (!fs::exists(dir + "/FAILED", ec)) {
      trialFolder(dir).fail("the trial process was interrupted (exit status " +
                            std::to_string(exitStatusOf(status)) + ")");
    }
  }
}

int runTrials(const TrialsOptions& o, const CLI::App& cmd) {
  if (!o.collect.empty()) {
    refuseWithCollect(cmd);
    return collectTrialResults(o);
  }
  if (o.scenario.empty() || o.seeds.empty() || o.out.empty()) {
    throw CLI::ValidationError(
        "trials",
        "needs --scenario, --seeds and --out (and --controller with a scene; or "
        "--collect DIR)");
  }
  if (o.print_commands && (cmd.count("--jobs") > 0 || o.no_aggregate)) {
    throw CLI::ValidationError(cmd.count("--jobs") > 0 ? "--jobs" : "--no-aggregate",
                               "is not used by --print-commands (each printed command runs one "
                               "trial)");
  }
  ExperimentSet set = loadExperimentSet(o.experiments);
  if (!o.robot.empty()) robotFolderOption(o.robot);  // cross-checked before any trial runs
  setRobot(set, o.robot);
  const Scenario& scenario = selectScenario(set, o.scenario, o.controller);
  std::vector<std::uint64_t> seeds;
  try {
    seeds = parseSeeds(o.seeds);
  } catch (const std::invalid_argument& e) {
    throw CLI::ValidationError("--seeds", e.what());
  }
  // The scenario's scene file, loaded now, and the plant built in the scenes at the corners
  // of the scene draws' ranges (every combination of their ends): no command is printed
  // that would fail, no trial starts that cannot run.
  const sim::SceneConfig base_scene = sceneOf(scenario);
  const std::vector<SceneDraw>& draws = set.trials.scene;
  for (const SceneDraw& d : draws) {
    if (!sim::hasSceneNumber(base_scene, d.key)) {
      std::fprintf(stderr,
                   "rollstep trials: scene %s of scenario %s has no number '%s': %s is "
                   "drawn (result.yaml) but not used\n",
                   base_scene.name.c_str(), scenario.name.c_str(), d.key.c_str(), d.name.c_str());
    }
  }
  if (draws.size() > 10) {
    throw InputError(set.source + ": trials.scene: more than 10 scene numbers drawn");
  }
  for (std::size_t corner_bits = 0; corner_bits < (std::size_t{1} << draws.size()); ++corner_bits) {
    TrialParameters corner;
    std::string text;
    for (std::size_t k = 0; k < draws.size(); ++k) {
      const SceneDraw& d = draws[k];
      const double v = (corner_bits >> k) & 1 ? d.max : d.min;
      corner.scene.push_back({d.name, d.key, d.offset, v});
      text += (text.empty() ? "" : ", ") + d.name + " " + numberText(v);
    }
    try {
      const sim::PlantOptions plant_options = plantOptionsOfRobot(robotOf(scenario));
      const sim::Plant plant(trialScene(base_scene, corner), plant_options);
    } catch (const std::exception& e) {
      throw InputError("scenario " + scenario.name + " of " + set.source +
                       " with the trial ranges (" + text + "): " + e.what());
    }
  }
  if (o.print_commands) {
    for (std::uint64_t seed : seeds)
      std::printf("%s\n", shellCommand(trialCommand(o, seed)).c_str());
    return 0;
  }
  // The aggregate is replaced as a whole at the end; until then, none (an interrupted run
  // leaves DIR/FAILED, each unfinished trial its own FAILED).
  const OutputFolder out_folder("trials", o.out, {"aggregate.md"});
  out_folder.create();
  if (o.no_aggregate) {
    // An aggregate already in DIR would no longer describe the trials there.
    std::error_code ec;
    fs::remove(fs::path(o.out) / "aggregate.md", ec);
    deferInterrupts();
  } else {
    out_folder.begin();
  }
  ProgressBar bar("rollstep trials");
  std::vector<TrialResult> results;
  int passed = 0;
  const auto done = [&](std::size_t count, std::uint64_t seed, bool ok) {
    passed += ok ? 1 : 0;
    bar.update(static_cast<double>(count) / seeds.size(),
               std::to_string(count) + "/" + std::to_string(seeds.size()) + " trials, " +
                   std::to_string(passed) + " passed (seed " + std::to_string(seed) +
                   (ok ? " passed)" : " failed)"));
  };
  std::map<pid_t, std::string> running_dirs;  // trial processes, for an interrupt
  try {
    if (o.jobs <= 1 || seeds.size() == 1) {
      for (std::size_t i = 0; i < seeds.size(); ++i) {
        bar.update(static_cast<double>(i) / seeds.size(), "seed " + std::to_string(seeds[i]));
        results.push_back(runTrial(o, set, scenario, seeds[i]));
        done(i + 1, seeds[i], results.back().passed);
      }
    } else {
      // Local processes, each one trial's self-contained command (the --print-commands line).
      std::map<pid_t, std::uint64_t> running;
      std::size_t next = 0, finished = 0;
      while (finished < seeds.size()) {
        throwIfInterrupted();
        while (running.size() < static_cast<std::size_t>(o.jobs) && next < seeds.size()) {
          const std::string dir = trialDir(fs::absolute(o.out).string(), scenario, seeds[next]);
          fs::create_directories(dir);
          std::vector<std::string> command = trialCommand(o, seeds[next]);
          const std::string program = command[0];
          command.erase(command.begin());
          const pid_t pid = startProcess(program, command, dir + "/trial.out", dir + "/trial.err");
          registerChild(pid);
          running[pid] = seeds[next];
          running_dirs[pid] = dir;
          ++next;
        }
        int status = 0;
        const pid_t pid = ::waitpid(-1, &status, 0);
        if (pid < 0) {
          if (errno == EINTR) continue;
          throw std::runtime_error(std::string("waitpid failed: ") + std::strerror(errno));
        }
        const auto it = running.find(pid);
        if (it == running.end()) continue;
        unregisterChild(pid);
        const std::uint64_t seed = it->second;
        running.erase(it);
        running_dirs.erase(pid);
        ++finished;
        const std::string dir = trialDir(fs::absolute(o.out).string(), scenario, seed);
        throwIfInterrupted();  // this trial's process too was interrupted: not a result
        TrialResult r;
        // The first line of the trial's own account of its failure, "" if it left none.
        const auto failedReason = [&dir] {
          std::error_code ec;
          const std::string failed =
              fs::exists(dir + "/FAILED", ec) ? readTextFile(dir + "/FAILED", "FAILED") : "";
          return failed.substr(0, failed.find('\n'));
        };
        if (exitStatusOf(status) == kOutputErrorExitStatus) {
          // The trial could not write its outputs: no verdict on the controller.
          const std::string failed = failedReason();
          throw OutputError("trial seed " + std::to_string(seed) + " could not write its outputs" +
                            (failed.empty() ? "" : ": " + failed));
        }
        if (exitStatusOf(status) == 0 && fs::exists(dir + "/result.yaml")) {
          r = parseTrialResult(readTextFile(dir + "/result.yaml", "trial result"), dir);
        } else {
          // A trial whose process died still counts: as failed, with the reason.
          const std::string failed = failedReason();
          std::string why = "the trial process exited with status " +
                            std::to_string(exitStatusOf(status)) + " (see " + dir + "/trial.err)";
          if (!failed.empty()) why += ": " + failed;
          std::fprintf(stderr, "rollstep trials: warning: seed %llu: %s\n",
                       static_cast<unsigned long long>(seed), why.c_str());
          r.scenario = scenario.name;
          r.controller = scenario.controller;
          r.parameters = drawTrial(seed, set.trials);
          r.failure = why;
          std::vector<std::string> command = trialCommand(o, seed);
          command[0] = "rollstep";
          r.command = shellCommand(command);
          writeFileAtomically(dir + "/result.yaml", toYaml(r));
          std::error_code ec;
          fs::remove(dir + "/FAILED", ec);
        }
        results.push_back(r);
        done(finished, seed, r.passed);
      }
    }
  } catch (const std::exception& e) {
    endRunningTrials(running_dirs);
    if (!o.no_aggregate) {
      out_folder.fail(std::string(e.what()) + " (" + std::to_string(results.size()) + " of " +
                      std::to_string(seeds.size()) + " trials ended)");
    }
    throw;
  }
  bar.finish(std::to_string(passed) + " of " + std::to_string(seeds.size()) + " passed");
  if (o.no_aggregate) {
    for (const TrialResult& r : results) {
      std::printf("rollstep trials: %s seed %llu %s%s\n", r.scenario.c_str(),
                  static_cast<unsigned long long>(r.parameters.seed),
                  r.passed ? "passed" : "FAILED: ", r.failure.c_str());
    }
    return 0;
  }
  // Exactly the seeds asked for: results of earlier runs in the same folder are not counted
  // (`--collect DIR` aggregates everything a folder holds).
  writeAggregate(aggregateText(results, {},
                               "Scenario " + scenario.name + " (" + literalText(set.source) +
                                   "), seeds " + o.seeds + "."),
                 results.size(), 0, o.out);
  return 0;
}

}  // namespace

void registerTrialsCommand(CLI::App& app, int& exit_status) {
  auto o = std::make_shared<TrialsOptions>();
  o->experiments = defaultExperimentsFile();
  CLI::App* cmd = app.add_subcommand(
      "trials",
      "Randomized trials of a scenario of the experiments file: step height, friction, start "
      "offset and sensor noise drawn from each seed; one result file per trial "
      "(DIR/<scenario>_seedNNNN/result.yaml) and an aggregate (DIR/aggregate.md: success rate, "
      "Table 1 metrics with spread).");
  cmd->footer(
      "Scale out: --print-commands prints one self-contained command per trial (for GNU parallel "
      "or a Slurm job array); afterwards `rollstep trials --collect DIR` aggregates the result "
      "files found under DIR. The sensor noise (DIR/<scenario>_seedNNNN/sensors.yaml) reaches "
      "the controllers that read the sensors (--state-source inekf). The aggregate counts "
      "exactly the seeds asked for; --collect counts every trial folder it finds and lists "
      "those without a result (unfinished: FAILED or no result.yaml; unreadable: why). Exit "
      "status: 0 when the trials ran (passed or not) and the aggregate was written; 3 with "
      "--collect when some trial folders hold no result; 1 on bad options or inputs; 128 + "
      "the signal when interrupted (SIGINT, SIGTERM: each unfinished trial folder then holds "
      "FAILED with the reason, DIR no aggregate.md).");
  cmd->add_option("--scenario", o->scenario,
                  "A scene (" + sim::sceneNamesText() +
                      ": its first scenario with --controller) or a scenario's name in the "
                      "experiments file (e.g. step20_nmpc_perception)")
      ->check(kNotEmpty);
  cmd->add_option("--controller", o->controller,
                  "Controller of the scenario (nmpc, ...); needed with a scene")
      ->check(kNotEmpty);
  cmd->add_option("--seeds", o->seeds, "Seeds: 0-29, 7 or 1,5,9-12");
  cmd->add_option("--out", o->out, "Output directory")->check(kNotEmpty);
  cmd->add_option("--jobs", o->jobs, "Trials run at once, as local processes")
      ->check(integerIn(1, 256))
      ->capture_default_str();
  cmd->add_flag("--print-commands", o->print_commands,
                "Print one self-contained command per trial and exit");
  cmd->add_flag("--no-aggregate", o->no_aggregate,
                "Write only the trials' result files (the printed commands use it); an "
                "aggregate.md in DIR is removed (it would no longer describe DIR)");
  cmd->add_option("--collect", o->collect,
                  "Aggregate the result.yaml files under DIR (repeatable); no trial is run")
      ->check(kNotEmpty);
  cmd->add_option("--experiments", o->experiments, "The experiments file")
      ->check(kNotEmpty)
      ->capture_default_str();
  cmd->add_option("--robot", o->robot, kRobotOptionHelp)->check(kNotEmpty);
  cmd->final_callback([o, cmd, &exit_status] { exit_status = runTrials(*o, *cmd); });
}

}  // namespace rollstep::apps
