// `rollstep report --out DIR`: the project's main job. Runs the experiments of
// config/experiments.yaml (each a `rollstep sim` child process in deterministic mode) with a
// progress bar, judges every run from its outputs, draws the figures (matplotlib, from
// apps/report/figures.py), renders snapshots and videos (MuJoCo offscreen, ffmpeg), and
// writes DIR/report.md and DIR/report.html with the same content. A failed run is shown as
// failed with its reason; nothing is invented; a missing tool is a stated gap, not a crash.
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
#include "experiments/document.hpp"
#include "experiments/process.hpp"
#include "experiments/render.hpp"
#include "experiments/replay.hpp"
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
};

std::string fixed(double v, int digits) {
  if (!std::isfinite(v)) return "-";
  char text[64];
  std::snprintf(text, sizeof text, "%.*f", digits, v);
  return text;
}

std::string percent(double v) {
  if (!std::isfinite(v)) return "-";
  char text[64];
  std::snprintf(text, sizeof text, "%+.0f %%", 100.0 * v);
  return text;
}

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
  j["passed"] = o.passed();
  j["failure"] = o.failureText();
  if (o.log && o.assessment.window.found) {
    j["window"] = {rounded(o.assessment.window.start, 4), rounded(o.assessment.window.end, 4)};
  } else {
    j["window"] = nullptr;
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

/// The figure script's complaint about figure `name` ("fig2: KeyError: ..."), or "".
std::string figureError(const std::string& out, const std::string& name) {
  std::ifstream err(out + "/figures.err");
  std::string line;
  while (std::getline(err, line)) {
    if (line.rfind(name + ": ", 0) == 0) return line.substr(name.size() + 2);
  }
  return "";
}

/// What one MPC update of each Fig. 6 run did, from its own outputs: the horizon from its
/// summary ("N = 100") and the Newton iterations of its updates after the first, converging
/// solve (mpc.csv), e.g. "step20_nmpc: N = 100, 2 real-time iterations per update".
std::string mpcUpdateDescription(const ExperimentSet& set,
                                 const std::vector<RunOutcome>& outcomes) {
  std::string text;
  for (std::size_t i = 0; i < set.scenarios.size() && i < outcomes.size(); ++i) {
    const RunOutcome& o = outcomes[i];
    if (!set.scenarios[i].feeds("fig6") || !o.mpc || !o.mpc->has("iterations[-]")) continue;
    const std::vector<double>& iterations = o.mpc->column("iterations[-]");
    int least = 0, most = 0;
    for (std::size_t r = 1; r < iterations.size(); ++r) {
      if (!(iterations[r] >= 1)) continue;  // NaN or a failed update
      const int k = static_cast<int>(iterations[r]);
      least = least == 0 ? k : std::min(least, k);
      most = std::max(most, k);
    }
    if (most == 0) continue;
    std::string what = set.scenarios[i].name + ": ";
    const std::string horizon_key = ", N = ";  // summary.txt's first line
    if (const std::size_t n = o.summary.find(horizon_key); n != std::string::npos) {
      const std::size_t from = n + horizon_key.size();
      const std::size_t end = o.summary.find_first_not_of("0123456789", from);
      what += "N = " + o.summary.substr(from, end - from) + ", ";
    }
    what += least == most ? std::to_string(most)
                          : std::to_string(least) + " to " + std::to_string(most);
    what += most == 1 ? " real-time iteration per update" : " real-time iterations per update";
    text += (text.empty() ? "" : "; ") + what;
  }
  return text;
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

int writeReport(const ReportOptions& o, const ExperimentSet& set, const Acceptance& file_acceptance,
                const std::vector<sim::SceneConfig>& scenes, const TrialCollection& trials,
                const std::vector<TrialAggregate>& trial_aggregates, const std::string& out,
                const std::vector<std::string>& argv);

int runReport(const ReportOptions& o, const std::vector<std::string>& argv) {
  // Inputs first: nothing is written before they load.
  ExperimentSet set = loadExperimentSet(o.experiments);
  // The file's acceptance, whatever --only keeps: its trial part is judged on trial results.
  const Acceptance file_acceptance = set.acceptance;
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
  std::vector<sim::SceneConfig> scenes;
  for (const Scenario& s : set.scenarios) scenes.push_back(sceneOf(s));
  // Trial results to include (read now: a bad result file is an input error, found before
  // anything is deleted; unfinished trials are listed in the report).
  TrialCollection trials;
  std::vector<TrialAggregate> trial_aggregates;
  if (!o.trials.empty()) {
    trials = collectTrials(o.trials);
    for (const UncountedTrial& u : trials.uncounted) {
      if (u.unreadable) throw InputError("--trials: trial folder '" + u.dir + "': " + u.reason);
    }
    trial_aggregates = aggregate(trials.results);
  }

  (void)figuresTimeLimit();  // a bad ROLLSTEP_FIGURES_TIME_LIMIT is an input error too

  // The report's files as a whole: removed now, written at the end; a run that fails or is
  // interrupted leaves DIR/FAILED with the reason instead (each run's folder its own).
  const std::string out = fs::absolute(o.out).lexically_normal().string();
  const OutputFolder folder("report", out,
                            {"report.md", "report.html", "figures.json", "figures.log",
                             "figures.err", "fig2.png", "fig4.png", "fig6.png", "fig8.png",
                             "map.png", "snapshots_*", "video_*", "replay.js", "replay_*"});
  folder.create();
  folder.begin();
  try {
    return writeReport(o, set, file_acceptance, scenes, trials, trial_aggregates, out, argv);
  } catch (const std::exception& e) {
    folder.fail(e.what());
    throw;
  }
}

int writeReport(const ReportOptions& o, const ExperimentSet& set, const Acceptance& file_acceptance,
                const std::vector<sim::SceneConfig>& scenes, const TrialCollection& trials,
                const std::vector<TrialAggregate>& trial_aggregates, const std::string& out,
                const std::vector<std::string>& argv) {
  const std::vector<TrialResult>& trial_results = trials.results;
  std::error_code ec;
  fs::create_directories(out + "/runs", ec);
  if (ec) throw OutputError("'" + out + "/runs': cannot create the directory: " + ec.message());

  // 1. The runs.
  std::vector<RunOutcome> outcomes;
  ProgressBar bar("rollstep report: runs");
  const double n = static_cast<double>(set.scenarios.size());
  for (std::size_t i = 0; i < set.scenarios.size(); ++i) {
    const Scenario& s = set.scenarios[i];
    const std::string dir = out + "/runs/" + s.name;
    for (const char* f : {"log.csv", "mpc.csv", "summary.txt", "FAILED"}) {
      fs::remove(fs::path(dir) / f, ec);
    }
    bar.update(i / n, s.name + " starting (" + std::to_string(i + 1) + "/" +
                          std::to_string(set.scenarios.size()) + ")");
    outcomes.push_back(
        executeRun(s, scenes[i], dir, set.criteria, "", [&](double done, double total) {
          bar.update((i + done / total) / n,
                     s.name + " " + fixed(done, 1) + " of " + fixed(total, 1) + " s simulated");
        }));
    throwIfInterrupted();  // the run was interrupted with us: its outcome is not a result
    bar.update((i + 1) / n, s.name + (outcomes.back().passed() ? " passed" : " FAILED"));
  }
  bar.finish("all " + std::to_string(set.scenarios.size()) + " runs done");

  // 2. Figures (matplotlib).
  std::string figures_gap;
  {
    Json json;
    json["out"] = out;
    json["machine"] = machineDescription();
    json["runs"] = Json::object();
    for (std::size_t i = 0; i < set.scenarios.size(); ++i) {
      std::vector<JointLimit> limits;
      try {
        limits = jointLimits(scenes[i], robotOf(set.scenarios[i]));
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
    writeFileAtomically(out + "/figures.json", json.dump() + "\n");
    const std::string python = "/usr/bin/python3";
    const std::string script = figuresScript();
    if (!fs::exists(python)) {
      figures_gap =
          "/usr/bin/python3 is not installed (Debian packages python3, python3-matplotlib)";
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
        figures_gap = "the figure script did not end within " + fixed(limit, 0) +
                      " s (ROLLSTEP_FIGURES_TIME_LIMIT) and was stopped";
      } else if (status != 0) {
        std::ifstream err(out + "/figures.err");
        std::stringstream text;
        text << err.rdbuf();
        figures_gap =
            "the figure script failed (exit " + std::to_string(status) + "): " + text.str();
      }
    }
    if (!figures_gap.empty()) warn("figures not available: " + figures_gap);
  }

  // 3. Snapshots and videos (MuJoCo offscreen + ffmpeg).
  std::string render_gap, video_gap;
  std::vector<std::pair<std::string, std::string>> snapshots, videos;  // file, caption
  std::vector<std::string> video_failures;
  if (!Renderer::available(render_gap)) {
    warn("snapshots and videos not available: " + render_gap);
  } else {
    if (!o.videos)
      video_gap = "not made (--no-videos)";
    else if (!onPath("ffmpeg"))
      video_gap = "ffmpeg is not installed (Debian package ffmpeg)";
    if (o.videos && !video_gap.empty()) warn("videos not available: " + video_gap);
    ProgressBar rbar("rollstep report: pictures");
    for (std::size_t i = 0; i < set.scenarios.size(); ++i) {
      const Scenario& s = set.scenarios[i];
      const RunOutcome& run = outcomes[i];
      if (!run.log || run.log->rows() == 0) continue;
      try {
        sim::PlantOptions po;
        po.robot_file = robotOf(s);
        const sim::Plant plant(scenes[i], po);
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
            frames.push_back(r.render(log, row, "t = " + fixed(t[row], 2) + " s"));
          }
          const std::string file = "snapshots_" + s.name + ".png";
          writePng(out + "/" + file, tile(frames, 3));
          snapshots.emplace_back(
              file, s.title + ": six moments, evenly spaced from t = " + fixed(t0, 2) + " s to " +
                        fixed(t1, 2) + " s (" +
                        (w ? "the traverse window" : "the whole run: no traverse window") + ")");
        }
        if (s.video && video_gap.empty()) {
          constexpr int kFps = 20;
          const double dt = t.size() > 1 ? t[1] - t[0] : 0.01;
          const std::size_t every =
              std::max<std::size_t>(1, static_cast<std::size_t>(std::lround(1.0 / (kFps * dt))));
          Renderer r(plant, 480, 270, true);
          const std::string file = "video_" + s.name + ".mp4";
          VideoWriter video(out + "/" + file, 480, 270, kFps, figuresTimeLimit());
          for (std::size_t row = 0; row < t.size(); row += every) {
            throwIfInterrupted();
            video.add(r.render(log, row, s.title + "  t = " + fixed(t[row], 1) + " s"));
            if (row % (every * 25) == 0) {
              rbar.update((i + static_cast<double>(row) / t.size()) / n, s.name + " video");
            }
          }
          video.finish();
          videos.emplace_back(file, s.title + " (" + fixed(t.back() - t.front(), 1) +
                                        " s at real speed, " + std::to_string(kFps) + " frames/s)");
        }
      } catch (const Interrupted&) {
        throw;
      } catch (const std::exception& e) {
        warn(s.name + ": pictures failed: " + e.what());
        video_failures.push_back(s.name + ": " + e.what());
      }
      rbar.update((i + 1) / n, s.name);
    }
    rbar.finish("done");
  }

  // 4. The replay pages (interactive 3D, from each run's replay.json, log.csv, plan.csv).
  std::vector<std::pair<std::string, std::string>> replays;  // file, title
  std::vector<std::string> replay_failures;
  for (std::size_t i = 0; i < set.scenarios.size(); ++i) {
    const Scenario& s = set.scenarios[i];
    if (!outcomes[i].log || !fs::exists(outcomes[i].dir + "/replay.json")) continue;
    const std::string file = "replay_" + s.name + ".html";
    try {
      writeReplayPage(outcomes[i].dir, out + "/" + file, s.name + ": " + s.title);
      replays.emplace_back(file, s.title);
    } catch (const std::exception& e) {
      warn(s.name + ": replay page failed: " + e.what());
      replay_failures.push_back(s.name + ": " + e.what());
    }
  }

  // 5. The report.
  Document doc;
  doc.heading(1, "rollstep report: the paper's experiments in simulation");
  doc.paragraph(
      "Tachyon 3 in MuJoCo, reproducing Section 4 of the paper (full-centroidal NMPC + CBF-QP "
      "against CBF-QP alone). Every number below is computed from the runs' own outputs "
      "(`runs/<scenario>/log.csv`, `mpc.csv`, `summary.txt`); a run that failed is shown as failed "
      "with its reason.");
  doc.bullets({"Command: `" + shellCommand(argv) + "`", "Version: " + versionDescription(),
               "Machine: " + machineDescription(),
               "Experiments: `" + set.source + "` (quoted in full at the end)",
               "State and terrain sources: per run, in the table below (terrain: the scene's "
               "blocks as convex regions, or perception in closed loop from the simulated "
               "LiDAR)."});

  doc.heading(2, "Runs");
  {
    std::vector<std::vector<std::string>> rows;
    for (std::size_t i = 0; i < outcomes.size(); ++i) {
      const RunOutcome& r = outcomes[i];
      rows.push_back({set.scenarios[i].name, set.scenarios[i].title, set.scenarios[i].terrainText(),
                      r.passed() ? "passed" : "**FAILED**",
                      r.passed() ? "no fall, body clear of the terrain, joints inside limits" +
                                       std::string(set.scenarios[i].traverse ? ", traversed" : "")
                                 : r.failureText()});
    }
    doc.table({"scenario", "what", "terrain", "result", "criteria / reason"}, rows);
    doc.paragraph(
        "Pass criteria: no fall (base tilt at most " +
        fixed(set.criteria.max_tilt * 180.0 / M_PI, 0) +
        " deg), the body never touched the terrain (`body_contact_periods` stays 0), every "
        "joint inside its MJCF range (tolerance " +
        fixed(set.criteria.joint_limit_tolerance, 3) +
        " rad or m), and for the step scenarios the traverse completed.");
  }

  doc.heading(2, "Table 1: step traverse");
  doc.paragraph(
      "Traverse time: from the first MF lift-off for the climb to the last MR touch-down after the "
      "descent; mean |v_z| and mean |w_y|: base local frame, over that window (paper's Table 1).");
  {
    std::vector<std::vector<std::string>> rows;
    for (std::size_t i = 0; i < set.scenarios.size(); ++i) {
      const Scenario& s = set.scenarios[i];
      if (!s.feeds("table1")) continue;
      const RunOutcome& r = outcomes[i];
      const auto& m = r.assessment.metrics;
      const bool have = r.log && m.has_value();
      const std::string paper_t = s.paper.given ? fixed(s.paper.traverse_time, 0) : "-";
      rows.push_back({s.title, have ? fixed(m->traverse_time, 2) : "not measured", paper_t,
                      have ? fixed(m->mean_abs_vz, 4) : "not measured",
                      s.paper.given ? fixed(s.paper.mean_abs_vz, 3) : "-",
                      have ? fixed(m->mean_abs_wy, 4) : "not measured",
                      s.paper.given ? fixed(s.paper.mean_abs_wy, 3) : "-",
                      r.passed() ? "passed" : "**FAILED**: " + r.failureText()});
    }
    doc.table({"controller", "traverse time [s]", "paper", "mean |v_z| [m/s]", "paper",
               "mean |w_y| [rad/s]", "paper", "run"},
              rows);
  }
  bool acceptance_met = true;
  std::string margins;  // each margin's verdict, for the summary on stdout
  if (set.acceptance.given) {
    const Acceptance& a = set.acceptance;
    doc.heading(3, "Acceptance");
    std::size_t ci = 0, bi = 0;
    for (std::size_t i = 0; i < set.scenarios.size(); ++i) {
      if (set.scenarios[i].name == a.candidate) ci = i;
      if (set.scenarios[i].name == a.baseline) bi = i;
    }
    const RunOutcome& c = outcomes[ci];
    const RunOutcome& b = outcomes[bi];
    if (!c.passed() || !b.passed() || !c.assessment.metrics || !b.assessment.metrics) {
      acceptance_met = false;
      doc.paragraph("**Not met**: " + a.candidate + " and " + a.baseline +
                    " must both pass to be compared (" + a.candidate + ": " +
                    (c.passed() ? "passed" : c.failureText()) + "; " + a.baseline + ": " +
                    (b.passed() ? "passed" : b.failureText()) + ").");
    } else {
      const Table1Metrics& cm = *c.assessment.metrics;
      const Table1Metrics& bm = *b.assessment.metrics;
      std::vector<std::vector<std::string>> rows;
      const auto row = [&](const char* what, double cv, double bv, double need) {
        const double change = relativeChange(cv, bv);
        const bool ok = meetsMargin(change, need);
        acceptance_met = acceptance_met && ok;
        rows.push_back(
            {what, percent(change), "at most " + percent(need), ok ? "met" : "**not met**"});
        margins += (margins.empty() ? "" : "; ") + std::string(what) + " " + percent(change) +
                   " (at most " + percent(need) + ") " + (ok ? "met" : "not met");
      };
      row("traverse time", cm.traverse_time, bm.traverse_time, a.traverse_time);
      row("mean |v_z|", cm.mean_abs_vz, bm.mean_abs_vz, a.mean_abs_vz);
      row("mean |w_y|", cm.mean_abs_wy, bm.mean_abs_wy, a.mean_abs_wy);
      doc.table({a.candidate + " vs " + a.baseline, "change", "required", "result"}, rows);
      // The traverse time is bounded by the distance the window spans and the speed the
      // robot may go: say what the margin asks of the candidate.
      if (cm.traverse_time > 0 && bm.traverse_time > 0 && a.traverse_time > -1) {
        doc.paragraph(
            "Mean speed over the traverse window (base travel / traverse time): " + a.candidate +
            " " + fixed(cm.distance, 3) + " m in " + fixed(cm.traverse_time, 2) + " s, " +
            fixed(cm.distance / cm.traverse_time, 3) + " m/s; " + a.baseline + " " +
            fixed(bm.distance, 3) + " m in " + fixed(bm.traverse_time, 2) + " s, " +
            fixed(bm.distance / bm.traverse_time, 3) + " m/s. The traverse margin asks " +
            a.candidate + " to cover its window in " +
            fixed((1 + a.traverse_time) * bm.traverse_time, 2) + " s, a mean speed of " +
            fixed(cm.distance / ((1 + a.traverse_time) * bm.traverse_time), 3) +
            " m/s; compare the commanded speed in the scenarios' commands below.");
      }
    }
  }

  const auto figure = [&](const std::string& file, const std::string& caption,
                          const std::string& needs) {
    if (fs::exists(out + "/" + file)) {
      doc.image(file, caption);
    } else if (!figures_gap.empty()) {
      doc.paragraph("Figure not available: " + figures_gap);
    } else if (const std::string why = figureError(out, file.substr(0, file.find('.')));
               !why.empty()) {
      doc.paragraph("Figure not drawn: " + why);
      warn("figure " + file + " not drawn: " + why);
    } else {
      doc.paragraph("Figure not drawn: " + needs);
    }
  };
  doc.heading(2, "Fig. 2: step20 time histories");
  figure("fig2.png",
         "Base local v_z, base local w_y, MF and MR wheel heights over time for each controller "
         "(shaded: the traverse window).",
         "no table1 run left a log");
  doc.heading(2, "Fig. 4: stairs2 histories");
  figure("fig4.png",
         "Base velocity (local), joint positions with their limits dashed, wheel heights.",
         "no fig4 run left a log");
  doc.heading(2, "Fig. 6: CPU time of every MPC update");
  const std::string updates = mpcUpdateDescription(set, outcomes);
  figure("fig6.png",
         "Wall time of each MPC update over the run" +
             (updates.empty() ? std::string() : " (" + updates + ")") + ", on " +
             machineDescription() +
             ". Machine-dependent: the one set of numbers in this report that re-running does not "
             "reproduce exactly.",
         "no fig6 run left an mpc.csv");
  doc.heading(2, "Fig. 8: joint commands with and without the internal state integrator");
  figure("fig8.png",
         "Target (command) and actual joint positions with the internal state integrator and with "
         "naive state feedback (`--integrator naive`).",
         "no fig8 run left a log");

  doc.heading(2, "Perception: top view");
  figure("map.png",
         "The elevation map (colour: height), the convex foothold regions in use (outlines) and "
         "the planned footholds (crosses) at three moments of each run with terrain perception "
         "(`runs/<scenario>/map/`, docs/PERCEPTION.md).",
         "no map run (figures: [map], terrain: perception) left a map log");

  doc.heading(2, "Snapshots");
  if (!render_gap.empty()) {
    doc.paragraph("Snapshots not available: " + render_gap);
  } else if (snapshots.empty()) {
    doc.paragraph("No snapshots: no snapshots run left a log.");
  }
  for (const auto& [file, caption] : snapshots) doc.image(file, caption);
  doc.heading(2, "Videos");
  if (!render_gap.empty()) {
    doc.paragraph("Videos not available: " + render_gap);
  } else if (!video_gap.empty()) {
    doc.paragraph("Videos not available: " + video_gap);
  }
  for (const auto& [file, caption] : videos) doc.video(file, caption);
  for (const std::string& f : video_failures) doc.paragraph("Pictures failed: " + f);
  doc.heading(2, "Replays");
  doc.paragraph(
      "Each run in 3D, in the browser from disk: the robot drawn from its model file, the "
      "terrain, the contact forces, the foothold regions and the MPC's plan in use at the "
      "time of a slider, with plots of the main signals (docs/REPLAY.md).");
  if (replays.empty() && replay_failures.empty()) doc.paragraph("No run left a replay.");
  {
    std::vector<std::string> links;
    for (const auto& [file, title] : replays) links.push_back("[" + title + "](" + file + ")");
    if (!links.empty()) doc.bullets(links);
  }
  for (const std::string& f : replay_failures) doc.paragraph("Replay failed: " + f);

  bool trials_met = true;
  doc.heading(2, "Randomized trials");
  if (o.trials.empty()) {
    doc.paragraph(
        "No trials in this report: run `rollstep trials --scenario step20 --controller nmpc "
        "--seeds 0-29 --out DIR` (and the same with the other controller), then `rollstep report "
        "--trials DIR`.");
  } else {
    std::string from;
    for (const std::string& d : o.trials) {
      const std::string text = literalText(d);  // a folder's name shown as it is
      from +=
          (from.empty() ? "" : ", ") + (!text.empty() && text[0] == '`' ? text : "`" + text + "`");
    }
    doc.paragraph("Results collected from " + from +
                  " (step height, friction, start offset and sensor noise scale drawn from each "
                  "trial's seed; the sensor noise reaches the runs whose state comes from the "
                  "estimator, `--state-source inekf`). Metrics over the passed "
                  "trials: mean ± sample standard deviation (min to max).");
    std::vector<std::vector<std::string>> rows;
    const auto cell = [](const Spread& s, int digits) {
      if (s.n == 0) return std::string("-");
      return fixed(s.mean, digits) + " ± " + fixed(s.stddev, digits) + " (" + fixed(s.min, digits) +
             " to " + fixed(s.max, digits) + ")";
    };
    for (const TrialAggregate& a : trial_aggregates) {
      rows.push_back({a.scenario, a.controller, std::to_string(a.trials), std::to_string(a.passed),
                      fixed(100.0 * a.successRate(), 1) + " %", cell(a.traverse_time, 2),
                      cell(a.mean_abs_vz, 4), cell(a.mean_abs_wy, 4)});
    }
    doc.table({"scenario", "controller", "trials", "passed", "success rate", "traverse time [s]",
               "mean |v_z| [m/s]", "mean |w_y| [rad/s]"},
              rows);
    if (!trials.uncounted.empty()) {
      doc.paragraph("Not counted: " + std::to_string(trials.uncounted.size()) + " of " +
                    std::to_string(trials.folders) + " trial folders hold no result:");
      std::vector<std::string> items;
      for (const UncountedTrial& u : trials.uncounted) {
        items.push_back(literalText(u.dir) + ": " + literalText(u.reason));
      }
      doc.bullets(items);
    }
    for (const TrialAggregate& a : trial_aggregates) {
      if (!a.failures.empty()) {
        doc.paragraph("Failed trials of " + a.scenario + ":");
        doc.bullets(a.failures);
      }
    }
    if (file_acceptance.given) {
      // The acceptance's trial part: the candidate's success rate; beside it the Table 1
      // margins over the seeds both controllers passed (the same terrains), for reference.
      const Acceptance& a = file_acceptance;
      const PairedComparison c = compareTrials(trial_results, a.candidate, a.baseline);
      doc.heading(3, "Acceptance over the trials");
      if (c.candidate_trials == 0) {
        trials_met = false;
        doc.paragraph("**Not met**: no trials of " + a.candidate + " among the results.");
      } else {
        const bool ok = c.candidateSuccessRate() >= a.trial_success_rate;
        trials_met = ok;
        std::string text = a.candidate + ": " + std::to_string(c.candidate_passed) + " of " +
                           std::to_string(c.candidate_trials) + " trials passed (" +
                           fixed(100.0 * c.candidateSuccessRate(), 1) + " %; required at least " +
                           fixed(100.0 * a.trial_success_rate, 1) +
                           " %): " + (ok ? "met" : "**not met**") + ".";
        if (c.baseline_trials > 0) {
          text += " " + a.baseline + ": " + std::to_string(c.baseline_passed) + " of " +
                  std::to_string(c.baseline_trials) + " passed (" +
                  fixed(100.0 * c.baselineSuccessRate(), 1) + " %).";
        }
        doc.paragraph(text);
      }
      if (c.paired > 0) {
        std::vector<std::vector<std::string>> paired_rows;
        const auto row = [&](const char* what, double cv, double bv, double need, int digits) {
          const double change = relativeChange(cv, bv);
          const bool ok = meetsMargin(change, need);
          paired_rows.push_back({what, fixed(cv, digits), fixed(bv, digits), percent(change),
                                 "at most " + percent(need), ok ? "met" : "not met"});
        };
        row("traverse time [s]", c.candidate_traverse_time, c.baseline_traverse_time,
            a.traverse_time, 2);
        row("mean |v_z| [m/s]", c.candidate_mean_abs_vz, c.baseline_mean_abs_vz, a.mean_abs_vz, 4);
        row("mean |w_y| [rad/s]", c.candidate_mean_abs_wy, c.baseline_mean_abs_wy, a.mean_abs_wy,
            4);
        doc.paragraph("Table 1 over the " + std::to_string(c.paired) +
                      " seeds that both controllers passed (the same step height, friction and "
                      "start offset for both; means). For reference: the margins are judged on "
                      "the single runs above.");
        doc.table({"metric", a.candidate, a.baseline, "change", "margin", "result"}, paired_rows);
      } else if (c.baseline_trials > 0) {
        doc.paragraph("No seed passed by both " + a.candidate + " and " + a.baseline + " (of " +
                      std::to_string(c.common) + " run by both): no paired Table 1.");
      }
    }
  }

  doc.heading(2, "How each run was made");
  for (std::size_t i = 0; i < outcomes.size(); ++i) {
    const RunOutcome& r = outcomes[i];
    doc.heading(3, set.scenarios[i].name);
    doc.paragraph("Outputs: `runs/" + set.scenarios[i].name + "/`; exit status " +
                  std::to_string(r.exit_status) + ".");
    doc.code(r.command);
    if (!r.summary.empty()) doc.code(r.summary);
    if (!r.error.empty()) doc.paragraph("Error: " + r.error);
  }
  doc.heading(2, "Configuration");
  doc.paragraph("The experiments file `" + set.source +
                "`. Settings not given in a run's options are the defaults documented in "
                "`config/control.yaml`, `config/ocp.yaml` and the robot files of `robots/`.");
  doc.code(set.text);

  writeFileAtomically(out + "/report.md", doc.markdown());
  writeFileAtomically(out + "/report.html", doc.html("rollstep report"));

  int failed = 0;
  for (const RunOutcome& r : outcomes) failed += r.passed() ? 0 : 1;
  std::printf("rollstep report: %zu runs, %d passed, %d failed", outcomes.size(),
              static_cast<int>(outcomes.size()) - failed, failed);
  // The runs' margins and, when trials were given, the candidate's trial success rate.
  const bool judged = set.acceptance.given || (file_acceptance.given && !o.trials.empty());
  acceptance_met = acceptance_met && trials_met;
  if (judged) std::printf("; acceptance %s", acceptance_met ? "met" : "NOT met");
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
  if (!margins.empty()) std::printf("  margins    %s\n", margins.c_str());
  std::printf("  report     %s/report.html (also report.md)\n", out.c_str());
  std::fflush(stdout);
  if (o.check && (failed > 0 || !acceptance_met)) return 3;
  return 0;
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
  cmd->final_callback([options, &exit_status, &app] {
    (void)app;
    std::vector<std::string> argv = {"rollstep",   "report",        "--out",
                                     options->out, "--experiments", options->experiments};
    if (!options->videos) argv.push_back("--no-videos");
    if (options->check) argv.push_back("--check");
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
