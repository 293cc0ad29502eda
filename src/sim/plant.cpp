#include "rollstep/sim/plant.hpp"

#include <mujoco/mujoco.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>

#include "rollstep/centroidal/ocp_settings.hpp"
#include "rollstep/common/markup.hpp"
#include "rollstep/common/text_file.hpp"

namespace rollstep::sim {

namespace {

constexpr int kMaxSubsteps = 1000;        // physics steps per control period
constexpr double kMaxGeomRadius = 100.0;  // [m] bounding radius of a robot geom

/// A number for messages: %g (0.001, 1e+30).
std::string num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

std::string trimmed(const char* text) {
  std::string s(text);
  while (!s.empty() && (s.back() == '\n' || s.back() == ' ' || s.back() == '\r')) s.pop_back();
  return s;
}

/// MuJoCo's virtual file system (~2 MB: never on the stack), emptied on destruction.
class Vfs {
 public:
  Vfs() : vfs_(std::make_unique<mjVFS>()) { mj_defaultVFS(vfs_.get()); }
  ~Vfs() { mj_deleteVFS(vfs_.get()); }
  Vfs(const Vfs&) = delete;
  Vfs& operator=(const Vfs&) = delete;
  /// Adds a file; MuJoCo finds it by its name without directories. (MuJoCo would abort
  /// the process on an empty file or a name of mjMAXVFSNAME characters or more.)
  bool add(const std::string& name, const std::string& text) {
    if (text.empty() || name.size() >= mjMAXVFSNAME) return false;
    if (text.size() > static_cast<std::size_t>(std::numeric_limits<int>::max())) return false;
    if (mj_makeEmptyFileVFS(vfs_.get(), name.c_str(), static_cast<int>(text.size())) != 0) {
      return false;
    }
    const int index = mj_findFileVFS(vfs_.get(), name.c_str());
    if (index < 0) return false;
    if (!text.empty()) std::memcpy(vfs_->filedata[index], text.data(), text.size());
    return true;
  }
  const mjVFS* get() const { return vfs_.get(); }

 private:
  std::unique_ptr<mjVFS> vfs_;
};

/// Loads the MJCF `path` with MuJoCo, whose files are taken from `vfs` first and then from
/// the disk relative to the directory of `path` (assets, meshes, includes).
mjModel* loadXml(const std::string& path, const Vfs& vfs, std::string& error) {
  char err[1024] = "";
  mjModel* model = mj_loadXML(path.c_str(), vfs.get(), err, sizeof err);
  error = trimmed(err);
  if (model == nullptr && error.empty()) error = "cannot load the model";
  return model;
}

/// Extent [m] of geom g along world +x from its centre (exact for the primitive shapes,
/// the bounding sphere otherwise).
double geomExtentX(const mjModel* m, const mjData* d, int g) {
  const mjtNum* size = m->geom_size + 3 * g;
  const mjtNum* r = d->geom_xmat + 9 * g;  // row-major; row 0 = world x of the geom axes
  switch (m->geom_type[g]) {
    case mjGEOM_SPHERE:
      return size[0];
    case mjGEOM_CAPSULE:
      return size[0] + std::abs(r[2]) * size[1];
    case mjGEOM_CYLINDER:
      return std::abs(r[2]) * size[1] + size[0] * std::sqrt(std::max(0.0, 1.0 - r[2] * r[2]));
    case mjGEOM_ELLIPSOID:
      return std::sqrt(std::pow(r[0] * size[0], 2) + std::pow(r[1] * size[1], 2) +
                       std::pow(r[2] * size[2], 2));
    case mjGEOM_BOX:
      return std::abs(r[0]) * size[0] + std::abs(r[1]) * size[1] + std::abs(r[2]) * size[2];
    default:
      return m->geom_rbound[g];
  }
}

}  // namespace

std::string robotsDirectory() {
  if (const char* dir = std::getenv("ROLLSTEP_ROBOTS_DIR"); dir != nullptr && *dir != '\0') {
    return dir;
  }
  return ROLLSTEP_ROBOTS_DIR;
}

std::string defaultRobotFile() { return robotsDirectory() + "/tachyon3/tachyon3.xml"; }

std::string defaultRobotDescriptionFile() {
  return robotsDirectory() + "/tachyon3/centroidal.yaml";
}

std::string legNameOfContactFrame(const std::string& frame) {
  const std::string suffix = "_wheel";
  if (frame.size() > suffix.size() &&
      frame.compare(frame.size() - suffix.size(), suffix.size(), suffix) == 0) {
    return frame.substr(0, frame.size() - suffix.size());
  }
  return frame;
}

int PlantLayout::jointIndex(const std::string& name) const {
  for (std::size_t j = 0; j < joints.size(); ++j) {
    if (joints[j].name == name) return static_cast<int>(j);
  }
  return -1;
}

int PlantLayout::legOfContactFrame(const std::string& frame) const {
  for (std::size_t l = 0; l < legs.size(); ++l) {
    if (legs[l].contact_frame == frame) return static_cast<int>(l);
  }
  return -1;
}

void SensorReadings::resize(const PlantLayout& layout) {
  joint_position.setZero(layout.numJoints());
  joint_velocity.setZero(layout.numJoints());
  wheel_position.setZero(layout.numDriveWheels());
  wheel_velocity.setZero(layout.numDriveWheels());
  foot_normal_force.assign(static_cast<std::size_t>(layout.numLegs()), 0.0);
  foot_contact.assign(static_cast<std::size_t>(layout.numLegs()), false);
}

void GroundTruth::resize(const PlantLayout& layout) {
  joint_position.setZero(layout.numJoints());
  joint_velocity.setZero(layout.numJoints());
  wheel_position.setZero(layout.numDriveWheels());
  wheel_velocity.setZero(layout.numDriveWheels());
  wheel_center.assign(static_cast<std::size_t>(layout.numLegs()), Eigen::Vector3d::Zero());
  foot_contact.assign(static_cast<std::size_t>(layout.numLegs()), false);
  foot_force.assign(static_cast<std::size_t>(layout.numLegs()), Eigen::Vector3d::Zero());
  contact_point.assign(static_cast<std::size_t>(layout.numLegs()), Eigen::Vector3d::Zero());
}

Plant::Plant(const SceneConfig& scene, const PlantOptions& options)
    : scene_(scene),
      robot_file_(options.robot_file.empty() ? defaultRobotFile() : options.robot_file),
      control_period_(options.control_period),
      contact_threshold_(options.contact_threshold),
      contact_frames_(options.contact_frames),
      drive_wheels_(options.drive_wheels) {
  const std::string scene_name = sceneName();
  if (contact_frames_.empty()) {
    const std::string description = defaultRobotDescriptionFile();
    try {
      const centroidal::RobotOcpDescription d = centroidal::loadRobotOcpDescription(description);
      contact_frames_ = d.contact_frames;
      drive_wheels_ = d.drive_wheels;
    } catch (const std::exception& e) {
      throw SimError(e.what());
    }
  }
  try {
    scene_.validate();
  } catch (const std::invalid_argument& e) {
    throw SimError("scene " + scene_name + ": " + e.what());
  }
  if (!std::isfinite(control_period_) || control_period_ <= 0.0 || control_period_ > 1.0) {
    throw SimError("PlantOptions::control_period = " + num(control_period_) +
                   " s: must be in (0, 1] s and a multiple of the model's timestep");
  }
  if (!std::isfinite(contact_threshold_) || contact_threshold_ < 0.0) {
    throw SimError("PlantOptions::contact_threshold = " + num(contact_threshold_) +
                   " N: must be finite and >= 0");
  }
  const std::string what = "robot model '" + robot_file_ + "'";
  std::string robot_xml = options.robot_xml;
  if (robot_xml.empty()) {
    try {
      robot_xml = readTextFile(robot_file_, "robot model");
    } catch (const InputError& e) {
      throw SimError(e.what());
    }
  }

  // The scene is a second MJCF that includes the robot file and adds the terrain in a
  // second <worldbody> (MuJoCo merges them; the terrain inherits the robot's defaults).
  // MuJoCo parses both, so comments, CDATA and any attribute text in the robot file are
  // what XML says they are. Both files live in a virtual file system named as if they
  // were in the robot's directory, so that the robot's relative paths (meshdir, assets,
  // its own includes) resolve as when MuJoCo loads the robot file itself.
  const std::size_t slash = robot_file_.find_last_of('/');
  const std::string dir = slash == std::string::npos ? "" : robot_file_.substr(0, slash + 1);
  const std::string base = slash == std::string::npos ? robot_file_ : robot_file_.substr(slash + 1);
  if (base.empty()) throw SimError(what + ": not a file name");
  if (robot_xml.empty()) throw SimError(what + ": the file is empty");
  const std::string scene_file =
      base == "rollstep_scene.xml" ? "rollstep_scene_0.xml" : "rollstep_scene.xml";
  const std::string scene_xml = "<mujoco model=\"rollstep_scene\">\n  <include file=\"" +
                                escapeMarkup(base) + "\"/>\n  <worldbody>\n" + terrainMjcf(scene_) +
                                "  </worldbody>\n</mujoco>\n";
  Vfs vfs;
  if (!vfs.add(base, robot_xml) || !vfs.add(scene_file, scene_xml)) {
    throw SimError(what + ": cannot place the model in MuJoCo's virtual file system");
  }

  // 1. The robot alone, so that MuJoCo's errors refer to the robot file itself.
  std::string error;
  if (mjModel* alone = loadXml(dir + base, vfs, error); alone != nullptr) {
    mj_deleteModel(alone);
  } else {
    throw SimError(what + ": MuJoCo: " + error);
  }
  // 2. The scene.
  model_ = loadXml(dir + scene_file, vfs, error);
  if (model_ == nullptr) {
    throw SimError("scene " + scene_name + " with " + what + ": MuJoCo: " + error);
  }

  // Everything below may throw: free MuJoCo memory on the way out.
  try {
    checkStructure();
    if (options.sensor_noise) {
      sensor_model_ =
          std::make_unique<SensorModel>(*options.sensor_noise, control_period_, layout_);
    }
    // mjData holds the stack of nstack numbers; MuJoCo aborts the process when an
    // allocation fails, so a model asking for absurd sizes is refused here.
    constexpr double kMaxDataBytes = 2e9;
    if (static_cast<double>(model_->nstack) * sizeof(mjtNum) + model_->nbuffer > kMaxDataBytes) {
      throw SimError(what + ": the model needs " +
                     num(static_cast<double>(model_->nstack) * sizeof(mjtNum) * 1e-6) +
                     " MB of simulation data (<size nstack=...>); the limit is 2000 MB");
    }
    data_ = mj_makeData(model_);
    if (data_ == nullptr) throw SimError(what + ": MuJoCo could not allocate its data");
    reset();
    // Each leg's first joint in the base frame at the nominal posture.
    const Eigen::Map<const Eigen::Vector3d> base_x(data_->xpos + 3 * base_body_);
    const Eigen::Quaterniond base_q(data_->xquat[4 * base_body_], data_->xquat[4 * base_body_ + 1],
                                    data_->xquat[4 * base_body_ + 2],
                                    data_->xquat[4 * base_body_ + 3]);
    for (const PlantLayout::Leg& leg : layout_.legs) {
      const int body =
          leg.joints.empty()
              ? wheel_body_[static_cast<std::size_t>(layout_.legOfContactFrame(leg.contact_frame))]
              : model_->jnt_bodyid[mj_name2id(
                    model_, mjOBJ_JOINT,
                    layout_.joints[static_cast<std::size_t>(leg.joints.front())].name.c_str())];
      const bool child_of_base = model_->body_parentid[body] == base_body_;
      hip_position_.push_back(
          child_of_base
              ? Eigen::Vector3d(model_->body_pos[3 * body], model_->body_pos[3 * body + 1],
                                model_->body_pos[3 * body + 2])
              : Eigen::Vector3d(
                    base_q.conjugate() *
                    (Eigen::Map<const Eigen::Vector3d>(data_->xpos + 3 * body) - base_x)));
    }
    checkStartPosition();
  } catch (...) {
    mj_deleteData(data_);
    mj_deleteModel(model_);
    throw;
  }
}

void Plant::checkStructure() {
  const std::string what = "robot model '" + robot_file_ + "'";
  const auto fail = [&](const std::string& problem) { throw SimError(what + ": " + problem); };
  const auto id = [&](int type, const std::string& name, const char* kind) {
    const int i = mj_name2id(model_, type, name.c_str());
    if (i < 0) fail(std::string("no ") + kind + " named '" + name + "'");
    return i;
  };
  const auto nameOf = [&](int type, int i) {
    const char* name = mj_id2name(model_, type, i);
    return name != nullptr ? "'" + std::string(name) + "'" : "#" + std::to_string(i);
  };
  // The one actuator driving joint j.
  const auto actuatorOf = [&](int j) {
    int found = -1;
    for (int a = 0; a < model_->nu; ++a) {
      if (model_->actuator_trntype[a] != mjTRN_JOINT || model_->actuator_trnid[2 * a] != j) {
        continue;
      }
      if (found >= 0) {
        fail("joint " + nameOf(mjOBJ_JOINT, j) + " has two actuators, " +
             nameOf(mjOBJ_ACTUATOR, found) + " and " + nameOf(mjOBJ_ACTUATOR, a));
      }
      found = a;
    }
    if (found < 0) fail("joint " + nameOf(mjOBJ_JOINT, j) + " has no actuator");
    return found;
  };
  // The address of the one sensor of `type` (dimension `dim`) on object `object` (any
  // object when -1; for touch sensors, a site of body `body`).
  const auto sensorOf = [&](int type, int dim, int object, int body, const std::string& of) {
    int found = -1;
    for (int s = 0; s < model_->nsensor; ++s) {
      if (model_->sensor_type[s] != type) continue;
      if (object >= 0 && model_->sensor_objid[s] != object) continue;
      if (body >= 0 && model_->site_bodyid[model_->sensor_objid[s]] != body) continue;
      if (model_->sensor_dim[s] != dim) fail("sensor " + nameOf(mjOBJ_SENSOR, s) + " of " + of);
      if (found >= 0) {
        fail("two sensors of the same kind for " + of + ": " + nameOf(mjOBJ_SENSOR, found) +
             " and " + nameOf(mjOBJ_SENSOR, s));
      }
      found = s;
    }
    if (found < 0) fail("no sensor for " + of);
    return model_->sensor_adr[found];
  };

  const double ts = model_->opt.timestep;
  substeps_ = static_cast<int>(std::lround(control_period_ / ts));
  if (!(ts > 0.0) || substeps_ < 1 || std::abs(substeps_ * ts - control_period_) > 1e-12) {
    fail("timestep " + num(ts) + " s does not divide the control period " + num(control_period_) +
         " s");
  }
  if (substeps_ > kMaxSubsteps) {
    fail("timestep " + num(ts) + " s is too small: " + std::to_string(substeps_) +
         " physics steps per control period of " + num(control_period_) + " s; valid range: 1 to " +
         std::to_string(kMaxSubsteps));
  }
  const int base_body = id(mjOBJ_BODY, "base", "body");
  if (model_->body_jntnum[base_body] != 1 ||
      model_->jnt_type[model_->body_jntadr[base_body]] != mjJNT_FREE) {
    fail("body 'base' needs one free joint");
  }
  base_body_ = base_body;
  base_qpos_ = model_->jnt_qposadr[model_->body_jntadr[base_body]];
  base_qvel_ = model_->jnt_dofadr[model_->body_jntadr[base_body]];
  geom_leg_.assign(static_cast<std::size_t>(model_->ngeom), -1);

  // The layout: legs in contact-frame order, each leg's joints from the base down.
  layout_ = PlantLayout{};
  if (contact_frames_.empty()) fail("the robot description lists no contact frames");
  std::vector<int> joint_ids;
  for (const std::string& frame : contact_frames_) {
    const int leg = layout_.numLegs();
    PlantLayout::Leg l;
    l.name = legNameOfContactFrame(frame);
    l.contact_frame = frame;
    const int wheel_body = mj_name2id(model_, mjOBJ_BODY, frame.c_str());
    if (wheel_body < 0) fail("no body named '" + frame + "' (a contact frame of the robot)");
    std::vector<int> chain;  // bodies from the wheel's parent up to the base's child
    for (int b = model_->body_parentid[wheel_body]; b != base_body; b = model_->body_parentid[b]) {
      if (b == 0) fail("body '" + frame + "' (a contact frame) is not below body 'base'");
      chain.push_back(b);
    }
    for (auto b = chain.rbegin(); b != chain.rend(); ++b) {
      for (int k = 0; k < model_->body_jntnum[*b]; ++k) {
        const int j = model_->body_jntadr[*b] + k;
        if (model_->jnt_type[j] != mjJNT_HINGE && model_->jnt_type[j] != mjJNT_SLIDE) {
          fail("joint " + nameOf(mjOBJ_JOINT, j) + " of leg '" + frame +
               "' must be a hinge or a slide joint");
        }
        const char* name = mj_id2name(model_, mjOBJ_JOINT, j);
        if (name == nullptr)
          fail("joint #" + std::to_string(j) + " of leg '" + frame + "' has no name");
        l.joints.push_back(layout_.numJoints());
        layout_.joints.push_back({name, model_->jnt_type[j] == mjJNT_SLIDE, leg});
        joint_ids.push_back(j);
      }
    }
    if (std::find(drive_wheels_.begin(), drive_wheels_.end(), frame) != drive_wheels_.end()) {
      l.drive_wheel = layout_.numDriveWheels();
      layout_.drive_wheel_legs.push_back(leg);
    }
    layout_.legs.push_back(std::move(l));
    wheel_body_.push_back(wheel_body);
  }
  for (const std::string& wheel : drive_wheels_) {
    if (layout_.legOfContactFrame(wheel) < 0) {
      fail("drive wheel '" + wheel + "' is not a contact frame of the robot description");
    }
  }

  const std::size_t nj = joint_ids.size();
  joint_qpos_.resize(nj);
  joint_qvel_.resize(nj);
  joint_ctrl_.resize(nj);
  sensor_jpos_.resize(nj);
  sensor_jvel_.resize(nj);
  for (std::size_t j = 0; j < nj; ++j) {
    const int jid = joint_ids[j];
    const std::string of = "joint '" + layout_.joints[j].name + "'";
    joint_qpos_[j] = model_->jnt_qposadr[jid];
    joint_qvel_[j] = model_->jnt_dofadr[jid];
    joint_ctrl_[j] = actuatorOf(jid);
    sensor_jpos_[j] = sensorOf(mjSENS_JOINTPOS, 1, jid, -1, "jointpos of " + of);
    sensor_jvel_[j] = sensorOf(mjSENS_JOINTVEL, 1, jid, -1, "jointvel of " + of);
  }

  wheel_speed_limit_ = std::numeric_limits<double>::infinity();
  for (int leg = 0; leg < layout_.numLegs(); ++leg) {
    const auto l = static_cast<std::size_t>(leg);
    const std::string& frame = layout_.legs[l].contact_frame;
    const int body = wheel_body_[l];
    int geom = -1;
    for (int g = model_->body_geomadr[body];
         g < model_->body_geomadr[body] + model_->body_geomnum[body]; ++g) {
      if (model_->geom_type[g] != mjGEOM_SPHERE) continue;
      if (geom >= 0) fail("body '" + frame + "' (a wheel) has two sphere geoms");
      geom = g;
    }
    if (geom < 0) fail("body '" + frame + "' (a wheel) needs a sphere geom, the wheel");
    wheel_geom_.push_back(geom);
    wheel_radius_.push_back(model_->geom_size[3 * geom]);
    geom_leg_[static_cast<std::size_t>(geom)] = leg;
    sensor_touch_.push_back(
        sensorOf(mjSENS_TOUCH, 1, -1, body, "touch on a site of body '" + frame + "'"));
    if (layout_.legs[l].drive_wheel < 0) continue;
    if (model_->body_jntnum[body] != 1 ||
        model_->jnt_type[model_->body_jntadr[body]] != mjJNT_HINGE) {
      fail("body '" + frame + "' (a drive wheel) needs one hinge joint, its axle");
    }
    const int jid = model_->body_jntadr[body];
    const std::string of = "drive wheel joint " + nameOf(mjOBJ_JOINT, jid);
    wheel_qpos_.push_back(model_->jnt_qposadr[jid]);
    wheel_qvel_.push_back(model_->jnt_dofadr[jid]);
    const int ctrl = actuatorOf(jid);
    wheel_ctrl_.push_back(ctrl);
    if (model_->actuator_ctrllimited[ctrl]) {
      const mjtNum* range = model_->actuator_ctrlrange + 2 * ctrl;
      wheel_speed_limit_ =
          std::min(wheel_speed_limit_, std::min(std::abs(range[0]), std::abs(range[1])));
    }
    sensor_wpos_.push_back(sensorOf(mjSENS_JOINTPOS, 1, jid, -1, "jointpos of " + of));
    sensor_wvel_.push_back(sensorOf(mjSENS_JOINTVEL, 1, jid, -1, "jointvel of " + of));
  }
  sensor_acc_ = sensorOf(mjSENS_ACCELEROMETER, 3, -1, -1, "the IMU's accelerometer");
  sensor_gyro_ = sensorOf(mjSENS_GYRO, 3, -1, -1, "the IMU's gyro");
  sensor_quat_ = sensorOf(mjSENS_FRAMEQUAT, 4, -1, -1, "the IMU's orientation (framequat)");
  key_nominal_ = id(mjOBJ_KEY, "nominal", "keyframe");
  total_mass_ = mj_getTotalmass(model_);

  const auto allFinite = [](const mjtNum* v, int n) {
    return std::all_of(v, v + n, [](mjtNum x) { return std::isfinite(x); });
  };
  if (!allFinite(model_->key_qpos + key_nominal_ * model_->nq, model_->nq) ||
      !allFinite(model_->key_qvel + key_nominal_ * model_->nv, model_->nv) ||
      !allFinite(model_->key_ctrl + key_nominal_ * model_->nu, model_->nu)) {
    fail("keyframe 'nominal' holds a non-finite qpos, qvel or ctrl");
  }
  if (!std::isfinite(total_mass_) || !(total_mass_ > 0.0)) {
    fail("total mass " + num(total_mass_) + " kg: must be finite and positive");
  }
  // Robot geoms beyond this size break collision detection (and are no robot).
  for (int g = 0; g < model_->ngeom; ++g) {
    if (model_->geom_bodyid[g] == 0) continue;
    if (!allFinite(model_->geom_size + 3 * g, 3) || !(model_->geom_rbound[g] <= kMaxGeomRadius)) {
      const char* name = mj_id2name(model_, mjOBJ_GEOM, g);
      fail("geom " + (name ? "'" + std::string(name) + "'" : "#" + std::to_string(g)) +
           " has a bounding radius of " + num(model_->geom_rbound[g]) + " m; valid range: up to " +
           num(kMaxGeomRadius) + " m");
    }
  }
  const mjtNum* key_ctrl = model_->key_ctrl + key_nominal_ * model_->nu;
  nominal_command_.joint_position.resize(layout_.numJoints());
  for (std::size_t j = 0; j < nj; ++j) {
    nominal_command_.joint_position[static_cast<Eigen::Index>(j)] = key_ctrl[joint_ctrl_[j]];
  }
  nominal_command_.wheel_velocity.setZero(layout_.numDriveWheels());
  command_ = nominal_command_;
  sensors_.resize(layout_);
  truth_.resize(layout_);
  contact_weight_.assign(static_cast<std::size_t>(layout_.numLegs()), 0.0);
}

void Plant::checkStartPosition() {
  // The nominal pose must be a real place (a finite keyframe can still put a body at
  // 1e300 m).
  for (int b = 1; b < model_->nbody; ++b) {
    const mjtNum* x = data_->xpos + 3 * b;
    if (!std::isfinite(x[0]) || !std::isfinite(x[1]) || !std::isfinite(x[2]) ||
        std::abs(x[0]) + std::abs(x[1]) + std::abs(x[2]) > 1e3) {
      const char* name = mj_id2name(model_, mjOBJ_BODY, b);
      throw SimError("robot model '" + robot_file_ + "': body " +
                     (name ? "'" + std::string(name) + "'" : "#" + std::to_string(b)) +
                     " is not within 1 km of the origin at the nominal pose");
    }
  }
  // Front of the robot at the nominal pose, base at x = 0: the largest world x of its
  // geoms (the world body's geoms are the terrain).
  front_extent_ = -std::numeric_limits<double>::infinity();
  for (int g = 0; g < model_->ngeom; ++g) {
    if (model_->geom_bodyid[g] == 0) continue;
    front_extent_ =
        std::max(front_extent_, data_->geom_xpos[3 * g] + geomExtentX(model_, data_, g));
  }
  if (!std::isfinite(front_extent_)) front_extent_ = 0.0;
  const SceneGeometry geometry = resolveScene(scene_);
  const double min_start_x = minStartX();
  if (const SceneSolid* solid = solidAtStart(geometry, min_start_x); solid != nullptr) {
    char text[1024];
    std::snprintf(
        text, sizeof text,
        "scene %s: %s reaches inside, under or against the robot '%s' (its front is "
        "at x = %.3f m at the nominal pose); for this robot, nothing may reach into "
        "|x|, |y| < %.3f m around the start (%.2f m clearance; in step20 and stairs2: start_x >= "
        "%.3f m)",
        sceneName().c_str(), solid->label.c_str(), robot_file_.c_str(), front_extent_, min_start_x,
        kStartClearance, min_start_x);
    throw SimError(text);
  }
}

std::string Plant::sceneName() const {
  return scene_.name + (scene_.source.empty() ? "" : " of " + scene_.source);
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
  if (sensor_model_) sensor_model_->reset();
  updateReadings();
  truth_.body_contact_periods = 0;
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
  if (command.joint_position.size() != layout_.numJoints() ||
      command.wheel_velocity.size() != layout_.numDriveWheels()) {
    throw std::invalid_argument(
        "Plant::setCommand: " + std::to_string(command.joint_position.size()) + " joint and " +
        std::to_string(command.wheel_velocity.size()) + " wheel targets; the robot has " +
        std::to_string(layout_.numJoints()) + " joints and " +
        std::to_string(layout_.numDriveWheels()) + " drive wheels (the command is unchanged)");
  }
  requireFinite(command.joint_position, "joint position");
  requireFinite(command.wheel_velocity, "wheel velocity");
  command_ = command;
  for (std::size_t j = 0; j < joint_ctrl_.size(); ++j) {
    data_->ctrl[joint_ctrl_[j]] = command.joint_position[static_cast<Eigen::Index>(j)];
  }
  for (std::size_t w = 0; w < wheel_ctrl_.size(); ++w) {
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
      if (truth_.body_contact) ++truth_.body_contact_periods;
      throw SimError("Plant::step: the simulation diverged at t = " + num(t) +
                     " s (MuJoCo found a non-finite or huge position, velocity or " +
                     "acceleration and reset the state); call reset() to continue");
    }
  }
  updateReadings();
  if (truth_.body_contact) ++truth_.body_contact_periods;
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
  for (std::size_t j = 0; j < joint_qpos_.size(); ++j) {
    const auto e = static_cast<Eigen::Index>(j);
    sensors_.joint_position[e] = s[sensor_jpos_[j]];
    sensors_.joint_velocity[e] = s[sensor_jvel_[j]];
    truth_.joint_position[e] = qpos[joint_qpos_[j]];
    truth_.joint_velocity[e] = qvel[joint_qvel_[j]];
  }
  for (std::size_t w = 0; w < wheel_qpos_.size(); ++w) {
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
  for (std::size_t l = 0; l < wheel_body_.size(); ++l) {
    sensors_.foot_normal_force[l] = s[sensor_touch_[l]];
    sensors_.foot_contact[l] = s[sensor_touch_[l]] > contact_threshold_;
    const mjtNum* c = data_->xpos + 3 * wheel_body_[l];
    truth_.wheel_center[l] = Eigen::Vector3d(c[0], c[1], c[2]);
    truth_.foot_contact[l] = false;
    truth_.foot_force[l].setZero();
    truth_.contact_point[l].setZero();
    contact_weight_[l] = 0.0;
  }
  truth_.body_contact = false;

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
    if (leg1 < 0 && leg2 < 0) {
      // Robot geoms collide only with the terrain: a contact without a wheel is the body.
      truth_.body_contact = true;
      continue;
    }
    mjtNum f[6];
    mj_contactForce(model_, data_, i, f);
    const Eigen::Vector3d world = f[0] * Eigen::Vector3d(con.frame[0], con.frame[1], con.frame[2]) +
                                  f[1] * Eigen::Vector3d(con.frame[3], con.frame[4], con.frame[5]) +
                                  f[2] * Eigen::Vector3d(con.frame[6], con.frame[7], con.frame[8]);
    const bool active = f[0] > 0.0;
    const Eigen::Vector3d point(con.pos[0], con.pos[1], con.pos[2]);
    const auto push = [&](int leg, const Eigen::Vector3d& force) {
      const auto l = static_cast<std::size_t>(leg);
      truth_.foot_force[l] += force;
      if (!active) return;
      truth_.foot_contact[l] = true;
      truth_.contact_point[l] += f[0] * point;
      contact_weight_[l] += f[0];
    };
    if (leg2 >= 0) push(leg2, world);
    if (leg1 >= 0) push(leg1, -world);
  }
  for (std::size_t l = 0; l < wheel_body_.size(); ++l) {
    if (contact_weight_[l] > 0.0) {
      truth_.contact_point[l] /= contact_weight_[l];
    } else {
      truth_.contact_point[l] = truth_.wheel_center[l];
    }
  }
  if (sensor_model_) sensor_model_->apply(sensors_);
}

}  // namespace rollstep::sim
