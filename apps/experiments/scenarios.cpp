#include "scenarios.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iterator>
#include <stdexcept>

#include "rollstep/common/number_text.hpp"
#include "rollstep/common/settings_table.hpp"
#include "rollstep/common/text_file.hpp"
#include "rollstep/common/yaml_tree.hpp"
#include "rollstep/sim/scene.hpp"
#include "sim_options.hpp"
#include "trials.hpp"

namespace rollstep::experiments {

bool Scenario::feeds(const std::string& figure) const {
  for (const std::string& f : figures) {
    if (f == figure) return true;
  }
  return false;
}

std::string Scenario::terrainText() const {
  return terrain == "perception" ? "perception (LiDAR, closed loop)" : "scene ground truth";
}

bool isDrawName(const std::string& name) {
  static const char* const kResultKeys[] = {"scenario",     "controller",  "seed",
                                            "sensor_noise", "speed",       "sensor_noise_applied",
                                            "passed",       "failure",     "traverse_time",
                                            "mean_abs_vz",  "mean_abs_wy", "command"};
  if (name.empty() || name.size() > 64 || !std::isalpha(static_cast<unsigned char>(name[0]))) {
    return false;
  }
  for (char c : name) {
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_') return false;
  }
  return std::none_of(std::begin(kResultKeys), std::end(kResultKeys),
                      [&](const char* k) { return name == k; });
}

sim::RunSpec Scenario::runSpec(const std::string& out_dir) const {
  // The run's own options (args) are read by rollstep sim's parser, with the scenario's
  // controller, duration and terrain they are checked against.
  std::vector<std::string> words{"--controller", controller, "--duration",
                                 shortestNumberText(duration)};
  if (terrain == "perception") words.insert(words.end(), {"--terrain", "perception"});
  words.insert(words.end(), args.begin(), args.end());
  sim::RunSpec spec = specAtSpeed(apps::runSpecFromSimArgs(words), speed);
  // The scene file when there is one (it names its scene), else the scene by name.
  if (scene_config.empty()) {
    spec.scene = scene;
  } else {
    spec.scene_file = scene_config;
  }
  spec.control_config = control_config;
  if (terrain == "perception" && feeds("map")) spec.map_log = out_dir + "/map";
  spec.out = out_dir;
  sim::checkRunSpec(spec);
  return spec;
}

std::string sweepRunName(const std::string& scenario, double speed) {
  char text[32];
  std::snprintf(text, sizeof text, "_v%03ld", std::lround(speed * 100.0));
  return scenario + text;
}

const Scenario* ExperimentSet::find(const std::string& name) const {
  for (const Scenario& s : scenarios) {
    if (s.name == name) return &s;
  }
  return nullptr;
}

namespace {

using settings::Range;

/// [min, max], each in `range`, min <= max.
std::array<double, 2> readPair(const yaml::Node& v, settings::Reader& r, const std::string& path,
                               const Range& range) {
  if (!v.isSequence() || v.size() != 2) r.fail(v, path + ": expected [min, max]");
  const std::vector<double> x = settings::detail::readNumbers(v, 2, range, r, path);
  if (x[0] > x[1]) r.fail(v, path + ": min is above max");
  return {x[0], x[1]};
}

std::string pairYaml(double min, double max) {
  return " [" + settings::numberYaml(min) + ", " + settings::numberYaml(max) + "]";
}

/// [min, max] into two members; `given` (when not null) set when read, and the key is
/// written only when it is set.
template <typename S>
settings::Table<S>& pairField(settings::Table<S>& table, const char* key, double S::*min,
                              double S::*max, Range range, bool S::*given = nullptr) {
  return table.custom(
      key,
      [=](const yaml::Node& v, S& s, settings::Reader& r, const std::string& path) {
        const std::array<double, 2> x = readPair(v, r, path, range);
        s.*min = x[0];
        s.*max = x[1];
        if (given != nullptr) s.*given = true;
      },
      [=](const S& s, const std::string&) -> std::string {
        if (given != nullptr && !(s.*given)) return "";
        return pairYaml(s.*min, s.*max);
      });
}

/// Fails at `key`'s line when the numbers given there do not increase.
void requireIncreasing(const std::vector<double>& values, const settings::Reader& r,
                       const std::string& key) {
  for (std::size_t i = 1; i < values.size(); ++i) {
    if (values[i] <= values[i - 1]) {
      r.failAtLine(r.lineOf({key}, 0), key + ": the values must increase");
    }
  }
}

settings::Table<SpeedSweep> sweepTable() {
  using W = SpeedSweep;
  return settings::Table<W>()
      .field("baseline", &W::baseline)
      .field("candidate", &W::candidate)
      .field("compared_speeds", &W::compared_speeds, "m/s", Range::closed(0.01, 1.0), 1)
      .field("max_ratio", &W::max_ratio, "", Range::closed(0, 100))
      .field("scenarios", &W::scenarios)
      .field("speeds", &W::speeds, "m/s", Range::closed(0.01, 1.0), 1);
}

settings::Table<RunCriteria> criteriaTable() {
  return settings::Table<RunCriteria>()
      .field("joint_limit_tolerance", &RunCriteria::joint_limit_tolerance, "rad or m",
             Range::closed(0, 1))
      .field("max_tilt", &RunCriteria::max_tilt, "rad", Range::closed(0.01, M_PI));
}

settings::Table<Acceptance> acceptanceTable() {
  using A = Acceptance;
  return settings::Table<A>()
      .field("baseline", &A::baseline)
      .field("candidate", &A::candidate)
      .field("mean_abs_vz", &A::mean_abs_vz, "", Range::closed(-1, 1))
      .field("mean_abs_wy", &A::mean_abs_wy, "", Range::closed(-1, 1))
      .field("traverse_time", &A::traverse_time, "", Range::closed(-1, 1))
      .field("trial_success_rate", &A::trial_success_rate, "", Range::closed(0, 1));
}

settings::Table<TrialRanges> trialsTable() {
  settings::Table<SceneDraw> draw;
  draw.field("key", &SceneDraw::key).required().field("name", &SceneDraw::name);
  pairField(draw, "offset", &SceneDraw::min, &SceneDraw::max, Range::closed(-1e6, 1e6),
            &SceneDraw::offset);
  draw.custom(
      "range",  // the value drawn (offset: added to the file's value)
      [](const yaml::Node& v, SceneDraw& d, settings::Reader& r, const std::string& path) {
        const std::array<double, 2> x = readPair(v, r, path, Range::closed(-1e6, 1e6));
        d.min = x[0];
        d.max = x[1];
      },
      [](const SceneDraw& d, const std::string&) -> std::string {
        return d.offset ? std::string() : pairYaml(d.min, d.max);
      });
  settings::ListOptions<SceneDraw> draws;  // the list replaces the default draws
  draws.finish = [](const yaml::Node& item, SceneDraw& d, settings::Reader& r,
                    const std::string& path) {
    if ((r.seen(path + ".range") != nullptr) == (r.seen(path + ".offset") != nullptr)) {
      r.fail(item, path +
                       ": needs one of range: [min, max] (the value) or offset: [min, max] "
                       "(added to the file's value)");
    }
    if (r.seen(path + ".name") != nullptr && !isDrawName(d.name)) {
      r.failAtLine(r.lineOf({path + ".name"}, item.line()),
                   path + ".name: '" + d.name +
                       "' is not a name for result.yaml (a letter, then letters, digits, _; not "
                       "a key of result.yaml)");
    }
    if (d.name.empty()) {
      if (!isDrawName(d.key)) {
        r.fail(item,
               path + ": name is missing (the key '" + d.key + "' cannot name it in result.yaml)");
      }
      d.name = d.key;
    }
  };
  settings::Table<TrialRanges> table;
  table.sections("scene", &TrialRanges::scene, draw, draws);
  pairField(table, "sensor_noise", &TrialRanges::sensor_noise_min, &TrialRanges::sensor_noise_max,
            Range::closed(0, 100));
  pairField(table, "speed", &TrialRanges::speed_min, &TrialRanges::speed_max,
            Range::closed(0.001, 1.8), &TrialRanges::has_speed);
  return table;
}

// Options a scenario's keys or the command set: given twice in args, every run would fail
// ("At Most 1 required but received 2").
void checkArgs(const Scenario& s, const settings::Reader& r, const yaml::Node& item,
               const std::string& path) {
  const std::string key = path + ".args";
  const auto fail = [&](const std::string& what) {
    r.failAtLine(r.lineOf({key}, item.line()), key + ": " + what);
  };
  for (const std::string& arg : s.args) {
    for (const auto& [option, by] :
         {std::pair<const char*, const char*>{"--out", "the command (runs/<name>)"},
          {"--duration", "the scenario's duration key"},
          {"--scene", "the scenario's scene key"},
          {"--scene-config", "the scenario's scene_config key"},
          {"--controller", "the scenario's controller key"}}) {
      const std::string with_value = std::string(option) + "=";
      if (arg == option || arg.rfind(with_value, 0) == 0) {
        fail("'" + std::string(option) + "' is set by " + by + ", not in args");
      }
    }
    if (arg == "--control-config") {
      fail(
          "'--control-config' is set by the scenario's control_config key (a path relative to "
          "this file)");
    }
    if (arg == "--terrain" || arg.rfind("--terrain=", 0) == 0 || arg == "--log-map") {
      fail("'" + arg +
           "' is set by the scenario's terrain key (terrain: perception | scene; its map log by "
           "figures: [map])");
    }
  }
}

settings::Table<Scenario> scenarioTable() {
  using P = PaperFigures;
  const settings::Table<P> paper =
      settings::Table<P>()
          .field("mean_abs_vz", &P::mean_abs_vz, "m/s", Range::closed(0, 1e6))
          .field("mean_abs_wy", &P::mean_abs_wy, "rad/s", Range::closed(0, 1e6))
          .field("traverse_time", &P::traverse_time, "s", Range::closed(0, 1e6));
  using S = Scenario;
  return settings::Table<S>()
      .field("args", &S::args, settings::Repeats::Allowed)
      .field("control_config", &S::control_config)
      .field("controller", &S::controller)
      .required()
      .field("duration", &S::duration, "s", Range::closed(0.001, 3600))
      .field("figures", &S::figures)
      .field("name", &S::name)
      .required()
      .section("paper", &S::paper, paper)
      .field("scene", &S::scene)
      .required()
      .field("scene_config", &S::scene_config)
      .field("terrain", &S::terrain)
      .field("title", &S::title)
      .field("traverse", &S::traverse)
      .field("video", &S::video);
}

settings::ListOptions<Scenario> scenarioChecks() {
  settings::ListOptions<Scenario> options;
  options.finish = [](const yaml::Node& item, Scenario& s, settings::Reader& r,
                      const std::string& path) {
    const auto failAt = [&](const char* key, const std::string& what) {
      r.failAtLine(r.lineOf({path + "." + key}, item.line()), path + "." + key + ": " + what);
    };
    if (!sim::isSceneName(s.scene))
      failAt("scene", "'" + s.scene + "' is not " + sim::sceneNamesText());
    checkArgs(s, r, item, path);
    if (s.terrain != "scene" && s.terrain != "perception") {
      failAt("terrain", "'" + s.terrain + "' is not scene or perception");
    }
    for (const std::string& name : s.figures) {
      if (name != "table1" && name != "fig4" && name != "fig6" && name != "fig8" &&
          name != "snapshots" && name != "map") {
        failAt("figures", "'" + name + "' is not table1, fig4, fig6, fig8, snapshots or map");
      }
    }
    if (const settings::Reader::Seen* paper = r.seen(path + ".paper")) {
      if (paper->text == "null") failAt("paper", "no value");
      s.paper.given = true;
    }
    for (char c : s.name) {
      if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-')) {
        r.fail(item, path + ".name: '" + s.name +
                         "': only letters, digits, '_' and '-' (it names a folder)");
      }
    }
    if (s.feeds("map") && s.terrain != "perception") {
      r.fail(item, path + ".figures: map (the perceived map's top view) needs terrain: perception");
    }
  };
  return options;
}

/// The experiments file's keys.
const settings::Table<ExperimentSet>& experimentsTable() {
  using E = ExperimentSet;
  static const settings::Table<E> table =
      settings::Table<E>()
          .section("acceptance", &E::acceptance, acceptanceTable())
          .section("criteria", &E::criteria, criteriaTable())
          .sections("scenarios", &E::scenarios, scenarioTable(), scenarioChecks())
          .section("speed_sweep", &E::sweep, sweepTable())
          .section("trials", &E::trials, trialsTable());
  return table;
}

}  // namespace

ExperimentSet parseExperimentSet(const std::string& text, const std::string& source,
                                 const std::string& base_dir) {
  ExperimentSet set;
  set.source = source;
  set.text = text;
  const yaml::Document doc = yaml::parseDocument(text, source + ": ");
  settings::Reader reader(source + ": ");
  experimentsTable().read(doc.root(), set, reader);
  // The cross-field checks, at the line of the key they name.
  const auto lineOf = [&](const std::string& key) { return reader.lineOf({key}, 0); };
  for (std::size_t i = 0; i < set.scenarios.size(); ++i) {
    Scenario& s = set.scenarios[i];
    const std::string path = "scenarios[" + std::to_string(i) + "]";
    for (std::size_t j = 0; j < i; ++j) {
      if (set.scenarios[j].name == s.name) {
        reader.failAtLine(lineOf(path + ".name"),
                          path + ".name: '" + s.name + "' is used by another scenario");
      }
    }
    for (std::string* file : {&s.scene_config, &s.control_config}) {
      if (!file->empty() && (*file)[0] != '/') *file = base_dir + "/" + *file;
    }
    if (s.title.empty()) s.title = s.name;
    // The run's options checked now, not when the run starts.
    try {
      s.runSpec("out");
    } catch (const std::exception& e) {
      reader.failAtLine(reader.lineOf({path + ".args", path + ".name"}, 0),
                        path + ".args: " + e.what());
    }
  }
  const std::vector<SceneDraw>& draws = set.trials.scene;
  for (std::size_t i = 0; i < draws.size(); ++i) {
    for (std::size_t j = 0; j < i; ++j) {
      if (draws[j].name == draws[i].name) {
        const std::string path = "trials.scene[" + std::to_string(i) + "]";
        reader.failAtLine(lineOf(path + ".key"),
                          path + ": name '" + draws[i].name + "' is drawn twice");
      }
    }
  }
  const int sweep_line = lineOf("speed_sweep");
  if (reader.seen("speed_sweep") != nullptr) {
    SpeedSweep& w = set.sweep;
    w.given = true;
    const auto fail = [&](const std::string& what) {
      reader.failAtLine(sweep_line, "speed_sweep: " + what);
    };
    requireIncreasing(w.speeds, reader, "speed_sweep.speeds");
    requireIncreasing(w.compared_speeds, reader, "speed_sweep.compared_speeds");
    if (w.scenarios.empty() || w.speeds.empty()) fail("needs scenarios and speeds");
    for (const std::string* name : {&w.candidate, &w.baseline}) {
      if (!name->empty() &&
          std::find(w.scenarios.begin(), w.scenarios.end(), *name) == w.scenarios.end()) {
        fail("'" + *name + "' (candidate or baseline) is not one of its scenarios");
      }
    }
    if (w.candidate.empty() != w.baseline.empty() ||
        (!w.candidate.empty() && w.candidate == w.baseline)) {
      fail("candidate and baseline: two different scenarios, or neither");
    }
    for (double v : w.compared_speeds) {
      if (std::none_of(w.speeds.begin(), w.speeds.end(),
                       [v](double s) { return std::abs(s - v) < 1e-9; })) {
        fail("compared speed " + shortestNumberText(v) + " is not one of speeds");
      }
    }
  }
  if (reader.seen("acceptance") != nullptr) {
    Acceptance& a = set.acceptance;
    a.given = true;
    const int line = lineOf("acceptance");
    if (a.candidate.empty() || a.baseline.empty()) {
      reader.failAtLine(line, "acceptance: needs candidate and baseline");
    }
    if (a.candidate == a.baseline) {
      reader.failAtLine(line, "acceptance: candidate and baseline are both '" + a.candidate +
                                  "' (a scenario compared with itself)");
    }
    for (const std::string* name : {&a.candidate, &a.baseline}) {
      if (set.find(*name) == nullptr) {
        reader.failAtLine(line, "acceptance: no scenario named '" + *name + "'");
      }
    }
  }
  if (set.scenarios.empty()) throw std::runtime_error(source + ": no scenarios");
  if (set.sweep.given) {
    const auto fail = [&](const std::string& what) {
      throw std::runtime_error(source + ": line " + std::to_string(sweep_line) +
                               ": speed_sweep: " + what);
    };
    std::vector<Scenario> runs;
    for (const std::string& name : set.sweep.scenarios) {
      const Scenario* base = set.find(name);
      if (base == nullptr) fail("no scenario named '" + name + "'");
      for (double speed : set.sweep.speeds) {
        TrialParameters p;
        p.speed = speed;
        const Scenario s_at_speed = trialScenario(*base, p);
        Scenario s = s_at_speed;
        try {
          if (s.runSpec("out") == base->runSpec("out")) {  // as it was: no speed
            fail("'" + name + "' has no forward command (--vx or --command) to scale");
          }
        } catch (const std::invalid_argument& e) {
          fail(std::string(e.what()));
        }
        s.name = sweepRunName(name, speed);
        if (set.find(s.name) != nullptr ||
            std::any_of(runs.begin(), runs.end(),
                        [&](const Scenario& r) { return r.name == s.name; })) {
          fail("'" + s.name + "' names two runs (speeds within 0.01 m/s, or a scenario's name)");
        }
        char speed_text[32];
        std::snprintf(speed_text, sizeof speed_text, "%.2f", speed);
        s.title = base->title + " at " + speed_text + " m/s";
        s.figures.clear();
        s.video = false;
        s.paper = PaperFigures{};
        s.sweep_of = name;
        s.sweep_speed = speed;
        runs.push_back(std::move(s));
      }
    }
    set.scenarios.insert(set.scenarios.end(), runs.begin(), runs.end());
  }
  return set;
}

ExperimentSet loadExperimentSet(const std::string& file) {
  const std::string text = readTextFile(file, "experiments", std::size_t{1} << 20);
  const std::string dir = std::filesystem::absolute(file).parent_path().string();
  return parseExperimentSet(text, "experiments '" + file + "'", dir);
}

}  // namespace rollstep::experiments
