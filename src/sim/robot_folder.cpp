#include "rollstep/sim/robot_folder.hpp"

#include <mujoco/mujoco.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <system_error>
#include <vector>

#include "rollstep/centroidal/ocp_settings.hpp"
#include "rollstep/common/text_file.hpp"
#include "rollstep/model/model.hpp"

namespace rollstep::sim {

namespace fs = std::filesystem;

namespace {

constexpr double kAxisTolerance = 1e-6;
constexpr double kLimitTolerance = 1e-6;
constexpr double kMassRelativeTolerance = 1e-6;
constexpr double kMassAbsoluteTolerance = 1e-9;  // [kg]
constexpr double kRadiusTolerance = 1e-4;        // [m], as rollstep sim's check
constexpr double kPostureTolerance = 1e-9;       // [rad or m] outside a range
// [rad or m] the keyframe `nominal` against nominal_joint_positions: the controllers plan
// from the description's posture, the plant starts at the keyframe's.
constexpr double kKeyframeTolerance = 1e-4;

std::string num(double v) {
  char text[32];
  std::snprintf(text, sizeof text, "%.9g", v);
  return text;
}

bool isFile(const fs::path& p) {
  std::error_code ec;
  return fs::is_regular_file(p, ec);
}

std::string robotsThere(const std::string& dir) {
  std::vector<std::string> names;
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    if (isFile(it->path() / "centroidal.yaml")) names.push_back(it->path().filename().string());
  }
  std::sort(names.begin(), names.end());
  std::string out;
  for (const std::string& n : names) out += (out.empty() ? "" : ", ") + n;
  return out.empty() ? "none" : out;
}

bool nearlyEqualMass(double a, double b) {
  return std::abs(a - b) <= kMassAbsoluteTolerance + kMassRelativeTolerance * std::max(a, b);
}

}  // namespace

RobotFolder findRobotFolder(const std::string& name_or_dir) {
  if (name_or_dir.empty()) throw InputError("--robot: an empty name; give a robot name or folder");
  const bool is_path =
      name_or_dir.find('/') != std::string::npos || name_or_dir == "." || name_or_dir == "..";
  std::string dir = is_path ? name_or_dir : robotsDirectory() + "/" + name_or_dir;
  while (dir.size() > 1 && dir.back() == '/') dir.pop_back();
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) {
    if (is_path) throw InputError("robot folder '" + dir + "': not a directory");
    throw InputError("robot '" + name_or_dir + "': no folder " + dir + " (robots in " +
                     robotsDirectory() + ": " + robotsThere(robotsDirectory()) +
                     "; or give a folder path)");
  }
  RobotFolder f;
  f.directory = dir;
  f.name = fs::path(dir).lexically_normal().filename().string();
  if (f.name.empty() || f.name == "." || f.name == "..") {
    f.name = fs::absolute(dir, ec).lexically_normal().filename().string();
    if (f.name.empty())
      f.name = fs::absolute(dir, ec).lexically_normal().parent_path().filename().string();
  }
  f.description = dir + "/centroidal.yaml";
  f.mjcf = dir + "/" + f.name + ".xml";
  if (!isFile(f.description)) {
    throw InputError("robot folder '" + dir +
                     "': missing file centroidal.yaml (the robot description: URDF, contact "
                     "frames, posture; docs/ROBOTS.md)");
  }
  if (!isFile(f.mjcf)) {
    throw InputError("robot folder '" + dir + "': missing file " + f.name +
                     ".xml (the MJCF of the simulated robot, named after the folder; "
                     "docs/ROBOTS.md)");
  }
  const auto optional = [&](const char* file) {
    const std::string path = dir + "/" + file;
    return isFile(path) ? path : std::string();
  };
  f.estimation = optional("estimation.yaml");
  f.sensors = optional("sensors.yaml");
  f.lidar = optional("lidar.yaml");
  return f;
}

std::string RobotFolder::optionalFile(const std::string& file) const {
  const std::string path = directory + "/" + file;
  return isFile(path) ? path : std::string();
}

RobotFolder defaultRobotFolder() { return findRobotFolder(robotsDirectory() + "/tachyon3"); }

PlantOptions plantOptionsFor(const RobotFolder& folder) {
  const centroidal::RobotOcpDescription d = centroidal::loadRobotOcpDescription(folder.description);
  PlantOptions o;
  o.robot_file = folder.mjcf;
  o.contact_frames = d.contact_frames;
  o.drive_wheels = d.drive_wheels;
  return o;
}

std::vector<std::string> crossCheckRobotFolder(const RobotFolder& folder) {
  std::vector<std::string> problems;
  centroidal::RobotOcpDescription d;
  try {
    d = centroidal::loadRobotOcpDescription(folder.description);
  } catch (const std::exception& e) {
    problems.push_back(e.what());
    return problems;
  }
  std::unique_ptr<model::Model> urdf;
  try {
    urdf = std::make_unique<model::Model>(model::buildModelFromUrdfFile(d.urdf));
  } catch (const std::exception& e) {
    problems.push_back(std::string(e.what()) + " (named by " + folder.description + ")");
    return problems;
  }
  const std::string in_description = "robot description '" + folder.description + "': ";
  const std::string in_urdf = "URDF '" + d.urdf + "'";
  const std::string in_mjcf = "MJCF '" + folder.mjcf + "'";
  for (const std::string& frame : d.contact_frames) {
    if (!urdf->existFrame(frame)) {
      problems.push_back(in_description + "contact frame '" + frame + "' is not a link of the " +
                         in_urdf);
    }
  }
  if (!problems.empty()) return problems;

  std::unique_ptr<Plant> plant;
  try {
    PlantOptions options;
    options.robot_file = folder.mjcf;
    options.contact_frames = d.contact_frames;
    options.drive_wheels = d.drive_wheels;
    plant = std::make_unique<Plant>(SceneConfig{}, options);
  } catch (const std::exception& e) {
    problems.push_back(e.what());
    return problems;
  }
  const mjModel* m = plant->mujocoModel();

  // Joints: names, kinds, axes, limits, and the mass they carry.
  for (std::size_t b = 1; b < urdf->bodies.size(); ++b) {
    const model::Body& body = urdf->bodies[b];
    const std::string what = "joint '" + body.joint + "'";
    const int j = mj_name2id(m, mjOBJ_JOINT, body.joint.c_str());
    if (j < 0) {
      problems.push_back(in_mjcf + ": no " + what + " (a joint of the " + in_urdf + ")");
      continue;
    }
    const bool prismatic = body.type == model::JointType::Prismatic;
    const int type = m->jnt_type[j];
    if (type != (prismatic ? mjJNT_SLIDE : mjJNT_HINGE)) {
      problems.push_back(what + ": " + (prismatic ? "prismatic" : "revolute") + " in the " +
                         in_urdf + ", " +
                         (type == mjJNT_SLIDE   ? "slide"
                          : type == mjJNT_HINGE ? "hinge"
                          : type == mjJNT_BALL  ? "ball"
                                                : "free") +
                         " in the " + in_mjcf);
      continue;
    }
    const Eigen::Vector3d mj_axis(m->jnt_axis[3 * j], m->jnt_axis[3 * j + 1],
                                  m->jnt_axis[3 * j + 2]);
    if ((mj_axis - body.axis.normalized()).norm() > kAxisTolerance) {
      problems.push_back(what + ": axis (" + num(body.axis.x()) + ", " + num(body.axis.y()) + ", " +
                         num(body.axis.z()) + ") in the " + in_urdf + ", (" + num(mj_axis.x()) +
                         ", " + num(mj_axis.y()) + ", " + num(mj_axis.z()) + ") in the " + in_mjcf +
                         " (each in its body's frame)");
    }
    const int q = body.idxQ - urdf->nqBase;
    const double lower = urdf->lowerPositionLimit[q], upper = urdf->upperPositionLimit[q];
    if (std::isfinite(lower) && std::isfinite(upper)) {
      if (!m->jnt_limited[j]) {
        problems.push_back(what + ": limits [" + num(lower) + ", " + num(upper) + "] in the " +
                           in_urdf + ", unlimited in the " + in_mjcf);
      } else if (std::abs(m->jnt_range[2 * j] - lower) > kLimitTolerance ||
                 std::abs(m->jnt_range[2 * j + 1] - upper) > kLimitTolerance) {
        problems.push_back(what + ": limits [" + num(lower) + ", " + num(upper) + "] in the " +
                           in_urdf + ", [" + num(m->jnt_range[2 * j]) + ", " +
                           num(m->jnt_range[2 * j + 1]) + "] in the " + in_mjcf);
      }
    }
    double urdf_mass = 0.0;
    for (int k = static_cast<int>(b); k < body.subtreeEnd; ++k) {
      urdf_mass += urdf->bodies[static_cast<std::size_t>(k)].mass;
    }
    const double mj_mass = m->body_subtreemass[m->jnt_bodyid[j]];
    if (!nearlyEqualMass(urdf_mass, mj_mass)) {
      problems.push_back(what + ": the bodies it moves weigh " + num(urdf_mass) + " kg in the " +
                         in_urdf + ", " + num(mj_mass) + " kg in the " + in_mjcf);
    }
  }
  double urdf_total = 0.0;
  for (const model::Body& body : urdf->bodies) urdf_total += body.mass;
  if (!nearlyEqualMass(urdf_total, plant->totalMass())) {
    problems.push_back("total mass " + num(urdf_total) + " kg in the " + in_urdf + ", " +
                       num(plant->totalMass()) + " kg in the " + in_mjcf);
  }
  const PlantLayout& layout = plant->layout();
  for (const PlantLayout::Joint& joint : layout.joints) {
    const auto& names = urdf->jointNames;
    if (std::find(names.begin(), names.end(), joint.name) == names.end()) {
      problems.push_back(in_mjcf + ": joint '" + joint.name + "' of leg '" +
                         layout.legs[static_cast<std::size_t>(joint.leg)].contact_frame +
                         "' is not a joint of the " + in_urdf);
    }
  }

  // The description against the MJCF: posture inside the ranges, wheel radius.
  if (d.nominal_joint_positions.size() == static_cast<Eigen::Index>(urdf->jointNames.size())) {
    for (std::size_t k = 0; k < urdf->jointNames.size(); ++k) {
      const std::string& name = urdf->jointNames[k];
      const int j = mj_name2id(m, mjOBJ_JOINT, name.c_str());
      if (j < 0 || !m->jnt_limited[j]) continue;
      const double value = d.nominal_joint_positions[static_cast<Eigen::Index>(k)];
      if (value < m->jnt_range[2 * j] - kPostureTolerance ||
          value > m->jnt_range[2 * j + 1] + kPostureTolerance) {
        problems.push_back(in_description + "nominal_joint_positions: " + num(value) +
                           " for joint '" + name + "' is outside its range [" +
                           num(m->jnt_range[2 * j]) + ", " + num(m->jnt_range[2 * j + 1]) +
                           "] in the " + in_mjcf);
      }
    }
    // The keyframe the plant starts from holds the same posture (qpos) and servo targets
    // (ctrl of the joint's position actuator).
    const int key = mj_name2id(m, mjOBJ_KEY, "nominal");
    for (std::size_t k = 0; key >= 0 && k < urdf->jointNames.size(); ++k) {
      const std::string& name = urdf->jointNames[k];
      const int j = mj_name2id(m, mjOBJ_JOINT, name.c_str());
      if (j < 0) continue;
      const double value = d.nominal_joint_positions[static_cast<Eigen::Index>(k)];
      const double key_qpos = m->key_qpos[key * m->nq + m->jnt_qposadr[j]];
      if (std::abs(key_qpos - value) > kKeyframeTolerance) {
        problems.push_back(in_mjcf + ": keyframe 'nominal': qpos of joint '" + name + "' is " +
                           num(key_qpos) + ", nominal_joint_positions in '" + folder.description +
                           "' says " + num(value));
      }
      for (int a = 0; a < m->nu; ++a) {
        if (m->actuator_trntype[a] != mjTRN_JOINT || m->actuator_trnid[2 * a] != j) continue;
        const double key_ctrl = m->key_ctrl[key * m->nu + a];
        if (std::abs(key_ctrl - value) > kKeyframeTolerance) {
          problems.push_back(in_mjcf + ": keyframe 'nominal': ctrl of actuator '" +
                             std::string(mj_id2name(m, mjOBJ_ACTUATOR, a) != nullptr
                                             ? mj_id2name(m, mjOBJ_ACTUATOR, a)
                                             : "(unnamed)") +
                             "' (joint '" + name + "') is " + num(key_ctrl) +
                             ", nominal_joint_positions in '" + folder.description + "' says " +
                             num(value));
        }
      }
    }
  } else {
    problems.push_back(in_description + "nominal_joint_positions: " +
                       std::to_string(d.nominal_joint_positions.size()) + " values, the " +
                       in_urdf + " has " + std::to_string(urdf->jointNames.size()) + " joints");
  }
  // A drive wheel's axle: the controllers command its speed about the wheel frame's y
  // (positive rolls forward); an axle along another axis rolls it the wrong way.
  for (const std::string& wheel : d.drive_wheels) {
    const int b = mj_name2id(m, mjOBJ_BODY, wheel.c_str());
    if (b < 0 || m->body_jntnum[b] != 1 || m->jnt_type[m->body_jntadr[b]] != mjJNT_HINGE) continue;
    const int j = m->body_jntadr[b];
    const Eigen::Vector3d axle(m->jnt_axis[3 * j], m->jnt_axis[3 * j + 1], m->jnt_axis[3 * j + 2]);
    if ((axle - Eigen::Vector3d::UnitY()).norm() > kAxisTolerance) {
      problems.push_back(
          in_mjcf + ": drive wheel '" + wheel + "': its axle '" +
          std::string(mj_id2name(m, mjOBJ_JOINT, j) != nullptr ? mj_id2name(m, mjOBJ_JOINT, j)
                                                               : "") +
          "' turns about (" + num(axle.x()) + ", " + num(axle.y()) + ", " + num(axle.z()) +
          ") in the wheel's frame; the controllers roll it about (0, 1, 0), "
          "positive forward");
    }
  }
  for (int leg = 0; leg < layout.numLegs(); ++leg) {
    if (std::abs(d.contact_offset - plant->wheelRadius(leg)) > kRadiusTolerance) {
      problems.push_back(in_description + "contact_offset: " + num(d.contact_offset) +
                         " m is not the radius of wheel '" +
                         layout.legs[static_cast<std::size_t>(leg)].contact_frame + "' in the " +
                         in_mjcf + " (" + num(plant->wheelRadius(leg)) + " m)");
    }
  }
  return problems;
}

void requireConsistentRobotFolder(const RobotFolder& folder) {
  const std::vector<std::string> problems = crossCheckRobotFolder(folder);
  if (problems.empty()) return;
  std::string text = "robot folder '" + folder.directory + "' is inconsistent:";
  for (const std::string& p : problems) text += "\n  " + p;
  throw InputError(text);
}

}  // namespace rollstep::sim
