#include <gtest/gtest.h>

#include "model_test_utils.hpp"

namespace rollstep::model {
namespace {

TEST(Loader, Tachyon3Structure) {
  const Model m =
      buildModelFromUrdfFile(std::string(ROLLSTEP_ROBOTS_DIR) + "/tachyon3/tachyon3.urdf");
  EXPECT_EQ(m.nq, 19);
  EXPECT_EQ(m.nv, 18);
  EXPECT_EQ(m.nj, 12);
  EXPECT_EQ(m.nbodies(), 13);  // base + 6 x (hip, shank); wheels merged into shanks
  EXPECT_EQ(m.nframes(), 25);  // one per link
  EXPECT_NEAR(m.totalMass, 40.0 + 4 * (1.5 + 1.2 + 0.8) + 2 * (1.5 + 1.2 + 0.5), 1e-12);
  EXPECT_EQ(m.jointNames[0], "LF_hip");
  EXPECT_EQ(m.jointNames[1], "LF_knee");
  EXPECT_NEAR(m.lowerPositionLimit[0], -0.785398163397, 1e-12);
  EXPECT_NEAR(m.upperPositionLimit[1], 0.36, 1e-12);
  EXPECT_NEAR(m.effortLimit[1], 1200.0, 1e-12);
  // LF_shank carries the wheel (0.8 kg at z = -0.1): merged com and mass.
  const Body& shank = m.bodies[static_cast<std::size_t>(m.frames[m.getFrameId("LF_shank")].body)];
  EXPECT_EQ(shank.name, "LF_shank");
  EXPECT_NEAR(shank.mass, 2.0, 1e-12);
  EXPECT_NEAR(shank.com.z(), (1.2 * -0.05 + 0.8 * -0.1) / 2.0, 1e-12);
  EXPECT_EQ(shank.type, JointType::Prismatic);
  // Parallel axis theorem for the merged x inertia.
  const double ixx = 0.0010675 + 0.001291666667 + 1.2 * std::pow(-0.05 - shank.com.z(), 2) +
                     0.8 * std::pow(-0.1 - shank.com.z(), 2);
  EXPECT_NEAR(shank.inertia(0, 0), ixx, 1e-12);
  const Frame& contact = m.frames[static_cast<std::size_t>(m.getFrameId("LF_contact"))];
  EXPECT_EQ(contact.body, m.frames[m.getFrameId("LF_shank")].body);
  EXPECT_NEAR(contact.translation.z(), -0.175, 1e-12);
  EXPECT_THROW(m.getFrameId("nope"), std::out_of_range);

  // Neutral posture: contact point below the hip.
  Data d(m);
  const Eigen::VectorXd q = neutralConfiguration(m);
  forwardKinematics(m, d, q);
  updateFramePlacements(m, d);
  EXPECT_TRUE(d.opf[m.getFrameId("LF_contact")].isApprox(Eigen::Vector3d(0.33, 0.22, -0.325)));
  // Knee (prismatic along -z of the hip link) extends the leg; the hip pitches about +y.
  Eigen::VectorXd q2 = q;
  q2[7 + m.getJointId("LF_knee")] = 0.1;
  q2[7 + m.getJointId("LF_hip")] = 0.5;
  forwardKinematics(m, d, q2);
  updateFramePlacements(m, d);
  const double l = 0.1 + 0.1 + 0.1 + 0.075;  // hip to contact
  EXPECT_TRUE(d.opf[m.getFrameId("LF_contact")].isApprox(
      Eigen::Vector3d(0.33 - l * std::sin(0.5), 0.22, -0.05 - l * std::cos(0.5)), 1e-12));
}

TEST(Loader, FixedRoot) {
  const Model m =
      buildModelFromUrdfFile(std::string(ROLLSTEP_TEST_DATA_DIR) + "/arm7.urdf", RootJoint::Fixed);
  EXPECT_EQ(m.nq, 7);
  EXPECT_EQ(m.nv, 7);
  EXPECT_EQ(m.nvBase, 0);
  EXPECT_FALSE(std::isfinite(m.upperPositionLimit[6]));  // continuous joint
  const Model f = buildModelFromUrdfFile(std::string(ROLLSTEP_TEST_DATA_DIR) + "/arm7.urdf");
  EXPECT_EQ(f.nq, 14);
  EXPECT_EQ(f.nv, 13);
}

std::string robotXml(const std::string& body) {
  return "<?xml version=\"1.0\"?><robot name=\"bad\">" + body + "</robot>";
}
const char* kLink =
    "<link name=\"a\"><inertial><mass value=\"1\"/>"
    "<inertia ixx=\"1\" ixy=\"0\" ixz=\"0\" iyy=\"1\" iyz=\"0\" izz=\"1\"/></inertial></link>";

void expectError(const std::string& xml, const std::string& needle) {
  try {
    buildModelFromUrdfString(xml);
    ADD_FAILURE() << "accepted a bad URDF; expected an error naming '" << needle << "'";
  } catch (const ModelError& e) {
    EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
  }
}

TEST(Loader, RejectsBadUrdf) {
  const std::string b =
      "<link name=\"b\"><inertial><mass value=\"1\"/>"
      "<inertia ixx=\"1\" ixy=\"0\" ixz=\"0\" iyy=\"1\" iyz=\"0\" izz=\"1\"/></inertial></link>";
  const std::string c =
      "<link name=\"c\"><inertial><mass value=\"1\"/>"
      "<inertia ixx=\"1\" ixy=\"0\" ixz=\"0\" iyy=\"1\" iyz=\"0\" izz=\"1\"/></inertial></link>";
  auto joint = [](const std::string& name, const std::string& type, const std::string& parent,
                  const std::string& child) {
    return "<joint name=\"" + name + "\" type=\"" + type + "\"><parent link=\"" + parent +
           "\"/><child link=\"" + child +
           "\"/><axis xyz=\"0 0 1\"/><limit lower=\"-1\" upper=\"1\" effort=\"1\" "
           "velocity=\"1\"/></joint>";
  };
  // Missing link.
  expectError(robotXml(kLink + joint("j1", "revolute", "a", "ghost")), "ghost");
  // Unsupported joint types.
  expectError(robotXml(kLink + b + joint("jf", "floating", "a", "b")), "jf");
  expectError(robotXml(kLink + b + joint("jp", "planar", "a", "b")), "jp");
  // Zero mass, non positive definite inertia.
  expectError(robotXml(kLink +
                       std::string("<link name=\"zm\"><inertial><mass value=\"0\"/><inertia "
                                   "ixx=\"1\" ixy=\"0\" ixz=\"0\" iyy=\"1\" iyz=\"0\" "
                                   "izz=\"1\"/></inertial></link>") +
                       joint("j", "revolute", "a", "zm")),
              "zm");
  expectError(robotXml(kLink +
                       std::string("<link name=\"npd\"><inertial><mass value=\"1\"/><inertia "
                                   "ixx=\"1\" ixy=\"2\" ixz=\"0\" iyy=\"1\" iyz=\"0\" "
                                   "izz=\"1\"/></inertial></link>") +
                       joint("j", "revolute", "a", "npd")),
              "npd");
  // Loop: c is the child of two joints.
  expectError(robotXml(kLink + b + c + joint("j1", "revolute", "a", "b") +
                       joint("j2", "revolute", "b", "c") + joint("j3", "revolute", "a", "c")),
              "'c'");
  // Two roots.
  expectError(robotXml(kLink + b), "root");
  // A link in a cycle detached from the root.
  expectError(robotXml(kLink + b + c + joint("j1", "revolute", "b", "c") +
                       joint("j2", "revolute", "c", "b")),
              "not connected");
  // Not XML.
  expectError("<robot", "URDF");
  // Continuous joints are accepted as revolute without limits.
  const Model m =
      buildModelFromUrdfString(robotXml(kLink + b + joint("jc", "continuous", "a", "b")));
  EXPECT_EQ(m.nj, 1);
  EXPECT_EQ(m.bodies[1].type, JointType::Revolute);
}

TEST(Loader, IntegrateDifference) {
  const Model m =
      buildModelFromUrdfFile(std::string(ROLLSTEP_ROBOTS_DIR) + "/tachyon3/tachyon3.urdf");
  std::mt19937 rng(3);
  const Eigen::VectorXd q0 = test::randomConfiguration(m, rng);
  const Eigen::VectorXd v = test::randomVector(m.nv, rng);
  Eigen::VectorXd q1(m.nq);
  integrate(m, q0, v, q1);
  Eigen::VectorXd back(m.nv);
  difference(m, q0, q1, back);
  EXPECT_TRUE(back.isApprox(v, 1e-12));
}

}  // namespace
}  // namespace rollstep::model
