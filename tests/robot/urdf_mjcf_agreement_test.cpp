// robots/tachyon3: the URDF (control model) and the MJCF (MuJoCo plant) describe the
// same robot: total mass, every body's mass, centre of mass and inertia, body frames,
// joint types, axes, limits and efforts, and the six wheel centres at 20 random joint
// configurations, to 1e-9.
//
// The URDF side is computed here directly from urdfdom (a small recursive forward
// kinematics), independent of the model layer; the MJCF side by MuJoCo itself.
#include <gtest/gtest.h>
#include <mujoco/mujoco.h>
#include <urdf_parser/urdf_parser.h>

#include <Eigen/Geometry>
#include <array>
#include <cmath>
#include <map>
#include <random>
#include <string>
#include <tuple>

#include "urdf_mjcf_fixture.hpp"

namespace {

using rollstep::testing::toIsometry;
using rollstep::testing::toVector;

const std::string kUrdf = std::string(ROLLSTEP_ROBOTS_DIR) + "/tachyon3/tachyon3.urdf";
const std::string kMjcf = std::string(ROLLSTEP_ROBOTS_DIR) + "/tachyon3/tachyon3.xml";
constexpr double kTol = 1e-9;
const std::array<std::string, 6> kLegs{"LF", "MF", "RF", "LR", "MR", "RR"};

class RobotDescription : public rollstep::testing::UrdfMjcfFixture {
 protected:
  RobotDescription() : UrdfMjcfFixture(kUrdf, kMjcf) {}
};

TEST_F(RobotDescription, TotalMass) {
  double urdf_mass = 0.0;
  std::vector<urdf::LinkSharedPtr> links;
  urdf_->getLinks(links);
  for (const auto& link : links) {
    if (link->inertial) urdf_mass += link->inertial->mass;
  }
  EXPECT_NEAR(urdf_mass, 60.4, kTol);
  EXPECT_NEAR(mj_getTotalmass(model_), urdf_mass, kTol);
}

TEST_F(RobotDescription, EveryBodyMassComAndInertia) {
  std::vector<urdf::LinkSharedPtr> links;
  urdf_->getLinks(links);
  int compared = 0;
  for (const auto& link : links) {
    if (!link->inertial) continue;  // frames such as <leg>_contact
    SCOPED_TRACE(link->name);
    const int body = mjId(mjOBJ_BODY, link->name);
    if (body < 0) continue;
    ++compared;
    EXPECT_NEAR(model_->body_mass[body], link->inertial->mass, kTol);
    const Eigen::Isometry3d com = toIsometry(link->inertial->origin);
    const Eigen::Vector3d ipos(model_->body_ipos + 3 * body);
    EXPECT_NEAR((ipos - com.translation()).norm(), 0.0, kTol);
    // Inertia about the COM, in the body frame.
    const urdf::Inertial& in = *link->inertial;
    Eigen::Matrix3d urdf_inertia;
    urdf_inertia << in.ixx, in.ixy, in.ixz, in.ixy, in.iyy, in.iyz, in.ixz, in.iyz, in.izz;
    urdf_inertia = com.linear() * urdf_inertia * com.linear().transpose();
    const mjtNum* iq = model_->body_iquat + 4 * body;
    const Eigen::Matrix3d r = Eigen::Quaterniond(iq[0], iq[1], iq[2], iq[3]).toRotationMatrix();
    const Eigen::Matrix3d mj_inertia =
        r * Eigen::Vector3d(model_->body_inertia + 3 * body).asDiagonal() * r.transpose();
    EXPECT_NEAR((mj_inertia - urdf_inertia).norm(), 0.0, kTol) << "URDF\n"
                                                               << urdf_inertia << "\nMJCF\n"
                                                               << mj_inertia;
  }
  EXPECT_EQ(compared, 1 + 3 * 6);  // base, 6 x (hip link, shank, wheel)
  // And no MJCF body carries mass that the URDF does not have.
  EXPECT_EQ(model_->nbody, 1 + compared);  // + the world body
}

TEST_F(RobotDescription, JointTypesAxesLimitsAndEfforts) {
  int compared = 0;
  for (const auto& [name, joint] : urdf_->joints_) {
    if (joint->type == urdf::Joint::FIXED) continue;
    SCOPED_TRACE(name);
    ++compared;
    const int j = mjId(mjOBJ_JOINT, name);
    if (j < 0) continue;
    EXPECT_EQ(model_->jnt_type[j],
              joint->type == urdf::Joint::PRISMATIC ? mjJNT_SLIDE : mjJNT_HINGE);
    const Eigen::Vector3d axis(model_->jnt_axis + 3 * j);
    EXPECT_NEAR((axis - toVector(joint->axis)).norm(), 0.0, kTol);
    // The joint sits at its body's origin in both descriptions.
    EXPECT_NEAR(Eigen::Vector3d(model_->jnt_pos + 3 * j).norm(), 0.0, kTol);
    ASSERT_TRUE(joint->limits);
    EXPECT_EQ(model_->jnt_limited[j], 1);
    EXPECT_NEAR(model_->jnt_range[2 * j], joint->limits->lower, kTol);
    EXPECT_NEAR(model_->jnt_range[2 * j + 1], joint->limits->upper, kTol);
    // Its position servo: force limited to the effort, target range = joint range.
    const int a = mjId(mjOBJ_ACTUATOR, name + "_servo");
    if (a < 0) continue;
    EXPECT_EQ(model_->actuator_trnid[2 * a], j);
    EXPECT_EQ(model_->actuator_forcelimited[a], 1);
    EXPECT_NEAR(model_->actuator_forcerange[2 * a], -joint->limits->effort, kTol);
    EXPECT_NEAR(model_->actuator_forcerange[2 * a + 1], joint->limits->effort, kTol);
    EXPECT_NEAR(model_->actuator_ctrlrange[2 * a], joint->limits->lower, kTol);
    EXPECT_NEAR(model_->actuator_ctrlrange[2 * a + 1], joint->limits->upper, kTol);
  }
  EXPECT_EQ(compared, 12);
}

TEST_F(RobotDescription, ServosHaveTheSpecGains) {
  // Spec (shared robot/tachyon3.md, "Reference actuator limits"): hips kp 3000 N m/rad,
  // kd 60; knees kp 60000 N/m, kd 1500 (kd as joint damping); drive wheels velocity
  // servos, 15 N m, 25 rad/s; omni wheels passive (ball joints, no actuator).
  for (const std::string& leg : kLegs) {
    SCOPED_TRACE(leg);
    for (const auto& [joint, kp, kd] :
         {std::tuple<std::string, double, double>{leg + "_hip", 3000.0, 60.0},
          std::tuple<std::string, double, double>{leg + "_knee", 60000.0, 1500.0}}) {
      const int a = mjId(mjOBJ_ACTUATOR, joint + "_servo");
      const int j = mjId(mjOBJ_JOINT, joint);
      if (a < 0 || j < 0) continue;
      EXPECT_NEAR(model_->actuator_gainprm[a * mjNGAIN], kp, kTol);
      EXPECT_NEAR(model_->actuator_biasprm[a * mjNBIAS + 1], -kp, kTol);
      EXPECT_NEAR(model_->dof_damping[model_->jnt_dofadr[j]], kd, kTol);
    }
    const int wheel = mjId(mjOBJ_JOINT, leg + "_wheel");
    const bool drive = leg[0] != 'M';
    EXPECT_EQ(model_->jnt_type[wheel], drive ? mjJNT_HINGE : mjJNT_BALL);
    const int servo = mj_name2id(model_, mjOBJ_ACTUATOR, (leg + "_wheel_servo").c_str());
    EXPECT_EQ(servo >= 0, drive);
    if (servo >= 0) {
      EXPECT_NEAR(model_->actuator_forcerange[2 * servo + 1], 15.0, kTol);
      EXPECT_NEAR(model_->actuator_ctrlrange[2 * servo + 1], 25.0, kTol);
      EXPECT_NEAR(Eigen::Vector3d(model_->jnt_axis + 3 * wheel).y(), 1.0, kTol);
    }
  }
  EXPECT_EQ(model_->nu, 16);  // 6 hips, 6 knees, 4 drive wheels
}

TEST_F(RobotDescription, BodyFramesAtZero) {
  // Each MJCF body is placed in its parent as the URDF joint origin (plus, for the
  // wheels, the fixed mount joint).
  expectBodyFramesAtZero(kTol);
}

TEST_F(RobotDescription, WheelCentresAtTwentyRandomConfigurations) {
  expectWheelCentresAgree(20261122, {kLegs.begin(), kLegs.end()}, kTol,
                          [](const std::string& leg, const std::map<std::string, double>& q,
                             const std::map<std::string, Eigen::Isometry3d>& poses) {
                            // Sanity: hip to wheel centre distance = 0.20 m + knee.
                            const Eigen::Vector3d hip = poses.at(leg + "_hip_link").translation();
                            EXPECT_NEAR((poses.at(leg + "_wheel").translation() - hip).norm(),
                                        0.20 + q.at(leg + "_knee"), kTol)
                                << leg;
                          });
}

}  // namespace
