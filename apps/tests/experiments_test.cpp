// The experiments' computations on synthetic logs and files: traverse window detection,
// Table 1 means in the base frame, the pass criteria, the experiments file loader, the
// trials' seeded draws, result files and aggregate, the report document.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <set>
#include <string>
#include <vector>

#include "experiments/acceptance.hpp"
#include "experiments/document.hpp"
#include "experiments/log_table.hpp"
#include "experiments/metrics.hpp"
#include "experiments/process.hpp"
#include "experiments/scenarios.hpp"
#include "experiments/speed_sweep.hpp"
#include "experiments/trials.hpp"

namespace rollstep::experiments {
namespace {

constexpr double kR = 0.075;                 // wheel radius
constexpr double kUp = kR + 0.10;            // up_height for a 0.20 m step
const TraverseLegs kMiddleLegs{"MF", "MR"};  // the synthetic log's legs
constexpr double kDt = 0.01;

/// A synthetic step traverse: MF lifts at 2.00 s, lands up at 2.40 s; MR stands up from
/// 5 s, lifts at 9.00 s, touches down on the floor at 9.50 s; trots on the floor before and
/// after (lift-offs that are not the climb). The base pitches with w_y = 0.1 inside
/// [2, 9.5] and 0.5 outside, and rises with local v_z = 0.02 inside.
struct Synthetic {
  std::vector<double> t, mf_z, mf_c, mr_z, mr_c;
  Synthetic() {
    for (int i = 0; i <= 1200; ++i) {
      const double ti = i * kDt;
      t.push_back(ti);
      // MF: floor trot lift-offs at 0.5-0.7 s and 1.2-1.4 s; the climb 2.0-2.4 s; up after.
      const bool mf_swing = (ti >= 0.5 && ti < 0.7) || (ti >= 1.2 && ti < 1.4) ||
                            (ti >= 2.0 && ti < 2.4) || (ti >= 6.0 && ti < 6.2);
      mf_c.push_back(mf_swing ? 0 : 1);
      mf_z.push_back(ti < 2.2 ? (mf_swing ? kR + 0.05 : kR) : kR + 0.20 + (mf_swing ? 0.05 : 0.0));
      // MR: floor until 4.6 s, up from 5.0 to 9.0 s, down at 9.5 s, one more floor step.
      const bool mr_swing =
          (ti >= 4.6 && ti < 5.0) || (ti >= 9.0 && ti < 9.5) || (ti >= 10.5 && ti < 10.7);
      mr_c.push_back(mr_swing ? 0 : 1);
      mr_z.push_back(ti >= 4.8 && ti < 9.2 ? kR + 0.20 : kR + (mr_swing ? 0.05 : 0.0));
    }
  }
};

TEST(TraverseWindow, FromTheClimbLiftOffToTheDescentTouchDown) {
  const Synthetic s;
  const TraverseWindow w =
      findTraverseWindow(s.t, s.mf_z, s.mf_c, s.mr_z, s.mr_c, kMiddleLegs, kUp);
  ASSERT_TRUE(w.found) << w.reason;
  EXPECT_NEAR(w.start, 2.0, 1e-9);  // not the floor lift-offs at 0.5 or 1.2 s
  EXPECT_NEAR(w.end, 9.5, 1e-9);    // not the floor touch-down at 10.7 s
}

TEST(TraverseWindow, LegsFromTheHips) {
  // Tachyon 3: three legs a side, the middle ones on the centre line.
  TraverseLegs legs =
      traverseLegs({"LF", "MF", "RF", "LR", "MR", "RR"}, {0.33, 0.33, 0.33, -0.33, -0.33, -0.33},
                   {0.22, 0.0, -0.22, 0.22, 0.0, -0.22});
  EXPECT_EQ(legs.climb, "MF");
  EXPECT_EQ(legs.descent, "MR");
  // A quadruped: the front pair side by side, the first of them; hind legs given first.
  legs = traverseLegs({"LH", "RH", "LF", "RF"}, {-0.3, -0.3, 0.3, 0.3}, {0.08, -0.08, 0.08, -0.08});
  EXPECT_EQ(legs.climb, "LF");
  EXPECT_EQ(legs.descent, "LH");
  // A leg further ahead wins over one nearer the middle.
  legs = traverseLegs({"A", "B"}, {0.2, 0.25}, {0.0, 0.3});
  EXPECT_EQ(legs.climb, "B");
  EXPECT_EQ(legs.descent, "A");
  EXPECT_THROW(traverseLegs({}, {}, {}), std::invalid_argument);
  EXPECT_THROW(traverseLegs({"A"}, {0.0, 1.0}, {0.0}), std::invalid_argument);
}

TEST(TraverseWindow, NamesItsLegs) {
  // The same traverse logged for legs named otherwise: the window comes from their columns.
  const Synthetic s;
  const TraverseWindow w =
      findTraverseWindow(s.t, s.mf_z, s.mf_c, s.mr_z, s.mr_c, TraverseLegs{"LF", "LH"}, kUp);
  ASSERT_TRUE(w.found) << w.reason;
  EXPECT_NEAR(w.start, 2.0, 1e-9);
  const std::vector<double> low(s.t.size(), kR);
  EXPECT_EQ(
      findTraverseWindow(s.t, s.mf_z, s.mf_c, low, s.mr_c, TraverseLegs{"LF", "LH"}, kUp).reason,
      "the LH wheel never stood on the step");
}

TEST(TraverseWindow, SaysWhyWhenThereIsNone) {
  Synthetic s;
  // MF never lands up (bumps into the step).
  std::vector<double> low(s.t.size(), kR);
  TraverseWindow w = findTraverseWindow(s.t, low, s.mf_c, s.mr_z, s.mr_c, kMiddleLegs, kUp);
  EXPECT_FALSE(w.found);
  EXPECT_EQ(w.reason, "the MF wheel never landed on the step");
  // MR stays up to the end.
  std::vector<double> mr_up = s.mr_z;
  for (std::size_t i = 480; i < mr_up.size(); ++i) mr_up[i] = kR + 0.20;
  w = findTraverseWindow(s.t, s.mf_z, s.mf_c, mr_up, s.mr_c, kMiddleLegs, kUp);
  EXPECT_FALSE(w.found);
  EXPECT_NE(w.reason.find("the MR wheel did not come down"), std::string::npos) << w.reason;
  // MR never gets up.
  w = findTraverseWindow(s.t, s.mf_z, s.mf_c, low, s.mr_c, kMiddleLegs, kUp);
  EXPECT_EQ(w.reason, "the MR wheel never stood on the step");
  // MF rolled onto the step without lifting off.
  std::vector<double> always(s.t.size(), 1.0);
  w = findTraverseWindow(s.t, s.mf_z, always, s.mr_z, s.mr_c, kMiddleLegs, kUp);
  EXPECT_EQ(w.reason, "no MF lift-off before it reached the step");
  EXPECT_THROW(findTraverseWindow(s.t, low, s.mf_c, s.mr_z, {1.0}, kMiddleLegs, kUp),
               std::invalid_argument);
}

/// A log.csv text of the synthetic traverse with the base pitched by `pitch` (constant) and
/// its world velocity chosen so that the local v_z is 0.02 inside the window, 0.3 outside.
std::string syntheticLog(double pitch, bool body_touch, double knee_peak) {
  const Synthetic s;
  std::string text =
      "time[s],base_x[m],base_y[m],base_qw[-],base_qx[-],base_qy[-],base_qz[-],base_vx[m/s],"
      "base_vy[m/s],base_vz[m/s],"
      "base_wy[rad/s],foot_z_MF[m],contact_MF[0/1],foot_z_MR[m],contact_MR[0/1],"
      "body_contact_periods[-],q_MF_knee[m],qp_status\n";
  const double qw = std::cos(pitch / 2), qy = std::sin(pitch / 2);
  char row[400];
  for (std::size_t i = 0; i < s.t.size(); ++i) {
    const bool inside = s.t[i] >= 2.0 - 1e-9 && s.t[i] <= 9.5 + 1e-9;
    const double vz_local = inside ? 0.02 : 0.3;
    const double vx_local = 0.2;
    // world = R_y(pitch) * local: x' = c x + s z, z' = -s x + c z.
    const double vx = std::cos(pitch) * vx_local + std::sin(pitch) * vz_local;
    const double vz = -std::sin(pitch) * vx_local + std::cos(pitch) * vz_local;
    const double wy = (inside ? 0.1 : 0.5) * (i % 2 == 0 ? 1 : -1);  // |w_y| matters
    const long body = body_touch && s.t[i] > 5.0 ? 3 : 0;
    const double knee = i == 700 ? knee_peak : 0.2;
    std::snprintf(row, sizeof row,
                  "%.2f,%.6f,%.6f,%.9f,0,%.9f,0,%.9f,0,%.9f,%.3f,%.4f,%.0f,%.4f,%.0f,%ld,%.4f,%s\n",
                  s.t[i], 0.15 * s.t[i], -0.02 * s.t[i], qw, qy, vx, vz, wy, s.mf_z[i], s.mf_c[i],
                  s.mr_z[i], s.mr_c[i], body, knee, i % 3 == 0 ? "optimal" : "fallback");
    text += row;
  }
  return text;
}

TEST(Table1, MeansInTheBaseFrameOverTheWindow) {
  const LogTable log = LogTable::parse(syntheticLog(0.3, false, 0.2), "synthetic");
  const TraverseWindow w = findTraverseWindow(log, kMiddleLegs, kUp);
  ASSERT_TRUE(w.found);
  const Table1Metrics m = table1Metrics(log, w);
  EXPECT_NEAR(m.traverse_time, 7.5, 1e-9);
  EXPECT_EQ(m.samples, 751);               // rows 2.00 .. 9.50
  EXPECT_NEAR(m.mean_abs_vz, 0.02, 1e-6);  // local, not the world's (which mixes in v_x)
  EXPECT_NEAR(m.mean_abs_wy, 0.1, 1e-9);   // absolute values, outside rows excluded
  EXPECT_NEAR(m.distance, 7.5 * std::hypot(0.15, 0.02), 1e-6);  // from 2.00 to 9.50 s
  const std::vector<double> vz = localVz(log);
  EXPECT_NEAR(vz[0], 0.3, 1e-6);
  EXPECT_THROW(table1Metrics(log, TraverseWindow{}), std::invalid_argument);
}

TEST(PassCriteria, EachFailureIsNamed) {
  std::vector<JointLimit> limits{{"MF_knee", 0.0, 0.36}};
  RunCriteria criteria;
  // A clean run passes.
  RunAssessment a = assessRun(LogTable::parse(syntheticLog(0.1, false, 0.2), "ok"), limits,
                              criteria, true, kMiddleLegs, kUp);
  EXPECT_TRUE(a.passed()) << (a.failures.empty() ? "" : a.failures[0]);
  EXPECT_EQ(a.body_contact_periods, 0);
  ASSERT_TRUE(a.metrics.has_value());
  // Body contact.
  a = assessRun(LogTable::parse(syntheticLog(0.1, true, 0.2), "body"), limits, criteria, true,
                kMiddleLegs, kUp);
  ASSERT_EQ(a.failures.size(), 1u);
  EXPECT_NE(a.failures[0].find("the body touched the terrain (first logged at t = 5.01 s"),
            std::string::npos)
      << a.failures[0];
  // A joint beyond its limit by more than the tolerance (within it: passes).
  a = assessRun(LogTable::parse(syntheticLog(0.1, false, 0.365), "joint"), limits, criteria, true,
                kMiddleLegs, kUp);
  EXPECT_TRUE(a.passed());
  a = assessRun(LogTable::parse(syntheticLog(0.1, false, 0.40), "joint"), limits, criteria, true,
                kMiddleLegs, kUp);
  ASSERT_EQ(a.failures.size(), 1u);
  EXPECT_NE(a.failures[0].find("MF_knee left its limits: 0.4000 at t = 7.00 s"), std::string::npos)
      << a.failures[0];
  // A fall: tilted 60 deg.
  a = assessRun(LogTable::parse(syntheticLog(M_PI / 3, false, 0.2), "fall"), limits, criteria, true,
                kMiddleLegs, kUp);
  ASSERT_EQ(a.failures.size(), 1u);
  EXPECT_NE(a.failures[0].find("fell: the base tilted 60 deg"), std::string::npos) << a.failures[0];
  // No traverse: required or not.
  const LogTable flat = LogTable::parse(syntheticLog(0.1, false, 0.2), "flat");
  a = assessRun(flat, limits, criteria, true, kMiddleLegs, 10.0);
  ASSERT_EQ(a.failures.size(), 1u);
  EXPECT_EQ(a.failures[0], "did not traverse the step: the MF wheel never landed on the step");
  EXPECT_TRUE(assessRun(flat, limits, criteria, false, kMiddleLegs, 10.0).passed());
  // A log without the body contact column cannot pass.
  const LogTable old = LogTable::parse(
      "time[s],base_qw[-],base_qx[-],base_qy[-],base_qz[-],"
      "foot_z_MF[m],contact_MF[0/1],foot_z_MR[m],contact_MR[0/1]\n"
      "0,1,0,0,0,0.075,1,0.075,1\n",
      "old");
  a = assessRun(old, {}, criteria, false, kMiddleLegs, kUp);
  ASSERT_EQ(a.failures.size(), 1u);
  EXPECT_NE(a.failures[0].find("body contact not checked"), std::string::npos);
}

TEST(LogTable, ColumnsWordsAndErrors) {
  const LogTable t = LogTable::parse("a[s],status\n1,ok\n2.5,fallback\n", "x.csv");
  EXPECT_EQ(t.rows(), 2u);
  EXPECT_EQ(t.column("a[s]")[1], 2.5);
  EXPECT_TRUE(std::isnan(t.column("status")[0]));
  EXPECT_EQ(t.text("status")[1], "fallback");
  try {
    (void)t.column("b[s]");
    FAIL();
  } catch (const std::runtime_error& e) {
    EXPECT_STREQ(e.what(), "x.csv: no column 'b[s]'");
  }
  try {
    LogTable::parse("a,b\n1,2\n3\n", "y.csv");
    FAIL();
  } catch (const std::runtime_error& e) {
    EXPECT_STREQ(e.what(), "y.csv: line 3: 1 fields, the header has 2");
  }
  EXPECT_THROW(LogTable::parse("", "empty"), std::runtime_error);
  EXPECT_THROW(LogTable::parse("a,a\n", "twice"), std::runtime_error);
}

TEST(ExperimentSet, LoadsTheProjectsFileAndRefusesMistakes) {
  const ExperimentSet set =
      loadExperimentSet(std::string(ROLLSTEP_SOURCE_DIR) + "/config/experiments.yaml");
  ASSERT_NE(set.find("step20_nmpc"), nullptr);
  ASSERT_NE(set.find("step20_cbfqp"), nullptr);
  EXPECT_TRUE(set.find("step20_nmpc")->feeds("table1"));
  EXPECT_EQ(set.find("step20_nmpc")->paper.traverse_time, 14.0);
  EXPECT_EQ(set.find("step20_cbfqp")->paper.mean_abs_vz, 0.055);
  EXPECT_EQ(set.acceptance.traverse_time, -0.20);
  EXPECT_EQ(set.acceptance.trial_success_rate, 0.95);
  ASSERT_EQ(set.trials.scene.size(), 3u);
  EXPECT_EQ(set.trials.scene[0].name, "step_height");
  EXPECT_EQ(set.trials.scene[0].key, "step1_height");
  EXPECT_EQ(set.trials.scene[0].min, 0.10);
  EXPECT_TRUE(set.trials.scene[2].offset);
  EXPECT_TRUE(set.trials.has_speed);
  EXPECT_EQ(set.trials.speed_max, 0.5);
  // The speed sweep: both step20 controllers at each speed, compared at three.
  EXPECT_TRUE(set.sweep.given);
  ASSERT_NE(set.find("step20_nmpc_v045"), nullptr);
  EXPECT_EQ(set.find("step20_cbfqp_v005")->runSpec("/o").command[0].command.v_x, 0.05);
  EXPECT_EQ(set.sweep.compared_speeds, (std::vector<double>{0.15, 0.3, 0.45}));
  // The run: the scenario's keys, its args read as rollstep sim reads them.
  const sim::RunSpec run = set.find("step20_nmpc")->runSpec("/o");
  EXPECT_EQ(run.scene, "step20");
  EXPECT_EQ(run.controller, sim::ControllerKind::Nmpc);
  EXPECT_EQ(run.duration, 28.0);
  EXPECT_EQ(run.gait, planning::GaitKind::Trot);
  ASSERT_EQ(run.command.size(), 1u);
  EXPECT_EQ(run.command[0].command.v_x, 0.15);
  EXPECT_EQ(run.mpc_timing, sim::TimingChoice::Deterministic);
  EXPECT_EQ(run.integrator, sim::IntegratorChoice::Internal);
  EXPECT_EQ(run.out, "/o");

  const std::string ok = "scenarios:\n  - {name: a, scene: flat, controller: nmpc}\n";
  EXPECT_EQ(parseExperimentSet(ok, "f", "/d").scenarios.size(), 1u);
  EXPECT_EQ(parseExperimentSet(ok, "f", "/d").scenarios[0].terrain, "scene");
  // Perception: the run gets --terrain perception, and its map log with the map figure.
  const ExperimentSet perceived = parseExperimentSet(
      "scenarios:\n  - {name: a, scene: flat, controller: nmpc, terrain: perception, figures: "
      "[map]}\n",
      "f", "/d");
  const sim::RunSpec perceived_run = perceived.scenarios[0].runSpec("/o");
  EXPECT_EQ(perceived_run.terrain, sim::TerrainSource::Perception);
  EXPECT_EQ(perceived_run.map_log, "/o/map");
  EXPECT_EQ(perceived_run.duration, 10.0);
  EXPECT_EQ(perceived.scenarios[0].terrainText(), "perception (LiDAR, closed loop)");
  // Control settings: a path relative to the experiments file's folder, given as
  // --control-config after the controller (not in args).
  const ExperimentSet tuned = parseExperimentSet(
      "scenarios:\n  - {name: a, scene: step20, controller: nmpc, control_config: "
      "behaviours/climb.yaml}\n",
      "f", "/d");
  EXPECT_EQ(tuned.scenarios[0].runSpec("/o").control_config, "/d/behaviours/climb.yaml");
  const auto error = [](const std::string& text) {
    try {
      parseExperimentSet(text, "f", "/d");
    } catch (const std::runtime_error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_EQ(error("scenarios:\n  - {name: a, scene: moon, controller: nmpc}\n"),
            "f: line 2: scenarios[0].scene: 'moon' is not flat, stairs2, step12, step20 or "
            "step20_custom");
  EXPECT_EQ(error("scenarios:\n  - {name: a, scene: flat, controler: nmpc}\n").substr(0, 48),
            "f: line 2: unknown key 'scenarios[0].controler' ");
  EXPECT_EQ(error("scenarios:\n  - {name: a, scene: flat}\n"),
            "f: line 2: missing key 'scenarios[0].controller'");
  EXPECT_EQ(error(ok + "  - {name: a, scene: flat, controller: x}\n"),
            "f: line 3: scenarios[1].name: 'a' is used by another scenario");
  EXPECT_EQ(error(ok + "criteria:\n  max_tilt: 9\n"),
            "f: line 4: criteria.max_tilt: 9 is outside [0.01, 3.141592653589793]");
  EXPECT_EQ(error(ok + "acceptance: {candidate: a, baseline: b}\n"),
            "f: line 3: acceptance: no scenario named 'b'");
  EXPECT_EQ(error(ok + "acceptance: {candidate: a, baseline: a, trial_success_rate: 1.5}\n"),
            "f: line 3: acceptance.trial_success_rate: 1.5 is outside [0, 1]");
  EXPECT_EQ(error(ok + "acceptance: {candidate: a, baseline: a}\n"),
            "f: line 3: acceptance: candidate and baseline are both 'a' (a scenario compared with "
            "itself)");
  // Options the scenario's keys set, repeated in args: each run would fail.
  for (const std::string option :
       {"--out", "--duration", "--scene", "--scene-config", "--controller", "--duration=3"}) {
    EXPECT_NE(error("scenarios:\n  - {name: a, scene: flat, controller: x, args: [" + option +
                    ", '1']}\n")
                  .find("f: line 2: scenarios[0].args: '" + option.substr(0, option.find('=')) +
                        "' is set by "),
              std::string::npos)
        << option;
  }
  EXPECT_EQ(error(ok + "trials: {scene: [{key: friction, range: [1.0, 0.6]}]}\n"),
            "f: line 3: trials.scene[0].range: min is above max");
  EXPECT_EQ(error(ok + "trials: {scene: [{key: friction}]}\n"),
            "f: line 3: trials.scene[0]: needs one of range: [min, max] (the value) or offset: "
            "[min, max] (added to the file's value)");
  EXPECT_EQ(error(ok + "trials: {scene: [{key: 'boxes[0].size[2]', range: [0.1, 0.2]}]}\n"),
            "f: line 3: trials.scene[0]: name is missing (the key 'boxes[0].size[2]' cannot name "
            "it in result.yaml)");
  EXPECT_EQ(error(ok + "trials: {scene: [{key: a, name: seed, range: [0, 1]}]}\n"),
            "f: line 3: trials.scene[0].name: 'seed' is not a name for result.yaml (a letter, then "
            "letters, digits, _; not a key of result.yaml)");
  EXPECT_EQ(error(ok + "trials: {scene: [{key: a, range: [0, 1]}, {key: a, offset: [0, 1]}]}\n"),
            "f: line 3: trials.scene[1]: name 'a' is drawn twice");
  EXPECT_EQ(error("scenarios:\n  - {name: a/b, scene: flat, controller: x}\n"),
            "f: line 2: scenarios[0].name: 'a/b': only letters, digits, '_' and '-' (it names a "
            "folder)");
  EXPECT_EQ(error("scenarios: []\n"), "f: no scenarios");
  EXPECT_EQ(error("scenarios:\n  - {name: a, scene: flat, controller: x, figures: [fig9]}\n"),
            "f: line 2: scenarios[0].figures: 'fig9' is not table1, fig4, fig6, fig8, snapshots or "
            "map");
  EXPECT_NE(error("scenarios:\n  - {name: a, scene: flat, controller: x, args: [--control-config, "
                  "c.yaml]}\n")
                .find("scenarios[0].args: '--control-config' is set by the scenario's "
                      "control_config key"),
            std::string::npos);
  // The terrain source: a key of its own (not --terrain in args); the map figure needs it.
  EXPECT_EQ(error("scenarios:\n  - {name: a, scene: flat, controller: x, terrain: lidar}\n"),
            "f: line 2: scenarios[0].terrain: 'lidar' is not scene or perception");
  EXPECT_NE(error("scenarios:\n  - {name: a, scene: flat, controller: x, args: [--terrain, "
                  "perception]}\n")
                .find("scenarios[0].args: '--terrain' is set by the scenario's terrain key"),
            std::string::npos);
  EXPECT_EQ(error("scenarios:\n  - {name: a, scene: flat, controller: x, figures: [map]}\n"),
            "f: line 2: scenarios[0].figures: map (the perceived map's top view) needs terrain: "
            "perception");
}

TEST(Trials, DrawsAreFixedBySeedAndInRange) {
  const TrialRanges r;
  std::set<double> heights;
  for (std::uint64_t seed = 0; seed < 200; ++seed) {
    const TrialParameters p = drawTrial(seed, r);
    const TrialParameters q = drawTrial(seed, r);
    EXPECT_EQ(p.sceneValue("step_height"), q.sceneValue("step_height"));
    EXPECT_EQ(p.sceneValue("friction"), q.sceneValue("friction"));
    EXPECT_GE(p.sceneValue("step_height"), 0.10);
    EXPECT_LE(p.sceneValue("step_height"), 0.20);
    EXPECT_GE(p.sceneValue("friction"), 0.6);
    EXPECT_LE(p.sceneValue("friction"), 1.0);
    EXPECT_GE(p.sceneValue("start_offset"), -0.2);
    EXPECT_LE(p.sceneValue("start_offset"), 0.2);
    heights.insert(p.sceneValue("step_height"));
  }
  EXPECT_GT(heights.size(), 150u);  // not a constant
  // Fixed numbers: the same on every machine (splitmix64, not the library's distributions).
  const TrialParameters p7 = drawTrial(7, r);
  // (Computed independently with Python's integers from the splitmix64 definition.)
  EXPECT_EQ(p7.sceneValue("step_height"), 0.139);
  EXPECT_EQ(p7.sceneValue("friction"), 0.6067);
  EXPECT_EQ(p7.sceneValue("start_offset"), 0.1603);
  EXPECT_EQ(p7.sensor_noise, 1.0829);
  const sim::SceneConfig base = sim::loadScene("step20");
  const sim::SceneConfig s = trialScene(base, p7);
  EXPECT_EQ(sim::sceneNumber(s, "step1_height"), 0.139);
  EXPECT_EQ(sim::sceneNumber(s, "friction"), 0.6067);
  EXPECT_EQ(sim::sceneNumber(s, "start_x"), 1.0 + 0.1603);
  EXPECT_DOUBLE_EQ(sim::resolveScene(s).solids[0].topCenter().z(), 0.139);
  // Any number of the file by its key path; a key the scene lacks is an error.
  TrialRanges yaw;
  yaw.scene = {{"yaw", "boxes[0].yaw_deg", false, -30.0, 30.0}};
  const TrialParameters py = drawTrial(7, yaw);
  EXPECT_EQ(sim::resolveScene(trialScene(base, py)).solids[0].yaw,
            py.sceneValue("yaw") * (M_PI / 180.0));
  // The flat floor has no step: only its friction is drawn into it.
  const sim::SceneConfig flat = trialScene(sim::loadScene("flat"), p7);
  EXPECT_EQ(sim::sceneNumber(flat, "friction"), 0.6067);
  EXPECT_TRUE(sim::resolveScene(flat).solids.empty());
  // The sensor noise: the defaults' noise terms times the draw, seeded by the trial; the
  // file the sim reads gives the same config back.
  const sim::SensorNoiseConfig defaults, n = trialSensorNoise(p7);
  EXPECT_EQ(n.seed, 7.0);
  EXPECT_DOUBLE_EQ(n.gyro_noise_density, 1.0829 * defaults.gyro_noise_density);
  EXPECT_DOUBLE_EQ(n.accel_initial_bias, 1.0829 * defaults.accel_initial_bias);
  EXPECT_DOUBLE_EQ(n.force_noise, 1.0829 * defaults.force_noise);
  EXPECT_EQ(n.knee_resolution, defaults.knee_resolution);
  EXPECT_EQ(n.force_threshold, defaults.force_threshold);
  const sim::SensorNoiseConfig back = sim::parseSensorNoiseConfig(n.toYaml(), "trial");
  EXPECT_EQ(back.toYaml(), n.toYaml());
  EXPECT_DOUBLE_EQ(back.wheel_velocity_noise, n.wheel_velocity_noise);
  Scenario nmpc, cbfqp;
  nmpc.scene = cbfqp.scene = "flat";
  nmpc.controller = "nmpc";
  nmpc.args = {"--gait", "trot", "--state-source", "inekf"};
  cbfqp.controller = "cbfqp";
  cbfqp.args = {"--gait", "trot"};
  EXPECT_TRUE(readsSensors(nmpc));
  EXPECT_FALSE(readsSensors(cbfqp));
}

TEST(Trials, DrawASpeedAfterTheOtherDrawsAndScaleTheCommandToIt) {
  TrialRanges with_speed;
  with_speed.has_speed = true;
  with_speed.speed_min = 0.05;
  with_speed.speed_max = 0.5;
  std::set<double> speeds;
  for (std::uint64_t seed = 0; seed < 200; ++seed) {
    const TrialParameters p = drawTrial(seed, with_speed);
    const TrialParameters without = drawTrial(seed, TrialRanges{});
    // The terrain and noise draws are those of the trials without a speed.
    EXPECT_EQ(p.sceneValue("step_height"), without.sceneValue("step_height"));
    EXPECT_EQ(p.sceneValue("start_offset"), without.sceneValue("start_offset"));
    EXPECT_EQ(p.sensor_noise, without.sensor_noise);
    EXPECT_EQ(without.speed, 0.0);
    EXPECT_EQ(p.speed, drawTrial(seed, with_speed).speed);
    EXPECT_GE(p.speed, 0.05);
    EXPECT_LE(p.speed, 0.5);
    speeds.insert(p.speed);
  }
  EXPECT_GT(speeds.size(), 150u);
  TrialParameters p;
  p.speed = 0.3;
  Scenario step;
  step.controller = "nmpc";
  step.scene = "flat";
  step.duration = 28;
  step.args = {"--gait", "trot", "--vx", "0.15", "--mpc-timing", "deterministic"};
  const sim::RunSpec fast = trialScenario(step, p).runSpec("out");
  ASSERT_EQ(fast.command.size(), 1u);
  EXPECT_EQ(fast.command[0].command.v_x, 0.3);
  EXPECT_DOUBLE_EQ(fast.duration, 14.0 + kTrialSpeedMargin);
  // A schedule: speeds scaled, times scaled back, backwards kept backwards.
  Scenario stairs;
  stairs.controller = "nmpc";
  stairs.scene = "flat";
  stairs.duration = 44;
  stairs.args = {"--gait", "trot", "--command", "0:0.15,19:0,21:-0.15"};
  const sim::RunSpec there_and_back = trialScenario(stairs, p).runSpec("out");
  ASSERT_EQ(there_and_back.command.size(), 3u);
  EXPECT_EQ(there_and_back.command[0].command.v_x, 0.3);
  EXPECT_EQ(there_and_back.command[1].time, 9.5);
  EXPECT_EQ(there_and_back.command[1].command.v_x, 0.0);
  EXPECT_EQ(there_and_back.command[2].time, 10.5);
  EXPECT_EQ(there_and_back.command[2].command.v_x, -0.3);
  EXPECT_DOUBLE_EQ(there_and_back.duration, 22.0 + kTrialSpeedMargin);
  // No speed drawn, or no forward command: the run as it is.
  EXPECT_EQ(trialScenario(step, TrialParameters{}).runSpec("out"), step.runSpec("out"));
  Scenario standing;
  standing.controller = "nmpc";
  standing.scene = "flat";
  standing.args = {"--gait", "standing"};
  EXPECT_EQ(trialScenario(standing, p).runSpec("out"), standing.runSpec("out"));
}

TEST(SpeedSweep, ExpandsEachScenarioAtEachSpeedAndRefusesMistakes) {
  const std::string base =
      "scenarios:\n"
      "  - {name: n, title: N, scene: step20, controller: nmpc, duration: 28, traverse: true,\n"
      "     figures: [table1], args: [--gait, trot, --vx, '0.15']}\n"
      "  - {name: b, scene: step20, controller: cbfqp, duration: 28, args: [--vx, '0.15']}\n"
      "  - {name: still, scene: flat, controller: nmpc, args: [--gait, standing]}\n";
  const ExperimentSet set = parseExperimentSet(
      "speed_sweep: {scenarios: [n, b], speeds: [0.05, 0.3], candidate: n, baseline: b,\n"
      "  compared_speeds: [0.3], max_ratio: 0.7}\n" +
          base,
      "f", "/d");
  ASSERT_EQ(set.scenarios.size(), 7u);  // the file's three, then n and b at two speeds
  const Scenario* slow = set.find("n_v005");
  ASSERT_NE(slow, nullptr);
  EXPECT_EQ(slow->runSpec("/o").command[0].command.v_x, 0.05);
  EXPECT_DOUBLE_EQ(slow->runSpec("/o").duration, 28 * 3 + kTrialSpeedMargin);
  EXPECT_TRUE(slow->traverse);
  EXPECT_FALSE(slow->feeds("table1"));  // the sweep has its own table
  EXPECT_EQ(slow->sweep_of, "n");
  EXPECT_EQ(slow->title, "N at 0.05 m/s");
  ASSERT_NE(set.find("b_v030"), nullptr);
  EXPECT_EQ(set.find("b_v030")->runSpec("/o").command[0].command.v_x, 0.3);
  EXPECT_EQ(set.find("n")->sweep_of, "");
  const auto fails = [&](const std::string& sweep, const std::string& part) {
    try {
      parseExperimentSet(sweep + base, "f", "/d");
      ADD_FAILURE() << "accepted: " << sweep;
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find(part), std::string::npos) << e.what();
    }
  };
  fails("speed_sweep: {scenarios: [x], speeds: [0.1]}\n", "no scenario named 'x'");
  fails("speed_sweep: {scenarios: [still], speeds: [0.1]}\n", "no forward command");
  fails("speed_sweep: {scenarios: [n], speeds: [0.2, 0.1]}\n", "must increase");
  fails(
      "speed_sweep: {scenarios: [n, b], speeds: [0.1], candidate: n, baseline: b,\n"
      "  compared_speeds: [0.2]}\n",
      "not one of speeds");
  fails("speed_sweep: {scenarios: [n], speeds: [0.1], candidate: n, baseline: b}\n",
        "not one of its scenarios");
  fails("speed_sweep: {scenarios: [n], speeds: [0.1], pace: 2}\n", "unknown key");
  fails("speed_sweep: {scenarios: [n], speeds: [0.101, 0.102]}\n", "'n_v010' names two runs");
}

TEST(SpeedSweep, JudgesRatiosAtTheComparedSpeedsAndTheFastestPassingTraverse) {
  const auto point = [](double speed, bool passed, double time, double vz, double wy) {
    SweepPoint p;
    p.speed = speed;
    p.passed = passed;
    if (time > 0) p.metrics = Table1Metrics{time, vz, wy, 100, 2.0};
    return p;
  };
  SpeedSweep sweep;
  sweep.given = true;
  sweep.scenarios = {"n", "b"};
  sweep.speeds = {0.15, 0.3, 0.45};
  sweep.candidate = "n";
  sweep.baseline = "b";
  sweep.compared_speeds = {0.15, 0.3};
  sweep.max_ratio = 0.7;
  SweepSeries n{"n",
                "N",
                {point(0.15, true, 12, 0.01, 0.04), point(0.3, true, 6, 0.03, 0.06),
                 point(0.45, false, 0, 0, 0)}};
  SweepSeries b{"b",
                "B",
                {point(0.15, true, 13, 0.05, 0.05), point(0.3, true, 8, 0.05, 0.1),
                 point(0.45, true, 6.3, 0.09, 0.1)}};
  SweepVerdict v = judgeSpeedSweep(sweep, {n, b});
  ASSERT_TRUE(v.judged);
  ASSERT_EQ(v.ratios.size(), 4u);
  // In order: |v_z| and |w_y| at 0.15, then at 0.3.
  EXPECT_TRUE(v.ratios[0].met);  // 0.2x
  EXPECT_NEAR(v.ratios[1].ratio, 0.8, 1e-12);
  EXPECT_FALSE(v.ratios[1].met);
  EXPECT_TRUE(v.ratios[2].met);  // 0.6x
  EXPECT_NEAR(v.ratios[3].ratio, 0.6, 1e-12);
  EXPECT_TRUE(v.ratios[3].met);
  EXPECT_FALSE(v.met());
  // The candidate's fastest pass is 6 s at 0.3, the baseline's 6.3 s at 0.45: met.
  EXPECT_EQ(v.candidate_speed, 0.3);
  EXPECT_EQ(v.baseline_speed, 0.45);
  EXPECT_TRUE(v.fastest_met);
  // A failed run at a compared speed is not a comparison, and not met.
  sweep.compared_speeds = {0.45};
  v = judgeSpeedSweep(sweep, {n, b});
  EXPECT_FALSE(v.ratios[0].compared);
  EXPECT_FALSE(v.met());
  // A slower fastest traverse is not met.
  b.points[2].metrics->traverse_time = 5.9;
  sweep.compared_speeds = {};
  v = judgeSpeedSweep(sweep, {n, b});
  EXPECT_FALSE(v.fastest_met);
  EXPECT_FALSE(v.met());
  // No candidate: listed, not judged.
  sweep.candidate.clear();
  EXPECT_FALSE(judgeSpeedSweep(sweep, {n, b}).judged);
}

TEST(Trials, SeedLists) {
  EXPECT_EQ(parseSeeds("0-3"), (std::vector<std::uint64_t>{0, 1, 2, 3}));
  EXPECT_EQ(parseSeeds("7"), (std::vector<std::uint64_t>{7}));
  EXPECT_EQ(parseSeeds("1,5,9-10"), (std::vector<std::uint64_t>{1, 5, 9, 10}));
  for (const char* bad : {"", "a", "3-1", "1,1", "-1", "1-", "0-1000000", "1.5"}) {
    EXPECT_THROW(parseSeeds(bad), std::invalid_argument) << bad;
  }
}

TEST(Trials, ResultFilesRoundTripAndAggregate) {
  std::vector<TrialResult> results;
  for (std::uint64_t seed = 0; seed < 4; ++seed) {
    TrialResult r;
    r.scenario = "step20_nmpc";
    r.controller = "nmpc";
    r.parameters = drawTrial(seed, TrialRanges{});
    r.passed = seed != 2;
    if (r.passed) {
      r.traverse_time = 10.0 + static_cast<double>(seed);
      r.mean_abs_vz = 0.02;
      r.mean_abs_wy = 0.05;
    } else {
      r.failure = "fell: \"the base\" tilted";
    }
    r.command = "rollstep trials --seeds " + std::to_string(seed);
    const TrialResult back = parseTrialResult(toYaml(r), "r" + std::to_string(seed));
    EXPECT_EQ(back.parameters.sceneValue("step_height"), r.parameters.sceneValue("step_height"));
    EXPECT_EQ(back.parameters.scene.size(), 3u);
    EXPECT_EQ(back.passed, r.passed);
    EXPECT_EQ(back.failure, r.failure);
    EXPECT_EQ(back.traverse_time, r.traverse_time);
    EXPECT_EQ(back.command, r.command);
    results.push_back(back);
  }
  const std::vector<TrialAggregate> a = aggregate(results);
  ASSERT_EQ(a.size(), 1u);
  EXPECT_EQ(a[0].trials, 4);
  EXPECT_EQ(a[0].passed, 3);
  EXPECT_DOUBLE_EQ(a[0].successRate(), 0.75);
  EXPECT_DOUBLE_EQ(a[0].traverse_time.mean, (10.0 + 11.0 + 13.0) / 3.0);
  EXPECT_NEAR(
      a[0].traverse_time.stddev,
      std::sqrt(((-4.0 / 3) * (-4.0 / 3) + (-1.0 / 3) * (-1.0 / 3) + (5.0 / 3) * (5.0 / 3)) / 2.0),
      1e-12);
  EXPECT_EQ(a[0].traverse_time.min, 10.0);
  EXPECT_EQ(a[0].failures, std::vector<std::string>{"seed 2: fell: \"the base\" tilted"});
  const std::string md = aggregateMarkdown(a);
  EXPECT_NE(md.find("| step20_nmpc | nmpc | 4 | 3 | 75.0 % | 11.33 ± 1.53 (10.00 to 13.00)"),
            std::string::npos)
      << md;
  // The same seed twice is an error naming both files.
  results.push_back(results[0]);
  results.back().source = "elsewhere";
  EXPECT_THROW(aggregate(results), std::runtime_error);
  EXPECT_THROW(parseTrialResult("scenario: a\nseed: 1\npassed: maybe\n", "x"), std::runtime_error);
  EXPECT_THROW(parseTrialResult("scenario: a\nseed: 1\n", "x"), std::runtime_error);
  EXPECT_THROW(parseTrialResult("scenario: a\nseed: 1\npassed: true\nextra: 1\n", "x"),
               std::runtime_error);
}

// A result file is an input: every field checked for its type and range, the error naming
// the file, the line and the key.
TEST(Trials, ResultFieldsAreCheckedLikeInputs) {
  const std::string head = "scenario: s\npassed: false\n";
  const std::string parameters =
      "\ncontroller: c\nstep_height: 0.1\nfriction: 0.5\nstart_offset: 0\nsensor_noise: 1";
  const auto error = [&](const std::string& line) {
    try {
      parseTrialResult(head + line + "\n", "r.yaml");
    } catch (const std::runtime_error& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_EQ(error("seed: 1\ntraverse_time: 1e308"),
            "r.yaml: line 4: traverse_time: 1e+308 is outside [0, 1000000]");
  EXPECT_EQ(error("seed: 1\ntraverse_time: -100"),
            "r.yaml: line 4: traverse_time: -100 is outside [0, 1000000]");
  EXPECT_EQ(error("seed: 1\ntraverse_time: 0"),
            "r.yaml: line 4: traverse_time: 0 is not a traverse time");
  EXPECT_EQ(error("seed: 1e30"),
            "r.yaml: line 3: seed: '1e30' is not a seed (an integer 0 to 999999999)");
  EXPECT_EQ(
      error("seed: 18446744073709551616"),
      "r.yaml: line 3: seed: '18446744073709551616' is not a seed (an integer 0 to 999999999)");
  EXPECT_EQ(error("seed: -1"),
            "r.yaml: line 3: seed: '-1' is not a seed (an integer 0 to 999999999)");
  EXPECT_EQ(error("seed: 1\nfriction: 1e7"),
            "r.yaml: line 4: friction: 10000000 is outside [-1000000, 1000000]");
  EXPECT_EQ(error("seed: 1\nfriction: [1]"),
            "r.yaml: line 4: unknown key 'friction' (known: scenario, controller, seed, "
            "sensor_noise, speed, sensor_noise_applied, passed, failure, traverse_time, "
            "mean_abs_vz, mean_abs_wy, command, or a drawn scene number's name with its number)");
  EXPECT_EQ(error("seed: 1\nseed: 2"), "r.yaml: line 4: seed: given twice (first on line 3)");
  EXPECT_EQ(error("seed: 1\nfriction: 1\nfriction: 2"),
            "r.yaml: line 5: friction: given twice (first on line 4)");
  EXPECT_EQ(error("seed: 1\nmean_abs_vz: -0.1"),
            "r.yaml: line 4: mean_abs_vz: -0.1 is outside [0, 1000]");
  EXPECT_EQ(error("seed: 1\ncontroller: [a, b]"),
            "r.yaml: line 4: controller: expected text, not a list or mapping");
  EXPECT_EQ(error("seed: 1\ncontroller: \"a|b\""),
            "r.yaml: line 4: controller: 'a|b' is not a name (letters, digits, _ - .)");
  EXPECT_EQ(error("seed: 1\nfailure: {a: 1}"),
            "r.yaml: line 4: failure: expected text, not a list or mapping");
  EXPECT_EQ(error("seed: 7" + parameters), "accepted");
  EXPECT_EQ(error("seed: 7"), "r.yaml: missing key 'controller'");
  try {
    parseTrialResult("scenario: {a: 1}\nseed: 1\npassed: true\n", "r.yaml");
    ADD_FAILURE() << "a mapping as the scenario's name";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()),
              "r.yaml: line 1: scenario: expected text, not a list or mapping");
  }
  EXPECT_THROW(parseTrialResult("scenario: s\nseed: 1\npassed: true\nfailure: fell\n", "r"),
               std::runtime_error);
}

// A result file always reads back: any failure text (a sim's message with a tab, a control
// character, a line separator, a byte that is not UTF-8) is written so that it does.
TEST(Trials, AnyFailureTextReadsBack) {
  TrialResult r;
  r.scenario = "s";
  r.controller = "c";
  r.parameters.scene = {{"friction", "friction", false, 0.5}};
  r.failure =
      "a\tb\x01"
      "c\"d\\e\nf\u2028g\u0085h\xff";
  const TrialResult back = parseTrialResult(toYaml(r), "r.yaml");
  EXPECT_EQ(back.failure,
            "a\tb\x01"
            "c\"d\\e\nf\u2028g\u0085h?");
  EXPECT_EQ(toYaml(parseTrialResult(toYaml(back), "again")), toYaml(back));
}

// Text from result files in the aggregate: shown as it is, never as markup or table rows.
TEST(Trials, FailureTextIsShownAsItIs) {
  EXPECT_EQ(literalText("did not traverse the step"), "did not traverse the step");
  EXPECT_EQ(literalText("a\n| x | y |\n<script>`b`"), "`a | x | y | <script>'b'`");
  TrialResult r;
  r.scenario = "s";
  r.failure = "fell\n| s | x | 1 | 1 | 100.0 % |";
  const std::string md = aggregateMarkdown(aggregate({r}));
  EXPECT_EQ(md.find("\n| s | x"), std::string::npos) << md;
  EXPECT_NE(md.find("- seed 0: `fell | s | x | 1 | 1 | 100.0 % |`\n"), std::string::npos) << md;
  Document doc;
  doc.bullets({literalText("<script>alert(1)</script>")});
  EXPECT_EQ(doc.html("t").find("<script>"), std::string::npos);
}

TEST(Trials, ComparisonPairsTheSeedsBothPassed) {
  const auto result = [](const char* scenario, std::uint64_t seed, bool passed, double t, double vz,
                         double wy) {
    TrialResult r;
    r.scenario = scenario;
    r.parameters.seed = seed;
    r.passed = passed;
    if (passed) {
      r.traverse_time = t;
      r.mean_abs_vz = vz;
      r.mean_abs_wy = wy;
    }
    return r;
  };
  const std::vector<TrialResult> results = {
      result("cand", 0, true, 10.0, 0.02, 0.04),  // paired with base seed 0
      result("cand", 1, true, 12.0, 0.03, 0.05),  // base seed 1 failed: not paired
      result("cand", 2, false, 0, 0, 0),          // failed: not paired
      result("cand", 3, true, 14.0, 0.04, 0.06),  // paired with base seed 3
      result("cand", 9, true, 99.0, 9.0, 9.0),    // no base trial of seed 9
      result("base", 0, true, 20.0, 0.08, 0.10), result("base", 1, false, 0, 0, 0),
      result("base", 2, true, 50.0, 5.0, 5.0),   result("base", 3, true, 16.0, 0.04, 0.06),
      result("other", 0, true, 1.0, 1.0, 1.0),
  };
  const PairedComparison c = compareTrials(results, "cand", "base");
  EXPECT_EQ(c.candidate_trials, 5);
  EXPECT_EQ(c.candidate_passed, 4);
  EXPECT_EQ(c.baseline_trials, 4);
  EXPECT_EQ(c.baseline_passed, 3);
  EXPECT_DOUBLE_EQ(c.candidateSuccessRate(), 0.8);
  EXPECT_DOUBLE_EQ(c.baselineSuccessRate(), 0.75);
  EXPECT_EQ(c.common, 4);
  EXPECT_EQ(c.paired, 2);
  EXPECT_DOUBLE_EQ(c.candidate_traverse_time, 12.0);
  EXPECT_DOUBLE_EQ(c.baseline_traverse_time, 18.0);
  EXPECT_DOUBLE_EQ(c.candidate_mean_abs_vz, 0.03);
  EXPECT_DOUBLE_EQ(c.baseline_mean_abs_vz, 0.06);
  EXPECT_DOUBLE_EQ(c.candidate_mean_abs_wy, 0.05);
  EXPECT_DOUBLE_EQ(c.baseline_mean_abs_wy, 0.08);
  // Nothing of the baseline: success rate only.
  const PairedComparison alone = compareTrials(results, "cand", "missing");
  EXPECT_EQ(alone.candidate_trials, 5);
  EXPECT_EQ(alone.baseline_trials, 0);
  EXPECT_EQ(alone.paired, 0);
  EXPECT_EQ(alone.candidate_traverse_time, 0.0);
}

TEST(Document, MarkdownAndHtmlCarryTheSameContent) {
  Document d;
  d.heading(2, "Table 1");
  d.paragraph("mean |v_z| <with> `code`");
  d.table({"a", "b|c"}, {{"1", "x|y"}, {"2", "**not met**"}});
  d.image("fig2.png", "caption");
  d.video("video_a.mp4", "a run");
  d.paragraph("[a replay](replay_a.html)");
  d.code("rollstep report --out 'a b'");
  const std::string md = d.markdown();
  const std::string html = d.html("t");
  EXPECT_NE(md.find("## Table 1\n"), std::string::npos);
  EXPECT_NE(md.find("| 1 | x\\|y |"), std::string::npos);
  EXPECT_NE(md.find("![caption](fig2.png)"), std::string::npos);
  EXPECT_NE(html.find("<h2>Table 1</h2>"), std::string::npos);
  EXPECT_NE(html.find("mean |v_z| &lt;with&gt; <code>code</code>"), std::string::npos);
  EXPECT_NE(html.find("<img src=\"fig2.png\""), std::string::npos);
  EXPECT_NE(html.find("<pre><code>rollstep report --out 'a b'\n</code></pre>"), std::string::npos);
  // GFM (cmark-gfm): a table, emphasis inside a cell, the video player, a link.
  EXPECT_NE(html.find("<td>x|y</td>"), std::string::npos);
  EXPECT_NE(html.find("<td><strong>not met</strong></td>"), std::string::npos);
  EXPECT_EQ(html.find("**"), std::string::npos);
  EXPECT_NE(html.find("<video controls src=\"video_a.mp4\"></video>"), std::string::npos);
  EXPECT_NE(html.find("<a href=\"replay_a.html\">a replay</a>"), std::string::npos);
}

TEST(Process, ShellQuoting) {
  EXPECT_EQ(shellCommand({"rollstep", "sim", "--out", "a b", "it's"}),
            "rollstep sim --out 'a b' 'it'\\''s'");
}

// The report's verdict: Table 1 margins of the candidate's run against the baseline's, only
// when both passed with metrics; the candidate's trial success rate, only when trials were
// given.
RunOutcome judgedRun(const std::string& name, double time, double vz, double wy) {
  RunOutcome o;
  o.name = name;
  o.log = LogTable::parse("t\n0\n", name);
  if (time > 0) o.assessment.metrics = Table1Metrics{time, vz, wy, 100, 2.0};
  return o;
}

ReportInputs acceptanceInputs() {
  ReportInputs in;
  for (const char* name : {"other", "b", "n"}) {
    Scenario s;
    s.name = name;
    in.set.scenarios.push_back(s);
  }
  Acceptance& a = in.set.acceptance;
  a.candidate = "n";
  a.baseline = "b";
  a.traverse_time = -0.2;
  a.mean_abs_vz = -0.5;
  a.mean_abs_wy = -0.1;
  a.trial_success_rate = 0.9;
  a.given = true;
  in.file_acceptance = a;
  return in;
}

TEST(JudgeAcceptance, MarginsOfTheCandidatesRunAgainstTheBaselines) {
  const ReportInputs in = acceptanceInputs();
  std::vector<RunOutcome> runs = {judgedRun("other", 0, 0, 0), judgedRun("b", 10, 0.05, 0.1),
                                  judgedRun("n", 7, 0.02, 0.08)};
  ReportVerdict v = judgeAcceptance(in, runs);
  EXPECT_TRUE(v.runs_given);
  EXPECT_EQ(v.candidate, 2u);
  EXPECT_EQ(v.baseline, 1u);
  ASSERT_TRUE(v.runs_compared);
  ASSERT_EQ(v.margins.size(), 3u);
  EXPECT_EQ(v.margins[0].metric, "traverse time");
  EXPECT_NEAR(v.margins[0].change, -0.3, 1e-12);
  EXPECT_EQ(v.margins[0].margin, -0.2);
  EXPECT_NEAR(v.margins[1].change, -0.6, 1e-12);
  EXPECT_NEAR(v.margins[2].change, -0.2, 1e-12);
  EXPECT_TRUE(v.margins[0].met && v.margins[1].met && v.margins[2].met);
  EXPECT_TRUE(v.runs_met);
  EXPECT_FALSE(v.trials_judged);  // no trial folders given
  EXPECT_TRUE(v.judged());
  EXPECT_TRUE(v.met());

  // One margin missed: |w_y| only 5 % less than the baseline's.
  runs[2] = judgedRun("n", 7, 0.02, 0.095);
  v = judgeAcceptance(in, runs);
  ASSERT_EQ(v.margins.size(), 3u);
  EXPECT_TRUE(v.margins[0].met && v.margins[1].met);
  EXPECT_FALSE(v.margins[2].met);
  EXPECT_FALSE(v.runs_met);
  EXPECT_FALSE(v.met());

  // A baseline of 0 gives no finite change: not met.
  runs[1] = judgedRun("b", 10, 0.0, 0.1);
  runs[2] = judgedRun("n", 7, 0.02, 0.08);
  v = judgeAcceptance(in, runs);
  EXPECT_FALSE(v.margins[1].met);
  EXPECT_FALSE(v.runs_met);

  // A run that failed, or passed without a traverse window: nothing compared, not met.
  runs[1] = judgedRun("b", 10, 0.05, 0.1);
  runs[1].assessment.failures = {"it fell"};
  v = judgeAcceptance(in, runs);
  EXPECT_FALSE(v.runs_compared);
  EXPECT_TRUE(v.margins.empty());
  EXPECT_FALSE(v.runs_met);
  runs[1] = judgedRun("b", 0, 0, 0);
  v = judgeAcceptance(in, runs);
  EXPECT_FALSE(v.runs_compared);
  EXPECT_FALSE(v.met());

  // No acceptance in the file: nothing judged, nothing to fail.
  ReportInputs none = acceptanceInputs();
  none.set.acceptance = Acceptance{};
  none.file_acceptance = Acceptance{};
  v = judgeAcceptance(none, runs);
  EXPECT_FALSE(v.runs_given);
  EXPECT_FALSE(v.judged());
  EXPECT_TRUE(v.met());
}

TEST(JudgeAcceptance, TheCandidatesTrialSuccessRateWhenTrialsAreGiven) {
  ReportInputs in = acceptanceInputs();
  in.set.acceptance = Acceptance{};  // --only left no acceptance runs: the trials still count
  const std::vector<RunOutcome> runs = {judgedRun("other", 0, 0, 0), judgedRun("b", 0, 0, 0),
                                        judgedRun("n", 0, 0, 0)};
  const auto trials = [](int candidate_passed) {
    std::vector<TrialResult> results;
    for (int seed = 0; seed < 10; ++seed) {
      for (const char* name : {"n", "b"}) {
        TrialResult r;
        r.scenario = name;
        r.parameters.seed = static_cast<std::uint64_t>(seed);
        r.passed = std::string(name) == "b" || seed < candidate_passed;
        results.push_back(r);
      }
    }
    return results;
  };
  in.trials.results = trials(9);
  // Results without --trials folders (as after --only): not judged.
  ReportVerdict v = judgeAcceptance(in, runs);
  EXPECT_FALSE(v.trials_judged);
  EXPECT_FALSE(v.judged());

  in.trial_dirs = {"trials"};
  v = judgeAcceptance(in, runs);
  ASSERT_TRUE(v.trials_judged);
  EXPECT_EQ(v.trials.candidate_trials, 10);
  EXPECT_EQ(v.trials.candidate_passed, 9);
  EXPECT_TRUE(v.trials_met);  // 0.9 >= 0.9
  EXPECT_TRUE(v.met());

  in.trials.results = trials(8);
  v = judgeAcceptance(in, runs);
  EXPECT_FALSE(v.trials_met);  // 0.8 < 0.9
  EXPECT_FALSE(v.met());

  // No candidate trial among the results: not met (a rate of nothing is no evidence).
  in.trials.results.erase(std::remove_if(in.trials.results.begin(), in.trials.results.end(),
                                         [](const TrialResult& r) { return r.scenario == "n"; }),
                          in.trials.results.end());
  v = judgeAcceptance(in, runs);
  EXPECT_EQ(v.trials.candidate_trials, 0);
  EXPECT_FALSE(v.trials_met);
}

}  // namespace
}  // namespace rollstep::experiments
