// `rollstep trials`: randomized trials of one scenario of config/experiments.yaml (step
// height, friction, start offset, sensor noise: all drawn from the seed), one result file
// per trial, an aggregate; --jobs local processes; --print-commands for GNU parallel or a
// Slurm job array, --collect to aggregate result files written anywhere. No scheduler of its
// own beyond --jobs.
#include <sys/wait.h>

#include <cstdio>
#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "cli_util.hpp"
#include "commands.hpp"
#include "experiments/process.hpp"
#include "experiments/runs.hpp"
#include "experiments/scenarios.hpp"
#include "experiments/trials.hpp"
#include "rollstep/common/text_file.hpp"
#include "rollstep/sim/scene.hpp"

namespace rollstep::apps {

namespace {

namespace fs = std::filesystem;
using namespace rollstep::experiments;

struct TrialsOptions {
  std::string scenario, controller, seeds, out, experiments;
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

/// Runs one trial in this process (its sim as a child) and writes its result.yaml.
TrialResult runTrial(const TrialsOptions& o, const ExperimentSet& set, const Scenario& s,
                     std::uint64_t seed) {
  const TrialParameters p = drawTrial(seed, set.trials);
  const sim::SceneConfig scene = trialScene(sceneOf(s), p);
  const std::string dir = trialDir(fs::absolute(o.out).string(), s, seed);
  fs::create_directories(dir + "/sim");
  writeFileAtomically(dir + "/scene.yaml", sim::toYaml(scene));
  writeFileAtomically(dir + "/sensors.yaml", trialSensorNoise(p).toYaml());
  Scenario trial = trialScenario(s, p);
  const std::vector<std::string> extra = trialSimArgs(dir + "/sensors.yaml");
  trial.args.insert(trial.args.end(), extra.begin(), extra.end());
  const RunOutcome run = executeRun(trial, scene, dir + "/sim", set.criteria, dir + "/scene.yaml");
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
}

void writeAggregate(const std::vector<TrialResult>& results, const std::string& out_dir,
                    const std::string& how) {
  const std::vector<TrialAggregate> a = aggregate(results);
  std::string text = "# rollstep trials: aggregate\n\n" + how + "\n\n" + aggregateMarkdown(a);
  writeFileAtomically(out_dir + "/aggregate.md", text);
  std::fputs(text.c_str(), stdout);
  std::printf("\nrollstep trials: %zu results; aggregate in %s/aggregate.md\n", results.size(),
              out_dir.c_str());
}

void runTrials(const TrialsOptions& o) {
  if (!o.collect.empty()) {
    const std::vector<TrialResult> results = collectResults(o.collect);
    if (results.empty()) throw InputError("--collect: no result.yaml found");
    const std::string out = o.out.empty() ? o.collect.front() : o.out;
    fs::create_directories(out);
    std::string from;
    for (const std::string& d : o.collect) from += " " + d;
    writeAggregate(results, out, "Collected from:" + from);
    return;
  }
  if (o.scenario.empty() || o.seeds.empty() || o.out.empty()) {
    throw CLI::ValidationError(
        "trials",
        "needs --scenario, --seeds and --out (and --controller with a scene; or "
        "--collect DIR)");
  }
  const ExperimentSet set = loadExperimentSet(o.experiments);
  const Scenario& scenario = selectScenario(set, o.scenario, o.controller);
  std::vector<std::uint64_t> seeds;
  try {
    seeds = parseSeeds(o.seeds);
  } catch (const std::invalid_argument& e) {
    throw CLI::ValidationError("--seeds", e.what());
  }
  if (o.print_commands) {
    for (std::uint64_t seed : seeds)
      std::printf("%s\n", shellCommand(trialCommand(o, seed)).c_str());
    return;
  }
  fs::create_directories(o.out);
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
      while (running.size() < static_cast<std::size_t>(o.jobs) && next < seeds.size()) {
        const std::string dir = trialDir(fs::absolute(o.out).string(), scenario, seeds[next]);
        fs::create_directories(dir);
        std::vector<std::string> command = trialCommand(o, seeds[next]);
        const std::string program = command[0];
        command.erase(command.begin());
        running[startProcess(program, command, dir + "/trial.out", dir + "/trial.err")] =
            seeds[next];
        ++next;
      }
      int status = 0;
      const pid_t pid = ::waitpid(-1, &status, 0);
      if (pid < 0) {
        if (errno == EINTR) continue;
        throw std::runtime_error("waitpid failed");
      }
      const auto it = running.find(pid);
      if (it == running.end()) continue;
      const std::uint64_t seed = it->second;
      running.erase(it);
      ++finished;
      const std::string dir = trialDir(fs::absolute(o.out).string(), scenario, seed);
      bool ok = false;
      if (exitStatusOf(status) == 0 && fs::exists(dir + "/result.yaml")) {
        ok = parseTrialResult(readTextFile(dir + "/result.yaml", "trial result"), dir).passed;
      } else {
        // A trial whose process died still counts: as failed, with the reason.
        const std::string why = "the trial process exited with status " +
                                std::to_string(exitStatusOf(status)) + " (see " + dir +
                                "/trial.err)";
        std::fprintf(stderr, "rollstep trials: warning: seed %llu: %s\n",
                     static_cast<unsigned long long>(seed), why.c_str());
        TrialResult r;
        r.scenario = scenario.name;
        r.controller = scenario.controller;
        r.parameters = drawTrial(seed, set.trials);
        r.failure = why;
        std::vector<std::string> command = trialCommand(o, seed);
        command[0] = "rollstep";
        r.command = shellCommand(command);
        writeFileAtomically(dir + "/result.yaml", toYaml(r));
      }
      done(finished, seed, ok);
    }
  }
  bar.finish(std::to_string(passed) + " of " + std::to_string(seeds.size()) + " passed");
  if (o.no_aggregate) {
    for (const TrialResult& r : results) {
      std::printf("rollstep trials: %s seed %llu %s%s\n", r.scenario.c_str(),
                  static_cast<unsigned long long>(r.parameters.seed),
                  r.passed ? "passed" : "FAILED: ", r.failure.c_str());
    }
    return;
  }
  writeAggregate(collectResults({o.out}), o.out,
                 "Scenario " + scenario.name + " (" + set.source + "), seeds " + o.seeds + ".");
}

}  // namespace

void registerTrialsCommand(CLI::App& app) {
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
      "the controllers that read the sensors (--state-source inekf).");
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
                "Write only the trials' result files (the printed commands use it)");
  cmd->add_option("--collect", o->collect,
                  "Aggregate the result.yaml files under DIR (repeatable); no trial is run")
      ->check(kNotEmpty);
  cmd->add_option("--experiments", o->experiments, "The experiments file")
      ->check(kNotEmpty)
      ->capture_default_str();
  cmd->final_callback([o] { runTrials(*o); });
}

}  // namespace rollstep::apps
