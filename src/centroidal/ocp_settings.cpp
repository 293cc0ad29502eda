#include "rollstep/centroidal/ocp_settings.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <map>
#include <stdexcept>
#include <type_traits>
#include <variant>

#include "rollstep/common/number_text.hpp"
#include "rollstep/common/text_file.hpp"
#include "rollstep/solver/settings_yaml.hpp"

namespace rollstep::centroidal {
namespace {

constexpr std::size_t kMaxConfigBytes = std::size_t{1} << 20;

using Vector6 = Eigen::Matrix<double, 6, 1>;
using Member = std::variant<int OcpSettings::*, double OcpSettings::*, bool OcpSettings::*,
                            Eigen::Vector3d OcpSettings::*, Vector6 OcpSettings::*>;

/// One key of the file: its member, the valid range of each number (lower/upper, and
/// whether the bound itself is allowed).
struct Field {
  const char* key;
  Member member;
  double lower, upper;
  bool lower_open, upper_open;
};

// The one table of keys (config/ocp.yaml documents each, in this order).
const std::array<Field, 53> kFields{{
    {"horizon", &OcpSettings::horizon, 1, 10000, false, false},
    {"dt", &OcpSettings::dt, 0, 10, true, false},
    {"base_velocity_weight", &OcpSettings::base_velocity_weight, 0, 1e12, false, false},
    {"base_position_weight", &OcpSettings::base_position_weight, 0, 1e12, false, false},
    {"base_orientation_weight", &OcpSettings::base_orientation_weight, 0, 1e12, false, false},
    {"joint_position_weight", &OcpSettings::joint_position_weight, 0, 1e12, false, false},
    {"momentum_weight", &OcpSettings::momentum_weight, 0, 1e12, false, false},
    {"joint_velocity_weight", &OcpSettings::joint_velocity_weight, 0, 1e12, false, false},
    {"force_weight", &OcpSettings::force_weight, 0, 1e12, false, false},
    {"freed_stance_velocity_weight", &OcpSettings::freed_stance_velocity_weight, 0, 1e12, false,
     false},
    {"lateral_slip_weight", &OcpSettings::lateral_slip_weight, 0, 1e12, false, false},
    {"terminal_weight_scale", &OcpSettings::terminal_weight_scale, 0, 1e12, false, false},
    {"swing_height_gain", &OcpSettings::swing_height_gain, 0, 1e6, false, false},
    {"swing_height_max_correction", &OcpSettings::swing_height_max_correction, 0, 100, false,
     false},
    {"friction_coefficient", &OcpSettings::friction_coefficient, 0, 10, true, false},
    {"min_normal_force", &OcpSettings::min_normal_force, 0, 1e6, false, false},
    {"torque_limit_scale", &OcpSettings::torque_limit_scale, 0, 1, true, false},
    {"joint_limit_margin", &OcpSettings::joint_limit_margin, 0, 10, false, false},
    {"velocity_limit_scale", &OcpSettings::velocity_limit_scale, 0, 1, true, false},
    {"soft_state_constraints", &OcpSettings::soft_state_constraints, 0, 0, false, false},
    {"soft_region_constraints", &OcpSettings::soft_region_constraints, 0, 0, false, false},
    {"soft_velocity_limits", &OcpSettings::soft_velocity_limits, 0, 0, false, false},
    {"soft_relaxation", &OcpSettings::soft_relaxation, 0, 1e3, true, false},
    {"soft_weight", &OcpSettings::soft_weight, 0, 1e12, true, false},
    {"swing_clearance", &OcpSettings::swing_clearance, 0, 2, false, false},
    {"swing_apex_margin", &OcpSettings::swing_apex_margin, 0, 0.5, true, false},
    {"base_height_reach", &OcpSettings::base_height_reach, 0, 10, false, false},
    {"base_height_slope", &OcpSettings::base_height_slope, 0, 100, false, false},
    {"base_height_rate", &OcpSettings::base_height_rate, 0, 0, false, false},
    {"foothold_gap_reach", &OcpSettings::foothold_gap_reach, 0, 10, false, false},
    {"step_down_max_hold", &OcpSettings::step_down_max_hold, 0, 10, false, false},
    {"edge_hold_lead", &OcpSettings::edge_hold_lead, 0, 10, false, false},
    {"step_down_reach", &OcpSettings::step_down_reach, 0, 1, false, false},
    {"step_up_max_hold", &OcpSettings::step_up_max_hold, 0, 10, false, false},
    {"step_up_setback", &OcpSettings::step_up_setback, 0, 1, false, false},
    {"step_up_reach", &OcpSettings::step_up_reach, 0, 1, false, false},
    {"foothold_edge_clearance", &OcpSettings::foothold_edge_clearance, 0, 1, false, false},
    {"anchor_stance_feet", &OcpSettings::anchor_stance_feet, 0, 0, false, false},
    {"latch_touchdowns", &OcpSettings::latch_touchdowns, 0, 0, false, false},
    {"late_touchdown_tolerance", &OcpSettings::late_touchdown_tolerance, 0, 1, false, false},
    {"late_touchdown_speed", &OcpSettings::late_touchdown_speed, 0, 100, true, false},
    {"late_touchdown_max_delay", &OcpSettings::late_touchdown_max_delay, 0, 10, false, false},
    {"gait_period", &OcpSettings::gait_period, 0, 100, true, false},
    {"trot_duty", &OcpSettings::trot_duty, 0, 1, true, true},
    {"walk_duty", &OcpSettings::walk_duty, 0, 1, true, true},
    {"walk_period", &OcpSettings::walk_period, 0, 100, true, false},
    {"speed_adaptation", &OcpSettings::speed_adaptation, 0, 0, false, false},
    {"max_step_height", &OcpSettings::max_step_height, 0, 2, true, false},
    {"swing_knee_speed_share", &OcpSettings::swing_knee_speed_share, 0, 1, true, false},
    {"stance_stroke_share", &OcpSettings::stance_stroke_share, 0, 10, true, false},
    {"step_speed_reach", &OcpSettings::step_speed_reach, 0, 10, false, false},
    {"command_acceleration", &OcpSettings::command_acceleration, 0, 100, false, false},
    {"solver", Member{}, 0, 0, false, false},  // nested mapping, read by the solver layer
}};

std::string knownKeys() {
  std::string keys;
  for (const Field& f : kFields) keys += (keys.empty() ? "" : ", ") + std::string(f.key);
  return keys;
}

std::string rangeText(const Field& f) {
  return std::string(f.lower_open ? "(" : "[") + shortestNumberText(f.lower) + ", " +
         shortestNumberText(f.upper) + (f.upper_open ? ")" : "]");
}

bool inRange(const Field& f, double v) {
  if (!std::isfinite(v)) return false;
  if (f.lower_open ? v <= f.lower : v < f.lower) return false;
  if (f.upper_open ? v >= f.upper : v > f.upper) return false;
  return true;
}

std::string lineOf(const yaml::Node& node) { return "line " + std::to_string(node.line()) + ": "; }

/// Parses a whole document with `read(root, fail)`; YAML errors become the loader's error.
template <typename Read>
void parseDocument(const std::string& text, const std::string& prefix, Read read) {
  try {
    const yaml::Document document = yaml::Document::parse(text);
    read(document.root());
  } catch (const yaml::YamlError& e) {
    throw std::runtime_error(prefix + "YAML error: " + e.what());
  }
}

}  // namespace

OcpSettings parseOcpSettings(const std::string& yaml_text, const std::string& source_name) {
  OcpSettings settings;
  parseDocument(yaml_text, "OCP settings " + source_name + ": ",
                [&](const yaml::Node& root) { settings = parseOcpSettings(root, source_name); });
  return settings;
}

OcpSettings parseOcpSettings(const yaml::Node& root, const std::string& source_name,
                             const std::string& key_path, const std::string& description) {
  return parseOcpSettings(root, OcpSettings{}, source_name, key_path, description);
}

OcpSettings parseOcpSettings(const yaml::Node& root, const OcpSettings& base,
                             const std::string& source_name, const std::string& key_path,
                             const std::string& description) {
  const std::string prefix = description + " " + source_name + ": ";
  OcpSettings settings = base;
  const auto fail = [&](const yaml::Node& at, const std::string& what) {
    throw std::runtime_error(prefix + lineOf(at) + what);
  };
  if (root.isNull()) return settings;
  if (!root.isMapping()) fail(root, "expected a mapping of key: value");
  std::map<std::string, int> seen;
  for (std::size_t item = 0; item < root.size(); ++item) {
    const yaml::Node key_node = root.key(item);
    const yaml::Node value = root.value(item);
    if (!key_node.isScalar()) fail(key_node, "a key must be a plain name");
    const std::string key = key_node.scalar();
    const Field* field = nullptr;
    for (const Field& f : kFields) {
      if (key == f.key) field = &f;
    }
    if (field == nullptr)
      fail(key_node, "unknown key '" + key_path + key + "' (known: " + knownKeys() + ")");
    if (const auto it = seen.find(key); it != seen.end()) {
      fail(key_node,
           key_path + key + ": given twice (first on line " + std::to_string(it->second) + ")");
    }
    seen.emplace(key, key_node.line());
    const std::string at = key_path + key + ": ";
    if (key == "solver") {
      if (!value.isMapping() && !value.isNull()) {
        fail(value, at + "expected a mapping of solver settings, got " + value.kindName());
      }
      settings.solver =
          solver::parseSolverSettings(value,
                                      source_name + " (key '" + key_path + "solver', line " +
                                          std::to_string(value.line()) + ")",
                                      base.solver);
      continue;
    }
    if (value.isNull()) fail(value, at + "no value");
    // A number within the field's range, or an error naming the key, value and range.
    const auto number = [&](const yaml::Node& node) {
      double v = 0.0;
      if (!node.isScalar() || !node.toDouble(v)) {
        fail(node, at + "'" + node.scalar() + "' is not a number" +
                       (node.isScalar() && !node.plain() ? " (it is quoted or tagged)" : ""));
      }
      if (!inRange(*field, v)) {
        fail(node, at + node.scalar() + " is outside " + rangeText(*field));
      }
      return v;
    };
    std::visit(
        [&](auto member) {
          using T = std::decay_t<decltype(settings.*member)>;
          if constexpr (std::is_same_v<T, bool>) {
            if (!value.isScalar() || !value.toBool(settings.*member)) {
              fail(value, at + "expected true or false, got " +
                              (value.isScalar() ? "'" + value.scalar() + "'" : value.kindName()));
            }
          } else if constexpr (std::is_same_v<T, int>) {
            int v = 0;
            if (!value.isScalar() || !value.toInt(v)) {
              fail(value, at + "expected an integer, got " +
                              (value.isScalar() ? "'" + value.scalar() + "'" : value.kindName()));
            }
            if (!inRange(*field, v)) {
              fail(value, at + std::to_string(v) + " is outside " + rangeText(*field));
            }
            settings.*member = v;
          } else if constexpr (std::is_same_v<T, double>) {
            if (!value.isScalar()) {
              fail(value, at + "expected a single number, got " + value.kindName());
            }
            settings.*member = number(value);
          } else {
            constexpr int n = T::RowsAtCompileTime;
            if (!value.isSequence() || value.size() != static_cast<std::size_t>(n)) {
              fail(value, at + "expected a list of " + std::to_string(n) + " numbers, got " +
                              (value.isSequence() ? "a list of " + std::to_string(value.size())
                                                  : std::string(value.kindName())));
            }
            T v;
            for (int i = 0; i < n; ++i) v[i] = number(value.item(static_cast<std::size_t>(i)));
            settings.*member = v;
          }
        },
        field->member);
  }
  return settings;
}

OcpSettings loadOcpSettings(const std::string& yaml_file) {
  return parseOcpSettings(readTextFile(yaml_file, "OCP settings", kMaxConfigBytes), yaml_file);
}

std::string toYaml(const OcpSettings& settings) {
  std::string out;
  for (const Field& f : kFields) {
    if (std::string(f.key) == "solver") continue;
    out += std::string(f.key) + ": ";
    std::visit(
        [&](auto member) {
          using T = std::decay_t<decltype(settings.*member)>;
          if constexpr (std::is_same_v<T, bool>) {
            out += settings.*member ? "true" : "false";
          } else if constexpr (std::is_same_v<T, int>) {
            out += std::to_string(settings.*member);
          } else if constexpr (std::is_same_v<T, double>) {
            out += shortestNumberText(settings.*member);
          } else {
            const T& v = settings.*member;
            out += "[";
            for (int i = 0; i < v.size(); ++i) out += (i ? ", " : "") + shortestNumberText(v[i]);
            out += "]";
          }
        },
        f.member);
    out += "\n";
  }
  out += "solver:\n";
  const std::string solver_text = solver::toYaml(settings.solver);
  std::size_t start = 0;
  while (start < solver_text.size()) {
    const std::size_t end = solver_text.find('\n', start);
    out += "  " + solver_text.substr(start, end - start) + "\n";
    if (end == std::string::npos) break;
    start = end + 1;
  }
  return out;
}

// --- the robot description ------------------------------------------------------------------

RobotOcpDescription parseRobotOcpDescription(const std::string& yaml_text,
                                             const std::string& source_name,
                                             const std::string& base_directory) {
  const std::string prefix = "robot description " + source_name + ": ";
  RobotOcpDescription d;
  d.source = source_name;
  parseDocument(yaml_text, prefix, [&](const yaml::Node& root) {
    const auto fail = [&](const yaml::Node& at, const std::string& what) {
      throw std::runtime_error(prefix + lineOf(at) + what);
    };
    if (!root.isMapping()) fail(root, "expected a mapping of key: value");
    const auto text = [&](const yaml::Node& node, const std::string& key) {
      if (!node.isScalar()) fail(node, key + ": expected a name, got " + node.kindName());
      return node.scalar();
    };
    const auto names = [&](const yaml::Node& node, const std::string& key) {
      if (!node.isSequence())
        fail(node, key + ": expected a list of names, got " + node.kindName());
      std::vector<std::string> out;
      for (std::size_t i = 0; i < node.size(); ++i) {
        std::string name = text(node.item(i), key);
        for (const std::string& other : out) {
          if (other == name) fail(node.item(i), key + ": '" + name + "' given twice");
        }
        out.push_back(std::move(name));
      }
      return out;
    };
    std::map<std::string, yaml::Node> given;
    const std::vector<std::string> known = {
        "urdf",           "contact_frames",          "drive_wheels",    "side_pairs",
        "contact_offset", "nominal_joint_positions", "servo_stiffness", "trot_groups",
        "walk_order"};
    for (std::size_t item = 0; item < root.size(); ++item) {
      const yaml::Node key_node = root.key(item);
      const std::string key = text(key_node, "key");
      bool is_known = false;
      for (const std::string& k : known) is_known = is_known || k == key;
      if (!is_known) fail(key_node, "unknown key '" + key + "'");
      if (given.count(key) != 0) {
        fail(key_node,
             key + ": given twice (first on line " + std::to_string(given.at(key).line()) + ")");
      }
      if (root.value(item).isNull()) fail(key_node, key + ": no value");
      given.emplace(key, root.value(item));
    }
    for (const char* required : {"urdf", "contact_frames", "nominal_joint_positions"}) {
      if (given.count(required) == 0) fail(root, std::string("missing key '") + required + "'");
    }
    d.urdf = text(given.at("urdf"), "urdf");
    if (!base_directory.empty() && !std::filesystem::path(d.urdf).is_absolute()) {
      d.urdf = (std::filesystem::path(base_directory) / d.urdf).lexically_normal().string();
    }
    d.contact_frames = names(given.at("contact_frames"), "contact_frames");
    if (d.contact_frames.empty()) fail(given.at("contact_frames"), "contact_frames: empty");
    const auto isContact = [&](const std::string& name) {
      for (const std::string& c : d.contact_frames) {
        if (c == name) return true;
      }
      return false;
    };
    const auto contactNames = [&](const char* key) {
      std::vector<std::string> out;
      if (given.count(key) == 0) return out;
      out = names(given.at(key), key);
      for (std::size_t i = 0; i < out.size(); ++i) {
        if (!isContact(out[i])) {
          fail(given.at(key).item(i),
               std::string(key) + ": '" + out[i] + "' is not a contact frame");
        }
      }
      return out;
    };
    d.drive_wheels = contactNames("drive_wheels");
    d.walk_order = contactNames("walk_order");
    if (given.count("side_pairs") != 0) {
      const yaml::Node pairs = given.at("side_pairs");
      if (!pairs.isSequence()) fail(pairs, "side_pairs: expected a list of [first, second]");
      for (std::size_t i = 0; i < pairs.size(); ++i) {
        const std::vector<std::string> pair = names(pairs.item(i), "side_pairs");
        if (pair.size() != 2) fail(pairs.item(i), "side_pairs: expected two names per pair");
        for (const std::string& name : pair) {
          if (!isContact(name))
            fail(pairs.item(i), "side_pairs: '" + name + "' is not a contact frame");
        }
        d.side_pairs.push_back({pair[0], pair[1]});
      }
    }
    if (given.count("trot_groups") != 0) {
      const yaml::Node groups = given.at("trot_groups");
      if (!groups.isSequence() || groups.size() != 2) {
        fail(groups, "trot_groups: expected two lists of contact frames");
      }
      d.trot_group_a = names(groups.item(0), "trot_groups");
      d.trot_group_b = names(groups.item(1), "trot_groups");
      for (const auto* group : {&d.trot_group_a, &d.trot_group_b}) {
        for (const std::string& name : *group) {
          if (!isContact(name)) fail(groups, "trot_groups: '" + name + "' is not a contact frame");
        }
      }
      // A trot alternates two groups that share no foot and together hold all of them.
      const auto in = [](const std::vector<std::string>& group, const std::string& name) {
        return std::find(group.begin(), group.end(), name) != group.end();
      };
      for (const std::string& frame : d.contact_frames) {
        const bool a = in(d.trot_group_a, frame), b = in(d.trot_group_b, frame);
        if (a && b) fail(groups, "trot_groups: '" + frame + "' is in both groups");
        if (!a && !b) {
          fail(groups, "trot_groups: '" + frame +
                           "' is in neither group (each contact frame in exactly one)");
        }
      }
    }
    if (!d.walk_order.empty()) {
      for (const std::string& frame : d.contact_frames) {
        if (std::find(d.walk_order.begin(), d.walk_order.end(), frame) == d.walk_order.end()) {
          fail(given.at("walk_order"), "walk_order: '" + frame +
                                           "' is missing (the order lists every contact "
                                           "frame once)");
        }
      }
    }
    if (given.count("contact_offset") != 0) {
      const yaml::Node node = given.at("contact_offset");
      if (!node.toDouble(d.contact_offset) || !std::isfinite(d.contact_offset) ||
          d.contact_offset < 0.0 || d.contact_offset > 10.0) {
        fail(node, "contact_offset: expected a distance in [0, 10] m, got '" + node.scalar() + "'");
      }
    }
    // A per-joint list of finite numbers (> 0 where `positive`).
    const auto jointNumbers = [&](const std::string& key, bool positive) {
      const yaml::Node node = given.at(key);
      if (!node.isSequence() || node.size() == 0) fail(node, key + ": expected a list of numbers");
      Eigen::VectorXd out(static_cast<Eigen::Index>(node.size()));
      for (std::size_t i = 0; i < node.size(); ++i) {
        double v = 0.0;
        if (!node.item(i).toDouble(v) || !std::isfinite(v) || (positive && v <= 0.0)) {
          fail(node.item(i), key + ": '" + node.item(i).scalar() + "' is not a finite number" +
                                 (positive ? " > 0" : ""));
        }
        out[static_cast<Eigen::Index>(i)] = v;
      }
      return out;
    };
    d.nominal_joint_positions = jointNumbers("nominal_joint_positions", false);
    if (given.count("servo_stiffness") != 0) {
      d.servo_stiffness = jointNumbers("servo_stiffness", true);
    }
  });
  return d;
}

RobotOcpDescription loadRobotOcpDescription(const std::string& yaml_file) {
  const std::string text = readTextFile(yaml_file, "robot description", kMaxConfigBytes);
  return parseRobotOcpDescription(text, yaml_file,
                                  std::filesystem::path(yaml_file).parent_path().string());
}

}  // namespace rollstep::centroidal
