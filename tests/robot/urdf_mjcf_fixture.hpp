#pragma once
// A robot's URDF (control model) beside its MJCF (MuJoCo plant), for the tests that check
// they describe the same robot. The URDF side is computed directly from urdfdom (a small
// recursive forward kinematics), independent of the model layer; the MJCF side by MuJoCo.
#include <gtest/gtest.h>
#include <mujoco/mujoco.h>
#include <urdf_parser/urdf_parser.h>

#include <Eigen/Geometry>
#include <functional>
#include <map>
#include <random>
#include <string>
#include <utility>
#include <vector>

namespace rollstep::testing {

inline Eigen::Isometry3d toIsometry(const urdf::Pose& p) {
  double x, y, z, w;
  p.rotation.getQuaternion(x, y, z, w);
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = Eigen::Quaterniond(w, x, y, z).normalized().toRotationMatrix();
  t.translation() = Eigen::Vector3d(p.position.x, p.position.y, p.position.z);
  return t;
}

inline Eigen::Vector3d toVector(const urdf::Vector3& v) { return {v.x, v.y, v.z}; }

class UrdfMjcfFixture : public ::testing::Test {
 protected:
  UrdfMjcfFixture(std::string urdf_file, std::string mjcf_file)
      : urdf_file_(std::move(urdf_file)), mjcf_file_(std::move(mjcf_file)) {}

  void SetUp() override {
    urdf_ = urdf::parseURDFFile(urdf_file_);
    ASSERT_TRUE(urdf_) << "cannot parse " << urdf_file_;
    char err[1000] = "";
    model_ = mj_loadXML(mjcf_file_.c_str(), nullptr, err, sizeof err);
    ASSERT_NE(model_, nullptr) << mjcf_file_ << ": " << err;
    data_ = mj_makeData(model_);
  }
  void TearDown() override {
    if (data_ != nullptr) mj_deleteData(data_);
    if (model_ != nullptr) mj_deleteModel(model_);
  }

  /// World placement of every URDF link at joint positions q (by joint name), base at
  /// the identity.
  void urdfForwardKinematics(const urdf::LinkConstSharedPtr& link, const Eigen::Isometry3d& pose,
                             const std::map<std::string, double>& q,
                             std::map<std::string, Eigen::Isometry3d>& out) const {
    out[link->name] = pose;
    for (const urdf::JointSharedPtr& joint : link->child_joints) {
      Eigen::Isometry3d motion = Eigen::Isometry3d::Identity();
      const auto it = q.find(joint->name);
      const double value = it == q.end() ? 0.0 : it->second;
      const Eigen::Vector3d axis = toVector(joint->axis);
      if (joint->type == urdf::Joint::REVOLUTE || joint->type == urdf::Joint::CONTINUOUS) {
        motion.linear() = Eigen::AngleAxisd(value, axis).toRotationMatrix();
      } else if (joint->type == urdf::Joint::PRISMATIC) {
        motion.translation() = value * axis;
      }
      const Eigen::Isometry3d child =
          pose * toIsometry(joint->parent_to_joint_origin_transform) * motion;
      urdfForwardKinematics(urdf_->getLink(joint->child_link_name), child, q, out);
    }
  }

  /// Each MJCF body is placed in its parent as the URDF joint origin that leads to it, and
  /// has the URDF joint's parent link as its parent (contact frames exist in the URDF only).
  void expectBodyFramesAtZero(double tolerance) const {
    for (const auto& [name, joint] : urdf_->joints_) {
      const int body = mj_name2id(model_, mjOBJ_BODY, joint->child_link_name.c_str());
      if (body < 0) continue;
      SCOPED_TRACE(name);
      const Eigen::Isometry3d origin = toIsometry(joint->parent_to_joint_origin_transform);
      EXPECT_NEAR((Eigen::Vector3d(model_->body_pos + 3 * body) - origin.translation()).norm(), 0.0,
                  tolerance);
      const mjtNum* bq = model_->body_quat + 4 * body;
      EXPECT_NEAR(Eigen::Quaterniond(bq[0], bq[1], bq[2], bq[3])
                      .angularDistance(Eigen::Quaterniond(origin.linear())),
                  0.0, tolerance);
      EXPECT_EQ(std::string(mj_id2name(model_, mjOBJ_BODY, model_->body_parentid[body])),
                joint->parent_link_name);
    }
  }

  /// Joint positions (by joint name) and the URDF links' world placements of one
  /// configuration, for a robot's own check of a leg.
  using LegCheck =
      std::function<void(const std::string& leg, const std::map<std::string, double>& q,
                         const std::map<std::string, Eigen::Isometry3d>& poses)>;

  /// At 20 random configurations (every moving URDF joint uniform inside its limits, drawn
  /// from std::mt19937(seed) in the URDF's joint order; the wheels spun: a hinge by up to
  /// 10 rad, a ball joint to a random orientation; the base at the identity) each leg's
  /// wheel centre (the body and URDF link <leg>_wheel) is where the URDF puts it, within
  /// `tolerance`; `check` adds the robot's own sanity check of each leg.
  void expectWheelCentresAgree(unsigned seed, const std::vector<std::string>& legs,
                               double tolerance, const LegCheck& check) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    for (int trial = 0; trial < 20; ++trial) {
      SCOPED_TRACE("configuration " + std::to_string(trial));
      std::map<std::string, double> q;
      mj_resetData(model_, data_);
      for (const auto& [name, joint] : urdf_->joints_) {
        if (joint->type == urdf::Joint::FIXED) continue;
        const double value =
            joint->limits->lower + unit(rng) * (joint->limits->upper - joint->limits->lower);
        q[name] = value;
        data_->qpos[model_->jnt_qposadr[mjId(mjOBJ_JOINT, name)]] = value;
      }
      // Spin the wheels too: it must not move their centres.
      for (const std::string& leg : legs) {
        const int j = mjId(mjOBJ_JOINT, leg + "_wheel");
        if (model_->jnt_type[j] == mjJNT_HINGE) {
          data_->qpos[model_->jnt_qposadr[j]] = 10.0 * unit(rng);
        } else {
          const Eigen::Quaterniond r = Eigen::Quaterniond::UnitRandom();
          mjtNum* p = data_->qpos + model_->jnt_qposadr[j];
          p[0] = r.w(), p[1] = r.x(), p[2] = r.y(), p[3] = r.z();
        }
      }
      // Base at the identity: free joint position 0, quaternion (1, 0, 0, 0).
      mjtNum* b = data_->qpos + model_->jnt_qposadr[model_->body_jntadr[mjId(mjOBJ_BODY, "base")]];
      b[0] = b[1] = b[2] = 0.0;
      b[3] = 1.0, b[4] = b[5] = b[6] = 0.0;
      mj_kinematics(model_, data_);

      std::map<std::string, Eigen::Isometry3d> poses;
      urdfForwardKinematics(urdf_->getRoot(), Eigen::Isometry3d::Identity(), q, poses);
      for (const std::string& leg : legs) {
        const Eigen::Vector3d urdf_centre = poses.at(leg + "_wheel").translation();
        const Eigen::Vector3d mj_centre(data_->xpos + 3 * mjId(mjOBJ_BODY, leg + "_wheel"));
        EXPECT_NEAR((urdf_centre - mj_centre).norm(), 0.0, tolerance) << leg;
        check(leg, q, poses);
      }
    }
  }

  int mjId(int type, const std::string& name) const {
    const int id = mj_name2id(model_, type, name.c_str());
    EXPECT_GE(id, 0) << "MJCF has no element named " << name;
    return id;
  }

  std::string urdf_file_, mjcf_file_;
  urdf::ModelInterfaceSharedPtr urdf_;
  mjModel* model_ = nullptr;
  mjData* data_ = nullptr;
};

}  // namespace rollstep::testing
