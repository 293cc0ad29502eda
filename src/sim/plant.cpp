#include "rollstep/sim/plant.hpp"

#include <mujoco/mujoco.h>

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>

namespace rollstep::sim {

namespace {

std::string trimmed(const char* text) {
  std::string s(text);
  while (!s.empty() && (s.back() == '\n' || s.back() == ' ' || s.back() == '\r')) s.pop_back();
  return s;
}

std::string readFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw SimError("robot model " + path + ": cannot open file");
  std::stringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

/// Loads `xml` (the text of a whole MJCF) through MuJoCo's virtual file system.
mjModel* loadFromString(const std::string& xml, const std::string& vfs_name, std::string& error) {
  auto vfs = std::make_unique<mjVFS>();  // ~2 MB: never on the stack
  mj_defaultVFS(vfs.get());
  if (mj_makeEmptyFileVFS(vfs.get(), vfs_name.c_str(), static_cast<int>(xml.size())) != 0) {
    error = "cannot create the in-memory scene file";
    return nullptr;
  }
  const int index = mj_findFileVFS(vfs.get(), vfs_name.c_str());
  std::memcpy(vfs->filedata[index], xml.data(), xml.size());
  char err[1024] = "";
  mjModel* model = mj_loadXML(vfs_name.c_str(), vfs.get(), err, sizeof err);
  mj_deleteVFS(vfs.get());
  error = trimmed(err);
  return model;
}

}  // namespace

std::string defaultRobotFile() {
  if (const char* dir = std::getenv("ROLLSTEP_ROBOTS_DIR"); dir != nullptr && *dir != '\0') {
    return std::string(dir) + "/tachyon3/tachyon3.xml";
  }
  return std::string(ROLLSTEP_ROBOTS_DIR) + "/tachyon3/tachyon3.xml";
}

Plant::Plant(const SceneConfig& scene, const PlantOptions& options)
    : scene_(scene),
      robot_file_(options.robot_file.empty() ? defaultRobotFile() : options.robot_file),
      control_period_(options.control_period),
      contact_threshold_(options.contact_threshold) {
  try {
    scene_.validate();
  } catch (const std::invalid_argument& e) {
    throw SimError(std::string("scene ") + std::string(toString(scene_.kind)) + ": " + e.what());
  }
  const std::string robot_xml = readFile(robot_file_);

  // 1. The robot alone, so that MuJoCo's errors refer to the robot file itself.
  {
    char err[1024] = "";
    mjModel* alone = mj_loadXML(robot_file_.c_str(), nullptr, err, sizeof err);
    if (alone == nullptr) {
      throw SimError("robot model " + robot_file_ + ": MuJoCo: " + trimmed(err));
    }
    mj_deleteModel(alone);
  }

  // 2. The scene: the robot file with the terrain appended to its worldbody (after the
  //    robot's lines, so line numbers in errors still match the robot file).
  const std::size_t close = robot_xml.rfind("</worldbody>");
  if (close == std::string::npos) {
    throw SimError("robot model " + robot_file_ + ": no <worldbody> element");
  }
  const std::string scene_xml =
      robot_xml.substr(0, close) + terrainMjcf(scene_) + robot_xml.substr(close);
  std::string error;
  const std::string scene_name = "scene_" + std::string(toString(scene_.kind)) + ".xml";
  model_ = loadFromString(scene_xml, scene_name, error);
  if (model_ == nullptr) {
    throw SimError("scene " + std::string(toString(scene_.kind)) + " with robot " + robot_file_ +
                   ": MuJoCo: " + error);
  }
  data_ = mj_makeData(model_);
  if (data_ == nullptr) {
    mj_deleteModel(model_);
    throw SimError("robot model " + robot_file_ + ": MuJoCo could not allocate its data");
  }

  // Everything below may throw: free MuJoCo memory on the way out.
  try {
    const auto id = [&](int type, const std::string& name, const char* what) {
      const int i = mj_name2id(model_, type, name.c_str());
      if (i < 0) {
        throw SimError("robot model " + robot_file_ + ": no " + what + " named '" + name + "'");
      }
      return i;
    };
    const double ts = model_->opt.timestep;
    substeps_ = static_cast<int>(std::lround(control_period_ / ts));
    if (substeps_ < 1 || std::abs(substeps_ * ts - control_period_) > 1e-12) {
      throw SimError("robot model " + robot_file_ + ": timestep " + std::to_string(ts) +
                     " s does not divide the control period " + std::to_string(control_period_) +
                     " s");
    }
    const int base_body = id(mjOBJ_BODY, "base", "body");
    if (model_->body_jntnum[base_body] != 1 ||
        model_->jnt_type[model_->body_jntadr[base_body]] != mjJNT_FREE) {
      throw SimError("robot model " + robot_file_ + ": body 'base' needs one free joint");
    }
    base_qpos_ = model_->jnt_qposadr[model_->body_jntadr[base_body]];
    base_qvel_ = model_->jnt_dofadr[model_->body_jntadr[base_body]];
    geom_leg_.assign(static_cast<std::size_t>(model_->ngeom), -1);

    int wheel = 0;
    for (int leg = 0; leg < kNumLegs; ++leg) {
      const auto l = static_cast<std::size_t>(leg);
      const std::string name = kLegNames[l];
      const char* joint_suffix[2] = {"_hip", "_knee"};
      for (int k = 0; k < 2; ++k) {
        const auto j = static_cast<std::size_t>(2 * leg + k);
        const int jid = id(mjOBJ_JOINT, name + joint_suffix[k], "joint");
        joint_qpos_[j] = model_->jnt_qposadr[jid];
        joint_qvel_[j] = model_->jnt_dofadr[jid];
        joint_ctrl_[j] = id(mjOBJ_ACTUATOR, name + joint_suffix[k] + "_servo", "actuator");
        sensor_jpos_[j] =
            model_->sensor_adr[id(mjOBJ_SENSOR, name + joint_suffix[k] + "_pos", "sensor")];
        sensor_jvel_[j] =
            model_->sensor_adr[id(mjOBJ_SENSOR, name + joint_suffix[k] + "_vel", "sensor")];
      }
      const int hip_body = id(mjOBJ_BODY, name + "_hip_link", "body");
      hip_position_[l] =
          Eigen::Vector3d(model_->body_pos[3 * hip_body], model_->body_pos[3 * hip_body + 1],
                          model_->body_pos[3 * hip_body + 2]);
      wheel_body_[l] = id(mjOBJ_BODY, name + "_wheel", "body");
      wheel_geom_[l] = id(mjOBJ_GEOM, name + "_wheel_geom", "geom");
      wheel_radius_[l] = model_->geom_size[3 * wheel_geom_[l]];
      geom_leg_[static_cast<std::size_t>(wheel_geom_[l])] = leg;
      sensor_touch_[l] = model_->sensor_adr[id(mjOBJ_SENSOR, name + "_touch", "sensor")];
      if (wheel < kNumDriveWheels && kDriveWheelLegs[static_cast<std::size_t>(wheel)] == leg) {
        const auto w = static_cast<std::size_t>(wheel);
        const int jid = id(mjOBJ_JOINT, name + "_wheel", "joint");
        wheel_qpos_[w] = model_->jnt_qposadr[jid];
        wheel_qvel_[w] = model_->jnt_dofadr[jid];
        wheel_ctrl_[w] = id(mjOBJ_ACTUATOR, name + "_wheel_servo", "actuator");
        sensor_wpos_[w] = model_->sensor_adr[id(mjOBJ_SENSOR, name + "_wheel_pos", "sensor")];
        sensor_wvel_[w] = model_->sensor_adr[id(mjOBJ_SENSOR, name + "_wheel_vel", "sensor")];
        ++wheel;
      }
    }
    sensor_acc_ = model_->sensor_adr[id(mjOBJ_SENSOR, "imu_acc", "sensor")];
    sensor_gyro_ = model_->sensor_adr[id(mjOBJ_SENSOR, "imu_gyro", "sensor")];
    sensor_quat_ = model_->sensor_adr[id(mjOBJ_SENSOR, "imu_quat", "sensor")];
    key_nominal_ = id(mjOBJ_KEY, "nominal", "keyframe");
    total_mass_ = mj_getTotalmass(model_);

    const mjtNum* key_ctrl = model_->key_ctrl + key_nominal_ * model_->nu;
    for (std::size_t j = 0; j < kNumJoints; ++j) {
      nominal_command_.joint_position[static_cast<Eigen::Index>(j)] = key_ctrl[joint_ctrl_[j]];
    }
    nominal_command_.wheel_velocity.setZero();
  } catch (...) {
    mj_deleteData(data_);
    mj_deleteModel(model_);
    throw;
  }
  reset();
}

Plant::~Plant() {
  mj_deleteData(data_);
  mj_deleteModel(model_);
}

void Plant::reset(double x, double y, double yaw, double lift) {
  if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(yaw) || !std::isfinite(lift)) {
    throw std::invalid_argument("Plant::reset: x, y, yaw and lift must be finite");
  }
  mj_resetDataKeyframe(model_, data_, key_nominal_);
  data_->qpos[base_qpos_ + 0] = x;
  data_->qpos[base_qpos_ + 1] = y;
  data_->qpos[base_qpos_ + 2] += lift;
  data_->qpos[base_qpos_ + 3] = std::cos(0.5 * yaw);
  data_->qpos[base_qpos_ + 4] = 0.0;
  data_->qpos[base_qpos_ + 5] = 0.0;
  data_->qpos[base_qpos_ + 6] = std::sin(0.5 * yaw);
  setCommand(nominal_command_);
  mj_forward(model_, data_);
  updateReadings();
}

void Plant::setCommand(const PlantCommand& command) {
  // MuJoCo would zero every control on a NaN and carry on: refuse it here instead.
  const auto requireFinite = [](const auto& targets, const char* what) {
    for (Eigen::Index i = 0; i < targets.size(); ++i) {
      if (!std::isfinite(targets[i])) {
        throw std::invalid_argument(std::string("Plant::setCommand: non-finite ") + what +
                                    " target " + std::to_string(i) + " (the command is unchanged)");
      }
    }
  };
  requireFinite(command.joint_position, "joint position");
  requireFinite(command.wheel_velocity, "wheel velocity");
  command_ = command;
  for (std::size_t j = 0; j < kNumJoints; ++j) {
    data_->ctrl[joint_ctrl_[j]] = command.joint_position[static_cast<Eigen::Index>(j)];
  }
  for (std::size_t w = 0; w < kNumDriveWheels; ++w) {
    data_->ctrl[wheel_ctrl_[w]] = command.wheel_velocity[static_cast<Eigen::Index>(w)];
  }
}

void Plant::step() {
  // MuJoCo answers a non-finite or exploding state by resetting it with a warning; a
  // robot teleported back to its initial pose would be silently wrong output.
  const auto bad = [this] {
    return data_->warning[mjWARN_BADQPOS].number + data_->warning[mjWARN_BADQVEL].number +
           data_->warning[mjWARN_BADQACC].number;
  };
  const int bad0 = bad();
  for (int i = 0; i < substeps_; ++i) {
    const double t = data_->time;
    mj_step(model_, data_);
    // The reset also clears the counters, so a time running backwards is checked too.
    if (bad() != bad0 || !(data_->time > t)) {
      updateReadings();
      throw SimError("Plant::step: the simulation diverged at t = " + std::to_string(t) +
                     " s (MuJoCo found a non-finite or huge position, velocity or " +
                     "acceleration and reset the state); call reset() to continue");
    }
  }
  updateReadings();
}

double Plant::time() const { return data_->time; }

int Plant::warningCount() const {
  int n = 0;
  for (int i = 0; i < mjNWARNING; ++i) n += data_->warning[i].number;
  return n;
}

double Plant::raycast(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                      double max_range) const {
  const mjtByte terrain_only[mjNGROUP] = {1, 0, 0, 0, 0, 0};
  const mjtNum pnt[3] = {origin.x(), origin.y(), origin.z()};
  const mjtNum vec[3] = {direction.x(), direction.y(), direction.z()};
  int geom = -1;
  const double dist = mj_ray(model_, data_, pnt, vec, terrain_only, 1, -1, &geom);
  if (dist < 0.0 || dist > max_range) return -1.0;
  return dist;
}

void Plant::updateReadings() {
  const mjtNum* s = data_->sensordata;
  const mjtNum* qpos = data_->qpos;
  const mjtNum* qvel = data_->qvel;
  for (std::size_t j = 0; j < kNumJoints; ++j) {
    const auto e = static_cast<Eigen::Index>(j);
    sensors_.joint_position[e] = s[sensor_jpos_[j]];
    sensors_.joint_velocity[e] = s[sensor_jvel_[j]];
    truth_.joint_position[e] = qpos[joint_qpos_[j]];
    truth_.joint_velocity[e] = qvel[joint_qvel_[j]];
  }
  for (std::size_t w = 0; w < kNumDriveWheels; ++w) {
    const auto e = static_cast<Eigen::Index>(w);
    sensors_.wheel_position[e] = s[sensor_wpos_[w]];
    sensors_.wheel_velocity[e] = s[sensor_wvel_[w]];
    truth_.wheel_position[e] = qpos[wheel_qpos_[w]];
    truth_.wheel_velocity[e] = qvel[wheel_qvel_[w]];
  }
  sensors_.imu_acceleration =
      Eigen::Vector3d(s[sensor_acc_], s[sensor_acc_ + 1], s[sensor_acc_ + 2]);
  sensors_.imu_angular_velocity =
      Eigen::Vector3d(s[sensor_gyro_], s[sensor_gyro_ + 1], s[sensor_gyro_ + 2]);
  sensors_.imu_orientation = Eigen::Quaterniond(s[sensor_quat_], s[sensor_quat_ + 1],
                                                s[sensor_quat_ + 2], s[sensor_quat_ + 3]);
  for (std::size_t l = 0; l < kNumLegs; ++l) {
    sensors_.foot_normal_force[l] = s[sensor_touch_[l]];
    sensors_.foot_contact[l] = s[sensor_touch_[l]] > contact_threshold_;
    const mjtNum* c = data_->xpos + 3 * wheel_body_[l];
    truth_.wheel_center[l] = Eigen::Vector3d(c[0], c[1], c[2]);
    truth_.foot_contact[l] = false;
    truth_.foot_force[l].setZero();
  }

  truth_.time = data_->time;
  const mjtNum* b = qpos + base_qpos_;
  truth_.base_position = Eigen::Vector3d(b[0], b[1], b[2]);
  truth_.base_orientation = Eigen::Quaterniond(b[3], b[4], b[5], b[6]);
  const mjtNum* v = qvel + base_qvel_;
  truth_.base_linear_velocity = Eigen::Vector3d(v[0], v[1], v[2]);
  truth_.base_angular_velocity = Eigen::Vector3d(v[3], v[4], v[5]);

  // Contact forces: the normal of contact i points from geom1 to geom2, and the force
  // of mj_contactForce (contact frame) acts on geom2 (its opposite on geom1).
  for (int i = 0; i < data_->ncon; ++i) {
    const mjContact& con = data_->contact[i];
    const int leg1 = geom_leg_[static_cast<std::size_t>(con.geom1)];
    const int leg2 = geom_leg_[static_cast<std::size_t>(con.geom2)];
    if (leg1 < 0 && leg2 < 0) continue;
    mjtNum f[6];
    mj_contactForce(model_, data_, i, f);
    const Eigen::Vector3d world = f[0] * Eigen::Vector3d(con.frame[0], con.frame[1], con.frame[2]) +
                                  f[1] * Eigen::Vector3d(con.frame[3], con.frame[4], con.frame[5]) +
                                  f[2] * Eigen::Vector3d(con.frame[6], con.frame[7], con.frame[8]);
    const bool active = f[0] > 0.0;
    if (leg2 >= 0) {
      truth_.foot_force[static_cast<std::size_t>(leg2)] += world;
      truth_.foot_contact[static_cast<std::size_t>(leg2)] |= active;
    }
    if (leg1 >= 0) {
      truth_.foot_force[static_cast<std::size_t>(leg1)] -= world;
      truth_.foot_contact[static_cast<std::size_t>(leg1)] |= active;
    }
  }
}

}  // namespace rollstep::sim
