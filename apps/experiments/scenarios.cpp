#include "scenarios.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <iterator>
#include <map>
#include <stdexcept>

#include "rollstep/common/number_text.hpp"
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

sim::RunSpec Scenario::runSpec(const std::string& out_dir,
                               const std::string& scene_config_override) const {
  // The run's own options (args) are read by rollstep sim's parser, with the scenario's
  // controller, duration and terrain they are checked against.
  std::vector<std::string> words{"--controller", controller, "--duration",
                                 shortestNumberText(duration)};
  if (terrain == "perception") words.insert(words.end(), {"--terrain", "perception"});
  words.insert(words.end(), args.begin(), args.end());
  sim::RunSpec spec = apps::runSpecFromSimArgs(words);
  // The scene file when there is one (it names its scene), else the scene by name.
  const std::string& file = scene_config_override.empty() ? scene_config : scene_config_override;
  if (file.empty()) {
    spec.scene = scene;
  } else {
    spec.scene_file = file;
  }
  spec.control_config = control_config;
  if (terrain == "perception" && feeds("map")) spec.map_log = out_dir + "/map";
  spec.out = out_dir;
  sim::checkRunSpec(spec);
  return spec;
}

std::string Scenario::option(const std::string& flag) const {
  for (std::size_t i = 0; i + 1 < args.size(); ++i) {
    if (args[i] == flag) return args[i + 1];
  }
  return "";
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

/// Reads one mapping: each key once, only known keys, errors naming file, line and key.
class MappingReader {
 public:
  MappingReader(const yaml::Node& node, std::string source, std::string prefix)
      : node_(node), source_(std::move(source)), prefix_(std::move(prefix)) {
    if (!node.isMapping())
      fail(node, prefix_.empty() ? "" : prefix_.substr(0, prefix_.size() - 1),
           std::string("expected a mapping, got ") + node.kindName());
  }
  /// Calls `read(value, full_key)` for each entry whose key is in `known`.
  void each(const std::map<std::string, std::function<void(const yaml::Node&, const std::string&)>>&
                known) {
    std::map<std::string, int> seen;
    for (std::size_t i = 0; i < node_.size(); ++i) {
      const yaml::Node key = node_.key(i);
      const std::string name = key.isScalar() ? key.scalar() : "<key>";
      const auto it = known.find(name);
      if (it == known.end()) {
        std::string list;
        for (const auto& k : known) list += (list.empty() ? "" : ", ") + k.first;
        fail(key, "", "unknown key '" + prefix_ + name + "' (known: " + list + ")");
      }
      if (const auto s = seen.find(name); s != seen.end()) {
        fail(key, prefix_ + name, "given twice (first on line " + std::to_string(s->second) + ")");
      }
      seen.emplace(name, key.line());
      if (node_.value(i).isNull()) fail(node_.value(i), prefix_ + name, "no value");
      it->second(node_.value(i), prefix_ + name);
    }
  }
  [[noreturn]] void fail(const yaml::Node& n, const std::string& key,
                         const std::string& what) const {
    throw std::runtime_error(source_ + ": line " + std::to_string(n.line()) + ": " +
                             (key.empty() ? "" : key + ": ") + what);
  }

 private:
  yaml::Node node_;
  std::string source_;
  std::string prefix_;
};

}  // namespace

ExperimentSet parseExperimentSet(const std::string& text, const std::string& source,
                                 const std::string& base_dir) {
  ExperimentSet set;
  set.source = source;
  set.text = text;
  yaml::Document doc = yaml::parseDocument(text, source + ": ");
  MappingReader top(doc.root(), source, "");
  const auto number = [&](const MappingReader& r, double min, double max) {
    return [&r, min, max](const yaml::Node& n, const std::string& key, double& out) {
      double v = 0.0;
      if (!n.isScalar() || !n.toDouble(v)) {
        r.fail(n, key,
               (n.isScalar() ? "'" + n.scalar() + "'" : std::string(n.kindName())) +
                   " is not a number");
      }
      if (!std::isfinite(v) || v < min || v > max) {
        r.fail(n, key,
               n.scalar() + " is outside [" + shortestNumberText(min) + ", " +
                   shortestNumberText(max) + "]");
      }
      out = v;
    };
  };
  const auto word = [](const MappingReader& r) {
    return [&r](const yaml::Node& n, const std::string& key, std::string& out) {
      if (!n.isScalar()) r.fail(n, key, std::string("expected text, got ") + n.kindName());
      out = n.scalar();
    };
  };
  const auto flag = [](const MappingReader& r) {
    return [&r](const yaml::Node& n, const std::string& key, bool& out) {
      if (!n.isScalar() || !n.toBool(out)) r.fail(n, key, "expected true or false");
    };
  };
  const auto words = [](const MappingReader& r) {
    return [&r](const yaml::Node& n, const std::string& key, std::vector<std::string>& out) {
      if (!n.isSequence()) r.fail(n, key, std::string("expected a list, got ") + n.kindName());
      for (std::size_t i = 0; i < n.size(); ++i) {
        if (!n.item(i).isScalar()) r.fail(n.item(i), key, "every item must be a single value");
        out.push_back(n.item(i).scalar());
      }
    };
  };
  // A [min, max] pair.
  const auto range = [&](const MappingReader& r, double lo, double hi) {
    return [&r, lo, hi, number](const yaml::Node& n, const std::string& key, double& min,
                                double& max) {
      if (!n.isSequence() || n.size() != 2) r.fail(n, key, "expected [min, max]");
      const auto num = number(r, lo, hi);
      num(n.item(0), key, min);
      num(n.item(1), key, max);
      if (min > max) r.fail(n, key, "min is above max");
    };
  };

  // A list of numbers in [lo, hi], increasing.
  const auto increasing = [&](const MappingReader& r, double lo, double hi) {
    return [&r, lo, hi, number](const yaml::Node& n, const std::string& key,
                                std::vector<double>& out) {
      if (!n.isSequence() || n.size() == 0) r.fail(n, key, "expected a list of numbers");
      const auto num = number(r, lo, hi);
      for (std::size_t i = 0; i < n.size(); ++i) {
        double v = 0.0;
        num(n.item(i), key, v);
        if (!out.empty() && v <= out.back()) r.fail(n.item(i), key, "the values must increase");
        out.push_back(v);
      }
    };
  };

  int acceptance_line = 0;
  int sweep_line = 0;
  top.each({
      {"speed_sweep",
       [&](const yaml::Node& n, const std::string& key) {
         MappingReader r(n, source, key + ".");
         sweep_line = n.line();
         SpeedSweep& w = set.sweep;
         w.given = true;
         r.each(
             {{"scenarios",
               [&](const yaml::Node& v, const std::string& k) { words(r)(v, k, w.scenarios); }},
              {"speeds", [&](const yaml::Node& v,
                             const std::string& k) { increasing(r, 0.01, 1.0)(v, k, w.speeds); }},
              {"candidate",
               [&](const yaml::Node& v, const std::string& k) { word(r)(v, k, w.candidate); }},
              {"baseline",
               [&](const yaml::Node& v, const std::string& k) { word(r)(v, k, w.baseline); }},
              {"compared_speeds",
               [&](const yaml::Node& v, const std::string& k) {
                 increasing(r, 0.01, 1.0)(v, k, w.compared_speeds);
               }},
              {"max_ratio", [&](const yaml::Node& v, const std::string& k) {
                 number(r, 0.0, 100.0)(v, k, w.max_ratio);
               }}});
         if (w.scenarios.empty() || w.speeds.empty()) r.fail(n, key, "needs scenarios and speeds");
         for (const std::string* name : {&w.candidate, &w.baseline}) {
           if (!name->empty() &&
               std::find(w.scenarios.begin(), w.scenarios.end(), *name) == w.scenarios.end()) {
             r.fail(n, key, "'" + *name + "' (candidate or baseline) is not one of its scenarios");
           }
         }
         if (w.candidate.empty() != w.baseline.empty() ||
             (!w.candidate.empty() && w.candidate == w.baseline)) {
           r.fail(n, key, "candidate and baseline: two different scenarios, or neither");
         }
         for (double v : w.compared_speeds) {
           if (std::none_of(w.speeds.begin(), w.speeds.end(),
                            [v](double s) { return std::abs(s - v) < 1e-9; })) {
             r.fail(n, key, "compared speed " + shortestNumberText(v) + " is not one of speeds");
           }
         }
       }},
      {"criteria",
       [&](const yaml::Node& n, const std::string& key) {
         MappingReader r(n, source, key + ".");
         r.each({{"max_tilt",
                  [&](const yaml::Node& v, const std::string& k) {
                    number(r, 0.01, M_PI)(v, k, set.criteria.max_tilt);
                  }},
                 {"joint_limit_tolerance", [&](const yaml::Node& v, const std::string& k) {
                    number(r, 0.0, 1.0)(v, k, set.criteria.joint_limit_tolerance);
                  }}});
       }},
      {"acceptance",
       [&](const yaml::Node& n, const std::string& key) {
         MappingReader r(n, source, key + ".");
         acceptance_line = n.line();
         set.acceptance.given = true;
         Acceptance& a = set.acceptance;
         r.each({{"candidate",
                  [&](const yaml::Node& v, const std::string& k) { word(r)(v, k, a.candidate); }},
                 {"baseline",
                  [&](const yaml::Node& v, const std::string& k) { word(r)(v, k, a.baseline); }},
                 {"traverse_time",
                  [&](const yaml::Node& v, const std::string& k) {
                    number(r, -1.0, 1.0)(v, k, a.traverse_time);
                  }},
                 {"mean_abs_vz",
                  [&](const yaml::Node& v, const std::string& k) {
                    number(r, -1.0, 1.0)(v, k, a.mean_abs_vz);
                  }},
                 {"mean_abs_wy",
                  [&](const yaml::Node& v, const std::string& k) {
                    number(r, -1.0, 1.0)(v, k, a.mean_abs_wy);
                  }},
                 {"trial_success_rate", [&](const yaml::Node& v, const std::string& k) {
                    number(r, 0.0, 1.0)(v, k, a.trial_success_rate);
                  }}});
         if (a.candidate.empty() || a.baseline.empty()) {
           r.fail(n, key, "needs candidate and baseline");
         }
         if (a.candidate == a.baseline) {
           r.fail(n, key,
                  "candidate and baseline are both '" + a.candidate +
                      "' (a scenario compared with itself)");
         }
       }},
      {"trials",
       [&](const yaml::Node& n, const std::string& key) {
         MappingReader r(n, source, key + ".");
         TrialRanges& t = set.trials;
         r.each({{"scene",
                  [&](const yaml::Node& v, const std::string& k) {
                    // The list replaces the default draws (an empty list: none).
                    if (!v.isSequence())
                      r.fail(v, k, std::string("expected a list, got ") + v.kindName());
                    t.scene.clear();
                    for (std::size_t i = 0; i < v.size(); ++i) {
                      const std::string ik = k + "[" + std::to_string(i) + "]";
                      MappingReader d(v.item(i), source, ik + ".");
                      SceneDraw draw;
                      bool has_range = false, has_offset = false;
                      d.each({{"name",
                               [&](const yaml::Node& x, const std::string& xk) {
                                 word(d)(x, xk, draw.name);
                                 if (!isDrawName(draw.name)) {
                                   d.fail(x, xk,
                                          "'" + draw.name +
                                              "' is not a name for result.yaml (a letter, "
                                              "then letters, digits, _; not a key of "
                                              "result.yaml)");
                                 }
                               }},
                              {"key", [&](const yaml::Node& x,
                                          const std::string& xk) { word(d)(x, xk, draw.key); }},
                              {"range",
                               [&](const yaml::Node& x, const std::string& xk) {
                                 range(d, -1e6, 1e6)(x, xk, draw.min, draw.max);
                                 has_range = true;
                               }},
                              {"offset", [&](const yaml::Node& x, const std::string& xk) {
                                 range(d, -1e6, 1e6)(x, xk, draw.min, draw.max);
                                 has_offset = true;
                                 draw.offset = true;
                               }}});
                      if (draw.key.empty())
                        r.fail(v.item(i), ik, "key (a scene number) is missing");
                      if (has_range == has_offset) {
                        r.fail(v.item(i), ik,
                               "needs one of range: [min, max] (the value) or "
                               "offset: [min, max] (added to the file's value)");
                      }
                      if (draw.name.empty()) {
                        if (!isDrawName(draw.key)) {
                          r.fail(v.item(i), ik,
                                 "name is missing (the key '" + draw.key +
                                     "' cannot name it in result.yaml)");
                        }
                        draw.name = draw.key;
                      }
                      for (const SceneDraw& other : t.scene) {
                        if (other.name == draw.name)
                          r.fail(v.item(i), ik, "name '" + draw.name + "' is drawn twice");
                      }
                      t.scene.push_back(draw);
                    }
                  }},
                 {"sensor_noise",
                  [&](const yaml::Node& v, const std::string& k) {
                    range(r, 0.0, 100.0)(v, k, t.sensor_noise_min, t.sensor_noise_max);
                  }},
                 {"speed", [&](const yaml::Node& v, const std::string& k) {
                    range(r, 0.001, 1.8)(v, k, t.speed_min, t.speed_max);
                    t.has_speed = true;
                  }}});
       }},
      {"scenarios",
       [&](const yaml::Node& n, const std::string& key) {
         if (!n.isSequence()) top.fail(n, key, std::string("expected a list, got ") + n.kindName());
         for (std::size_t i = 0; i < n.size(); ++i) {
           const yaml::Node item = n.item(i);
           const std::string prefix = key + "[" + std::to_string(i) + "].";
           MappingReader r(item, source, prefix);
           Scenario s;
           r.each({
               {"name", [&](const yaml::Node& v, const std::string& k) { word(r)(v, k, s.name); }},
               {"title",
                [&](const yaml::Node& v, const std::string& k) { word(r)(v, k, s.title); }},
               {"scene",
                [&](const yaml::Node& v, const std::string& k) {
                  word(r)(v, k, s.scene);
                  if (!sim::isSceneName(s.scene)) {
                    r.fail(v, k, "'" + s.scene + "' is not " + sim::sceneNamesText());
                  }
                }},
               {"scene_config",
                [&](const yaml::Node& v, const std::string& k) {
                  word(r)(v, k, s.scene_config);
                  if (!s.scene_config.empty() && s.scene_config[0] != '/') {
                    s.scene_config = base_dir + "/" + s.scene_config;
                  }
                }},
               {"controller",
                [&](const yaml::Node& v, const std::string& k) { word(r)(v, k, s.controller); }},
               {"control_config",
                [&](const yaml::Node& v, const std::string& k) {
                  word(r)(v, k, s.control_config);
                  if (!s.control_config.empty() && s.control_config[0] != '/') {
                    s.control_config = base_dir + "/" + s.control_config;
                  }
                }},
               {"duration",
                [&](const yaml::Node& v, const std::string& k) {
                  number(r, 0.001, 3600.0)(v, k, s.duration);
                }},
               {"args",
                [&](const yaml::Node& v, const std::string& k) {
                  words(r)(v, k, s.args);
                  for (std::size_t a = 0; a < s.args.size(); ++a) {
                    // Options the scenario's keys or the command set: given twice, every
                    // run would fail ("At Most 1 required but received 2").
                    for (const auto& [option, by] :
                         {std::pair<const char*, const char*>{"--out", "the command (runs/<name>)"},
                          {"--duration", "the scenario's duration key"},
                          {"--scene", "the scenario's scene key"},
                          {"--scene-config", "the scenario's scene_config key"},
                          {"--controller", "the scenario's controller key"}}) {
                      const std::string with_value = std::string(option) + "=";
                      if (s.args[a] == option || s.args[a].rfind(with_value, 0) == 0) {
                        r.fail(v.item(a), k,
                               "'" + std::string(option) + "' is set by " + by + ", not in args");
                      }
                    }
                    if (s.args[a] == "--control-config") {
                      r.fail(v.item(a), k,
                             "'--control-config' is set by the scenario's control_config key "
                             "(a path relative to this file)");
                    }
                    if (s.args[a] == "--terrain" || s.args[a].rfind("--terrain=", 0) == 0 ||
                        s.args[a] == "--log-map") {
                      r.fail(v.item(a), k,
                             "'" + s.args[a] +
                                 "' is set by the scenario's terrain key (terrain: "
                                 "perception | scene; its map log by figures: [map])");
                    }
                  }
                }},
               {"terrain",
                [&](const yaml::Node& v, const std::string& k) {
                  word(r)(v, k, s.terrain);
                  if (s.terrain != "scene" && s.terrain != "perception") {
                    r.fail(v, k, "'" + s.terrain + "' is not scene or perception");
                  }
                }},
               {"traverse",
                [&](const yaml::Node& v, const std::string& k) { flag(r)(v, k, s.traverse); }},
               {"video",
                [&](const yaml::Node& v, const std::string& k) { flag(r)(v, k, s.video); }},
               {"figures",
                [&](const yaml::Node& v, const std::string& k) {
                  words(r)(v, k, s.figures);
                  for (std::size_t f = 0; f < s.figures.size(); ++f) {
                    const std::string& name = s.figures[f];
                    if (name != "table1" && name != "fig4" && name != "fig6" && name != "fig8" &&
                        name != "snapshots" && name != "map") {
                      r.fail(v.item(f), k,
                             "'" + name + "' is not table1, fig4, fig6, fig8, snapshots or map");
                    }
                  }
                }},
               {"paper",
                [&](const yaml::Node& v, const std::string& k) {
                  MappingReader p(v, source, k + ".");
                  s.paper.given = true;
                  p.each({{"traverse_time",
                           [&](const yaml::Node& x, const std::string& kk) {
                             number(p, 0.0, 1e6)(x, kk, s.paper.traverse_time);
                           }},
                          {"mean_abs_vz",
                           [&](const yaml::Node& x, const std::string& kk) {
                             number(p, 0.0, 1e6)(x, kk, s.paper.mean_abs_vz);
                           }},
                          {"mean_abs_wy", [&](const yaml::Node& x, const std::string& kk) {
                             number(p, 0.0, 1e6)(x, kk, s.paper.mean_abs_wy);
                           }}});
                }},
           });
           for (const auto& [field, value] :
                {std::pair<const char*, const std::string*>{"name", &s.name},
                 {"scene", &s.scene},
                 {"controller", &s.controller}}) {
             if (value->empty()) r.fail(item, prefix + field, "missing (required)");
           }
           for (char c : s.name) {
             if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-')) {
               r.fail(item, prefix + "name",
                      "'" + s.name + "': only letters, digits, '_' and '-' (it names a folder)");
             }
           }
           if (set.find(s.name) != nullptr) {
             r.fail(item, prefix + "name", "'" + s.name + "' is used by another scenario");
           }
           if (s.feeds("map") && s.terrain != "perception") {
             r.fail(item, prefix + "figures",
                    "map (the perceived map's top view) needs terrain: perception");
           }
           if (s.title.empty()) s.title = s.name;
           // The run's options checked now, not when the run starts.
           try {
             s.runSpec("out");
           } catch (const std::exception& e) {
             r.fail(item, prefix + "args", e.what());
           }
           set.scenarios.push_back(std::move(s));
         }
       }},
  });
  if (set.acceptance.given) {
    for (const std::string* name : {&set.acceptance.candidate, &set.acceptance.baseline}) {
      if (set.find(*name) == nullptr) {
        throw std::runtime_error(source + ": line " + std::to_string(acceptance_line) +
                                 ": acceptance: no scenario named '" + *name + "'");
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
        Scenario s;
        try {
          s = trialScenario(*base, p);
        } catch (const std::invalid_argument& e) {
          fail(std::string(e.what()));
        }
        if (s.duration == base->duration && s.args == base->args) {  // as it was: no speed
          fail("'" + name + "' has no forward command (--vx or --command) to scale");
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
