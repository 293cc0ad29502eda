#include "rollstep/control/control_settings.hpp"

#include <array>
#include <cmath>
#include <filesystem>
#include <map>
#include <optional>
#include <stdexcept>
#include <type_traits>
#include <variant>
#include <vector>

#include "rollstep/common/number_text.hpp"
#include "rollstep/common/text_file.hpp"
#include "rollstep/common/yaml_tree.hpp"
#include "rollstep/solver/settings_yaml.hpp"

namespace rollstep::control {

const char* toString(MpcTiming timing) {
  switch (timing) {
    case MpcTiming::Deterministic:
      return "deterministic";
    case MpcTiming::Asynchronous:
      return "asynchronous";
  }
  return "unknown";
}

const char* toString(IntegratorMode mode) {
  switch (mode) {
    case IntegratorMode::Internal:
      return "internal";
    case IntegratorMode::Naive:
      return "naive";
  }
  return "unknown";
}

namespace {

constexpr std::size_t kMaxConfigBytes = std::size_t{1} << 20;
constexpr double kBig = 1e12;  // upper end of weights: keeps a typo (1e21) out

/// The member of section struct S a key reads and writes.
template <typename S>
using Member =
    std::variant<int S::*, double S::*, Vector6 S::*, MpcTiming S::*, IntegratorMode S::*>;

/// One key of a section: its member and the valid range of each number (lower/upper, and
/// whether the bound itself is allowed; unused for the enums).
template <typename S>
struct Field {
  const char* key;
  Member<S> member;
  double lower, upper;
  bool lower_open, upper_open;
};

// The tables of keys, one per section (config/control.yaml documents each, in this order).
// A new settings field goes here and into config/control.yaml.
const std::array<Field<ControlSettings>, 1> kTopFields{{
    {"control_period", &ControlSettings::control_period, 0, 0.1, true, false},
}};
const std::array<Field<MpcSettings>, 7> kMpcFields{{
    {"timing", &MpcSettings::timing, 0, 0, false, false},
    // > 0 in deterministic timing (checked with the others in problemOf).
    {"period", &MpcSettings::period, 0, 10, false, false},
    {"latency", &MpcSettings::latency, 0, 1, false, false},
    {"initial_iterations", &MpcSettings::initial_iterations, 1, 1000000, false, false},
    {"max_solution_age", &MpcSettings::max_solution_age, 0, 100, true, false},
    {"reference_leash", &MpcSettings::reference_leash, 0, 100, false, false},
    {"reference_leash_yaw", &MpcSettings::reference_leash_yaw, 0, 4, false, false},
}};
const std::array<Field<RefinementSettings>, 2> kRefinementFields{{
    {"horizon", &RefinementSettings::horizon, 0, 10, false, false},
    {"substeps", &RefinementSettings::substeps, 1, 100, false, false},
}};
const std::array<Field<FeedbackSettings>, 6> kFeedbackFields{{
    {"base_kp", &FeedbackSettings::base_kp, 0, kBig, false, false},
    {"base_kd", &FeedbackSettings::base_kd, 0, kBig, false, false},
    {"foot_kp", &FeedbackSettings::foot_kp, 0, kBig, false, false},
    {"foot_kd", &FeedbackSettings::foot_kd, 0, kBig, false, false},
    {"joint_kp", &FeedbackSettings::joint_kp, 0, kBig, false, false},
    {"joint_kd", &FeedbackSettings::joint_kd, 0, kBig, false, false},
}};
const std::array<Field<CbfQpSettings>, 22> kCbfQpFields{{
    {"base_weight", &CbfQpSettings::base_weight, 0, kBig, false, false},
    {"foot_weight", &CbfQpSettings::foot_weight, 0, kBig, false, false},
    {"joint_weight", &CbfQpSettings::joint_weight, 0, kBig, false, false},
    {"damping", &CbfQpSettings::damping, 0, 1e6, true, false},
    {"contact_gain", &CbfQpSettings::contact_gain, 0, 1e6, false, false},
    {"freed_contact_weight", &CbfQpSettings::freed_contact_weight, 0, kBig, false, false},
    {"joint_position_gamma", &CbfQpSettings::joint_position_gamma, 0, 1e6, false, false},
    {"joint_position_margin", &CbfQpSettings::joint_position_margin, 0, 10, false, false},
    {"joint_velocity_gamma", &CbfQpSettings::joint_velocity_gamma, 0, 1e6, false, false},
    {"velocity_limit_scale", &CbfQpSettings::velocity_limit_scale, 0, 1, true, false},
    {"region_gamma", &CbfQpSettings::region_gamma, 0, 1e6, false, false},
    {"clearance_gamma", &CbfQpSettings::clearance_gamma, 0, 1e6, false, false},
    {"clearance", &CbfQpSettings::clearance, 0, 2, false, false},
    {"max_iterations", &CbfQpSettings::max_iterations, 1, 100000, false, false},
    {"fallback_brake_time", &CbfQpSettings::fallback_brake_time, 0, 100, true, false},
    {"relaxation_weight", &CbfQpSettings::relaxation_weight, 0, 1e12, false, false},
    {"support_gamma", &CbfQpSettings::support_gamma, 0, 1e6, false, false},
    {"support_margin", &CbfQpSettings::support_margin, 0, 1, false, false},
    {"collision_gamma", &CbfQpSettings::collision_gamma, 0, 1e6, false, false},
    {"collision_sharpness", &CbfQpSettings::collision_sharpness, 0, 1e6, true, false},
    {"collision_clearance", &CbfQpSettings::collision_clearance, 0, 1, false, false},
    {"collision_range", &CbfQpSettings::collision_range, 0, 10, true, false},
}};
const std::array<Field<IntegratorSettings>, 4> kIntegratorFields{{
    {"mode", &IntegratorSettings::mode, 0, 0, false, false},
    // 0: take the measured value every tick.
    {"position_time_constant", &IntegratorSettings::position_time_constant, 0, 1000, false, false},
    {"velocity_time_constant", &IntegratorSettings::velocity_time_constant, 0, 1000, false, false},
    {"deflection_compensation", &IntegratorSettings::deflection_compensation, 0, 2, false, false},
}};
const std::array<Field<WheelSettings>, 2> kWheelFields{{
    {"skid_track_factor", &WheelSettings::skid_track_factor, 0, 100, true, false},
    {"skid_yaw_rate_gain", &WheelSettings::skid_yaw_rate_gain, 0, 1000, false, false},
}};
const std::array<Field<BaselineSettings>, 10> kBaselineFields{{
    {"gait_period", &BaselineSettings::gait_period, 0, 100, true, false},
    {"trot_duty", &BaselineSettings::trot_duty, 0.5, 1, true, true},
    {"swing_clearance", &BaselineSettings::swing_clearance, 0, 2, false, false},
    {"foothold_lookahead", &BaselineSettings::foothold_lookahead, 0, 2, false, false},
    {"descent_offset", &BaselineSettings::descent_offset, 0, 2, false, false},
    {"height_lookahead", &BaselineSettings::height_lookahead, 0, 5, false, false},
    {"height_offset", &BaselineSettings::height_offset, 0, 1, false, false},
    {"max_height_rate", &BaselineSettings::max_height_rate, 0, 10, true, false},
    {"foothold_margin", &BaselineSettings::foothold_margin, 0, 1, false, false},
    {"stance_foot_gain", &BaselineSettings::stance_foot_gain, 0, kBig, false, false},
}};
// The top-level keys, in file order: control_period, the sections, ocp (read and written by
// the centroidal layer).
const std::array<const char*, 10> kTopKeys{{"extends", "control_period", "mpc", "refinement",
                                            "feedback", "cbf_qp", "integrator", "wheels",
                                            "baseline", "ocp"}};
// extends: chains longer than this are refused (a file that extends itself, directly or not).
constexpr int kMaxExtendsDepth = 8;

constexpr std::array<MpcTiming, 2> kTimings{{MpcTiming::Deterministic, MpcTiming::Asynchronous}};
constexpr std::array<IntegratorMode, 2> kModes{{IntegratorMode::Internal, IntegratorMode::Naive}};
const std::array<MpcTiming, 2>& enumValues(MpcTiming) { return kTimings; }
const std::array<IntegratorMode, 2>& enumValues(IntegratorMode) { return kModes; }

template <typename E>
std::string enumChoices() {
  std::string out;
  for (const E v : enumValues(E{})) out += (out.empty() ? "" : " or ") + std::string(toString(v));
  return out;
}

template <typename S, std::size_t N>
std::string knownKeys(const std::array<Field<S>, N>& fields) {
  std::string keys;
  for (const Field<S>& f : fields) keys += (keys.empty() ? "" : ", ") + std::string(f.key);
  return keys;
}

std::string knownTopKeys() {
  std::string keys;
  for (const char* k : kTopKeys) keys += (keys.empty() ? "" : ", ") + std::string(k);
  return keys;
}

template <typename S>
std::string rangeText(const Field<S>& f) {
  return std::string(f.lower_open ? "(" : "[") + shortestNumberText(f.lower) + ", " +
         shortestNumberText(f.upper) + (f.upper_open ? ")" : "]");
}

template <typename S>
bool inRange(const Field<S>& f, double v) {
  if (!std::isfinite(v)) return false;
  if (f.lower_open ? v <= f.lower : v < f.lower) return false;
  if (f.upper_open ? v >= f.upper : v > f.upper) return false;
  return true;
}

std::string lineOf(const yaml::Node& node) { return "line " + std::to_string(node.line()) + ": "; }

/// A settings value that the ranges of the tables allow but that contradicts another:
/// `keys` (full paths) are the keys involved, the first one named in the message.
struct Problem {
  std::vector<std::string> keys;
  std::string what;
};

/// The first field of `section` (prefix "mpc." etc.) outside its range, as a Problem.
template <typename S, std::size_t N>
std::optional<Problem> rangeProblem(const S& section, const std::array<Field<S>, N>& fields,
                                    const std::string& prefix) {
  for (const Field<S>& f : fields) {
    std::optional<Problem> problem;
    std::visit(
        [&](auto member) {
          using T = std::decay_t<decltype(section.*member)>;
          const std::string key = prefix + f.key;
          if constexpr (std::is_same_v<T, int> || std::is_same_v<T, double>) {
            const T v = section.*member;
            if (!inRange(f, static_cast<double>(v))) {
              problem = Problem{
                  {key},
                  shortestNumberText(static_cast<double>(v)) + " is outside " + rangeText(f)};
            }
          } else if constexpr (std::is_same_v<T, Vector6>) {
            for (int i = 0; i < 6 && !problem; ++i) {
              if (!inRange(f, (section.*member)[i])) {
                problem = Problem{{key},
                                  "entry " + std::to_string(i) + ", " +
                                      shortestNumberText((section.*member)[i]) + ", is outside " +
                                      rangeText(f)};
              }
            }
          } else {
            bool known = false;
            for (const T v : enumValues(T{})) known = known || v == section.*member;
            if (!known) problem = Problem{{key}, "not " + enumChoices<T>()};
          }
        },
        f.member);
    if (problem) return problem;
  }
  return std::nullopt;
}

/// The first problem of the control settings proper (not the nested OCP's), or none.
std::optional<Problem> problemOf(const ControlSettings& s) {
  if (auto p = rangeProblem(s, kTopFields, "")) return p;
  if (auto p = rangeProblem(s.mpc, kMpcFields, "mpc.")) return p;
  if (auto p = rangeProblem(s.refinement, kRefinementFields, "refinement.")) return p;
  if (auto p = rangeProblem(s.feedback, kFeedbackFields, "feedback.")) return p;
  if (auto p = rangeProblem(s.cbf_qp, kCbfQpFields, "cbf_qp.")) return p;
  if (auto p = rangeProblem(s.integrator, kIntegratorFields, "integrator.")) return p;
  if (auto p = rangeProblem(s.wheels, kWheelFields, "wheels.")) return p;
  if (auto p = rangeProblem(s.baseline, kBaselineFields, "baseline.")) return p;
  // A plan's gait clock reaches the real-time side with the plan, at most max_solution_age
  // after its state: an edge hold planned to begin sooner could begin unseen there.
  if ((s.ocp.step_down_max_hold > 0.0 || s.ocp.step_up_max_hold > 0.0) &&
      s.ocp.edge_hold_lead < s.mpc.max_solution_age) {
    return Problem{{"ocp.edge_hold_lead", "mpc.max_solution_age"},
                   shortestNumberText(s.ocp.edge_hold_lead) + " is below mpc.max_solution_age (" +
                       shortestNumberText(s.mpc.max_solution_age) +
                       "): a hold could begin before the real-time side has the plan"};
  }
  if (s.mpc.timing == MpcTiming::Deterministic) {
    if (!(s.mpc.period > 0.0)) {
      return Problem{{"mpc.period", "mpc.timing"},
                     "0 is allowed in asynchronous timing only (deterministic: a solve every "
                     "period, > 0)"};
    }
    // One MPC thread cannot start a solve before the previous one has finished.
    if (s.mpc.latency > s.mpc.period) {
      return Problem{{"mpc.latency", "mpc.period", "mpc.timing"},
                     shortestNumberText(s.mpc.latency) + " is above mpc.period (" +
                         shortestNumberText(s.mpc.period) +
                         "): in deterministic timing a solve takes at most a period"};
    }
  }
  return std::nullopt;
}

/// Reads one entry (key_node: value) of a mapping into `section` with the table `fields`;
/// `prefix` ("mpc.") names the keys, `lines` records the line of every key read (full
/// path), `fail(node, what)` throws.
template <typename S, std::size_t N, typename Fail>
void readEntry(const yaml::Node& key_node, const yaml::Node& value, S& section,
               const std::array<Field<S>, N>& fields, const std::string& prefix,
               std::map<std::string, int>& lines, Fail fail) {
  if (!key_node.isScalar()) fail(key_node, prefix + "<key>: a key must be a plain name");
  const std::string key = key_node.scalar();
  const Field<S>* field = nullptr;
  for (const Field<S>& f : fields) {
    if (key == f.key) field = &f;
  }
  if (field == nullptr) {
    fail(key_node, "unknown key '" + prefix + key + "' (known in " +
                       prefix.substr(0, prefix.size() - 1) + ": " + knownKeys(fields) + ")");
  }
  const std::string path = prefix + key;
  if (const auto it = lines.find(path); it != lines.end()) {
    fail(key_node, path + ": given twice (first on line " + std::to_string(it->second) + ")");
  }
  lines.emplace(path, key_node.line());
  const std::string at = path + ": ";
  if (value.isNull()) fail(value, at + "no value");
  const auto got = [&](const yaml::Node& n) {
    return n.isScalar() ? "'" + n.scalar() + "'" : std::string(n.kindName());
  };
  // A number within the field's range, or an error naming the key, value and range.
  const auto number = [&](const yaml::Node& n) {
    double v = 0.0;
    if (!n.isScalar() || !n.toDouble(v)) {
      fail(n, at + got(n) + " is not a number" +
                  (n.isScalar() && !n.plain() ? " (it is quoted or tagged)" : ""));
    }
    if (!inRange(*field, v)) fail(n, at + n.scalar() + " is outside " + rangeText(*field));
    return v;
  };
  std::visit(
      [&](auto member) {
        using T = std::decay_t<decltype(section.*member)>;
        if constexpr (std::is_same_v<T, int>) {
          int v = 0;
          if (!value.isScalar() || !value.toInt(v)) {
            fail(value, at + "expected an integer, got " + got(value));
          }
          if (!inRange(*field, v)) {
            fail(value, at + std::to_string(v) + " is outside " + rangeText(*field));
          }
          section.*member = v;
        } else if constexpr (std::is_same_v<T, double>) {
          if (!value.isScalar()) {
            fail(value, at + "expected a single number, got " + value.kindName());
          }
          section.*member = number(value);
        } else if constexpr (std::is_same_v<T, Vector6>) {
          if (!value.isSequence() || value.size() != 6) {
            fail(value, at + "expected a list of 6 numbers, got " +
                            (value.isSequence() ? "a list of " + std::to_string(value.size())
                                                : std::string(value.kindName())));
          }
          Vector6 v;
          for (int i = 0; i < 6; ++i) v[i] = number(value.item(static_cast<std::size_t>(i)));
          section.*member = v;
        } else {
          bool read = false;
          if (value.isScalar() && value.plain()) {
            for (const T v : enumValues(T{})) {
              if (value.scalar() == toString(v)) {
                section.*member = v;
                read = true;
              }
            }
          }
          if (!read) fail(value, at + "expected " + enumChoices<T>() + ", got " + got(value));
        }
      },
      field->member);
}

/// Reads the section mapping `node` (or null: nothing) entry by entry (readEntry).
template <typename S, std::size_t N, typename Fail>
void readSection(const yaml::Node& node, S& section, const std::array<Field<S>, N>& fields,
                 const std::string& prefix, std::map<std::string, int>& lines, Fail fail) {
  for (std::size_t item = 0; item < node.size(); ++item) {
    readEntry(node.key(item), node.value(item), section, fields, prefix, lines, fail);
  }
}

/// Writes the fields of `section`, one "key: value" line each with `indent` in front.
template <typename S, std::size_t N>
void writeSection(const S& section, const std::array<Field<S>, N>& fields,
                  const std::string& indent, std::string& out) {
  for (const Field<S>& f : fields) {
    out += indent + f.key + ": ";
    std::visit(
        [&](auto member) {
          using T = std::decay_t<decltype(section.*member)>;
          const T& v = section.*member;
          if constexpr (std::is_same_v<T, int>) {
            out += std::to_string(v);
          } else if constexpr (std::is_same_v<T, double>) {
            out += shortestNumberText(v);
          } else if constexpr (std::is_same_v<T, Vector6>) {
            out += "[";
            for (int i = 0; i < 6; ++i) out += (i ? ", " : "") + shortestNumberText(v[i]);
            out += "]";
          } else {
            out += toString(v);
          }
        },
        f.member);
    out += "\n";
  }
}

}  // namespace

void checkSettings(const ControlSettings& settings) {
  if (const std::optional<Problem> p = problemOf(settings)) {
    throw std::invalid_argument("control settings: " + p->keys.front() + ": " + p->what);
  }
  try {
    solver::checkSettings(settings.ocp.solver);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(std::string("control settings: ocp.solver: ") + e.what());
  }
  // The OCP's ranges are its own table's: read its settings back through it.
  try {
    (void)centroidal::parseOcpSettings(centroidal::toYaml(settings.ocp), "(checkSettings)");
  } catch (const std::runtime_error& e) {
    throw std::invalid_argument(std::string("control settings: ocp: ") + e.what());
  }
}

namespace {

ControlSettings loadControlSettingsAt(const std::string& yaml_file, int depth);

/// The settings of yaml_text over the defaults, or over the file its `extends:` names
/// (relative to base_directory, the directory of the file being read).
ControlSettings parseControlSettingsAt(const std::string& yaml_text, const std::string& source_name,
                                       const std::filesystem::path& base_directory, int depth) {
  const std::string prefix = "control settings " + source_name + ": ";
  const auto fail = [&](const yaml::Node& at, const std::string& what) {
    throw std::runtime_error(prefix + lineOf(at) + what);
  };
  ControlSettings settings;
  try {
    const yaml::Document document = yaml::Document::parse(yaml_text);
    const yaml::Node root = document.root();
    if (root.isNull()) return settings;
    if (!root.isMapping()) fail(root, "expected a mapping of key: value");
    // extends: first, wherever it stands: the keys of this file then override its values.
    std::optional<std::size_t> extends;
    for (std::size_t item = 0; item < root.size(); ++item) {
      const yaml::Node key_node = root.key(item);
      if (!key_node.isScalar() || key_node.scalar() != "extends") continue;
      if (extends) {
        fail(key_node, "extends: given twice (first on line " +
                           std::to_string(root.key(*extends).line()) + ")");
      }
      extends = item;
    }
    if (extends) {
      const yaml::Node value = root.value(*extends);
      if (!value.isScalar() || value.scalar().empty()) {
        fail(value, "extends: expected the path of another control settings file");
      }
      if (depth >= kMaxExtendsDepth) {
        fail(value, "extends: more than " + std::to_string(kMaxExtendsDepth) +
                        " files deep (does a file extend itself?)");
      }
      const std::filesystem::path named(value.scalar());
      const std::filesystem::path file = named.is_absolute() ? named : base_directory / named;
      try {
        settings = loadControlSettingsAt(file.string(), depth + 1);
      } catch (const std::runtime_error& e) {
        fail(value, std::string("extends: ") + e.what());
      }
    }
    std::map<std::string, int> lines;  // full key path -> line, of every key read
    for (std::size_t item = 0; item < root.size(); ++item) {
      const yaml::Node key_node = root.key(item);
      const yaml::Node value = root.value(item);
      if (!key_node.isScalar()) fail(key_node, "a key must be a plain name");
      const std::string key = key_node.scalar();
      bool known = false;
      for (const char* k : kTopKeys) known = known || key == k;
      if (!known) fail(key_node, "unknown key '" + key + "' (known: " + knownTopKeys() + ")");
      if (key == "extends") continue;  // read above
      if (key == "control_period") {   // the one top-level number, through its own table
        readEntry(key_node, value, settings, kTopFields, "", lines, fail);
        continue;
      }
      if (const auto it = lines.find(key); it != lines.end()) {
        fail(key_node, key + ": given twice (first on line " + std::to_string(it->second) + ")");
      }
      lines.emplace(key, key_node.line());
      if (key == "ocp") {
        if (!value.isMapping() && !value.isNull()) {
          fail(value, "ocp: expected a mapping of OCP settings (config/ocp.yaml), got " +
                          std::string(value.kindName()));
        }
        settings.ocp = centroidal::parseOcpSettings(value, settings.ocp, source_name, "ocp.",
                                                    "control settings");
        continue;
      }
      if (!value.isMapping() && !value.isNull()) {
        fail(value, key + ": expected a mapping, got " + value.kindName());
      }
      if (key == "mpc") readSection(value, settings.mpc, kMpcFields, "mpc.", lines, fail);
      if (key == "refinement") {
        readSection(value, settings.refinement, kRefinementFields, "refinement.", lines, fail);
      }
      if (key == "feedback") {
        readSection(value, settings.feedback, kFeedbackFields, "feedback.", lines, fail);
      }
      if (key == "cbf_qp")
        readSection(value, settings.cbf_qp, kCbfQpFields, "cbf_qp.", lines, fail);
      if (key == "integrator") {
        readSection(value, settings.integrator, kIntegratorFields, "integrator.", lines, fail);
      }
      if (key == "wheels") {
        readSection(value, settings.wheels, kWheelFields, "wheels.", lines, fail);
      }
      if (key == "baseline") {
        readSection(value, settings.baseline, kBaselineFields, "baseline.", lines, fail);
      }
    }
    if (const std::optional<Problem> p = problemOf(settings)) {
      int line = root.line();
      for (auto k = p->keys.rbegin(); k != p->keys.rend(); ++k) {
        if (const auto it = lines.find(*k); it != lines.end()) line = it->second;
      }
      throw std::runtime_error(prefix + "line " + std::to_string(line) + ": " + p->keys.front() +
                               ": " + p->what);
    }
  } catch (const yaml::YamlError& e) {
    throw std::runtime_error(prefix + "YAML error: " + e.what());
  }
  return settings;
}

ControlSettings loadControlSettingsAt(const std::string& yaml_file, int depth) {
  return parseControlSettingsAt(readTextFile(yaml_file, "control settings", kMaxConfigBytes),
                                yaml_file, std::filesystem::path(yaml_file).parent_path(), depth);
}

}  // namespace

ControlSettings parseControlSettings(const std::string& yaml_text, const std::string& source_name) {
  return parseControlSettingsAt(yaml_text, source_name, std::filesystem::current_path(), 0);
}

ControlSettings loadControlSettings(const std::string& yaml_file) {
  return loadControlSettingsAt(yaml_file, 0);
}

std::string toYaml(const ControlSettings& settings) {
  std::string out;
  writeSection(settings, kTopFields, "", out);
  out += "mpc:\n";
  writeSection(settings.mpc, kMpcFields, "  ", out);
  out += "refinement:\n";
  writeSection(settings.refinement, kRefinementFields, "  ", out);
  out += "feedback:\n";
  writeSection(settings.feedback, kFeedbackFields, "  ", out);
  out += "cbf_qp:\n";
  writeSection(settings.cbf_qp, kCbfQpFields, "  ", out);
  out += "integrator:\n";
  writeSection(settings.integrator, kIntegratorFields, "  ", out);
  out += "wheels:\n";
  writeSection(settings.wheels, kWheelFields, "  ", out);
  out += "baseline:\n";
  writeSection(settings.baseline, kBaselineFields, "  ", out);
  out += "ocp:\n";
  const std::string ocp_text = centroidal::toYaml(settings.ocp);
  for (std::size_t start = 0; start < ocp_text.size();) {
    const std::size_t end = ocp_text.find('\n', start);
    out += "  " + ocp_text.substr(start, end - start) + "\n";
    if (end == std::string::npos) break;
    start = end + 1;
  }
  return out;
}

}  // namespace rollstep::control
