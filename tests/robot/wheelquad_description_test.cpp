// robots/wheelquad: the URDF (control model) and the MJCF (MuJoCo plant) describe the same
// robot (total mass, every body's mass, centre of mass and inertia, body frames, joint
// types, axes, limits and efforts, the four wheel centres at 20 random joint configurations,
// to 1e-9); the servos have the gains of wheelquad.md; the keyframe "nominal" is the OCP
// description's posture with the wheels touching; and in MuJoCo, on a flat floor under its
// position servos, the robot stands at that keyframe, rolls straight on its wheels and turns on
// the spot by skid steering.
//
// The URDF side is computed here directly from urdfdom (a small recursive forward
// kinematics), independent of the model layer; the MJCF side by MuJoCo itself.
#include <gtest/gtest.h>
#include <mujoco/mujoco.h>
#include <urdf_parser/urdf_parser.h>

#include <Eigen/Geometry>
#include <array>
#include <cmath>
#include <cstring>
#include <fstream>
#include <map>
#include <random>
#include <sstream>
#include <string>

#include "urdf_mjcf_fixture.hpp"

namespace {

using rollstep::testing::toIsometry;
using rollstep::testing::toVector;

const std::string kDir = std::string(ROLLSTEP_ROBOTS_DIR) + "/wheelquad/";
const std::string kUrdf = kDir + "wheelquad.urdf";
const std::string kMjcf = kDir + "wheelquad.xml";
constexpr double kTol = 1e-9;
const std::array<std::string, 4> kLegs{"LF", "RF", "LH", "RH"};
const std::array<std::string, 3> kJoints{"HAA", "HFE", "KFE"};
// wheelquad.md: the nominal posture, the servos, the wheels.
constexpr double kNominal[3] = {0.0, 0.8, -1.6};
constexpr double kWheelRadius = 0.085;
constexpr double kServoKp = 1500.0, kServoKd = 30.0;
constexpr double kWheelEffort = 20.0, kWheelSpeed = 30.0;

std::string readFile(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

class Wheelquad : public rollstep::testing::UrdfMjcfFixture {
 protected:
  Wheelquad() : UrdfMjcfFixture(kUrdf, kMjcf) {}
};

TEST_F(Wheelquad, TotalMass) {
  double urdf_mass = 0.0;
  std::vector<urdf::LinkSharedPtr> links;
  urdf_->getLinks(links);
  for (const auto& link : links) {
    if (link->inertial) urdf_mass += link->inertial->mass;
  }
  EXPECT_NEAR(urdf_mass, 51.6, kTol);  // wheelquad.md
  EXPECT_NEAR(mj_getTotalmass(model_), urdf_mass, kTol);
}

TEST_F(Wheelquad, EveryBodyMassComAndInertia) {
  std::vector<urdf::LinkSharedPtr> links;
  urdf_->getLinks(links);
  int compared = 0;
  for (const auto& link : links) {
    if (!link->inertial) continue;  // the <leg>_contact frames
    SCOPED_TRACE(link->name);
    const int body = mjId(mjOBJ_BODY, link->name);
    if (body < 0) continue;
    ++compared;
    EXPECT_NEAR(model_->body_mass[body], link->inertial->mass, kTol);
    const Eigen::Isometry3d com = toIsometry(link->inertial->origin);
    EXPECT_NEAR((Eigen::Vector3d(model_->body_ipos + 3 * body) - com.translation()).norm(), 0.0,
                kTol);
    const urdf::Inertial& in = *link->inertial;
    Eigen::Matrix3d urdf_inertia;
    urdf_inertia << in.ixx, in.ixy, in.ixz, in.ixy, in.iyy, in.iyz, in.ixz, in.iyz, in.izz;
    urdf_inertia = com.linear() * urdf_inertia * com.linear().transpose();
    const mjtNum* iq = model_->body_iquat + 4 * body;
    const Eigen::Matrix3d r = Eigen::Quaterniond(iq[0], iq[1], iq[2], iq[3]).toRotationMatrix();
    const Eigen::Matrix3d mj_inertia =
        r * Eigen::Vector3d(model_->body_inertia + 3 * body).asDiagonal() * r.transpose();
    EXPECT_NEAR((mj_inertia - urdf_inertia).norm(), 0.0, kTol);
  }
  EXPECT_EQ(compared, 1 + 4 * 4);          // base, 4 x (hip, thigh, shank, wheel)
  EXPECT_EQ(model_->nbody, 1 + compared);  // + the world body: no mass the URDF lacks
}

TEST_F(Wheelquad, JointsLimitsEffortsAndServos) {
  int compared = 0;
  for (const auto& [name, joint] : urdf_->joints_) {
    if (joint->type == urdf::Joint::FIXED) continue;
    SCOPED_TRACE(name);
    ++compared;
    EXPECT_EQ(joint->type, urdf::Joint::REVOLUTE);
    const int j = mjId(mjOBJ_JOINT, name);
    if (j < 0) continue;
    EXPECT_EQ(model_->jnt_type[j], mjJNT_HINGE);
    EXPECT_NEAR((Eigen::Vector3d(model_->jnt_axis + 3 * j) - toVector(joint->axis)).norm(), 0.0,
                kTol);
    EXPECT_NEAR(Eigen::Vector3d(model_->jnt_pos + 3 * j).norm(), 0.0, kTol);
    ASSERT_TRUE(joint->limits);
    EXPECT_EQ(model_->jnt_limited[j], 1);
    EXPECT_NEAR(model_->jnt_range[2 * j], joint->limits->lower, kTol);
    EXPECT_NEAR(model_->jnt_range[2 * j + 1], joint->limits->upper, kTol);
    // Its position servo: the spec's gains, force limited to the effort, target range =
    // joint range.
    const int a = mjId(mjOBJ_ACTUATOR, name + "_servo");
    if (a < 0) continue;
    EXPECT_EQ(model_->actuator_trnid[2 * a], j);
    EXPECT_NEAR(model_->actuator_gainprm[a * mjNGAIN], kServoKp, kTol);
    EXPECT_NEAR(model_->actuator_biasprm[a * mjNBIAS + 1], -kServoKp, kTol);
    EXPECT_NEAR(model_->dof_damping[model_->jnt_dofadr[j]], kServoKd, kTol);
    EXPECT_EQ(model_->actuator_forcelimited[a], 1);
    EXPECT_NEAR(model_->actuator_forcerange[2 * a], -joint->limits->effort, kTol);
    EXPECT_NEAR(model_->actuator_forcerange[2 * a + 1], joint->limits->effort, kTol);
    EXPECT_NEAR(model_->actuator_ctrlrange[2 * a], joint->limits->lower, kTol);
    EXPECT_NEAR(model_->actuator_ctrlrange[2 * a + 1], joint->limits->upper, kTol);
    for (const char* kind : {"_pos", "_vel"}) {
      const int s = mjId(mjOBJ_SENSOR, name + kind);
      if (s >= 0) {
        EXPECT_EQ(model_->sensor_objid[s], j);
      }
    }
  }
  EXPECT_EQ(compared, 12);
  // Four drive wheels: hinges about the axle with a velocity servo.
  for (const std::string& leg : kLegs) {
    SCOPED_TRACE(leg);
    const int wheel = mjId(mjOBJ_JOINT, leg + "_wheel");
    const int servo = mjId(mjOBJ_ACTUATOR, leg + "_wheel_servo");
    if (wheel < 0 || servo < 0) continue;
    EXPECT_EQ(model_->jnt_type[wheel], mjJNT_HINGE);
    EXPECT_NEAR((Eigen::Vector3d(model_->jnt_axis + 3 * wheel) - Eigen::Vector3d::UnitY()).norm(),
                0.0, kTol);
    EXPECT_EQ(model_->actuator_trnid[2 * servo], wheel);
    EXPECT_NEAR(model_->actuator_forcerange[2 * servo + 1], kWheelEffort, kTol);
    EXPECT_NEAR(model_->actuator_ctrlrange[2 * servo + 1], kWheelSpeed, kTol);
    const int geom = mjId(mjOBJ_GEOM, leg + "_wheel_geom");
    if (geom >= 0) {
      EXPECT_EQ(model_->geom_type[geom], mjGEOM_SPHERE);
      EXPECT_NEAR(model_->geom_size[3 * geom], kWheelRadius, kTol);
    }
    mjId(mjOBJ_SENSOR, leg + "_touch");
  }
  EXPECT_EQ(model_->nu, 16);  // 12 leg servos, 4 drive wheels
  for (const char* sensor : {"imu_acc", "imu_gyro", "imu_quat"}) mjId(mjOBJ_SENSOR, sensor);
}

TEST_F(Wheelquad, BodyFramesAtZero) { expectBodyFramesAtZero(kTol); }

TEST_F(Wheelquad, WheelCentresAtTwentyRandomConfigurations) {
  expectWheelCentresAgree(20261207, {kLegs.begin(), kLegs.end()}, kTol,
                          [](const std::string& leg, const std::map<std::string, double>& q,
                             const std::map<std::string, Eigen::Isometry3d>& poses) {
                            // Sanity: thigh and shank 0.30 m each, the knee angle between them.
                            const Eigen::Vector3d hfe = poses.at(leg + "_thigh").translation();
                            EXPECT_NEAR((poses.at(leg + "_wheel").translation() - hfe).norm(),
                                        2.0 * 0.3 * std::cos(0.5 * q.at(leg + "_KFE")), kTol)
                                << leg;
                          });
}

TEST_F(Wheelquad, NominalKeyframeHasTheWheelsOnTheGround) {
  const int key = mjId(mjOBJ_KEY, "nominal");
  ASSERT_GE(key, 0);
  mj_resetDataKeyframe(model_, data_, key);
  for (const std::string& leg : kLegs) {
    for (int k = 0; k < 3; ++k) {
      const std::string name = leg + "_" + kJoints[static_cast<std::size_t>(k)];
      EXPECT_EQ(data_->qpos[model_->jnt_qposadr[mjId(mjOBJ_JOINT, name)]], kNominal[k]) << name;
      EXPECT_EQ(data_->ctrl[mjId(mjOBJ_ACTUATOR, name + "_servo")], kNominal[k]) << name;
    }
  }
  mj_kinematics(model_, data_);
  for (const std::string& leg : kLegs) {
    const mjtNum* centre = data_->xpos + 3 * mjId(mjOBJ_BODY, leg + "_wheel");
    EXPECT_NEAR(centre[2] - kWheelRadius, 0.0, kTol) << leg << ": touches the ground";
    const mjtNum* hip = data_->xpos + 3 * mjId(mjOBJ_BODY, leg + "_thigh");
    EXPECT_NEAR(centre[0], hip[0], kTol) << leg << ": under its hip";
  }
}

/// MuJoCo's virtual file system, emptied on destruction (about 2 MB: on the heap).
struct Vfs {
  std::unique_ptr<mjVFS> vfs = std::make_unique<mjVFS>();
  Vfs() { mj_defaultVFS(vfs.get()); }
  ~Vfs() { mj_deleteVFS(vfs.get()); }
  Vfs(const Vfs&) = delete;
  Vfs& operator=(const Vfs&) = delete;
  bool add(const std::string& name, const std::string& text) {
    if (mj_makeEmptyFileVFS(vfs.get(), name.c_str(), static_cast<int>(text.size())) != 0) {
      return false;
    }
    const int i = mj_findFileVFS(vfs.get(), name.c_str());
    if (i < 0) return false;
    std::memcpy(vfs->filedata[i], text.data(), text.size());
    return true;
  }
};

/// The robot on a floor of friction 0.8 (the reference scenes'), at the nominal keyframe
/// (its servos' targets the nominal posture, the wheels braked).
struct OnAFloor {
  mjModel* m = nullptr;
  mjData* d = nullptr;
  OnAFloor() {
    Vfs vfs;
    const std::string scene =
        "<mujoco model=\"wheelquad_floor\">\n  <include file=\"wheelquad.xml\"/>\n"
        "  <worldbody>\n    <geom name=\"floor\" type=\"plane\" size=\"20 20 0.1\" group=\"0\" "
        "contype=\"1\" conaffinity=\"1\" friction=\"0.8 0.005 0.0001\"/>\n  </worldbody>\n"
        "</mujoco>\n";
    EXPECT_TRUE(vfs.add("wheelquad.xml", readFile(kMjcf)));
    EXPECT_TRUE(vfs.add("wheelquad_floor.xml", scene));
    char err[1000] = "";
    m = mj_loadXML((kDir + "wheelquad_floor.xml").c_str(), vfs.vfs.get(), err, sizeof err);
    EXPECT_NE(m, nullptr) << err;
    if (m == nullptr) return;
    d = mj_makeData(m);
    const int key = mj_name2id(m, mjOBJ_KEY, "nominal");
    EXPECT_GE(key, 0);
    if (key >= 0) mj_resetDataKeyframe(m, d, key);
  }
  ~OnAFloor() {
    if (d != nullptr) mj_deleteData(d);
    if (m != nullptr) mj_deleteModel(m);
  }
  OnAFloor(const OnAFloor&) = delete;
  OnAFloor& operator=(const OnAFloor&) = delete;
  Eigen::Vector3d base() const { return {d->qpos[0], d->qpos[1], d->qpos[2]}; }
  Eigen::Quaterniond attitude() const {
    return Eigen::Quaterniond(d->qpos[3], d->qpos[4], d->qpos[5], d->qpos[6]);
  }
  void setWheelSpeed(const std::string& leg, double speed) {
    d->ctrl[mj_name2id(m, mjOBJ_ACTUATOR, (leg + "_wheel_servo").c_str())] = speed;
  }
  void run(double seconds) {
    for (int step = 0; step < static_cast<int>(std::lround(seconds / m->opt.timestep)); ++step) {
      mj_step(m, d);
    }
  }
};

TEST(WheelquadInMujoco, StandsAtTheNominalKeyframeUnderItsServos) {
  // Released at the nominal keyframe: after 3 s it stands still where it started, a few
  // millimetres lower (the soft contacts and the servos' deflection under load), level,
  // every wheel loaded.
  OnAFloor f;
  ASSERT_NE(f.d, nullptr);
  mjModel* m = f.m;
  mjData* d = f.d;
  const Eigen::Vector3d start = f.base();
  f.run(3.0);

  const Eigen::Vector3d end(d->qpos[0], d->qpos[1], d->qpos[2]);
  const Eigen::Quaterniond attitude(d->qpos[3], d->qpos[4], d->qpos[5], d->qpos[6]);
  std::printf("base moved (%.4f, %.4f, %.4f) m, tilt %.3f deg\n", (end - start).x(),
              (end - start).y(), (end - start).z(),
              std::acos(std::min(1.0, (attitude * Eigen::Vector3d::UnitZ()).z())) * 180.0 / M_PI);
  EXPECT_LT((end - start).head<2>().norm(), 0.01);
  EXPECT_LT(end.z(), start.z());
  EXPECT_GT(end.z(), start.z() - 0.03);
  EXPECT_GT((attitude * Eigen::Vector3d::UnitZ()).z(), std::cos(0.02));
  Eigen::VectorXd v(m->nv);
  for (int i = 0; i < m->nv; ++i) v[i] = d->qvel[i];
  EXPECT_LT(v.lpNorm<Eigen::Infinity>(), 1e-2) << "still moving";
  // Every joint within 0.05 rad of its target; every wheel carries a share of the weight.
  for (const std::string& leg : kLegs) {
    for (int k = 0; k < 3; ++k) {
      const std::string name = leg + "_" + kJoints[static_cast<std::size_t>(k)];
      const int j = mj_name2id(m, mjOBJ_JOINT, name.c_str());
      EXPECT_NEAR(d->qpos[m->jnt_qposadr[j]], kNominal[k], 0.05) << name;
    }
    const int touch = mj_name2id(m, mjOBJ_SENSOR, (leg + "_touch").c_str());
    ASSERT_GE(touch, 0);
    const double weight = mj_getTotalmass(m) * 9.81;
    const double load = d->sensordata[m->sensor_adr[touch]];
    EXPECT_GT(load, 0.15 * weight) << leg;
    EXPECT_LT(load, 0.35 * weight) << leg;
  }
}

TEST(WheelquadInMujoco, RollsStraightAtOneMetrePerSecondOnItsWheels) {
  // The four velocity servos at 1 m/s over the wheel radius, the legs held at the nominal
  // posture: after 1 s of acceleration it rolls at about 1 m/s (a little less: a loaded
  // wheel rolls on a radius a few millimetres smaller), straight, level, on four wheels.
  OnAFloor f;
  ASSERT_NE(f.d, nullptr);
  for (const std::string& leg : kLegs) f.setWheelSpeed(leg, 1.0 / kWheelRadius);
  f.run(1.5);
  const Eigen::Vector3d start = f.base();
  f.run(1.0);
  const Eigen::Vector3d travel = f.base() - start;
  std::printf("rolled (%.4f, %.4f, %.4f) m in 1 s\n", travel.x(), travel.y(), travel.z());
  EXPECT_NEAR(travel.x(), 1.0, 0.05);
  EXPECT_LT(std::abs(travel.y()), 0.01);
  EXPECT_LT(std::abs(travel.z()), 0.005);
  EXPECT_GT((f.attitude() * Eigen::Vector3d::UnitZ()).z(), std::cos(0.02));
  for (const std::string& leg : kLegs) {
    const int touch = mj_name2id(f.m, mjOBJ_SENSOR, (leg + "_touch").c_str());
    EXPECT_GT(f.d->sensordata[f.m->sensor_adr[touch]], 0.15 * mj_getTotalmass(f.m) * 9.81) << leg;
  }
}

TEST(WheelquadInMujoco, TurnsOnTheSpotBySkidSteering) {
  // Left wheels backwards, right wheels forwards (0.3 m/s at the rim): the body turns
  // counter-clockwise about a point near its centre (the centre of mass lies 1.5 cm behind
  // it), the wheels sliding sideways. Sliding wheels realize only part of the 1.5 rad/s a
  // 0.4 m track gives without slip (measured 0.4 rad/s: an effective track about 4 times
  // the geometric one, as Tachyon 3's, config/behaviours/turn_in_place.yaml).
  OnAFloor f;
  ASSERT_NE(f.d, nullptr);
  for (const std::string& leg : kLegs)
    f.setWheelSpeed(leg, (leg[0] == 'L' ? -0.3 : 0.3) / kWheelRadius);
  f.run(3.0);
  const Eigen::Vector3d forward = f.attitude() * Eigen::Vector3d::UnitX();
  const double yaw = std::atan2(forward.y(), forward.x());
  std::printf("turned %.3f rad in 3 s, base moved %.4f m\n", yaw, f.base().head<2>().norm());
  EXPECT_GT(yaw, 0.15 * 1.5 * 3.0);
  EXPECT_LT(yaw, 0.5 * 1.5 * 3.0);
  EXPECT_LT(f.base().head<2>().norm(), 0.1);
  EXPECT_GT((f.attitude() * Eigen::Vector3d::UnitZ()).z(), std::cos(0.05));
}

}  // namespace
