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
#include "rollstep/common/settings_table.hpp"
#include "rollstep/common/text_file.hpp"
#include "rollstep/solver/settings_yaml.hpp"

namespace rollstep::centroidal {
namespace {

constexpr std::size_t kMaxConfigBytes = std::size_t{1} << 20;

using settings::Range;

// The one table of keys (config/ocp.yaml documents each, in this order).
settings::Table<OcpSettings> makeTable() {
  using S = OcpSettings;
  return settings::Table<S>()
      .field("horizon", &S::horizon, "", Range::closed(1, 10000))
      .field("dt", &S::dt, "s", Range::leftOpen(0, 10))
      .field("base_velocity_weight", &S::base_velocity_weight, "", Range::closed(0, 1e12))
      .field("base_position_weight", &S::base_position_weight, "", Range::closed(0, 1e12))
      .field("base_orientation_weight", &S::base_orientation_weight, "", Range::closed(0, 1e12))
      .field("joint_position_weight", &S::joint_position_weight, "", Range::closed(0, 1e12))
      .field("momentum_weight", &S::momentum_weight, "", Range::closed(0, 1e12))
      .field("joint_velocity_weight", &S::joint_velocity_weight, "", Range::closed(0, 1e12))
      .field("force_weight", &S::force_weight, "", Range::closed(0, 1e12))
      .field("freed_stance_velocity_weight", &S::freed_stance_velocity_weight, "",
             Range::closed(0, 1e12))
      .field("lateral_slip_weight", &S::lateral_slip_weight, "", Range::closed(0, 1e12))
      .field("terminal_weight_scale", &S::terminal_weight_scale, "", Range::closed(0, 1e12))
      .field("swing_height_gain", &S::swing_height_gain, "", Range::closed(0, 1e6))
      .field("swing_height_max_correction", &S::swing_height_max_correction, "m/s",
             Range::closed(0, 100))
      .field("friction_coefficient", &S::friction_coefficient, "", Range::leftOpen(0, 10))
      .field("min_normal_force", &S::min_normal_force, "N", Range::closed(0, 1e6))
      .field("torque_limit_scale", &S::torque_limit_scale, "", Range::leftOpen(0, 1))
      .field("joint_limit_margin", &S::joint_limit_margin, "rad or m", Range::closed(0, 10))
      .field("velocity_limit_scale", &S::velocity_limit_scale, "", Range::leftOpen(0, 1))
      .field("soft_state_constraints", &S::soft_state_constraints)
      .field("soft_region_constraints", &S::soft_region_constraints)
      .field("soft_velocity_limits", &S::soft_velocity_limits)
      .field("soft_relaxation", &S::soft_relaxation, "", Range::leftOpen(0, 1e3))
      .field("soft_weight", &S::soft_weight, "", Range::leftOpen(0, 1e12))
      .field("swing_clearance", &S::swing_clearance, "m", Range::closed(0, 2))
      .field("swing_apex_margin", &S::swing_apex_margin, "", Range::leftOpen(0, 0.5))
      .field("base_height_reach", &S::base_height_reach, "m", Range::closed(0, 10))
      .field("base_height_slope", &S::base_height_slope, "", Range::closed(0, 100))
      .field("base_height_rate", &S::base_height_rate)
      .field("foothold_gap_reach", &S::foothold_gap_reach, "m", Range::closed(0, 10))
      .field("step_down_max_hold", &S::step_down_max_hold, "s", Range::closed(0, 10))
      .field("edge_hold_lead", &S::edge_hold_lead, "s", Range::closed(0, 10))
      .field("step_down_reach", &S::step_down_reach, "m", Range::closed(0, 1))
      .field("step_up_max_hold", &S::step_up_max_hold, "s", Range::closed(0, 10))
      .field("step_up_setback", &S::step_up_setback, "m", Range::closed(0, 1))
      .field("step_up_reach", &S::step_up_reach, "m", Range::closed(0, 1))
      .field("foothold_edge_clearance", &S::foothold_edge_clearance, "m", Range::closed(0, 1))
      .field("anchor_stance_feet", &S::anchor_stance_feet)
      .field("latch_touchdowns", &S::latch_touchdowns)
      .field("late_touchdown_tolerance", &S::late_touchdown_tolerance, "m", Range::closed(0, 1))
      .field("late_touchdown_speed", &S::late_touchdown_speed, "m/s", Range::leftOpen(0, 100))
      .field("late_touchdown_max_delay", &S::late_touchdown_max_delay, "s", Range::closed(0, 10))
      .field("gait_period", &S::gait_period, "s", Range::leftOpen(0, 100))
      .field("trot_duty", &S::trot_duty, "", Range::open(0, 1))
      .field("walk_duty", &S::walk_duty, "", Range::open(0, 1))
      .field("walk_period", &S::walk_period, "s", Range::leftOpen(0, 100))
      .field("speed_adaptation", &S::speed_adaptation)
      .field("max_step_height", &S::max_step_height, "m", Range::leftOpen(0, 2))
      .field("swing_knee_speed_share", &S::swing_knee_speed_share, "", Range::leftOpen(0, 1))
      .field("stance_stroke_share", &S::stance_stroke_share, "", Range::leftOpen(0, 10))
      .field("step_speed_reach", &S::step_speed_reach, "m", Range::closed(0, 10))
      .field("command_acceleration", &S::command_acceleration, "m/s^2", Range::closed(0, 100))
      .custom(
          "solver",
          [](const yaml::Node& value, S& s, settings::Reader& reader, const std::string& path) {
            solver::readSolverSettings(value, s.solver, reader, path + ".");
          },
          [](const S& s, const std::string& indent) {
            return "\n" + solver::solverSettingsTable().write(s.solver, indent + "  ");
          },
          /*is_section=*/true);
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

const settings::Table<OcpSettings>& ocpSettingsTable() {
  static const settings::Table<OcpSettings> table = makeTable();
  return table;
}

void readOcpSettings(const yaml::Node& node, OcpSettings& settings, settings::Reader& reader,
                     const std::string& prefix) {
  ocpSettingsTable().read(node, settings, reader, prefix);
}

OcpSettings parseOcpSettings(const std::string& yaml_text, const std::string& source_name) {
  return settings::readDocument(yaml_text, ocpSettingsTable(),
                                "OCP settings " + source_name + ": ");
}

OcpSettings parseOcpSettings(const yaml::Node& root, const std::string& source_name,
                             const std::string& key_path, const std::string& description) {
  return parseOcpSettings(root, OcpSettings{}, source_name, key_path, description);
}

OcpSettings parseOcpSettings(const yaml::Node& root, const OcpSettings& base,
                             const std::string& source_name, const std::string& key_path,
                             const std::string& description) {
  OcpSettings settings = base;
  settings::Reader reader(description + " " + source_name + ": ");
  readOcpSettings(root, settings, reader, key_path);
  return settings;
}

OcpSettings loadOcpSettings(const std::string& yaml_file) {
  return parseOcpSettings(readTextFile(yaml_file, "OCP settings", kMaxConfigBytes), yaml_file);
}

std::string toYaml(const OcpSettings& settings) { return ocpSettingsTable().write(settings); }

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
