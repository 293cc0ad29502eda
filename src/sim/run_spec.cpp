#include "rollstep/sim/run_spec.hpp"

#include <cctype>
#include <cmath>
#include <filesystem>

#include "rollstep/common/number_text.hpp"
#include "rollstep/common/settings_table.hpp"
#include "rollstep/common/text_file.hpp"

namespace rollstep::sim {

namespace {

namespace fs = std::filesystem;
using settings::Range;

// Speeds of a command entry: the ranges of `rollstep sim --vx`, --vy and --yaw-rate.
constexpr double kMaxVx = 1.0, kMaxVy = 0.5, kMaxYawRate = 1.0;  // [m/s], [m/s], [rad/s]
constexpr double kMaxDuration = 3600.0;                          // [s]

/// Text as YAML: plain when it is only letters, digits and _ . / - (and not a word YAML
/// reads as null or a flag), else double-quoted.
std::string textYaml(const std::string& text) {
  bool plain = !text.empty() && text[0] != '-' && text[0] != '.';
  for (const char c : text) {
    plain = plain && (std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '.' ||
                      c == '/' || c == '-');
  }
  for (const char* word : {"null", "Null", "NULL", "true", "True", "TRUE", "false", "False",
                           "FALSE", "yes", "no", "on", "off", "y", "n"}) {
    plain = plain && text != word;
  }
  if (plain) return text;
  std::string out = "\"";
  for (const char c : text) {
    if (c == '\n') {
      out += "\\n";
    } else if (c == '\t') {
      out += "\\t";
    } else {
      if (c == '"' || c == '\\') out += '\\';
      out += c;
    }
  }
  return out + "\"";
}

/// A text key (a name or a path): any scalar, quoted or not.
void addText(settings::Table<RunSpec>& table, const char* key, std::string RunSpec::*member) {
  table.custom(
      key,
      [member](const yaml::Node& v, RunSpec& s, settings::Reader& r, const std::string& path) {
        if (!v.isScalar()) r.fail(v, path + ": expected text, got " + v.kindName());
        s.*member = v.scalar();
      },
      [member](const RunSpec& s, const std::string&) { return " " + textYaml(s.*member); });
}

/// `command:` as a list of [time, vx, vy, yaw_rate] entries (vy and yaw_rate may be left
/// out: 0).
void readCommand(const yaml::Node& v, RunSpec& s, settings::Reader& r, const std::string& path) {
  if (!v.isSequence() || v.size() == 0) {
    r.fail(v, path + ": expected a list of [time, vx, vy, yaw_rate] entries");
  }
  s.command.clear();
  for (std::size_t i = 0; i < v.size(); ++i) {
    const yaml::Node item = v.item(i);
    const std::string at = path + "[" + std::to_string(i) + "]";
    if (!item.isSequence() || item.size() < 2 || item.size() > 4) {
      r.fail(item, at + ": expected [time, vx, vy, yaw_rate] (2 to 4 numbers)");
    }
    std::array<double, 4> x{0.0, 0.0, 0.0, 0.0};
    for (std::size_t k = 0; k < item.size(); ++k) {
      x[k] = settings::detail::readNumber(item.item(k), Range::anyFinite(), r, at);
    }
    s.command.push_back({x[0], {x[1], x[2], x[3]}});
  }
}

std::string writeCommand(const RunSpec& s, const std::string&) {
  std::string out = " [";
  for (std::size_t i = 0; i < s.command.size(); ++i) {
    const planning::TimedBaseCommand& c = s.command[i];
    const double x[4] = {c.time, c.command.v_x, c.command.v_y, c.command.yaw_rate};
    out += (i ? ", " : "") + settings::detail::numbersYaml(x, 4);
  }
  return out + "]";
}

/// `control:` a mapping of control settings (the control settings' own reader: its keys,
/// ranges and checks, named control.<key>), or null for none.
void readControl(const yaml::Node& v, RunSpec& s, settings::Reader& r, const std::string& path,
                 const std::string& base_dir) {
  if (v.isNull()) {
    s.control.reset();
    return;
  }
  // Over the settings the spec had (a spec read over another: its keys replace values).
  s.control = control::readControlSettings(v, r, path + ".", base_dir,
                                           s.control ? *s.control : control::ControlSettings{});
}

std::string writeControl(const RunSpec& s, const std::string& indent) {
  if (!s.control) return " null";
  return "\n" + control::toYaml(*s.control, indent + "  ");
}

/// `inline_scene:` a mapping of a scene file's keys (the scene's own reader: its keys and
/// checks, named inline_scene.<key>), or null for none.
void readInlineScene(const yaml::Node& v, RunSpec& s, settings::Reader& r,
                     const std::string& path) {
  if (v.isNull()) {
    s.inline_scene.reset();
    return;
  }
  s.inline_scene = readSceneConfig(v, r, path + ".", s.scene);
}

std::string writeInlineScene(const RunSpec& s, const std::string& indent) {
  if (!s.inline_scene) return " null";
  const std::string keys = sceneYaml(*s.inline_scene, indent + "  ");
  return keys.empty() ? " {}" : "\n" + keys;
}

/// `scene_parameters:` a mapping of name: number (the names are checked against the scene
/// once the spec is read: parseRunSpec).
void readSceneNumbers(const yaml::Node& v, RunSpec& s, settings::Reader& r,
                      const std::string& path) {
  s.scene_parameters.clear();
  if (v.isNull()) return;
  if (!v.isMapping()) r.fail(v, path + ": expected a mapping of name: number");
  for (std::size_t i = 0; i < v.size(); ++i) {
    const yaml::Node key = v.key(i);
    if (!key.isScalar() || key.scalar().empty()) {
      r.fail(key, path + ": a name is not a plain name");
    }
    const std::string at = path + "." + key.scalar();
    r.note(at, key, v.value(i));
    if (!v.value(i).isScalar()) {
      r.fail(v.value(i), at + ": expected a single number, got " + v.value(i).kindName());
    }
    s.scene_parameters.push_back(
        {key.scalar(), settings::detail::readNumber(v.value(i), Range::anyFinite(), r, at)});
  }
}

std::string writeSceneNumbers(const RunSpec& s, const std::string& indent) {
  if (s.scene_parameters.empty()) return " {}";
  std::string out = "\n";
  for (const SceneNumberValue& n : s.scene_parameters) {
    out += indent + "  " + textYaml(n.name) + ": " + settings::numberYaml(n.value) + "\n";
  }
  return out;
}

settings::Table<RunSpec> makeTable(const std::string& base_dir) {
  settings::Table<RunSpec> t;
  addText(t, "robot", &RunSpec::robot);
  addText(t, "scene", &RunSpec::scene);
  addText(t, "scene_file", &RunSpec::scene_file);
  t.custom("inline_scene", readInlineScene, writeInlineScene, /*is_section=*/true)
      .documentedAs([](const std::string&) {
        return std::string(
            " null  # none: scene or scene_file; else a mapping of a scene file's keys, scene "
            "its name\n");
      });
  t.custom("scene_parameters", readSceneNumbers, writeSceneNumbers, /*is_section=*/true)
      .documentedAs([](const std::string&) {
        return std::string(
            " {}  # name: number, each a parameter of the scene, friction or a key path "
            "(boxes[0].size[2])\n");
      });
  t.field("controller", &RunSpec::controller)
      .field("duration", &RunSpec::duration, "s", Range::closed(0.001, kMaxDuration))
      .field("gait", &RunSpec::gait)
      .custom("command", readCommand, writeCommand)
      .field("drive_speed", &RunSpec::drive_speed, "m/s", Range::closed(-1.8, 1.8))
      .field("drive_turn_speed", &RunSpec::drive_turn_speed, "m/s", Range::closed(-1.0, 1.0));
  addText(t, "control_config", &RunSpec::control_config);
  t.custom(
       "control",
       [base_dir](const yaml::Node& v, RunSpec& s, settings::Reader& r, const std::string& path) {
         readControl(v, s, r, path, base_dir);
       },
       writeControl, /*is_section=*/true)
      .documentedAs([](const std::string&) {
        return std::string(
            " null  # none: control_config; else a mapping of the control settings file's keys "
            "(config/control.yaml)\n");
      });
  t.field("mpc_timing", &RunSpec::mpc_timing)
      .field("integrator", &RunSpec::integrator)
      .field("terrain", &RunSpec::terrain);
  addText(t, "lidar_config", &RunSpec::lidar_config);
  addText(t, "perception_config", &RunSpec::perception_config);
  t.field("perception_timing", &RunSpec::perception_timing)
      .field("state_source", &RunSpec::state_source);
  addText(t, "estimator_config", &RunSpec::estimator_config);
  addText(t, "sensor_config", &RunSpec::sensor_config);
  addText(t, "out", &RunSpec::out);
  t.field("log_every", &RunSpec::log_every, "", Range::closed(1, 100000));
  addText(t, "map_log", &RunSpec::map_log);
  t.field("map_log_rate", &RunSpec::map_log_rate, "Hz", Range::closed(0.01, 100.0))
      .field("log_violations", &RunSpec::log_violations);
  return t;
}

const settings::Table<RunSpec>& table() {
  static const settings::Table<RunSpec> kTable = makeTable("");
  return kTable;
}

bool sameCommand(const std::vector<planning::TimedBaseCommand>& a,
                 const std::vector<planning::TimedBaseCommand>& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (a[i].time != b[i].time || a[i].command.v_x != b[i].command.v_x ||
        a[i].command.v_y != b[i].command.v_y || a[i].command.yaw_rate != b[i].command.yaw_rate) {
      return false;
    }
  }
  return true;
}

/// The first problem of the command schedule, none when valid.
std::optional<std::string> commandProblem(const RunSpec& s) {
  if (s.command.empty()) return "no entry (give [[0, vx, vy, yaw_rate]])";
  for (std::size_t k = 0; k < s.command.size(); ++k) {
    const planning::TimedBaseCommand& c = s.command[k];
    const std::string entry = "entry " + std::to_string(k) + ": ";
    if (k == 0 && c.time != 0.0) return entry + "the first time must be 0";
    if (k > 0 && !(c.time > s.command[k - 1].time)) return entry + "times must increase";
    if (k > 0 && c.time >= s.duration) {
      return entry + "time " + shortestNumberText(c.time) + " s is not before the run's end (" +
             "duration " + shortestNumberText(s.duration) + " s): the entry would never apply";
    }
    if (!(std::abs(c.command.v_x) <= kMaxVx)) {
      return entry + "vx " + shortestNumberText(c.command.v_x) + " outside [-1, 1] m/s";
    }
    if (!(std::abs(c.command.v_y) <= kMaxVy)) {
      return entry + "vy " + shortestNumberText(c.command.v_y) + " outside [-0.5, 0.5] m/s";
    }
    if (!(std::abs(c.command.yaw_rate) <= kMaxYawRate)) {
      return entry + "yaw rate " + shortestNumberText(c.command.yaw_rate) +
             " outside [-1, 1] rad/s";
    }
  }
  return std::nullopt;
}

/// The first cross-field problem: {key, what}.
std::optional<settings::Problem> crossProblem(const RunSpec& s) {
  const RunSpec d;
  const bool pipeline =
      s.controller == ControllerKind::Nmpc || s.controller == ControllerKind::CbfQp;
  const bool nmpc = s.controller == ControllerKind::Nmpc;
  const bool perception = s.terrain == TerrainSource::Perception;
  if (s.inline_scene && !s.scene_file.empty()) {
    return settings::Problem{"inline_scene", "and scene_file exclude each other (give one)"};
  }
  if (!s.scene_file.empty() && s.scene != d.scene) {
    return settings::Problem{"scene_file",
                             "and scene exclude each other (the file names its scene)"};
  }
  if (s.scene.empty()) return settings::Problem{"scene", "empty (a scene name or file)"};
  if (s.control && !s.control_config.empty()) {
    return settings::Problem{"control", "and control_config exclude each other (give one)"};
  }
  for (std::size_t i = 0; i < s.scene_parameters.size(); ++i) {
    for (std::size_t j = 0; j < i; ++j) {
      if (s.scene_parameters[j].name == s.scene_parameters[i].name) {
        return settings::Problem{"scene_parameters",
                                 "'" + s.scene_parameters[i].name + "' given twice"};
      }
    }
    if (!std::isfinite(s.scene_parameters[i].value)) {
      return settings::Problem{"scene_parameters",
                               s.scene_parameters[i].name + ": not a finite number"};
    }
  }
  if (s.out.empty()) return settings::Problem{"out", "empty (the output folder)"};
  if (s.gait == planning::GaitKind::Custom) {
    return settings::Problem{"gait", "custom is not a gait a run can name"};
  }
  if (auto p = commandProblem(s)) return settings::Problem{"command", *p};
  // Keys that apply to some controllers or terrains only: left at their defaults elsewhere.
  const auto only = [](const char* key, const char* who) {
    return settings::Problem{key, std::string("is used only ") + who};
  };
  if (!perception) {
    if (s.lidar_config != d.lidar_config) return only("lidar_config", "with terrain perception");
    if (s.perception_config != d.perception_config) {
      return only("perception_config", "with terrain perception");
    }
    if (s.perception_timing != d.perception_timing) {
      return only("perception_timing", "with terrain perception");
    }
    if (s.map_log != d.map_log) return only("map_log", "with terrain perception");
  }
  if (s.map_log.empty() && s.map_log_rate != d.map_log_rate) {
    return only("map_log_rate", "with map_log (no map log is written without it)");
  }
  if (!pipeline) {
    if (s.gait != d.gait) return only("gait", "by the nmpc and cbfqp controllers");
    if (!sameCommand(s.command, d.command)) {
      return only("command", "by the nmpc and cbfqp controllers");
    }
    if (s.control_config != d.control_config) {
      return only("control_config", "by the nmpc and cbfqp controllers");
    }
    if (s.control) return only("control", "by the nmpc and cbfqp controllers");
    if (s.terrain != d.terrain) return only("terrain", "by the nmpc and cbfqp controllers");
  }
  if (s.controller == ControllerKind::CbfQp && s.gait == planning::GaitKind::StaticWalk) {
    return settings::Problem{
        "gait", "static_walk is not a gait of the cbfqp baseline (standing, rolling or trot)"};
  }
  if (s.controller == ControllerKind::CbfQp && s.command.size() > 1) {
    return settings::Problem{"command", "the cbfqp baseline takes one constant command"};
  }
  if (!nmpc) {
    if (s.mpc_timing != d.mpc_timing) return only("mpc_timing", "by the nmpc controller");
    if (s.integrator != d.integrator) return only("integrator", "by the nmpc controller");
    if (s.state_source != d.state_source) return only("state_source", "by the nmpc controller");
    if (s.log_violations != d.log_violations) {
      return only("log_violations", "by the nmpc controller");
    }
  }
  if (s.state_source != StateSourceKind::Inekf && !s.estimator_config.empty()) {
    return only("estimator_config",
                "with state_source inekf (the state here is the simulator's ground truth)");
  }
  if (s.controller != ControllerKind::Drive) {
    if (s.drive_speed != d.drive_speed) return only("drive_speed", "by the drive controller");
    if (s.drive_turn_speed != d.drive_turn_speed) {
      return only("drive_turn_speed", "by the drive controller");
    }
  }
  return std::nullopt;
}

bool isPath(const std::string& value, bool yaml_name) {
  return value.find('/') != std::string::npos || value == "." || value == ".." ||
         (yaml_name && value.size() > 5 && value.compare(value.size() - 5, 5, ".yaml") == 0);
}

/// Applies `f` to every path of the spec (robot and scene only when they are paths).
template <typename F>
void forEachPath(RunSpec& s, F f) {
  if (isPath(s.robot, false)) f(s.robot);
  if (isPath(s.scene, true)) f(s.scene);
  for (std::string* p : {&s.scene_file, &s.control_config, &s.lidar_config, &s.perception_config,
                         &s.estimator_config, &s.sensor_config, &s.out, &s.map_log}) {
    if (!p->empty()) f(*p);
  }
}

}  // namespace

bool RunSpec::operator==(const RunSpec& o) const {
  return robot == o.robot && scene == o.scene && scene_file == o.scene_file &&
         controller == o.controller && duration == o.duration && gait == o.gait &&
         sameCommand(command, o.command) && drive_speed == o.drive_speed &&
         drive_turn_speed == o.drive_turn_speed && control_config == o.control_config &&
         mpc_timing == o.mpc_timing && integrator == o.integrator && terrain == o.terrain &&
         lidar_config == o.lidar_config && perception_config == o.perception_config &&
         perception_timing == o.perception_timing && state_source == o.state_source &&
         estimator_config == o.estimator_config && sensor_config == o.sensor_config &&
         out == o.out && log_every == o.log_every && map_log == o.map_log &&
         map_log_rate == o.map_log_rate && log_violations == o.log_violations &&
         scene_parameters == o.scene_parameters &&
         inline_scene.has_value() == o.inline_scene.has_value() &&
         (!inline_scene || sceneYaml(*inline_scene, "") == sceneYaml(*o.inline_scene, "")) &&
         control.has_value() == o.control.has_value() &&
         (!control || control::toYaml(*control) == control::toYaml(*o.control));
}

void checkRunSpec(const RunSpec& spec) {
  if (auto p = table().check(spec)) throw RunSpecError(p->path, p->what);
  if (auto p = crossProblem(spec)) throw RunSpecError(p->path, p->what);
  if (spec.control) {
    try {
      control::checkSettings(*spec.control);
    } catch (const std::invalid_argument& e) {  // "control settings: <key>: <problem>"
      const std::string what = e.what();
      const std::string head = "control settings: ";
      throw RunSpecError("control",
                         what.rfind(head, 0) == 0 ? "control." + what.substr(head.size()) : what);
    }
  }
}

RunSpec parseRunSpec(const std::string& text, const std::string& source,
                     const std::string& base_dir, const RunSpec& base) {
  const std::string head = source + ": ";
  const yaml::Document document = yaml::parseDocument(text, head + "YAML error: ");
  RunSpec spec = base;
  settings::Reader reader(head);
  // The inline control settings' extends: is relative to the spec's folder.
  const settings::Table<RunSpec> dir_table = makeTable(base_dir);
  dir_table.read(document.root(), spec, reader);
  if (spec.inline_scene) spec.inline_scene->name = spec.scene;  // whichever key came first
  if (auto p = crossProblem(spec)) {
    reader.failAtLine(reader.lineOf({p->path}, document.root().line()), p->path + ": " + p->what);
  }
  if (!base_dir.empty()) {
    forEachPath(spec, [&](std::string& path) {
      if (fs::path(path).is_relative()) path = (fs::path(base_dir) / path).lexically_normal();
    });
  }
  // The scene numbers against the scene's own (its file read only when there are some).
  if (!spec.scene_parameters.empty()) {
    const char* scene_key = spec.scene_file.empty() ? "scene" : "scene_file";
    SceneConfig scene;
    try {
      scene = spec.inline_scene         ? *spec.inline_scene
              : spec.scene_file.empty() ? loadScene(spec.scene)
                                        : loadSceneConfig(spec.scene_file);
    } catch (const std::exception& e) {  // the scene itself cannot be loaded
      reader.failAtLine(reader.lineOf({scene_key, "scene_parameters"}, document.root().line()),
                        std::string(scene_key) + ": " + e.what());
    }
    const auto lineOf = [&](std::size_t i) {
      return reader.lineOf({"scene_parameters." + spec.scene_parameters[i].name},
                           document.root().line());
    };
    for (std::size_t i = 0; i < spec.scene_parameters.size(); ++i) {
      if (!hasSceneNumber(scene, spec.scene_parameters[i].name)) {
        try {
          withSceneNumbers(scene, {spec.scene_parameters[i]});
        } catch (const RunSpecError& e) {
          reader.failAtLine(lineOf(i), e.what());
        }
      }
    }
    try {
      (void)withSceneNumbers(scene, spec.scene_parameters);
    } catch (const RunSpecError& e) {
      // The first number whose setting makes the scene invalid names the line.
      std::size_t first = 0;
      for (std::size_t k = 1; k <= spec.scene_parameters.size(); ++k) {
        first = k - 1;
        try {
          const std::vector<SceneNumberValue> some(
              spec.scene_parameters.begin(),
              spec.scene_parameters.begin() + static_cast<std::ptrdiff_t>(k));
          (void)withSceneNumbers(scene, some);
        } catch (const RunSpecError&) {
          break;
        }
      }
      reader.failAtLine(lineOf(first), e.what());
    }
  }
  return spec;
}

RunSpec loadRunSpec(const std::string& file) {
  const std::string text = readTextFile(file, "run spec", std::size_t{1} << 20);
  const std::string dir = fs::absolute(file).parent_path().string();
  return parseRunSpec(text, "run spec '" + file + "'", dir);
}

std::string toYaml(const RunSpec& spec) { return table().write(spec); }

RunSpec withAbsolutePaths(const RunSpec& spec) {
  RunSpec s = spec;
  forEachPath(s, [](std::string& path) { path = fs::absolute(path).lexically_normal(); });
  return s;
}

std::string runSpecDefaults() { return table().documented(); }

SceneConfig withSceneNumbers(SceneConfig scene, const std::vector<SceneNumberValue>& values) {
  for (const SceneNumberValue& n : values) {
    if (!hasSceneNumber(scene, n.name)) {
      std::string known = "friction";
      for (const SceneParameter& p : scene.parameters) known += ", " + p.name;
      throw RunSpecError("scene_parameters", "'" + n.name + "' is not a number of scene " +
                                                 scene.name +
                                                 " (its parameters and friction: " + known +
                                                 "; or a key path such as boxes[0].size[2])");
    }
    setSceneNumber(scene, n.name, n.value);
  }
  if (!values.empty()) {
    try {
      scene.validate();
    } catch (const std::invalid_argument& e) {
      throw RunSpecError("scene_parameters",
                         std::string("the scene with these numbers: ") + e.what());
    }
  }
  return scene;
}

SceneConfig sceneOf(const RunSpec& spec) {
  SceneConfig scene;
  if (spec.inline_scene) {
    scene = *spec.inline_scene;
    scene.name = spec.scene;
  } else {
    scene = spec.scene_file.empty() ? loadScene(spec.scene) : loadSceneConfig(spec.scene_file);
  }
  return withSceneNumbers(std::move(scene), spec.scene_parameters);
}

}  // namespace rollstep::sim
