// `rollstep sim`: the plant demo. Runs a run spec (sim/run_spec.hpp: the options below, or
// a spec file with --spec): a scene with the robot folder's robot and a controller (stand:
// hold the nominal posture; drive: hold it and roll on the drive wheels; nmpc: the full
// control pipeline, NMPC + CBF-QP + internal state integrator; cbfqp: the CBF-QP baseline
// without MPC) for a duration, writes DIR/log.csv, DIR/summary.txt and DIR/run.yaml (the
// spec it ran; nmpc also DIR/mpc.csv), prints the summary.
//
// Outputs rule (docs/USER_GUIDE.md): a run that fails on its inputs (options, scene config,
// robot file) writes nothing. Once the simulation starts, the previous run's log.csv,
// summary.txt and FAILED are removed; log.csv and summary.txt are written under
// temporary names with every write checked and renamed into place only when complete
// and the run succeeded; a run that fails after that point (divergence, full disk)
// leaves only DIR/FAILED holding the error, and exits non-zero.
#include <mujoco/mujoco.h>

#include <array>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>
#include <stdexcept>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

#include "cli_util.hpp"
#include "commands.hpp"
#include "experiments/replay.hpp"
#include "experiments/sim_options.hpp"
#include "output_folder.hpp"
#include "rollstep/common/gzip_text.hpp"
#include "rollstep/common/interrupt.hpp"
#include "rollstep/common/text_file.hpp"
#include "rollstep/sim/estimator_source.hpp"
#include "rollstep/sim/run.hpp"

namespace rollstep::apps {

namespace {

namespace fs = std::filesystem;

/// Result files of a run in the output directory.
struct OutputFiles {
  fs::path log, summary, failed, mpc, violations, replay, plan, old_plan, terrains, spec;
  explicit OutputFiles(const fs::path& dir)
      : log(dir / "log.csv"),
        summary(dir / "summary.txt"),
        failed(dir / "FAILED"),
        mpc(dir / "mpc.csv"),
        violations(dir / "mpc_violations.csv"),
        replay(dir / "replay.json"),
        plan(dir / "plan.csv.gz"),
        old_plan(dir / "plan.csv"),  // older versions' uncompressed plan log
        terrains(dir / "terrains.csv"),
        spec(dir / "run.yaml") {}
  /// `rollstep sim --spec DIR/run.yaml --out DIR` reruns a run in place: its run.yaml is the
  /// input, kept until the run rewrites it (a failed rerun leaves it as it was).
  bool spec_is_input = false;
};

/// Creates the output directory if needed and removes the previous run's result files.
void prepareOutputDir(const std::string& dir, const OutputFiles& files) {
  std::error_code ec;
  if (fs::exists(dir, ec) && !fs::is_directory(dir, ec)) {
    throw OutputError("--out '" + dir + "': exists and is not a directory");
  }
  fs::create_directories(dir, ec);
  if (ec) throw OutputError("--out '" + dir + "': cannot create the directory: " + ec.message());
  for (const fs::path& p : {files.log, files.summary, files.failed, files.mpc, files.violations,
                            files.replay, files.plan, files.old_plan, files.terrains, files.spec}) {
    if (p == files.spec && files.spec_is_input) continue;
    fs::remove(p, ec);
    if (ec) {
      throw OutputError("cannot remove the previous run's '" + p.string() + "': " + ec.message());
    }
  }
  removeStaleTemporaries(
      dir, {"log.csv", "summary.txt", "FAILED", "mpc.csv", "mpc_violations.csv", "replay.json",
            "plan.csv.gz", "plan.csv", "terrains.csv", "run.yaml"});
}

/// After a failure: no result files, and DIR/FAILED with the error (best effort: returns
/// false if FAILED could not be written either).
bool markFailed(const OutputFiles& files, const std::string& error) {
  std::error_code ec;
  fs::remove(files.log, ec);
  fs::remove(files.summary, ec);
  fs::remove(files.mpc, ec);
  fs::remove(files.violations, ec);
  fs::remove(files.replay, ec);
  fs::remove(files.plan, ec);
  fs::remove(files.terrains, ec);
  if (!files.spec_is_input) fs::remove(files.spec, ec);
  try {
    writeFileAtomically(files.failed.string(), "rollstep sim failed: " + error + "\n");
    return true;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "rollstep: warning: %s\n", e.what());
    return false;
  }
}

/// --log-map DIR: refused before anything is written if it names something that is not a
/// directory (the map log's files would have nowhere to go).
void checkMapLogDir(const std::string& dir) {
  if (dir.empty()) return;
  std::error_code ec;
  if (fs::exists(dir, ec) && !fs::is_directory(dir, ec)) {
    throw OutputError("--log-map '" + dir +
                      "': cannot create the directory: exists and is not a directory");
  }
  fs::create_directories(dir, ec);
  if (ec)
    throw OutputError("--log-map '" + dir + "': cannot create the directory: " + ec.message());
}

/// After a failure: the map log's files of this run removed (its snapshots without their
/// index would be a log that is not whole); FAILED is in --out.
void discardMapLog(const std::string& dir) {
  if (dir.empty()) return;
  std::error_code ec;
  for (const char* name : {"maps.csv", "regions.csv", "footholds.csv"})
    fs::remove(fs::path(dir) / name, ec);
  std::vector<fs::path> snapshots;
  for (const auto& entry : fs::directory_iterator(dir, ec)) {
    const std::string name = entry.path().filename().string();
    if (name.rfind("heights_", 0) == 0 && entry.path().extension() == ".npy") {
      snapshots.push_back(entry.path());
    }
  }
  for (const fs::path& p : snapshots) fs::remove(p, ec);
}

/// MuJoCo's warnings on stderr (its default handler also appends them to MUJOCO_LOG.TXT in
/// the working directory, a file nobody asked for).
void printMujocoWarning(const char* message) {
  std::fprintf(stderr, "rollstep: MuJoCo warning: %s\n", message);
}

/// The estimate's horizontal position and yaw errors against the plant's ground truth.
struct GroundTruthErrors {
  double position = 0.0, yaw_deg = 0.0;
};
GroundTruthErrors estimateErrors(const sim::EstimatorSource& e, const sim::GroundTruth& g) {
  const estimation::InvariantEkf& f = e.filter();
  GroundTruthErrors out;
  out.position = (f.position() - g.base_position).head<2>().norm();
  out.yaw_deg = std::abs(std::remainder(
                    sim::yawOf(f.orientation()) - sim::yawOf(g.base_orientation), 2.0 * M_PI)) *
                180.0 / M_PI;
  return out;
}

/// A count in words up to twelve ("six"), else in digits.
std::string countText(int n) {
  static const char* const kWords[] = {"no",    "one",   "two",  "three", "four",   "five",  "six",
                                       "seven", "eight", "nine", "ten",   "eleven", "twelve"};
  return n >= 0 && n <= 12 ? kWords[n] : std::to_string(n);
}

/// The summary's perception line.
std::string perceptionText(const sim::OnlinePerception& p, std::uint64_t refused,
                           std::uint64_t in_use) {
  const sim::OnlinePerceptionCounters& c = p.counters();
  std::string text = formatText(
      "  perception %llu scans at %s Hz: %llu new terrains (%llu handed over, %llu refused), "
      "%llu kept the last (%llu no points, %llu no finite point, %llu bad pose, %llu no "
      "planar region); map update + segmentation mean %.1f ms, max %.1f ms; %d regions at "
      "the end\n",
      static_cast<unsigned long long>(c.scans), numberText(p.lidar().settings().rate).c_str(),
      static_cast<unsigned long long>(c.terrains), static_cast<unsigned long long>(in_use),
      static_cast<unsigned long long>(refused), static_cast<unsigned long long>(c.kept),
      static_cast<unsigned long long>(c.no_points), static_cast<unsigned long long>(c.non_finite),
      static_cast<unsigned long long>(c.invalid_pose),
      static_cast<unsigned long long>(c.no_planar_region),
      c.scans > c.superseded ? c.total_update_ms / static_cast<double>(c.scans - c.superseded)
                             : 0.0,
      c.max_update_ms, p.terrain().size());
  if (p.asynchronous()) {
    text += formatText(
        "  perception on its own thread: %llu scans superseded by a newer one before "
        "processing\n",
        static_cast<unsigned long long>(c.superseded));
  }
  if (p.snapshots() > 0) text += formatText("  map log    %d snapshots\n", p.snapshots());
  return text;
}

/// The summary's line on the speed rule: the trot's timing and where the command was slowed
/// down at a step (within the run's duration); empty without speed adaptation.
std::string speedRuleText(const sim::NmpcController& nmpc, double duration) {
  const control::ControlPipeline& pipeline = nmpc.pipeline();
  if (!pipeline.settings().ocp.speed_adaptation) return "";
  std::string text = "  speed      ";
  const planning::TrotTiming& t = nmpc.trotTiming();
  if (t.period > 0.0) {
    text += formatText("trot period %.2f s, duty %.2f (swing %.2f s); step speed limit %.2f m/s",
                       t.period, t.duty, t.swing, pipeline.stepSpeedLimit());
  } else {
    text += "no trot: the command ramped only";
  }
  int slowdowns = 0;
  for (const planning::StepSlowdown& d : pipeline.stepSlowdowns()) {
    if (d.start >= duration) continue;
    text += formatText("%s slowed down at a step from %.2f to %.2f m/s, %.2f-%.2f s",
                       slowdowns == 0 ? ";" : ",", d.commanded_speed, d.limited_speed, d.start,
                       std::min(d.end, duration));
    ++slowdowns;
  }
  if (slowdowns == 0 && t.period > 0.0) text += "; not slowed down";
  const planning::ApproachTiming& a = pipeline.approachTiming();
  if (a.timed && a.delay > 0.0) {
    text += formatText(
        "; approach delayed %.2f s (%.2f-%.2f s) to land the first touch-down onto a step %.2f m "
        "past its riser (%.2f m without)",
        a.delay, a.dip_start, a.dip_end, a.after, a.before);
  } else if (a.timed) {
    text += formatText("; approach on time (first touch-down onto a step %.2f m past its riser)",
                       a.after);
  }
  for (std::size_t k = 1; k < a.edges.size(); ++k) {
    const planning::EdgeTiming& e = a.edges[k];
    if (e.touchdown >= duration) break;
    if (e.delay > 0.0) {
      text += formatText(
          "; %s delayed %.2f s (%.2f-%.2f s): %.2f m past its riser (%.2f m without)",
          e.up ? "step up" : "step down", e.delay, e.dip_start, e.dip_end, e.after, e.before);
    } else {
      text += formatText("; %s on time (%.2f m past its riser)", e.up ? "step up" : "step down",
                         e.after);
    }
  }
  for (const planning::SidewaysHold& h : pipeline.sidewaysHolds()) {
    if (h.start >= duration) continue;
    text += formatText("; sideways motion held at a step %.2f-%.2f s", h.start,
                       std::min(h.end, duration));
  }
  return text + "\n";
}

/// buildRun; for a spec from the command line, a value that does not fit the robot or its
/// files is named by its option.
sim::BuiltRun buildFromOptions(const sim::RunSpec& spec, bool from_options) {
  try {
    return sim::buildRun(spec);
  } catch (const sim::RunSpecError& e) {
    if (!from_options) throw std::invalid_argument("run spec: " + std::string(e.what()));
    if (e.key() == "log_violations") {
      throw std::invalid_argument("--log-violations needs --mpc-timing deterministic");
    }
    std::string option = e.key() == "drive_speed" ? "speed" : e.key();
    for (char& c : option) c = c == '_' ? '-' : c;
    throw CLI::ValidationError("--" + option, e.problem());
  }
}

/// The summary's lines on the NMPC (solutions, CBF-QP, watchdog, speed rule, estimator,
/// perception); writes its mpc.csv, plan.csv.gz and violations.
std::string nmpcResults(const sim::BuiltRun& run, const OutputFiles& files) {
  const sim::NmpcController& nmpc = *run.nmpc;
  writeFileAtomically(files.mpc.string(), nmpc.mpcUpdatesCsv());
  GzipFileWriter plan(files.plan.string());
  nmpc.writePlanCsv([&plan](std::string_view piece) { plan.write(piece); });
  plan.commit();
  if (nmpc.planLogDropped() > 0) {
    std::fprintf(stderr,
                 "rollstep sim: warning: plan.csv.gz lacks the last %zu MPC solutions (its "
                 "storage, reserved for the run's duration, was full)\n",
                 nmpc.planLogDropped());
  }
  if (nmpc.mpcUpdatesDropped() > 0) {
    std::fprintf(stderr,
                 "rollstep sim: warning: mpc.csv lacks the last %zu MPC solutions (its "
                 "storage, reserved for the run's duration, was full)\n",
                 nmpc.mpcUpdatesDropped());
  }
  if (run.spec.log_violations) {
    writeFileAtomically(files.violations.string(), nmpc.violationsCsv());
  }
  const control::PipelineCounters& c = nmpc.pipeline().counters();
  const control::MpcRunner& runner = nmpc.pipeline().runner();
  double solve_sum = 0.0, solve_max = 0.0;
  const auto& updates = nmpc.mpcUpdates();
  for (size_t k = 1; k < updates.size(); ++k) {  // the first is the initial cold solve
    solve_sum += updates[k].solve_time_ms;
    solve_max = std::max(solve_max, updates[k].solve_time_ms);
  }
  const double updates_n = updates.size() > 1 ? static_cast<double>(updates.size() - 1) : 1.0;
  std::string text = formatText(
      "  MPC        %zu solutions (%llu rejected), solve time mean %.2f ms, max %.2f ms; %s\n"
      "  CBF-QP     %llu fallbacks, %llu relaxed in %llu ticks\n",
      updates.size(), static_cast<unsigned long long>(c.solutions_rejected), solve_sum / updates_n,
      solve_max, files.mpc.c_str(), static_cast<unsigned long long>(c.qp_fallbacks),
      static_cast<unsigned long long>(c.qp_relaxations), static_cast<unsigned long long>(c.ticks));
  text += formatText("  watchdog   %llu trips, %llu ticks holding, %llu stale solutions\n",
                     static_cast<unsigned long long>(c.watchdog_trips),
                     static_cast<unsigned long long>(c.holding_ticks),
                     static_cast<unsigned long long>(c.stale_solutions));
  text += speedRuleText(nmpc, run.spec.duration);
  if (runner.solveExceptions() > 0) {
    text += formatText("  MPC errors %llu solves failed on an exception, the first: %s\n",
                       static_cast<unsigned long long>(runner.solveExceptions()),
                       runner.firstSolveException());
  }
  if (c.late_touchdown_ticks > 0) {
    text += formatText("  landing    %llu ticks with a late touch-down under way\n",
                       static_cast<unsigned long long>(c.late_touchdown_ticks));
  }
  if (const sim::EstimatorSource* e = nmpc.estimator(); e != nullptr) {
    const estimation::EstimatorCounters& k = e->filter().counters();
    const GroundTruthErrors err = estimateErrors(*e, run.plant->groundTruth());
    text += formatText(
        "  estimator  error at the end %.3f m, %.2f deg (ground truth); rejected samples: "
        "%llu IMU, %llu encoder, %llu time; contacts %llu used, %llu gated out\n",
        err.position, err.yaw_deg, static_cast<unsigned long long>(k.imu_rejected),
        static_cast<unsigned long long>(k.encoder_rejected),
        static_cast<unsigned long long>(k.time_rejected),
        static_cast<unsigned long long>(k.contacts_used),
        static_cast<unsigned long long>(k.contacts_rejected));
  }
  if (sim::OnlinePerception* p = run.nmpc->perception(); p != nullptr) {
    p->closeLog();
    text += perceptionText(*p, nmpc.terrainsRefused(), c.terrain_updates);
  }
  return text;
}

/// The summary's lines on the CBF-QP baseline.
std::string cbfqpResults(const sim::BuiltRun& run) {
  const control::PipelineCounters& c = run.cbfqp->pipeline().counters();
  std::string text = formatText("  CBF-QP     %llu fallbacks, %llu relaxed in %llu ticks\n",
                                static_cast<unsigned long long>(c.qp_fallbacks),
                                static_cast<unsigned long long>(c.qp_relaxations),
                                static_cast<unsigned long long>(c.ticks));
  if (sim::OnlinePerception* p = run.cbfqp->perception(); p != nullptr) {
    p->closeLog();
    text += perceptionText(*p, run.cbfqp->terrainsRefused(), c.terrain_updates);
  }
  return text;
}

std::string summaryText(const sim::BuiltRun& run, const sim::RunSummary& s,
                        const OutputFiles& files, const std::string& controller_lines) {
  const sim::Plant& plant = *run.plant;
  const double deg = 180.0 / M_PI;
  return formatText(
      "rollstep sim: scene %s, controller %s\n"
      "  robot      %s\n"
      "  simulated  %.3f s at %.0f Hz in %.3f s wall time (%.1fx real time)\n"
      "  base       start (%.3f, %.3f, %.3f) m -> end (%.3f, %.3f, %.3f) m, distance %.3f m, "
      "yaw change %.2f deg\n"
      "  height     min %.4f m, max %.4f m; mean forward speed %.3f m/s\n"
      "  contacts   all %s wheels on the ground %.1f %% of the time\n"
      "  MuJoCo     %d warnings\n"
      "%s"
      "  outputs    %s (CSV, units in the header, every %d ms), %s\n",
      run.scene.name.c_str(), run.controller_text.c_str(), plant.robotFile().c_str(), s.sim_time,
      1.0 / plant.controlPeriod(), s.wall_time, s.real_time_factor, s.start_position.x(),
      s.start_position.y(), s.start_position.z(), s.end_position.x(), s.end_position.y(),
      s.end_position.z(), (s.end_position - s.start_position).head<2>().norm(), s.yaw_change * deg,
      s.min_base_height, s.max_base_height, s.mean_forward_speed,
      countText(plant.layout().numLegs()).c_str(), 100.0 * s.all_feet_contact_fraction, s.warnings,
      controller_lines.c_str(), files.log.c_str(),
      static_cast<int>(std::lround(run.spec.log_every * plant.controlPeriod() * 1000.0)),
      files.summary.c_str());
}

/// Runs the built run and writes its results; returns the summary.
std::string simulateAndWrite(sim::BuiltRun& run, const OutputFiles& files) {
  if (sim::OnlinePerception* p = run.perception(); p != nullptr) p->openLog();
  sim::CsvLog log(files.log.string(), run.plant->layout(), run.controller->logColumns());
  // A progress line on stderr for runs that take more than a few seconds.
  const auto progress = [](const sim::Progress& p) {
    if (p.wall_time < 3.0) return;
    std::fprintf(stderr, "rollstep sim: %.1f of %.1f s simulated (%.0f %%), %.1fx real time\n",
                 p.sim_time, p.duration, 100.0 * p.sim_time / p.duration, p.sim_time / p.wall_time);
  };
  const sim::RunSummary s = sim::runScenario(*run.plant, *run.controller, run.spec.duration, &log,
                                             run.spec.log_every, progress);
  // Asynchronous perception: its thread finishes (and reports a failure) before the
  // counters are read.
  if (sim::OnlinePerception* p = run.perception(); p != nullptr) p->stop();
  log.commit();
  writeFileAtomically(
      files.replay.string(),
      experiments::replayModelJson(*run.plant, run.start_regions, run.start_regions_source));
  std::string controller_lines;
  if (run.nmpc != nullptr) controller_lines = nmpcResults(run, files);
  if (run.cbfqp != nullptr) controller_lines = cbfqpResults(run);
  // Perception runs: every terrain handed to the controller, by version (the replay's).
  std::string terrains;
  if (run.nmpc != nullptr) terrains = run.nmpc->terrainsCsv();
  if (run.cbfqp != nullptr) terrains = run.cbfqp->terrainsCsv();
  if (!terrains.empty()) writeFileAtomically(files.terrains.string(), terrains);
  writeFileAtomically(files.spec.string(), sim::toYaml(sim::withAbsolutePaths(run.spec)));
  const std::string text = summaryText(run, s, files, controller_lines);
  writeFileAtomically(files.summary.string(), text);
  return text;
}

void runSim(const sim::RunSpec& spec, const std::string& spec_file) {
  const bool from_options = spec_file.empty();
  mju_user_warning = printMujocoWarning;
  // Inputs: nothing is written before they have all loaded.
  sim::BuiltRun run = buildFromOptions(spec, from_options);

  // Outputs. From here an interrupt (SIGINT, SIGTERM) ends the run through the catch below:
  // temporary files removed, FAILED with the reason.
  checkMapLogDir(spec.map_log);
  OutputFiles files(spec.out);
  std::error_code ec;
  files.spec_is_input = !from_options && fs::equivalent(spec_file, files.spec, ec);
  deferInterrupts();
  throwIfInterrupted();
  prepareOutputDir(spec.out, files);
  std::string text;
  try {
    text = simulateAndWrite(run, files);
  } catch (const std::exception& e) {
    const bool marked = markFailed(files, e.what());
    discardMapLog(spec.map_log);
    if (dynamic_cast<const Interrupted*>(&e) != nullptr) {
      std::fprintf(stderr, "rollstep sim: %s: no %s or %s is left%s\n", e.what(), files.log.c_str(),
                   files.summary.c_str(),
                   marked ? ("; the reason is in " + files.failed.string()).c_str() : "");
      throw;
    }
    const std::string message = std::string(e.what()) + "\n  the run failed: no " +
                                files.log.string() + " or " + files.summary.string() + " is left" +
                                (marked ? "; the error is in " + files.failed.string() : "");
    // Kept apart: an output that cannot be written ends the program with its own status.
    if (dynamic_cast<const OutputError*>(&e) != nullptr) throw OutputError(message);
    throw std::runtime_error(message);
  }
  std::fputs(text.c_str(), stdout);
  if (std::fflush(stdout) != 0 || std::ferror(stdout)) {
    throw OutputError(std::string("cannot write the summary to standard output: ") +
                      std::strerror(errno));
  }
}

}  // namespace

void registerSimCommand(CLI::App& app) {
  auto options = std::make_shared<SimOptions>();
  CLI::App* cmd = app.add_subcommand(
      "sim",
      "Run the MuJoCo plant (a robot folder's robot in a scene) with a controller; write a CSV "
      "log (time, base pose and twist, joint positions, commands, contacts; units in the "
      "header), a summary and the run spec it ran (run.yaml), and print the summary.");
  auto set = std::make_shared<SimOptionSet>(*cmd, *options);
  cmd->final_callback([options, set] {
    const bool from_options = options->spec.empty();
    const sim::RunSpec spec = set->runSpec();
    // A spec from the command line names the robot's file problem by its option.
    std::error_code ec;
    if (from_options && !spec.robot.empty() && fs::is_regular_file(spec.robot, ec)) {
      throw CLI::ValidationError(
          "--robot", "'" + spec.robot +
                         "' is a file; --robot takes a robot name (robots/NAME) or a robot folder "
                         "holding centroidal.yaml and the MJCF <folder name>.xml (docs/ROBOTS.md)");
    }
    runSim(spec, options->spec);
  });
}

}  // namespace rollstep::apps
