#pragma once
// A robot's URDF (control model) beside its MJCF (MuJoCo plant), for the tests that check
// they describe the same robot. The URDF side is computed directly from urdfdom (a small
// recursive forward kinematics), independent of the model layer; the MJCF side by MuJoCo.
#include <gtest/gtest.h>
#include <mujoco/mujoco.h>
#include <urdf_parser/urdf_parser.h>

#include <Eigen/Geometry>
#include <map>
#include <string>
#include <utility>

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
