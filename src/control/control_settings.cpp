#include "rollstep/control/control_settings.hpp"

#include <array>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <optional>
#include <set>
#include <stdexcept>
#include <string_view>
#include <type_traits>
#include <variant>
#include <vector>

#include "rollstep/common/number_text.hpp"
#include "rollstep/common/text_file.hpp"
#include "rollstep/common/yaml_tree.hpp"
#include "rollstep/solver/settings_yaml.hpp"

namespace rollstep::control {

const char* toString(MpcTiming timing) { return enumName(timing); }

const char* toString(IntegratorMode mode) { return enumName(mode); }

namespace {

using settings::Range;

constexpr std::size_t kMaxConfigBytes = std::size_t{1} << 20;
constexpr double kBig = 1e12;  // upper end of weights: keeps a typo (1e21) out

constexpr std::string_view kLibraryPrefix = "library:";

/// The file an `extends:` value names: `library:NAME` is NAME in the library's config/
/// ($ROLLSTEP_CONFIG_DIR if set), so that a robot folder anywhere can start from the
/// library's files; anything else is a path relative to base_directory.
std::filesystem::path extendedFile(const std::string& value,
                                   const std::filesystem::path& base_directory) {
  if (value.rfind(kLibraryPrefix, 0) == 0) {
    const std::filesystem::path name = value.substr(kLibraryPrefix.size());
    if (const char* dir = std::getenv("ROLLSTEP_CONFIG_DIR"); dir != nullptr && *dir != '\0') {
      return std::filesystem::path(dir) / name;
    }
    return std::filesystem::path(ROLLSTEP_LIBRARY_CONFIG_DIR) / name;
  }
  const std::filesystem::path named(value);
  return named.is_absolute() ? named : base_directory / named;
}

settings::Table<MpcSettings> makeMpcFields() {
  using S = MpcSettings;
  return settings::Table<S>()
      .field("timing", &S::timing)
      // > 0 in deterministic timing (checked with the others in problemOf).
      .field("period", &S::period, "s", Range::closed(0, 10))
      .field("latency", &S::latency, "s", Range::closed(0, 1))
      .field("initial_iterations", &S::initial_iterations, "", Range::closed(1, 1000000))
      .field("max_solution_age", &S::max_solution_age, "s", Range::leftOpen(0, 100))
      .field("reference_leash", &S::reference_leash, "m", Range::closed(0, 100))
      .field("reference_leash_yaw", &S::reference_leash_yaw, "rad", Range::closed(0, 4))
      .field("reference_leash_lateral", &S::reference_leash_lateral, "m", Range::closed(0, 100));
}

settings::Table<RefinementSettings> makeRefinementFields() {
  using S = RefinementSettings;
  return settings::Table<S>()
      .field("horizon", &S::horizon, "s", Range::closed(0, 10))
      .field("substeps", &S::substeps, "", Range::closed(1, 100));
}

settings::Table<FeedbackSettings> makeFeedbackFields() {
  using S = FeedbackSettings;
  return settings::Table<S>()
      .field("base_kp", &S::base_kp, "", Range::closed(0, kBig))
      .field("base_kd", &S::base_kd, "", Range::closed(0, kBig))
      .field("foot_kp", &S::foot_kp, "", Range::closed(0, kBig))
      .field("foot_kd", &S::foot_kd, "", Range::closed(0, kBig))
      .field("joint_kp", &S::joint_kp, "", Range::closed(0, kBig))
      .field("joint_kd", &S::joint_kd, "", Range::closed(0, kBig));
}

settings::Table<CbfQpSettings> makeCbfQpFields() {
  using S = CbfQpSettings;
  return settings::Table<S>()
      .field("base_weight", &S::base_weight, "", Range::closed(0, kBig))
      .field("foot_weight", &S::foot_weight, "", Range::closed(0, kBig))
      .field("joint_weight", &S::joint_weight, "", Range::closed(0, kBig))
      .field("damping", &S::damping, "", Range::leftOpen(0, 1e6))
      .field("contact_gain", &S::contact_gain, "", Range::closed(0, 1e6))
      .field("freed_contact_weight", &S::freed_contact_weight, "", Range::closed(0, kBig))
      .field("joint_position_gamma", &S::joint_position_gamma, "", Range::closed(0, 1e6))
      .field("joint_position_margin", &S::joint_position_margin, "rad or m", Range::closed(0, 10))
      .field("joint_velocity_gamma", &S::joint_velocity_gamma, "", Range::closed(0, 1e6))
      .field("velocity_limit_scale", &S::velocity_limit_scale, "", Range::leftOpen(0, 1))
      .field("region_gamma", &S::region_gamma, "", Range::closed(0, 1e6))
      .field("clearance_gamma", &S::clearance_gamma, "", Range::closed(0, 1e6))
      .field("clearance", &S::clearance, "m", Range::closed(0, 2))
      .field("max_iterations", &S::max_iterations, "", Range::closed(1, 100000))
      .field("fallback_brake_time", &S::fallback_brake_time, "s", Range::leftOpen(0, 100))
      .field("relaxation_weight", &S::relaxation_weight, "", Range::closed(0, 1e12))
      .field("support_gamma", &S::support_gamma, "", Range::closed(0, 1e6))
      .field("support_margin", &S::support_margin, "m", Range::closed(0, 1))
      .field("collision_gamma", &S::collision_gamma, "", Range::closed(0, 1e6))
      .field("collision_sharpness", &S::collision_sharpness, "", Range::leftOpen(0, 1e6))
      .field("collision_clearance", &S::collision_clearance, "m", Range::closed(0, 1))
      .field("collision_range", &S::collision_range, "m", Range::leftOpen(0, 10));
}

settings::Table<IntegratorSettings> makeIntegratorFields() {
  using S = IntegratorSettings;
  return settings::Table<S>()
      .field("mode", &S::mode)
      // 0: take the measured value every tick.
      .field("position_time_constant", &S::position_time_constant, "s", Range::closed(0, 1000))
      .field("velocity_time_constant", &S::velocity_time_constant, "", Range::closed(0, 1000))
      .field("deflection_compensation", &S::deflection_compensation, "", Range::closed(0, 2));
}

settings::Table<WheelSettings> makeWheelFields() {
  using S = WheelSettings;
  return settings::Table<S>()
      .field("skid_track_factor", &S::skid_track_factor, "", Range::leftOpen(0, 100))
      .field("skid_yaw_rate_gain", &S::skid_yaw_rate_gain, "", Range::closed(0, 1000))
      .field("skid_velocity_gain", &S::skid_velocity_gain, "", Range::closed(0, 1000))
      .field("skid_position_gain", &S::skid_position_gain, "1/s", Range::closed(0, 1000));
}

settings::Table<BaselineSettings> makeBaselineFields() {
  using S = BaselineSettings;
  return settings::Table<S>()
      .field("gait_period", &S::gait_period, "s", Range::leftOpen(0, 100))
      .field("trot_duty", &S::trot_duty, "", Range::open(0.5, 1))
      .field("swing_clearance", &S::swing_clearance, "m", Range::closed(0, 2))
      .field("foothold_lookahead", &S::foothold_lookahead, "m", Range::closed(0, 2))
      .field("descent_offset", &S::descent_offset, "m", Range::closed(0, 2))
      .field("height_lookahead", &S::height_lookahead, "m", Range::closed(0, 5))
      .field("height_offset", &S::height_offset, "m", Range::closed(0, 1))
      .field("max_height_rate", &S::max_height_rate, "m/s", Range::leftOpen(0, 10))
      .field("foothold_margin", &S::foothold_margin, "m", Range::closed(0, 1))
      .field("stance_foot_gain", &S::stance_foot_gain, "", Range::closed(0, kBig))
      .field("position_leash", &S::position_leash, "m", Range::closed(0, 1));
}

// The whole file: control_period, the sections, ocp (the centroidal layer's table, read
// through the same reader so that its errors name the line and ocp.<key>). extends: is read
// before the table (parseControlSettingsAt).
settings::Table<ControlSettings> makeTable() {
  using S = ControlSettings;
  return settings::Table<S>()
      .custom(  // read first, by parseControlSettingsAt; not written (the settings are whole)
          "extends", [](const yaml::Node&, S&, settings::Reader&, const std::string&) {},
          [](const S&, const std::string&) { return std::string(); })
      .field("control_period", &S::control_period, "s", Range::leftOpen(0, 0.1))
      .section("mpc", &S::mpc, makeMpcFields())
      .section("refinement", &S::refinement, makeRefinementFields())
      .section("feedback", &S::feedback, makeFeedbackFields())
      .section("cbf_qp", &S::cbf_qp, makeCbfQpFields())
      .section("integrator", &S::integrator, makeIntegratorFields())
      .section("wheels", &S::wheels, makeWheelFields())
      .section("baseline", &S::baseline, makeBaselineFields())
      .custom(
          "ocp",
          [](const yaml::Node& value, S& s, settings::Reader& reader, const std::string& path) {
            centroidal::readOcpSettings(value, s.ocp, reader, path + ".");
          },
          [](const S& s, const std::string& indent) {
            return "\n" + centroidal::ocpSettingsTable().write(s.ocp, indent + "  ");
          },
          /*is_section=*/true);
}

const settings::Table<ControlSettings>& table() {
  static const settings::Table<ControlSettings> t = makeTable();
  return t;
}

// extends: chains longer than this are refused (a file that extends itself, directly or not).
constexpr int kMaxExtendsDepth = 8;

/// A settings value that the ranges of the tables allow but that contradicts another:
/// `keys` (full paths) are the keys involved, the first one named in the message.
struct Problem {
  std::vector<std::string> keys;
  std::string what;
};

/// The first problem of the control settings proper (not the nested OCP's), or none.
std::optional<Problem> problemOf(const ControlSettings& s) {
  if (auto p = table().check(s)) return Problem{{p->path}, p->what};
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
  // The OCP's ranges are its own table's.
  if (const std::optional<settings::Problem> p =
          centroidal::ocpSettingsTable().check(settings.ocp)) {
    throw std::invalid_argument("control settings: ocp." + p->path + ": " + p->what);
  }
}

namespace {

ControlSettings loadControlSettingsAt(const std::string& yaml_file, int depth,
                                      std::set<std::string>* sections_given);

/// Reads the mapping `root` (its keys named prefix + key) over the defaults, or over the
/// file its `extends:` names (relative to base_directory), then checks the settings as a
/// whole; `sections_given` (when not null) gets the top-level keys given here or by a file
/// extended.
ControlSettings readControlSettingsAt(const yaml::Node& root, settings::Reader& reader,
                                      const std::string& prefix,
                                      const std::filesystem::path& base_directory, int depth,
                                      std::set<std::string>* sections_given,
                                      const ControlSettings& start = ControlSettings{}) {
  ControlSettings settings = start;
  if (root.isNull()) return settings;
  if (!root.isMapping()) {
    if (prefix.empty()) reader.fail(root, "expected a mapping of key: value");
    reader.fail(
        root, prefix.substr(0, prefix.size() - 1) + ": expected a mapping, got " + root.kindName());
  }
  // extends: first, wherever it stands: the keys of this file then override its values.
  std::optional<std::size_t> extends;
  for (std::size_t item = 0; item < root.size(); ++item) {
    const yaml::Node key_node = root.key(item);
    if (!key_node.isScalar() || key_node.scalar() != "extends") continue;
    if (extends) {
      reader.fail(key_node, prefix + "extends: given twice (first on line " +
                                std::to_string(root.key(*extends).line()) + ")");
    }
    extends = item;
  }
  if (extends) {
    const yaml::Node value = root.value(*extends);
    if (!value.isScalar() || value.scalar().empty()) {
      reader.fail(value, prefix + "extends: expected the path of another control settings file");
    }
    if (depth >= kMaxExtendsDepth) {
      reader.fail(value, prefix + "extends: more than " + std::to_string(kMaxExtendsDepth) +
                             " files deep (does a file extend itself?)");
    }
    const std::filesystem::path file = extendedFile(value.scalar(), base_directory);
    try {
      settings = loadControlSettingsAt(file.string(), depth + 1, sections_given);
    } catch (const std::runtime_error& e) {
      reader.fail(value, prefix + "extends: " + e.what());
    }
  }
  for (std::size_t item = 0; item < root.size(); ++item) {
    const yaml::Node key_node = root.key(item);
    table().readEntry(key_node, root.value(item), settings, reader, prefix);  // (extends: a no-op)
    if (sections_given != nullptr) sections_given->insert(key_node.scalar());
  }
  if (const std::optional<Problem> p = problemOf(settings)) {
    std::vector<std::string> paths;
    for (const std::string& key : p->keys) paths.push_back(prefix + key);
    reader.failAtLine(reader.lineOf(paths, root.line()), prefix + p->keys.front() + ": " + p->what);
  }
  return settings;
}

/// The settings of yaml_text (see readControlSettingsAt).
ControlSettings parseControlSettingsAt(const std::string& yaml_text, const std::string& source_name,
                                       const std::filesystem::path& base_directory, int depth,
                                       std::set<std::string>* sections_given) {
  const std::string head = "control settings " + source_name + ": ";
  const yaml::Document document = yaml::parseDocument(yaml_text, head + "YAML error: ");
  settings::Reader reader(head);
  return readControlSettingsAt(document.root(), reader, "", base_directory, depth, sections_given);
}

ControlSettings loadControlSettingsAt(const std::string& yaml_file, int depth,
                                      std::set<std::string>* sections_given) {
  return parseControlSettingsAt(readTextFile(yaml_file, "control settings", kMaxConfigBytes),
                                yaml_file, std::filesystem::path(yaml_file).parent_path(), depth,
                                sections_given);
}

}  // namespace

ControlSettings parseControlSettings(const std::string& yaml_text, const std::string& source_name) {
  return parseControlSettingsAt(yaml_text, source_name, std::filesystem::current_path(), 0,
                                nullptr);
}

ControlSettings loadControlSettings(const std::string& yaml_file,
                                    std::set<std::string>* sections_given) {
  return loadControlSettingsAt(yaml_file, 0, sections_given);
}

ControlSettings readControlSettings(const yaml::Node& node, settings::Reader& reader,
                                    const std::string& prefix, const std::string& base_directory,
                                    const ControlSettings& start) {
  return readControlSettingsAt(node, reader, prefix,
                               base_directory.empty() ? std::filesystem::current_path()
                                                      : std::filesystem::path(base_directory),
                               0, nullptr, start);
}

std::string toYaml(const ControlSettings& settings, const std::string& indent) {
  return table().write(settings, indent);
}

}  // namespace rollstep::control
