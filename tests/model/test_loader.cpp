#include <gtest/gtest.h>
#include <pthread.h>
#include <sys/stat.h>
#include <unistd.h>

#include <Eigen/Geometry>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>

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

// ---------------------------------------------------------------------------------------
// Input hardening (issue 16): every class of impossible input is refused with a message
// naming the element, the value and the valid range.

std::string errorOf(const std::string& xml, RootJoint root = RootJoint::FreeFlyer) {
  try {
    buildModelFromUrdfString(xml, root);
  } catch (const ModelError& e) {
    return e.what();
  }
  return "";
}

bool has(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

/// A two-link robot (base `a`, child `b` on joint `j`) with the given pieces.
struct TwoLinks {
  std::string joint_type = "revolute";
  std::string joint_origin = "<origin xyz=\"0.1 0 0\" rpy=\"0 0 0\"/>";
  std::string axis = "0 0 1";
  std::string limit = "lower=\"-1\" upper=\"1\" velocity=\"2\" effort=\"3\"";
  std::string dynamics;
  std::string b_inertial =
      "<inertial><origin xyz=\"0 0 0.1\"/><mass value=\"1\"/>"
      "<inertia ixx=\"0.1\" ixy=\"0\" ixz=\"0\" iyy=\"0.1\" iyz=\"0\" izz=\"0.1\"/>"
      "</inertial>";
  std::string xml() const {
    return robotXml(std::string(kLink) + "<link name=\"b\">" + b_inertial +
                    "</link><joint name=\"j\" type=\"" + joint_type +
                    "\"><parent link=\"a\"/><child link=\"b\"/>" + joint_origin + "<axis xyz=\"" +
                    axis + "\"/><limit " + limit + "/>" + dynamics + "</joint>");
  }
};

std::string inertial(const std::string& mass, const std::string& ixx, const std::string& iyy,
                     const std::string& izz, const std::string& ixy = "0",
                     const std::string& ixz = "0", const std::string& iyz = "0",
                     const std::string& origin = "0 0 0") {
  return "<inertial><origin xyz=\"" + origin + "\"/><mass value=\"" + mass + "\"/><inertia ixx=\"" +
         ixx + "\" ixy=\"" + ixy + "\" ixz=\"" + ixz + "\" iyy=\"" + iyy + "\" iyz=\"" + iyz +
         "\" izz=\"" + izz + "\"/></inertial>";
}

TEST(LoaderHardening, TheReferenceTwoLinkRobotIsAccepted) {
  const Model m = buildModelFromUrdfString(TwoLinks{}.xml());
  EXPECT_EQ(m.nj, 1);
  EXPECT_EQ(m.velocityLimit[0], 2.0);
  EXPECT_EQ(m.effortLimit[0], 3.0);
}

TEST(LoaderHardening, NonFiniteAndUnreadableNumbersAreRefusedEverywhere) {
  // Every numeric attribute the model uses, with every non-finite or unreadable spelling:
  // never accepted (urdfdom itself reads some of them as 0 or drops the <inertial>).
  const std::vector<std::string> bad = {"nan", "NaN", "inf", "-inf", "1e999",
                                        "abc", "",    "1 2", "0x10"};
  const std::vector<std::function<void(TwoLinks&, const std::string&)>> places = {
      [](TwoLinks& t, const std::string& v) { t.b_inertial = inertial(v, "1", "1", "1"); },
      [](TwoLinks& t, const std::string& v) { t.b_inertial = inertial("1", v, "1", "1"); },
      [](TwoLinks& t, const std::string& v) { t.b_inertial = inertial("1", "1", v, "1"); },
      [](TwoLinks& t, const std::string& v) { t.b_inertial = inertial("1", "1", "1", v); },
      [](TwoLinks& t, const std::string& v) { t.b_inertial = inertial("1", "1", "1", "1", v); },
      [](TwoLinks& t, const std::string& v) {
        t.b_inertial = inertial("1", "1", "1", "1", "0", v);
      },
      [](TwoLinks& t, const std::string& v) {
        t.b_inertial = inertial("1", "1", "1", "1", "0", "0", v);
      },
      [](TwoLinks& t, const std::string& v) {
        t.b_inertial = inertial("1", "1", "1", "1", "0", "0", "0", v + " 0 0");
      },
      [](TwoLinks& t, const std::string& v) { t.joint_origin = "<origin xyz=\"0 " + v + " 0\"/>"; },
      [](TwoLinks& t, const std::string& v) { t.joint_origin = "<origin rpy=\"0 0 " + v + "\"/>"; },
      [](TwoLinks& t, const std::string& v) { t.axis = "0 " + v + " 1"; },
      [](TwoLinks& t, const std::string& v) {
        t.limit = "lower=\"" + v + "\" upper=\"1\" velocity=\"1\" effort=\"1\"";
      },
      [](TwoLinks& t, const std::string& v) {
        t.limit = "lower=\"-1\" upper=\"" + v + "\" velocity=\"1\" effort=\"1\"";
      },
      [](TwoLinks& t, const std::string& v) {
        t.limit = "lower=\"-1\" upper=\"1\" velocity=\"" + v + "\" effort=\"1\"";
      },
      [](TwoLinks& t, const std::string& v) {
        t.limit = "lower=\"-1\" upper=\"1\" velocity=\"1\" effort=\"" + v + "\"";
      },
      [](TwoLinks& t, const std::string& v) {
        t.dynamics = "<dynamics damping=\"" + v + "\" friction=\"0\"/>";
      },
  };
  for (std::size_t p = 0; p < places.size(); ++p) {
    for (const std::string& v : bad) {
      if (v.empty() && (p == 8 || p == 9 || p == 10)) continue;  // "0  0": a 2-vector, refused
      TwoLinks t;
      places[p](t, v);
      const std::string e = errorOf(t.xml());
      EXPECT_FALSE(e.empty()) << "place " << p << " value '" << v << "' accepted";
    }
  }
  // The messages name the element and the text found.
  TwoLinks t;
  t.b_inertial = inertial("nan", "1", "1", "1");
  std::string e = errorOf(t.xml());
  EXPECT_TRUE(has(e, "link 'b'") && has(e, "mass value=\"nan\"") && has(e, "(0, 100000]")) << e;
  t.b_inertial = inertial("1", "1", "1", "1", "1e999");
  e = errorOf(t.xml());
  EXPECT_TRUE(has(e, "link 'b'") && has(e, "ixy=\"1e999\"")) << e;
}

TEST(LoaderHardening, ImpossibleMassesAreRefusedWithTheirValue) {
  for (const std::string mass : {"0", "-0", "-1", "-1e-300", "1e6", "2e5"}) {
    TwoLinks t;
    t.b_inertial = inertial(mass, "1", "1", "1");
    const std::string e = errorOf(t.xml());
    EXPECT_TRUE(has(e, "link 'b'") && has(e, "\"" + mass + "\"") && has(e, "(0, 100000] kg"))
        << mass << " -> " << e;
  }
  TwoLinks t;
  t.b_inertial = inertial("1e5", "1", "1", "1");
  EXPECT_EQ(errorOf(t.xml()), "");
}

/// An inertia tensor with the given principal moments in a rotated frame.
Eigen::Matrix3d rotatedInertia(const Eigen::Vector3d& moments, std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  const Eigen::Matrix3d R =
      Eigen::Quaterniond(n(rng), n(rng), n(rng), n(rng)).normalized().toRotationMatrix();
  return R * moments.asDiagonal() * R.transpose();
}

std::string inertialOf(const Eigen::Matrix3d& I) {
  const auto s = [](double v) {
    char buf[40];
    std::snprintf(buf, sizeof buf, "%.17g", v);
    return std::string(buf);
  };
  return inertial("1", s(I(0, 0)), s(I(1, 1)), s(I(2, 2)), s(I(0, 1)), s(I(0, 2)), s(I(1, 2)));
}

TEST(LoaderHardening, InertiaMustBeRealisableInAnyFrame) {
  std::mt19937 rng(16);
  // Principal moments that no rigid body has, seen in random frames: refused.
  const std::vector<Eigen::Vector3d> impossible = {
      {1.0, 1.0, 3.0},     // A + B < C
      {0.1, 0.2, 0.31},    // just beyond
      {-0.1, 1.0, 1.0},    // negative moment
      {0.0, 0.0, 1.0},     // 0 + 0 < 1
      {-1.0, -1.0, -1.0},  // negative definite
  };
  for (const Eigen::Vector3d& m : impossible) {
    for (int k = 0; k < 5; ++k) {
      TwoLinks t;
      t.b_inertial = inertialOf(rotatedInertia(m, rng));
      const std::string e = errorOf(t.xml());
      EXPECT_TRUE(has(e, "link 'b'") && has(e, "principal moments")) << m.transpose() << ": " << e;
    }
  }
  // Physically possible ones, the limiting cases included (thin rod, thin disc, point mass).
  const std::vector<Eigen::Vector3d> possible = {
      {1.0, 2.0, 2.5}, {0.0, 1.0, 1.0}, {0.5, 0.5, 1.0}, {0.0, 0.0, 0.0}, {1e-9, 1e-9, 1e-9}};
  for (const Eigen::Vector3d& m : possible) {
    for (int k = 0; k < 5; ++k) {
      TwoLinks t;
      t.b_inertial = inertialOf(rotatedInertia(m, rng));
      EXPECT_EQ(errorOf(t.xml()), "") << m.transpose();
    }
  }
  // Readable message for a diagonal violation.
  TwoLinks t;
  t.b_inertial = inertial("1", "1", "1", "3");
  const std::string e = errorOf(t.xml());
  EXPECT_TRUE(has(e, "triangle inequality") && has(e, "(1, 1, 3)")) << e;
  // Absurd magnitudes.
  t.b_inertial = inertial("1", "1e6", "1e6", "1e6");
  EXPECT_TRUE(has(errorOf(t.xml()), "within 100000 kg m^2"));
}

TEST(LoaderHardening, JointNumbersMustBePossible) {
  struct Case {
    std::function<void(TwoLinks&)> edit;
    std::vector<std::string> needles;
  };
  const std::vector<Case> cases = {
      {[](TwoLinks& t) { t.limit = "lower=\"1\" upper=\"-1\" velocity=\"1\" effort=\"1\""; },
       {"joint 'j'", "lower = 1, upper = -1", "lower <= upper"}},
      {[](TwoLinks& t) {
         t.joint_type = "prismatic";
         t.limit = "lower=\"0.3\" upper=\"0.2\" velocity=\"1\" effort=\"1\"";
       },
       {"joint 'j'", "lower = 0.3, upper = 0.2"}},
      {[](TwoLinks& t) { t.limit = "lower=\"-1\" upper=\"1\" velocity=\"-2\" effort=\"1\""; },
       {"joint 'j'", "velocity = -2", ">= 0"}},
      {[](TwoLinks& t) { t.limit = "lower=\"-1\" upper=\"1\" velocity=\"1\" effort=\"-5\""; },
       {"joint 'j'", "effort = -5", ">= 0"}},
      {[](TwoLinks& t) {  // continuous: no position limits, but velocity still checked
         t.joint_type = "continuous";
         t.limit = "velocity=\"-1\" effort=\"1\"";
       },
       {"joint 'j'", "velocity = -1"}},
      {[](TwoLinks& t) { t.axis = "0 0 0"; }, {"joint 'j'", "axis xyz = (0, 0, 0)", "non-zero"}},
      {[](TwoLinks& t) { t.axis = "1e-300 0 0"; }, {"joint 'j'", "axis"}},
      {[](TwoLinks& t) { t.joint_origin = "<origin xyz=\"1e308 0 0\"/>"; },
       {"joint 'j'", "origin xyz = (1e+308, 0, 0)", "within 1000 m"}},
      {[](TwoLinks& t) { t.joint_origin = "<origin xyz=\"0 -2000 0\"/>"; },
       {"joint 'j'", "within 1000 m"}},
      {[](TwoLinks& t) { t.b_inertial = inertial("1", "1", "1", "1", "0", "0", "0", "0 0 1e4"); },
       {"link 'b' <inertial>", "origin xyz = (0, 0, 10000)"}},
      {[](TwoLinks& t) { t.dynamics = "<dynamics damping=\"-0.1\" friction=\"0\"/>"; },
       {"joint 'j'", "damping = -0.1"}},
  };
  for (std::size_t i = 0; i < cases.size(); ++i) {
    TwoLinks t;
    cases[i].edit(t);
    const std::string e = errorOf(t.xml());
    for (const std::string& needle : cases[i].needles) {
      EXPECT_TRUE(has(e, needle)) << "case " << i << ": '" << needle << "' not in: " << e;
    }
  }
  // Boundary cases that are possible: a locked joint (lower == upper), 0 = no limit.
  TwoLinks t;
  t.limit = "lower=\"0.5\" upper=\"0.5\" velocity=\"0\" effort=\"0\"";
  const Model m = buildModelFromUrdfString(t.xml());
  EXPECT_EQ(m.lowerPositionLimit[0], 0.5);
  EXPECT_TRUE(std::isinf(m.velocityLimit[0]) && std::isinf(m.effortLimit[0]));
}

TEST(LoaderHardening, MasslessLinksAndTheWholeRobot) {
  // A massless link (no <inertial>) is fine anywhere: a frame merged by a fixed joint, or a
  // moving intermediate link, as long as the robot has mass.
  const std::string tip = "<link name=\"tip\"/>";
  const std::string mid = "<link name=\"m\"/>";
  const std::string xml = robotXml(
      std::string(kLink) + mid + tip + "<link name=\"c\">" + inertial("1", "0.1", "0.1", "0.1") +
      "</link>" +
      "<joint name=\"j1\" type=\"revolute\"><parent link=\"a\"/><child link=\"m\"/>"
      "<axis xyz=\"0 1 0\"/><limit lower=\"-1\" upper=\"1\" velocity=\"1\" effort=\"1\"/></joint>"
      "<joint name=\"j2\" type=\"revolute\"><parent link=\"m\"/><child link=\"c\"/>"
      "<origin xyz=\"0 0 -0.5\"/><axis xyz=\"0 1 0\"/>"
      "<limit lower=\"-1\" upper=\"1\" velocity=\"1\" effort=\"1\"/></joint>"
      "<joint name=\"jt\" type=\"fixed\"><parent link=\"c\"/><child link=\"tip\"/>"
      "<origin xyz=\"0 0 -0.2\"/></joint>");
  const Model m = buildModelFromUrdfString(xml);
  EXPECT_EQ(m.nj, 2);
  EXPECT_EQ(m.bodies[1].mass, 0.0);
  EXPECT_EQ(m.totalMass, 2.0);
  EXPECT_EQ(m.frames[static_cast<std::size_t>(m.getFrameId("tip"))].body, 2);
  // No mass at all.
  const std::string e =
      errorOf(robotXml("<link name=\"a\"/><link name=\"b\"/>"
                       "<joint name=\"j\" type=\"fixed\"><parent link=\"a\"/>"
                       "<child link=\"b\"/></joint>"));
  EXPECT_TRUE(has(e, "zero total mass")) << e;
  // A floating point mass has no rotational inertia: the centroidal map is singular.
  const std::string point =
      robotXml("<link name=\"a\">" + inertial("1", "0", "0", "0") + "</link>");
  EXPECT_TRUE(has(errorOf(point), "rotational inertia of the whole robot"));
  EXPECT_EQ(errorOf(point, RootJoint::Fixed), "");  // fine on a fixed base
  // Two point masses: still a line, singular; three off a line: fine.
  TwoLinks two;
  two.b_inertial = inertial("1", "0", "0", "0", "0", "0", "0", "0 0 0");
  EXPECT_TRUE(has(errorOf(robotXml("<link name=\"a\">" + inertial("1", "0", "0", "0") +
                                   "</link><link name=\"b\">" + two.b_inertial +
                                   "</link><joint name=\"j\" type=\"fixed\"><parent "
                                   "link=\"a\"/><child link=\"b\"/><origin xyz=\"1 0 "
                                   "0\"/></joint>")),
                  "rotational inertia of the whole robot"));
}

TEST(LoaderHardening, LoopsAreRefusedBeforeUrdfdomLinksThem) {
  // A loop away from the root plus a later error urdfdom stops at: urdfdom used to drop its
  // partly linked tree (shared pointers in a cycle) and leak it (found by fuzz_urdf; the
  // sanitizer build reports a leak if it comes back).
  const auto j = [](const std::string& name, const std::string& parent, const std::string& child) {
    return "<joint name=\"" + name + "\" type=\"revolute\"><parent link=\"" + parent +
           "\"/><child link=\"" + child +
           "\"/><axis xyz=\"0 0 1\"/><limit lower=\"-1\" upper=\"1\" effort=\"1\" "
           "velocity=\"1\"/></joint>";
  };
  std::string links = kLink;
  for (const char* name : {"b", "c", "d"}) {
    links += "<link name=\"" + std::string(name) + "\">" + inertial("1", "1", "1", "1") + "</link>";
  }
  const std::string broken = "<joint name=\"broken\" type=\"fixed\"><child link=\"d\"/></joint>";
  std::string e = errorOf(robotXml(links + j("j1", "b", "c") + j("j2", "c", "b") + broken));
  EXPECT_TRUE(has(e, "its own ancestor") && has(e, "kinematic loop")) << e;
  e = errorOf(robotXml(links + j("self", "b", "b")));
  EXPECT_TRUE(has(e, "link 'b' is its own ancestor through joint 'self'")) << e;
  e = errorOf(robotXml(links + j("j1", "a", "b") + j("j2", "b", "c") + j("j3", "c", "d") +
                       j("j4", "d", "b")));
  EXPECT_TRUE(has(e, "link 'b' is the child of two joints ('j1' and 'j4')")) << e;
  // A long chain is checked in linear time and accepted.
  EXPECT_EQ(errorOf(robotXml(links + j("j1", "a", "b") + j("j2", "b", "c") + j("j3", "c", "d"))),
            "");
}

TEST(LoaderHardening, MalformedXmlIsAClearErrorNotACrash) {
  const std::vector<std::string> inputs = {
      "",
      "not xml at all",
      "<robot",
      "<robot name=\"r\"><link name=\"a\">",
      std::string("<robot name=\"r\">\0</robot>", 24),
      "<?xml version=\"1.0\"?>",
      "<robot name=\"r\"></robot>",
      "<robot name=\"r\"><link/></robot>",
      "<robot name=\"r\"><joint name=\"j\" type=\"revolute\"/></robot>",
      "<robot name=\"r\"><link name=\"a\"><inertial/></link></robot>",
      "<robot name=\"r\"><link name=\"a\"><inertial><mass value=\"1\"/></inertial></link></robot>",
      "<notarobot/>",
      "\xff\xfe<\x00r\x00",
  };
  for (const std::string& xml : inputs) {
    const std::string e = errorOf(xml);
    EXPECT_FALSE(e.empty()) << "accepted: " << xml;
  }
  // Deep nesting: refused before TinyXML recurses into it.
  std::string deep = "<robot name=\"r\">";
  for (int i = 0; i < 100000; ++i) deep += "<a>";
  const std::string e = errorOf(deep);
  EXPECT_TRUE(has(e, "nests elements more than 64 deep")) << e;
  // Nesting hidden in comments, CDATA and attribute values does not count.
  std::string shallow =
      robotXml(std::string(kLink) + "<!-- " + std::string(1000, '<') + " --><![CDATA[<<<<<<]]>");
  EXPECT_EQ(errorOf(shallow), "");
}

/// Runs fn on a thread with a small stack (recursion per link would overflow it).
void onSmallStack(const std::function<void()>& fn) {
  pthread_attr_t attr;
  pthread_attr_init(&attr);
  pthread_attr_setstacksize(&attr, 1 << 20);
  pthread_t thread;
  struct Arg {
    const std::function<void()>* fn;
    std::string error;
  } arg{&fn, ""};
  const auto body = [](void* p) -> void* {
    auto* a = static_cast<Arg*>(p);
    try {
      (*a->fn)();
    } catch (const std::exception& e) {
      a->error = e.what();
    }
    return nullptr;
  };
  ASSERT_EQ(pthread_create(&thread, &attr, body, &arg), 0);
  pthread_join(thread, nullptr);
  pthread_attr_destroy(&attr);
  EXPECT_EQ(arg.error, "");
}

/// A planar chain: link i (mass 1 + i/n) on a revolute z joint at x = `step` from the
/// previous one; every `fixed_every`-th joint is fixed instead (merged). Link names l0..ln.
std::string planarChain(int n, double step, int fixed_every) {
  std::string xml = "<?xml version=\"1.0\"?><robot name=\"chain\">";
  char buf[512];
  for (int i = 0; i <= n; ++i) {
    std::snprintf(buf, sizeof buf,
                  "<link name=\"l%d\"><inertial><origin xyz=\"%g 0 0\"/><mass value=\"%.17g\"/>"
                  "<inertia ixx=\"0.01\" ixy=\"0\" ixz=\"0\" iyy=\"0.01\" iyz=\"0\" "
                  "izz=\"0.01\"/></inertial></link>",
                  i, step / 2, 1.0 + static_cast<double>(i) / n);
    xml += buf;
  }
  for (int i = 1; i <= n; ++i) {
    const bool fixed = fixed_every > 0 && i % fixed_every == 0;
    std::snprintf(buf, sizeof buf,
                  "<joint name=\"j%d\" type=\"%s\"><parent link=\"l%d\"/><child link=\"l%d\"/>"
                  "<origin xyz=\"%g 0 0\"/><axis xyz=\"0 0 1\"/>"
                  "<limit lower=\"-3\" upper=\"3\" velocity=\"1\" effort=\"1\"/></joint>",
                  i, fixed ? "fixed" : "revolute", i - 1, i, step);
    xml += buf;
  }
  return xml + "</robot>";
}

/// Checks a planar chain's kinematics against the closed form: the frame of link i sits at
/// sum_k step (cos, sin)(theta_k) with theta_k the sum of the joint angles up to link k-1.
void checkPlanarChain(const Model& m, int n, double step, int fixed_every) {
  const int movable = fixed_every > 0 ? n - n / fixed_every : n;
  ASSERT_EQ(m.nj, movable);
  ASSERT_EQ(m.nbodies(), movable + 1);
  ASSERT_EQ(m.nframes(), n + 1);
  double mass = 0.0;
  for (int i = 0; i <= n; ++i) mass += 1.0 + static_cast<double>(i) / n;
  EXPECT_NEAR(m.totalMass, mass, 1e-9 * mass);
  // Joints are numbered along the chain.
  int j = 0;
  for (int i = 1; i <= n; ++i) {
    if (fixed_every > 0 && i % fixed_every == 0) continue;
    ASSERT_EQ(m.jointNames[static_cast<std::size_t>(j++)], "j" + std::to_string(i));
  }
  Data d(m);
  Eigen::VectorXd q = neutralConfiguration(m);
  std::vector<double> angle(static_cast<std::size_t>(n) + 1, 0.0);  // joint i's angle
  j = 0;
  for (int i = 1; i <= n; ++i) {
    if (fixed_every > 0 && i % fixed_every == 0) continue;
    const double a = 0.3 * std::sin(0.7 * i) / std::sqrt(static_cast<double>(n));
    angle[static_cast<std::size_t>(i)] = a;
    q[m.nqBase + j++] = a;
  }
  forwardKinematics(m, d, q);
  updateFramePlacements(m, d);
  double x = 0.0, y = 0.0, theta = 0.0;
  for (int i = 1; i <= n; ++i) {
    x += step * std::cos(theta);
    y += step * std::sin(theta);
    theta += angle[static_cast<std::size_t>(i)];
    if (i % 97 == 0 || i == n) {  // a sample of the frames, the tip included
      const FrameIndex f = m.getFrameId("l" + std::to_string(i));
      ASSERT_LT((d.opf[f] - Eigen::Vector3d(x, y, 0.0)).norm(), 1e-9 * i) << "link " << i;
      EXPECT_NEAR(std::atan2(d.oRf[f](1, 0), d.oRf[f](0, 0)), std::remainder(theta, 2 * M_PI),
                  1e-9 * i);
    }
  }
}

TEST(LoaderHardening, GeneratedChainHasTheClosedFormKinematics) {
  for (const int fixed_every : {0, 3}) {
    const std::string xml = planarChain(12, 0.25, fixed_every);
    const Model m = buildModelFromUrdfString(xml, RootJoint::Fixed);
    checkPlanarChain(m, 12, 0.25, fixed_every);
  }
}

TEST(LoaderHardening, TenThousandLinkChainLoadsWithoutDeepRecursion) {
  const int n = 10000;
  const std::string xml = planarChain(n, 0.01, 5);
  Model m;
  onSmallStack([&] { m = buildModelFromUrdfString(xml, RootJoint::Fixed); });
  checkPlanarChain(m, n, 0.01, 5);
}

TEST(LoaderHardening, FileErrorsNameTheFile) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("rollstep_urdf_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const auto fileError = [](const std::string& path) {
    try {
      buildModelFromUrdfFile(path);
    } catch (const ModelError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  std::string e = fileError(dir.string());
  EXPECT_TRUE(has(e, "URDF file '" + dir.string() + "'") && has(e, "directory")) << e;
  const std::string fifo = (dir / "robot.urdf").string();
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  e = fileError(fifo);  // refused at once, not blocking on the FIFO
  EXPECT_TRUE(has(e, "FIFO")) << e;
  e = fileError((dir / "missing.urdf").string());
  EXPECT_TRUE(has(e, "missing.urdf") && has(e, "No such file")) << e;
  const std::string bad = (dir / "bad.urdf").string();
  {
    TwoLinks t;
    t.limit = "lower=\"2\" upper=\"1\" velocity=\"1\" effort=\"1\"";
    std::ofstream(bad) << t.xml();
  }
  e = fileError(bad);
  EXPECT_TRUE(has(e, "URDF file '" + bad + "': joint 'j'") && has(e, "lower = 2")) << e;
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace rollstep::model
