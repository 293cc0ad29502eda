#include "report_document.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include "metrics.hpp"
#include "process.hpp"

namespace rollstep::experiments {

namespace {

namespace fs = std::filesystem;

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

/// The title, what the report reproduces, and the command, version and machine that made it:
/// enough to make the same report again.
void addIntroduction(Document& doc, const ReportInputs& in) {
  doc.heading(1, "rollstep report: the paper's experiments in simulation");
  doc.paragraph(
      "Tachyon 3 in MuJoCo, reproducing Section 4 of the paper (full-centroidal NMPC + CBF-QP "
      "against CBF-QP alone). Every number below is computed from the runs' own outputs "
      "(`runs/<scenario>/log.csv`, `mpc.csv`, `summary.txt`); a run that failed is shown as failed "
      "with its reason.");
  doc.bullets({"Command: `" + shellCommand(in.argv) + "`", "Version: " + versionDescription(),
               "Machine: " + machineDescription(),
               "Experiments: `" + in.set.source + "` (quoted in full at the end)",
               "State and terrain sources: per run, in the table below (terrain: the scene's "
               "blocks as convex regions, or perception in closed loop from the simulated "
               "LiDAR)."});
}

/// Every run passed or failed with its reason, and the criteria it was judged on.
void addRuns(Document& doc, const ReportInputs& in, const std::vector<RunOutcome>& outcomes) {
  const ExperimentSet& set = in.set;
  doc.heading(2, "Runs");
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
  doc.paragraph("Pass criteria: no fall (base tilt at most " +
                decimalText(set.criteria.max_tilt * 180.0 / M_PI, 0) +
                " deg), the body never touched the terrain (`body_contact_periods` stays 0), every "
                "joint inside its MJCF range (tolerance " +
                decimalText(set.criteria.joint_limit_tolerance, 3) +
                " rad or m), and for the step scenarios the traverse completed.");
}

/// The paper's Table 1 for the runs that feed it, beside the paper's figures; a run without
/// metrics says "not measured" rather than a number.
void addTable1(Document& doc, const ReportInputs& in, const std::vector<RunOutcome>& outcomes) {
  doc.heading(2, "Table 1: step traverse");
  doc.paragraph(
      "Traverse time: from the first MF lift-off for the climb to the last MR touch-down after the "
      "descent; mean |v_z| and mean |w_y|: base local frame, over that window (paper's Table 1).");
  std::vector<std::vector<std::string>> rows;
  for (std::size_t i = 0; i < in.set.scenarios.size(); ++i) {
    const Scenario& s = in.set.scenarios[i];
    if (!s.feeds("table1")) continue;
    const RunOutcome& r = outcomes[i];
    const auto& m = r.assessment.metrics;
    const bool have = r.log && m.has_value();
    const std::string paper_t = s.paper.given ? decimalText(s.paper.traverse_time, 0) : "-";
    rows.push_back({s.title, have ? decimalText(m->traverse_time, 2) : "not measured", paper_t,
                    have ? decimalText(m->mean_abs_vz, 4) : "not measured",
                    s.paper.given ? decimalText(s.paper.mean_abs_vz, 3) : "-",
                    have ? decimalText(m->mean_abs_wy, 4) : "not measured",
                    s.paper.given ? decimalText(s.paper.mean_abs_wy, 3) : "-",
                    r.passed() ? "passed" : "**FAILED**: " + r.failureText()});
  }
  doc.table({"controller", "traverse time [s]", "paper", "mean |v_z| [m/s]", "paper",
             "mean |w_y| [rad/s]", "paper", "run"},
            rows);
}

/// The acceptance on the runs: each margin's verdict, or why the two runs could not be
/// compared; and what the traverse margin asks of the candidate's speed.
void addRunAcceptance(Document& doc, const ReportInputs& in,
                      const std::vector<RunOutcome>& outcomes, const ReportVerdict& verdict) {
  if (!verdict.runs_given) return;
  const Acceptance& a = in.set.acceptance;
  doc.heading(3, "Acceptance");
  const RunOutcome& c = outcomes[verdict.candidate];
  const RunOutcome& b = outcomes[verdict.baseline];
  if (!verdict.runs_compared) {
    doc.paragraph("**Not met**: " + a.candidate + " and " + a.baseline +
                  " must both pass to be compared (" + a.candidate + ": " +
                  (c.passed() ? "passed" : c.failureText()) + "; " + a.baseline + ": " +
                  (b.passed() ? "passed" : b.failureText()) + ").");
    return;
  }
  const Table1Metrics& cm = *c.assessment.metrics;
  const Table1Metrics& bm = *b.assessment.metrics;
  std::vector<std::vector<std::string>> rows;
  for (const MarginVerdict& m : verdict.margins) {
    rows.push_back({m.metric, percentText(m.change), "at most " + percentText(m.margin),
                    m.met ? "met" : "**not met**"});
  }
  doc.table({a.candidate + " vs " + a.baseline, "change", "required", "result"}, rows);
  // The traverse time is bounded by the distance the window spans and the speed the
  // robot may go: say what the margin asks of the candidate.
  if (cm.traverse_time > 0 && bm.traverse_time > 0 && a.traverse_time > -1) {
    doc.paragraph(
        "Mean speed over the traverse window (base travel / traverse time): " + a.candidate + " " +
        decimalText(cm.distance, 3) + " m in " + decimalText(cm.traverse_time, 2) + " s, " +
        decimalText(cm.distance / cm.traverse_time, 3) + " m/s; " + a.baseline + " " +
        decimalText(bm.distance, 3) + " m in " + decimalText(bm.traverse_time, 2) + " s, " +
        decimalText(bm.distance / bm.traverse_time, 3) + " m/s. The traverse margin asks " +
        a.candidate + " to cover its window in " +
        decimalText((1 + a.traverse_time) * bm.traverse_time, 2) + " s, a mean speed of " +
        decimalText(cm.distance / ((1 + a.traverse_time) * bm.traverse_time), 3) +
        " m/s; compare the commanded speed in the scenarios' commands below.");
  }
}

/// The speed sweep: per commanded speed each controller's result and Table 1 metrics, the
/// figure, and the comparison's verdicts, computed from the runs.
void addSpeedSweep(Document& doc, const ReportInputs& in, const ReportResults& results,
                   std::vector<std::string>& warnings) {
  const SpeedSweep& sweep = in.set.sweep;
  const std::vector<SweepSeries>& series = results.verdict.sweep_series;
  if (!sweep.given || series.empty()) return;
  doc.heading(2, "Speed sweep");
  doc.paragraph(
      "Each controller's scenario run again at each commanded speed (its command scaled to the "
      "speed, the run's duration scaled back, plus " +
      decimalText(kTrialSpeedMargin, 0) +
      " s). Traverse time, mean |v_z| and mean |w_y| as in Table 1; a failed run shows its "
      "reason.");
  std::vector<std::string> header = {"speed [m/s]"};
  for (const SweepSeries& s : series) {
    for (const char* column : {"", " traverse [s]", " mean |v_z| [m/s]", " mean |w_y| [rad/s]"}) {
      header.push_back(s.title + column);
    }
  }
  std::vector<double> speeds;
  for (const SweepSeries& s : series) {
    for (const SweepPoint& p : s.points) {
      if (std::none_of(speeds.begin(), speeds.end(),
                       [&](double v) { return std::abs(v - p.speed) < 1e-9; })) {
        speeds.push_back(p.speed);
      }
    }
  }
  std::sort(speeds.begin(), speeds.end());
  std::vector<std::vector<std::string>> rows;
  for (double speed : speeds) {
    std::vector<std::string> row = {decimalText(speed, 2)};
    for (const SweepSeries& s : series) {
      const SweepPoint* p = s.at(speed);
      if (p == nullptr) {
        row.insert(row.end(), {"not run", "-", "-", "-"});
        continue;
      }
      const bool have = p->metrics.has_value();
      row.push_back(p->passed ? "passed" : "**FAILED**: " + p->failure);
      row.push_back(have ? decimalText(p->metrics->traverse_time, 2) : "not measured");
      row.push_back(have ? decimalText(p->metrics->mean_abs_vz, 4) : "not measured");
      row.push_back(have ? decimalText(p->metrics->mean_abs_wy, 4) : "not measured");
    }
    rows.push_back(row);
  }
  doc.table(header, rows);
  const std::string figure = "speed_sweep.png";
  if (fs::exists(in.out + "/" + figure)) {
    doc.image(figure,
              "Traverse time, mean |v_z| and mean |w_y| against the commanded speed (crosses: "
              "failed runs, at the speed they were commanded).");
  } else if (!results.figures_gap.empty()) {
    doc.paragraph("Figure not available: " + results.figures_gap);
  } else if (const std::string why = figureError(in.out, "speed_sweep"); !why.empty()) {
    doc.paragraph("Figure not drawn: " + why);
    warnings.push_back("figure " + figure + " not drawn: " + why);
  } else {
    doc.paragraph("Figure not drawn: no sweep run left a log");
  }
  const SweepVerdict& v = results.verdict.sweep;
  if (!v.judged) return;
  doc.heading(3, "Acceptance over the sweep");
  std::vector<std::vector<std::string>> verdicts;
  for (const SweepRatio& r : v.ratios) {
    verdicts.push_back({r.metric + " at " + decimalText(r.speed, 2) + " m/s",
                        r.compared
                            ? decimalText(r.candidate, 4) + " vs " + decimalText(r.baseline, 4) +
                                  ": " + decimalText(r.ratio, 2) + "x"
                            : "not compared (a run is missing or failed)",
                        "at most " + decimalText(sweep.max_ratio, 2) + "x",
                        r.compared && r.met ? "met" : "**not met**"});
  }
  const auto fastest = [](double speed, double time) {
    return decimalText(time, 2) + " s at " + decimalText(speed, 2) + " m/s";
  };
  verdicts.push_back({"traverse time at the fastest passing speed",
                      v.fastest_compared ? fastest(v.candidate_speed, v.candidate_time) + " vs " +
                                               fastest(v.baseline_speed, v.baseline_time)
                                         : "a controller has no passing run",
                      "at most the baseline's", v.fastest_met ? "met" : "**not met**"});
  doc.table({sweep.candidate + " vs " + sweep.baseline, "measured", "required", "result"},
            verdicts);
}

/// Figs. 2, 4, 6, 8 and the perception top view: each drawn, or why not (the figure
/// script missing or failed, its complaint about that figure, or no run to draw it from).
void addFigures(Document& doc, const ReportInputs& in, const ReportResults& results,
                std::vector<std::string>& warnings) {
  const std::string& out = in.out;
  const auto figure = [&](const std::string& file, const std::string& caption,
                          const std::string& needs) {
    if (fs::exists(out + "/" + file)) {
      doc.image(file, caption);
    } else if (!results.figures_gap.empty()) {
      doc.paragraph("Figure not available: " + results.figures_gap);
    } else if (const std::string why = figureError(out, file.substr(0, file.find('.')));
               !why.empty()) {
      doc.paragraph("Figure not drawn: " + why);
      warnings.push_back("figure " + file + " not drawn: " + why);
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
  const std::string updates = mpcUpdateDescription(in.set, results.outcomes);
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
}

/// Snapshots and videos: each made, or why not.
void addPictures(Document& doc, const ReportPictures& pictures) {
  doc.heading(2, "Snapshots");
  if (!pictures.render_gap.empty()) {
    doc.paragraph("Snapshots not available: " + pictures.render_gap);
  } else if (pictures.snapshots.empty()) {
    doc.paragraph("No snapshots: no snapshots run left a log.");
  }
  for (const ReportFile& s : pictures.snapshots) doc.image(s.file, s.caption);
  doc.heading(2, "Videos");
  if (!pictures.render_gap.empty()) {
    doc.paragraph("Videos not available: " + pictures.render_gap);
  } else if (!pictures.video_gap.empty()) {
    doc.paragraph("Videos not available: " + pictures.video_gap);
  }
  for (const ReportFile& v : pictures.videos) doc.video(v.file, v.caption);
  for (const std::string& f : pictures.failures) doc.paragraph("Pictures failed: " + f);
}

/// Links to the interactive replay pages, and the runs whose page failed.
void addReplays(Document& doc, const ReportReplays& replays) {
  doc.heading(2, "Replays");
  doc.paragraph(
      "Each run in 3D, in the browser from disk: the robot drawn from its model file, the "
      "terrain, the contact forces, the foothold regions and the MPC's plan in use at the "
      "time of a slider, with plots of the main signals (docs/REPLAY.md).");
  if (replays.pages.empty() && replays.failures.empty()) doc.paragraph("No run left a replay.");
  std::vector<std::string> links;
  for (const ReportFile& p : replays.pages) links.push_back("[" + p.caption + "](" + p.file + ")");
  if (!links.empty()) doc.bullets(links);
  for (const std::string& f : replays.failures) doc.paragraph("Replay failed: " + f);
}

/// The acceptance over the trials: the candidate's success rate against the required one,
/// and, for reference, Table 1 over the seeds both controllers passed.
void addTrialAcceptance(Document& doc, const ReportInputs& in, const ReportVerdict& verdict) {
  if (!verdict.trials_judged) return;
  const Acceptance& a = in.file_acceptance;
  const PairedComparison& c = verdict.trials;
  doc.heading(3, "Acceptance over the trials");
  if (c.candidate_trials == 0) {
    doc.paragraph("**Not met**: no trials of " + a.candidate + " among the results.");
  } else {
    const bool ok = verdict.trials_met;
    std::string text = a.candidate + ": " + std::to_string(c.candidate_passed) + " of " +
                       std::to_string(c.candidate_trials) + " trials passed (" +
                       decimalText(100.0 * c.candidateSuccessRate(), 1) + " %; required at least " +
                       decimalText(100.0 * a.trial_success_rate, 1) +
                       " %): " + (ok ? "met" : "**not met**") + ".";
    if (c.baseline_trials > 0) {
      text += " " + a.baseline + ": " + std::to_string(c.baseline_passed) + " of " +
              std::to_string(c.baseline_trials) + " passed (" +
              decimalText(100.0 * c.baselineSuccessRate(), 1) + " %).";
    }
    doc.paragraph(text);
  }
  if (c.paired > 0) {
    std::vector<std::vector<std::string>> paired_rows;
    const auto row = [&](const char* what, double cv, double bv, double need, int digits) {
      const double change = relativeChange(cv, bv);
      const bool ok = meetsMargin(change, need);
      paired_rows.push_back({what, decimalText(cv, digits), decimalText(bv, digits),
                             percentText(change), "at most " + percentText(need),
                             ok ? "met" : "not met"});
    };
    row("traverse time [s]", c.candidate_traverse_time, c.baseline_traverse_time, a.traverse_time,
        2);
    row("mean |v_z| [m/s]", c.candidate_mean_abs_vz, c.baseline_mean_abs_vz, a.mean_abs_vz, 4);
    row("mean |w_y| [rad/s]", c.candidate_mean_abs_wy, c.baseline_mean_abs_wy, a.mean_abs_wy, 4);
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

/// The randomized trials given: how to make them when none were, else each scenario's
/// success rate and metric spread, the folders not counted, the failed seeds and the
/// acceptance over the trials.
void addTrials(Document& doc, const ReportInputs& in, const ReportVerdict& verdict) {
  doc.heading(2, "Randomized trials");
  if (in.trial_dirs.empty()) {
    doc.paragraph(
        "No trials in this report: run `rollstep trials --scenario step20 --controller nmpc "
        "--seeds 0-29 --out DIR` (and the same with the other controller), then `rollstep report "
        "--trials DIR`.");
    return;
  }
  std::string from;
  for (const std::string& d : in.trial_dirs) {
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
    return decimalText(s.mean, digits) + " ± " + decimalText(s.stddev, digits) + " (" +
           decimalText(s.min, digits) + " to " + decimalText(s.max, digits) + ")";
  };
  for (const TrialAggregate& a : in.trial_aggregates) {
    rows.push_back({a.scenario, a.controller, std::to_string(a.trials), std::to_string(a.passed),
                    decimalText(100.0 * a.successRate(), 1) + " %", cell(a.traverse_time, 2),
                    cell(a.mean_abs_vz, 4), cell(a.mean_abs_wy, 4)});
  }
  doc.table({"scenario", "controller", "trials", "passed", "success rate", "traverse time [s]",
             "mean |v_z| [m/s]", "mean |w_y| [rad/s]"},
            rows);
  if (!in.trials.uncounted.empty()) {
    doc.paragraph("Not counted: " + std::to_string(in.trials.uncounted.size()) + " of " +
                  std::to_string(in.trials.folders) + " trial folders hold no result:");
    std::vector<std::string> items;
    for (const UncountedTrial& u : in.trials.uncounted) {
      items.push_back(literalText(u.dir) + ": " + literalText(u.reason));
    }
    doc.bullets(items);
  }
  for (const TrialAggregate& a : in.trial_aggregates) {
    if (!a.failures.empty()) {
      doc.paragraph("Failed trials of " + a.scenario + ":");
      doc.bullets(a.failures);
    }
  }
  addTrialAcceptance(doc, in, verdict);
}

/// Each run's exact command, exit status, summary and error: what to run to see it again.
void addRunCommands(Document& doc, const ReportInputs& in,
                    const std::vector<RunOutcome>& outcomes) {
  doc.heading(2, "How each run was made");
  for (std::size_t i = 0; i < outcomes.size(); ++i) {
    const RunOutcome& r = outcomes[i];
    doc.heading(3, in.set.scenarios[i].name);
    doc.paragraph("Outputs: `runs/" + in.set.scenarios[i].name + "/`; exit status " +
                  std::to_string(r.exit_status) + ".");
    doc.code(r.command);
    if (!r.spec.empty()) {
      doc.paragraph("The run spec it was given (`runs/" + in.set.scenarios[i].name +
                    "/spec.yaml`; the run's own `run.yaml` is the same):");
      doc.code(r.spec);
    }
    if (!r.summary.empty()) doc.code(r.summary);
    if (!r.error.empty()) doc.paragraph("Error: " + r.error);
  }
}

/// The experiments file quoted in full: the report's one input besides the defaults.
void addConfiguration(Document& doc, const ReportInputs& in) {
  doc.heading(2, "Configuration");
  doc.paragraph("The experiments file `" + in.set.source +
                "`. Settings not given in a run's options are the defaults documented in "
                "`config/control.yaml`, `config/ocp.yaml` and the robot files of `robots/`.");
  doc.code(in.set.text);
}

}  // namespace

std::string decimalText(double v, int digits) {
  if (!std::isfinite(v)) return "-";
  char text[64];
  std::snprintf(text, sizeof text, "%.*f", digits, v);
  return text;
}

std::string percentText(double v) {
  if (!std::isfinite(v)) return "-";
  char text[64];
  std::snprintf(text, sizeof text, "%+.0f %%", 100.0 * v);
  return text;
}

ComposedReport composeReport(const ReportInputs& in, const ReportResults& results) {
  ComposedReport report;
  Document& doc = report.document;
  addIntroduction(doc, in);
  addRuns(doc, in, results.outcomes);
  addTable1(doc, in, results.outcomes);
  addRunAcceptance(doc, in, results.outcomes, results.verdict);
  addSpeedSweep(doc, in, results, report.warnings);
  addFigures(doc, in, results, report.warnings);
  addPictures(doc, results.pictures);
  addReplays(doc, results.replays);
  addTrials(doc, in, results.verdict);
  addRunCommands(doc, in, results.outcomes);
  addConfiguration(doc, in);
  return report;
}

}  // namespace rollstep::experiments
