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
      .field("approach_timing", &S::approach_timing)
      .field("approach_timing_every_edge", &S::approach_timing_every_edge)
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

namespace {

// The keys of a robot description file as written; RobotOcpDescription is built from it
// after the cross-field checks (every name a contact frame, the trot groups a partition).
struct DescriptionFile {
  std::string urdf;
  std::vector<std::string> contact_frames;
  std::vector<std::string> drive_wheels;
  std::vector<std::vector<std::string>> side_pairs;
  double contact_offset = 0.0;
  Eigen::VectorXd nominal_joint_positions;
  Eigen::VectorXd servo_stiffness;
  std::vector<std::vector<std::string>> trot_groups;
  std::vector<std::string> walk_order;
};

const settings::Table<DescriptionFile>& descriptionTable() {
  using D = DescriptionFile;
  constexpr double kInf = std::numeric_limits<double>::infinity();
  static const settings::Table<D> table =
      settings::Table<D>()
          .field("urdf", &D::urdf)
          .required()
          .field("contact_frames", &D::contact_frames)
          .required()
          .field("drive_wheels", &D::drive_wheels)
          .field("side_pairs", &D::side_pairs, /*lists=*/0, /*names_per_list=*/2)
          .field("contact_offset", &D::contact_offset, "m", Range::closed(0, 10))
          .field("nominal_joint_positions", &D::nominal_joint_positions, "rad or m",
                 Range::anyFinite(), /*min_size=*/1)
          .required()
          .field("servo_stiffness", &D::servo_stiffness, "N m/rad or N/m", Range::open(0, kInf),
                 /*min_size=*/1)
          .field("trot_groups", &D::trot_groups, /*lists=*/2)
          .field("walk_order", &D::walk_order);
  return table;
}

}  // namespace

RobotOcpDescription parseRobotOcpDescription(const std::string& yaml_text,
                                             const std::string& source_name,
                                             const std::string& base_directory) {
  const std::string head = "robot description " + source_name + ": ";
  const yaml::Document document = yaml::parseDocument(yaml_text, head + "YAML error: ");
  DescriptionFile file;
  settings::Reader reader(head);
  descriptionTable().read(document.root(), file, reader);
  // The cross-field checks, each at the line of the key it names.
  const auto fail = [&](const char* key, const std::string& what) {
    reader.failAtLine(reader.lineOf({key}, document.root().line()), key + (": " + what));
  };
  if (file.contact_frames.empty()) fail("contact_frames", "empty");
  const auto isContact = [&](const std::string& name) {
    return std::find(file.contact_frames.begin(), file.contact_frames.end(), name) !=
           file.contact_frames.end();
  };
  const auto requireContacts = [&](const char* key, const std::vector<std::string>& names) {
    for (const std::string& name : names) {
      if (!isContact(name)) {
        std::string frames;
        for (const std::string& frame : file.contact_frames) {
          frames += (frames.empty() ? "" : ", ") + frame;
        }
        fail(key, "'" + name + "' is not a contact frame (contact_frames: [" + frames + "])");
      }
    }
  };
  requireContacts("drive_wheels", file.drive_wheels);
  requireContacts("walk_order", file.walk_order);
  for (const std::vector<std::string>& pair : file.side_pairs) requireContacts("side_pairs", pair);
  for (const std::vector<std::string>& group : file.trot_groups) {
    requireContacts("trot_groups", group);
  }
  if (!file.trot_groups.empty()) {
    // A trot alternates two groups that share no foot and together hold all of them.
    const auto in = [](const std::vector<std::string>& group, const std::string& name) {
      return std::find(group.begin(), group.end(), name) != group.end();
    };
    for (const std::string& frame : file.contact_frames) {
      const bool a = in(file.trot_groups[0], frame), b = in(file.trot_groups[1], frame);
      if (a && b) fail("trot_groups", "'" + frame + "' is in both groups");
      if (!a && !b) {
        fail("trot_groups",
             "'" + frame + "' is in neither group (each contact frame in exactly one)");
      }
    }
  }
  if (!file.walk_order.empty()) {
    for (const std::string& frame : file.contact_frames) {
      if (std::find(file.walk_order.begin(), file.walk_order.end(), frame) ==
          file.walk_order.end()) {
        fail("walk_order", "'" + frame + "' is missing (the order lists every contact frame once)");
      }
    }
  }

  RobotOcpDescription d;
  d.source = source_name;
  d.urdf = file.urdf;
  if (!base_directory.empty() && !std::filesystem::path(d.urdf).is_absolute()) {
    d.urdf = (std::filesystem::path(base_directory) / d.urdf).lexically_normal().string();
  }
  d.contact_frames = std::move(file.contact_frames);
  d.drive_wheels = std::move(file.drive_wheels);
  for (const std::vector<std::string>& pair : file.side_pairs) {
    d.side_pairs.push_back({pair[0], pair[1]});
  }
  d.contact_offset = file.contact_offset;
  d.nominal_joint_positions = std::move(file.nominal_joint_positions);
  d.servo_stiffness = std::move(file.servo_stiffness);
  if (!file.trot_groups.empty()) {
    d.trot_group_a = std::move(file.trot_groups[0]);
    d.trot_group_b = std::move(file.trot_groups[1]);
  }
  d.walk_order = std::move(file.walk_order);
  return d;
}

std::string documentedRobotDescription() { return descriptionTable().documented(); }

RobotOcpDescription loadRobotOcpDescription(const std::string& yaml_file) {
  const std::string text = readTextFile(yaml_file, "robot description", kMaxConfigBytes);
  return parseRobotOcpDescription(text, yaml_file,
                                  std::filesystem::path(yaml_file).parent_path().string());
}

}  // namespace rollstep::centroidal
