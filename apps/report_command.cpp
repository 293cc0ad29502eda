// `rollstep report --out DIR`: the project's main job. Runs the experiments of
// config/experiments.yaml (each a `rollstep sim` child process in deterministic mode) with a
// progress bar, judges every run from its outputs, draws the figures (matplotlib, from
// apps/report/figures.py), renders snapshots and videos (MuJoCo offscreen, ffmpeg), and
// writes DIR/report.md and DIR/report.html with the same content. A failed run is shown as
// failed with its reason; nothing is invented; a missing tool is a stated gap, not a crash.
//
// The stages, in writeReport's order: runScenarios, drawFigures, renderSnapshotsAndVideos,
// writeReplayPages, judgeAcceptance, then the document (experiments/report_document.cpp)
// and the summary on stdout. Each reads the ReportInputs and the results of the stages
// before it (ReportResults).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "cli_util.hpp"
#include "commands.hpp"
#include "experiments/acceptance.hpp"
#include "experiments/document.hpp"
#include "experiments/process.hpp"
#include "experiments/render.hpp"
#include "experiments/replay.hpp"
#include "experiments/report_document.hpp"
#include "experiments/runs.hpp"
#include "experiments/scenarios.hpp"
#include "experiments/trials.hpp"
#include "output_folder.hpp"
#include "rollstep/common/interrupt.hpp"
#include "rollstep/common/text_file.hpp"
#include "rollstep/sim/plant.hpp"

namespace rollstep::apps {

namespace {

namespace fs = std::filesystem;
using namespace rollstep::experiments;

struct ReportOptions {
  std::string out;
  std::string experiments;
  bool videos = true;
  bool check = false;
  std::vector<std::string> only;
  std::vector<std::string> trials;
  std::string robot;
};

using Json = nlohmann::ordered_json;  // keys in the order written

/// `v` rounded to `digits` decimals (as the figures read it); null when not finite.
Json rounded(double v, int digits) {
  if (!std::isfinite(v)) return nullptr;
  const double scale = std::pow(10.0, digits);
  return std::round(v * scale) / scale;
}

/// One run as the figure script sees it.
Json runJson(const Scenario& s, const RunOutcome& o, const std::vector<JointLimit>& limits) {
  Json j;
  j["name"] = s.name;
  j["title"] = s.title;
  j["log"] = o.log ? Json(o.dir + "/log.csv") : Json(nullptr);
  j["mpc"] = o.mpc ? Json(o.dir + "/mpc.csv") : Json(nullptr);
  const std::string maps = o.dir + "/map/maps.csv";
  j["map"] = s.feeds("map") && fs::exists(maps) ? Json(o.dir + "/map") : Json(nullptr);
  j["terrain"] = s.terrainText();
  j["scene"] = s.scene;
  j["passed"] = o.passed();
  j["failure"] = o.failureText();
  if (o.log && o.assessment.window.found) {
    j["window"] = {rounded(o.assessment.window.start, 4), rounded(o.assessment.window.end, 4)};
  } else {
    j["window"] = nullptr;
  }
  // The legs the window is defined on (figure 2 plots their wheel heights).
  if (!o.traverse_legs.climb.empty()) {
    j["traverse_legs"] = {o.traverse_legs.climb, o.traverse_legs.descent};
  } else {
    j["traverse_legs"] = nullptr;
  }
  Json l = Json::object();
  for (const JointLimit& limit : limits) {
    l[limit.name] = {rounded(limit.lower, 6), rounded(limit.upper, 6)};
  }
  j["limits"] = l;
  return j;
}

std::string figuresScript() {
  if (const char* s = std::getenv("ROLLSTEP_FIGURES_SCRIPT"); s != nullptr && *s != '\0') return s;
  return ROLLSTEP_FIGURES_SCRIPT;
}

/// How long the figure script may run [s]: ROLLSTEP_FIGURES_TIME_LIMIT, default 600.
double figuresTimeLimit() {
  const char* text = std::getenv("ROLLSTEP_FIGURES_TIME_LIMIT");
  if (text == nullptr || *text == '\0') return 600.0;
  char* end = nullptr;
  const double v = std::strtod(text, &end);
  if (*end != '\0' || !std::isfinite(v) || v < 1.0 || v > 86400.0) {
    throw InputError("ROLLSTEP_FIGURES_TIME_LIMIT '" + std::string(text) +
                     "': not a number of seconds in [1, 86400]");
  }
  return v;
}

void warn(const std::string& text) {
  std::fprintf(stderr, "rollstep report: warning: %s\n", text.c_str());
}

/// Log rows to show: `count` evenly spaced over [t0, t1].
std::vector<std::size_t> rowsBetween(const LogTable& log, double t0, double t1, int count) {
  const auto& t = log.column("time[s]");
  std::vector<std::size_t> rows;
  for (int k = 0; k < count; ++k) {
    const double target = t0 + (t1 - t0) * k / std::max(1, count - 1);
    std::size_t best = 0;
    for (std::size_t i = 0; i < t.size(); ++i) {
      if (std::abs(t[i] - target) < std::abs(t[best] - target)) best = i;
    }
    rows.push_back(best);
  }
  return rows;
}

/// The report's inputs, loaded and checked before anything is written: the experiments
/// (--only applied), their scenes, the trial results given.
ReportInputs loadInputs(const ReportOptions& o, const std::vector<std::string>& argv) {
  ReportInputs in;
  in.set = loadExperimentSet(o.experiments);
  ExperimentSet& set = in.set;
  if (!o.robot.empty()) robotFolderOption(o.robot);  // cross-checked before any run
  setRobot(set, o.robot);
  in.file_acceptance = set.acceptance;
  if (!o.only.empty()) {
    std::vector<Scenario> chosen;
    for (const std::string& name : o.only) {
      if (std::count(o.only.begin(), o.only.end(), name) > 1) {
        throw CLI::ValidationError("--only", "scenario '" + name + "' is given twice");
      }
      const Scenario* s = set.find(name);
      if (s == nullptr) {
        std::string have;
        for (const Scenario& x : set.scenarios) have += (have.empty() ? "" : ", ") + x.name;
        throw CLI::ValidationError(
            "--only", "no scenario '" + name + "' in " + set.source + " (it has: " + have + ")");
      }
      chosen.push_back(*s);
    }
    set.scenarios = chosen;
    // The comparison needs both of its runs.
    set.acceptance.given = set.acceptance.given && set.find(set.acceptance.candidate) != nullptr &&
                           set.find(set.acceptance.baseline) != nullptr;
  }
  for (const Scenario& s : set.scenarios) in.scenes.push_back(sceneOf(s));
  // Trial results to include (read now: a bad result file is an input error, found before
  // anything is deleted; unfinished trials are listed in the report).
  in.trial_dirs = o.trials;
  if (!o.trials.empty()) {
    in.trials = collectTrials(o.trials);
    for (const UncountedTrial& u : in.trials.uncounted) {
      if (u.unreadable) throw InputError("--trials: trial folder '" + u.dir + "': " + u.reason);
    }
    in.trial_aggregates = aggregate(in.trials.results);
  }
  (void)figuresTimeLimit();  // a bad ROLLSTEP_FIGURES_TIME_LIMIT is an input error too
  in.out = fs::absolute(o.out).lexically_normal().string();
  in.argv = argv;
  in.videos = o.videos;
  return in;
}

/// Runs every scenario as a `rollstep sim` child into DIR/runs/<name>/ (its previous
/// outputs removed first, so that a stale log is never judged), with a progress bar, and
/// judges each from what it wrote. An interrupt ends the report: a cut run is no result.
std::vector<RunOutcome> runScenarios(const ReportInputs& in) {
  const ExperimentSet& set = in.set;
  std::error_code ec;
  std::vector<RunOutcome> outcomes;
  ProgressBar bar("rollstep report: runs");
  const double n = static_cast<double>(set.scenarios.size());
  for (std::size_t i = 0; i < set.scenarios.size(); ++i) {
    const Scenario& s = set.scenarios[i];
    const std::string dir = in.out + "/runs/" + s.name;
    for (const char* f : {"log.csv", "mpc.csv", "summary.txt", "FAILED"}) {
      fs::remove(fs::path(dir) / f, ec);
    }
    bar.update(i / n, s.name + " starting (" + std::to_string(i + 1) + "/" +
                          std::to_string(set.scenarios.size()) + ")");
    outcomes.push_back(
        executeRun(s, s.runSpec(dir), in.scenes[i], set.criteria, [&](double done, double total) {
          bar.update((i + done / total) / n, s.name + " " + decimalText(done, 1) + " of " +
                                                 decimalText(total, 1) + " s simulated");
        }));
    throwIfInterrupted();  // the run was interrupted with us: its outcome is not a result
    bar.update((i + 1) / n, s.name + (outcomes.back().passed() ? " passed" : " FAILED"));
  }
  bar.finish("all " + std::to_string(set.scenarios.size()) + " runs done");
  return outcomes;
}

/// Writes DIR/figures.json (each run's files, window and joint limits; which runs feed
/// which figure) and has the figure script draw from it. Returns why no figure could be
/// drawn ("" when the script ran): the document states it instead of a missing picture.
std::string drawFigures(const ReportInputs& in, const std::vector<RunOutcome>& outcomes) {
  const ExperimentSet& set = in.set;
  const std::string& out = in.out;
  std::string figures_gap;
  Json json;
  json["out"] = out;
  json["machine"] = machineDescription();
  json["runs"] = Json::object();
  for (std::size_t i = 0; i < set.scenarios.size(); ++i) {
    std::vector<JointLimit> limits;
    try {
      limits = jointLimits(in.scenes[i], robotOf(set.scenarios[i]));
    } catch (const std::exception&) {
    }
    json["runs"][set.scenarios[i].name] = runJson(set.scenarios[i], outcomes[i], limits);
  }
  json["figures"] = Json::object();
  for (const char* figure : {"table1", "fig4", "fig6", "fig8", "map"}) {
    Json names = Json::array();
    for (const Scenario& s : set.scenarios) {
      if (s.feeds(figure)) names.push_back(s.name);
    }
    json["figures"][figure] = names;
  }
  // The speed sweep's points, per scenario of the sweep (speed_sweep.png).
  Json sweep = Json::array();
  for (const SweepSeries& series : sweepSeries(set, outcomes)) {
    Json points = Json::array();
    for (const SweepPoint& p : series.points) {
      Json point;
      point["speed"] = rounded(p.speed, 4);
      point["passed"] = p.passed;
      point["traverse_time"] = p.metrics ? rounded(p.metrics->traverse_time, 4) : Json(nullptr);
      point["mean_abs_vz"] = p.metrics ? rounded(p.metrics->mean_abs_vz, 6) : Json(nullptr);
      point["mean_abs_wy"] = p.metrics ? rounded(p.metrics->mean_abs_wy, 6) : Json(nullptr);
      points.push_back(point);
    }
    sweep.push_back({{"scenario", series.scenario}, {"title", series.title}, {"points", points}});
  }
  json["speed_sweep"] = sweep;
  writeFileAtomically(out + "/figures.json", json.dump() + "\n");
  const std::string python = "/usr/bin/python3";
  const std::string script = figuresScript();
  if (!fs::exists(python)) {
    figures_gap = "/usr/bin/python3 is not installed (Debian packages python3, python3-matplotlib)";
  } else if (!fs::exists(script)) {
    figures_gap = "the figure script " + script + " is missing";
  } else {
    std::fprintf(stderr, "rollstep report: drawing the figures (%s)\n", script.c_str());
    bool timed_out = false;
    const double limit = figuresTimeLimit();
    const int status = runProcess(python, {script, out + "/figures.json"}, out + "/figures.log",
                                  out + "/figures.err", {}, limit, &timed_out);
    throwIfInterrupted();
    if (timed_out) {
      figures_gap = "the figure script did not end within " + decimalText(limit, 0) +
                    " s (ROLLSTEP_FIGURES_TIME_LIMIT) and was stopped";
    } else if (status != 0) {
      std::ifstream err(out + "/figures.err");
      std::stringstream text;
      text << err.rdbuf();
      figures_gap = "the figure script failed (exit " + std::to_string(status) + "): " + text.str();
    }
  }
  if (!figures_gap.empty()) warn("figures not available: " + figures_gap);
  return figures_gap;
}

/// Renders each logged run offscreen from its log.csv: six snapshots over its traverse
/// window (or the whole run) for the runs that feed "snapshots", and a real-speed video
/// (ffmpeg) for the runs with `video`. A run whose pictures fail is listed, not fatal;
/// without OSMesa or ffmpeg the gap is stated.
ReportPictures renderSnapshotsAndVideos(const ReportInputs& in,
                                        const std::vector<RunOutcome>& outcomes) {
  const ExperimentSet& set = in.set;
  const std::string& out = in.out;
  ReportPictures pictures;
  if (!Renderer::available(pictures.render_gap)) {
    warn("snapshots and videos not available: " + pictures.render_gap);
    return pictures;
  }
  if (!in.videos)
    pictures.video_gap = "not made (--no-videos)";
  else if (!onPath("ffmpeg"))
    pictures.video_gap = "ffmpeg is not installed (Debian package ffmpeg)";
  if (in.videos && !pictures.video_gap.empty()) warn("videos not available: " + pictures.video_gap);
  ProgressBar rbar("rollstep report: pictures");
  const double n = static_cast<double>(set.scenarios.size());
  for (std::size_t i = 0; i < set.scenarios.size(); ++i) {
    const Scenario& s = set.scenarios[i];
    const RunOutcome& run = outcomes[i];
    if (!run.log || run.log->rows() == 0) continue;
    try {
      const sim::Plant plant(in.scenes[i], plantOptionsOfRobot(robotOf(s)));
      const LogTable& log = *run.log;
      const auto& t = log.column("time[s]");
      if (s.feeds("snapshots")) {
        Renderer r(plant, 400, 300);
        const bool w = run.assessment.window.found;
        const double t0 = w ? run.assessment.window.start : t.front();
        const double t1 = w ? run.assessment.window.end : t.back();
        std::vector<Image> frames;
        for (std::size_t row : rowsBetween(log, t0, t1, 6)) {
          throwIfInterrupted();
          frames.push_back(r.render(log, row, "t = " + decimalText(t[row], 2) + " s"));
        }
        const std::string file = "snapshots_" + s.name + ".png";
        writePng(out + "/" + file, tile(frames, 3));
        pictures.snapshots.push_back(
            {file, s.title + ": six moments, evenly spaced from t = " + decimalText(t0, 2) +
                       " s to " + decimalText(t1, 2) + " s (" +
                       (w ? "the traverse window" : "the whole run: no traverse window") + ")"});
      }
      if (s.video && pictures.video_gap.empty()) {
        constexpr int kFps = 20;
        const double dt = t.size() > 1 ? t[1] - t[0] : 0.01;
        const std::size_t every =
            std::max<std::size_t>(1, static_cast<std::size_t>(std::lround(1.0 / (kFps * dt))));
        Renderer r(plant, 480, 270, true);
        const std::string file = "video_" + s.name + ".mp4";
        VideoWriter video(out + "/" + file, 480, 270, kFps, figuresTimeLimit());
        for (std::size_t row = 0; row < t.size(); row += every) {
          throwIfInterrupted();
          video.add(r.render(log, row, s.title + "  t = " + decimalText(t[row], 1) + " s"));
          if (row % (every * 25) == 0) {
            rbar.update((i + static_cast<double>(row) / t.size()) / n, s.name + " video");
          }
        }
        video.finish();
        pictures.videos.push_back({file, s.title + " (" + decimalText(t.back() - t.front(), 1) +
                                             " s at real speed, " + std::to_string(kFps) +
                                             " frames/s)"});
      }
    } catch (const Interrupted&) {
      throw;
    } catch (const std::exception& e) {
      warn(s.name + ": pictures failed: " + e.what());
      pictures.failures.push_back(s.name + ": " + e.what());
    }
    rbar.update((i + 1) / n, s.name);
  }
  rbar.finish("done");
  return pictures;
}

/// Writes an interactive 3D page (DIR/replay_<name>.html) for each run that left a log and
/// a replay.json; a page that fails is listed, not fatal.
ReportReplays writeReplayPages(const ReportInputs& in, const std::vector<RunOutcome>& outcomes) {
  ReportReplays replays;
  for (std::size_t i = 0; i < in.set.scenarios.size(); ++i) {
    const Scenario& s = in.set.scenarios[i];
    if (!outcomes[i].log || !fs::exists(outcomes[i].dir + "/replay.json")) continue;
    const std::string file = "replay_" + s.name + ".html";
    try {
      writeReplayPage(outcomes[i].dir, in.out + "/" + file, s.name + ": " + s.title);
      replays.pages.push_back({file, s.title});
    } catch (const OutputError&) {
      throw;  // a page that cannot be written (full disk): the report is not complete
    } catch (const std::exception& e) {
      warn(s.name + ": replay page failed: " + e.what());
      replays.failures.push_back(s.name + ": " + e.what());
    }
  }
  return replays;
}

/// The summary on stdout: runs passed and failed, the acceptance verdict, each run's result
/// and metrics, the margins. Returns the exit status (3 under --check when a run failed or
/// the acceptance was not met).
int printSummary(const ReportInputs& in, const ReportResults& r, bool check) {
  const std::vector<RunOutcome>& outcomes = r.outcomes;
  int failed = 0;
  for (const RunOutcome& o : outcomes) failed += o.passed() ? 0 : 1;
  std::printf("rollstep report: %zu runs, %d passed, %d failed", outcomes.size(),
              static_cast<int>(outcomes.size()) - failed, failed);
  // The runs' margins and, when trials were given, the candidate's trial success rate.
  const bool acceptance_met = r.verdict.met();
  if (r.verdict.judged()) std::printf("; acceptance %s", acceptance_met ? "met" : "NOT met");
  std::printf("\n");
  for (std::size_t i = 0; i < outcomes.size(); ++i) {
    std::printf("  %-22s %s%s\n", outcomes[i].name.c_str(),
                outcomes[i].passed() ? "passed" : "FAILED: ",
                outcomes[i].passed() ? "" : outcomes[i].failureText().c_str());
    if (outcomes[i].assessment.metrics) {
      const Table1Metrics& m = *outcomes[i].assessment.metrics;
      std::printf("  %-22s traverse %.2f s, mean |v_z| %.4f m/s, mean |w_y| %.4f rad/s\n", "",
                  m.traverse_time, m.mean_abs_vz, m.mean_abs_wy);
    }
  }
  std::string margins;  // each margin's verdict
  for (const MarginVerdict& m : r.verdict.margins) {
    margins += (margins.empty() ? "" : "; ") + m.metric + " " + percentText(m.change) +
               " (at most " + percentText(m.margin) + ") " + (m.met ? "met" : "not met");
  }
  if (!margins.empty()) std::printf("  margins    %s\n", margins.c_str());
  if (r.verdict.sweep.judged) {
    const SweepVerdict& s = r.verdict.sweep;
    std::string ratios;
    for (const SweepRatio& x : s.ratios) {
      ratios += (ratios.empty() ? "" : "; ") + x.metric + " at " + decimalText(x.speed, 2) + " " +
                (x.compared ? decimalText(x.ratio, 2) + "x " + (x.met ? "met" : "not met")
                            : std::string("not compared"));
    }
    const std::string fastest = s.fastest_compared
                                    ? decimalText(s.candidate_time, 2) + " s at " +
                                          decimalText(s.candidate_speed, 2) + " m/s vs " +
                                          decimalText(s.baseline_time, 2) + " s at " +
                                          decimalText(s.baseline_speed, 2) + " m/s "
                                    : std::string();
    std::printf("  speed sweep %s%sfastest passing %s%s\n", ratios.c_str(),
                ratios.empty() ? "" : "; ", fastest.c_str(), s.fastest_met ? "met" : "not met");
  }
  std::printf("  report     %s/report.html (also report.md)\n", in.out.c_str());
  std::fflush(stdout);
  if (check && (failed > 0 || !acceptance_met)) return 3;
  return 0;
}

/// The report's stages in order, into the folder runReport prepared.
int writeReport(const ReportInputs& in, bool check) {
  std::error_code ec;
  fs::create_directories(in.out + "/runs", ec);
  if (ec) throw OutputError("'" + in.out + "/runs': cannot create the directory: " + ec.message());

  ReportResults results;
  results.outcomes = runScenarios(in);
  results.figures_gap = drawFigures(in, results.outcomes);
  results.pictures = renderSnapshotsAndVideos(in, results.outcomes);
  results.replays = writeReplayPages(in, results.outcomes);
  results.verdict = judgeAcceptance(in, results.outcomes);

  const ComposedReport report = composeReport(in, results);
  for (const std::string& w : report.warnings) warn(w);
  writeFileAtomically(in.out + "/report.md", report.document.markdown());
  writeFileAtomically(in.out + "/report.html", report.document.html("rollstep report"));

  return printSummary(in, results, check);
}

/// Loads and checks the inputs, prepares the report's folder (its old files removed; on any
/// failure DIR/FAILED says why) and writes the report.
int runReport(const ReportOptions& o, const std::vector<std::string>& argv) {
  // Inputs first: nothing is written before they load.
  const ReportInputs in = loadInputs(o, argv);

  // The report's files as a whole: removed now, written at the end; a run that fails or is
  // interrupted leaves DIR/FAILED with the reason instead (each run's folder its own).
  const OutputFolder folder(
      "report", in.out,
      {"report.md", "report.html", "figures.json", "figures.log", "figures.err", "fig2.png",
       "fig4.png", "fig6.png", "fig8.png", "map.png", "speed_sweep.png", "snapshots_*", "video_*",
       "replay.js", "replay_*"});
  folder.create();
  folder.begin();
  try {
    return writeReport(in, o.check);
  } catch (const std::exception& e) {
    folder.fail(e.what());
    throw;
  }
}

}  // namespace

void registerReportCommand(CLI::App& app, int& exit_status) {
  auto options = std::make_shared<ReportOptions>();
  options->experiments = defaultExperimentsFile();
  CLI::App* cmd = app.add_subcommand(
      "report",
      "Run the paper's experiments (config/experiments.yaml: step20 with both controllers, "
      "stairs2, the integrator comparison) in deterministic mode and write a self-contained "
      "report: DIR/report.html and DIR/report.md (Table 1, Fig. 2/4/6/8-like figures, "
      "snapshots, videos, the exact commands, configuration and version).");
  cmd->footer(
      "Each run is a `rollstep sim` child process writing DIR/runs/<scenario>/; a failed run is "
      "reported as failed with its reason. Figures need /usr/bin/python3 with matplotlib, "
      "snapshots and videos OSMesa and ffmpeg: without them the report says they are not "
      "available. The figure script may run ROLLSTEP_FIGURES_TIME_LIMIT seconds (default "
      "600), ffmpeg as long per video. The report's files are replaced as a whole: a report "
      "that fails or is interrupted leaves DIR/FAILED with the reason instead. Exit status: 0 "
      "when the report was written (with --check: 3 if a run failed or the acceptance criteria "
      "were not met), 1 on bad options or inputs, 128 + the signal when interrupted.");
  cmd->add_option("--out", options->out, "Output directory (created if needed)")
      ->required()
      ->check(kNotEmpty);
  cmd->add_option("--experiments", options->experiments,
                  "The experiments file (scenarios, criteria, acceptance margins, trial ranges)")
      ->check(kNotEmpty)
      ->capture_default_str();
  cmd->add_flag("!--no-videos", options->videos, "Skip the MP4 videos (snapshots are still made)");
  cmd->add_option("--only", options->only,
                  "Run only these scenarios (names of the experiments file), e.g. --only "
                  "step20_nmpc,step20_cbfqp")
      ->delimiter(',');
  cmd->add_option("--trials", options->trials,
                  "Include the randomized trials whose result files are under DIR (repeatable; "
                  "written by `rollstep trials`)")
      ->check(kNotEmpty);
  cmd->add_flag("--check", options->check,
                "Exit with status 3 if a run failed or the acceptance criteria were not met");
  cmd->add_option("--robot", options->robot, kRobotOptionHelp)->check(kNotEmpty);
  cmd->final_callback([options, &exit_status, &app] {
    (void)app;
    std::vector<std::string> argv = {"rollstep",   "report",        "--out",
                                     options->out, "--experiments", options->experiments};
    if (!options->videos) argv.push_back("--no-videos");
    if (options->check) argv.push_back("--check");
    if (!options->robot.empty()) argv.insert(argv.end(), {"--robot", options->robot});
    for (const std::string& d : options->trials) argv.insert(argv.end(), {"--trials", d});
    if (!options->only.empty()) {
      std::string names;
      for (const std::string& n : options->only) names += (names.empty() ? "" : ",") + n;
      argv.insert(argv.end(), {"--only", names});
    }
    exit_status = runReport(*options, argv);
  });
}

}  // namespace rollstep::apps
