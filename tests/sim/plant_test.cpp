// The plant: loading, conventions, sensors, raycast, errors, no allocation.
#include "rollstep/sim/plant.hpp"

#include <gtest/gtest.h>
#include <mujoco/mujoco.h>
#include <sys/stat.h>

#include <cstdint>
#include <cstdio>
#include <fstream>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "common/alloc_counter.hpp"
#include "rollstep/sim/scenario.hpp"
#include "rollstep/sim/simple_controllers.hpp"

namespace rollstep::sim {
namespace {

SceneConfig scene(const std::string& kind) {
  SceneConfig c = loadScene(kind);
  return c;
}

TEST(Plant, LoadsEveryScene) {
  for (const char* k : {"flat", "step20", "stairs2"}) {
    Plant plant(scene(k));
    EXPECT_NEAR(plant.totalMass(), 60.4, 1e-9);
    EXPECT_DOUBLE_EQ(plant.time(), 0.0);
    EXPECT_EQ(plant.physicsStepsPerControl(), 1);
  }
}

TEST(Plant, NominalPostureAndConventions) {
  Plant plant(scene("flat"));
  const GroundTruth& t = plant.groundTruth();
  EXPECT_NEAR(t.base_position.z(), 0.375, 1e-12);
  const PlantLayout& layout = plant.layout();
  ASSERT_EQ(layout.numLegs(), 6);
  ASSERT_EQ(layout.numJoints(), 12);
  for (int leg = 0; leg < layout.numLegs(); ++leg) {
    const std::vector<int>& joints = layout.legs[static_cast<std::size_t>(leg)].joints;
    ASSERT_EQ(joints.size(), 2u);
    EXPECT_FALSE(layout.joints[static_cast<std::size_t>(joints[0])].prismatic);
    EXPECT_TRUE(layout.joints[static_cast<std::size_t>(joints[1])].prismatic);
    EXPECT_NEAR(plant.nominalCommand().joint_position[joints[0]], 0.0, 1e-12);
    EXPECT_NEAR(plant.nominalCommand().joint_position[joints[1]], 0.05, 1e-12);
    EXPECT_NEAR(t.joint_position[joints[1]], 0.05, 1e-12);
    EXPECT_NEAR(plant.wheelRadius(leg), 0.075, 1e-12);
    // wheel centre = hip + 0.25 m down; wheel bottom touches the floor
    const Eigen::Vector3d expected =
        t.base_position + plant.hipPosition(leg) - Eigen::Vector3d(0, 0, 0.25);
    EXPECT_NEAR((t.wheel_center[static_cast<std::size_t>(leg)] - expected).norm(), 0.0, 1e-12);
    EXPECT_NEAR(t.wheel_center[static_cast<std::size_t>(leg)].z(), 0.075, 1e-12);
  }
  // Leg order LF, MF, RF, LR, MR, RR: x front then rear, y left, middle, right.
  EXPECT_GT(plant.hipPosition(0).y(), 0.0);
  EXPECT_EQ(plant.hipPosition(1).y(), 0.0);
  EXPECT_LT(plant.hipPosition(2).y(), 0.0);
  EXPECT_LT(plant.hipPosition(3).x(), 0.0);
  // Legs in the description's contact-frame order, named from the frames; the joints per
  // leg from the base down; drive wheels LF, RF, LR, RR.
  std::string names;
  for (const PlantLayout::Leg& leg : layout.legs) names += leg.name + " ";
  EXPECT_EQ(names, "LF MF RF LR MR RR ");
  std::string joints;
  for (const PlantLayout::Joint& joint : layout.joints) joints += joint.name + " ";
  EXPECT_EQ(joints,
            "LF_hip LF_knee MF_hip MF_knee RF_hip RF_knee LR_hip LR_knee MR_hip MR_knee RR_hip "
            "RR_knee ");
  EXPECT_EQ(layout.drive_wheel_legs, (std::vector<int>{0, 2, 3, 5}));
  EXPECT_EQ(layout.legs[1].drive_wheel, -1);
  EXPECT_EQ(layout.legs[2].drive_wheel, 1);
}

TEST(Plant, ResetPlacesTheBase) {
  Plant plant(scene("flat"));
  plant.reset(1.0, -2.0, 0.5);
  const GroundTruth& t = plant.groundTruth();
  EXPECT_NEAR(t.base_position.x(), 1.0, 1e-12);
  EXPECT_NEAR(t.base_position.y(), -2.0, 1e-12);
  const Eigen::Vector3d x = t.base_orientation * Eigen::Vector3d::UnitX();
  EXPECT_NEAR(std::atan2(x.y(), x.x()), 0.5, 1e-12);
}

TEST(Plant, RaycastSeesTerrainOnly) {
  SceneConfig c = scene("step20");
  Plant plant(c);
  // Straight down through the robot's base: the floor, not the robot.
  EXPECT_NEAR(plant.raycast(Eigen::Vector3d(0, 0, 2), -Eigen::Vector3d::UnitZ(), 10), 2.0, 1e-9);
  // Down onto the block top.
  EXPECT_NEAR(plant.raycast(Eigen::Vector3d(1.5, 0, 2), -Eigen::Vector3d::UnitZ(), 10), 1.8, 1e-9);
  // Forward at 0.1 m height: the block's near face at x = 1.0.
  EXPECT_NEAR(plant.raycast(Eigen::Vector3d(0, 0, 0.1), Eigen::Vector3d::UnitX(), 10), 1.0, 1e-9);
  // Upward: nothing, and out of range.
  EXPECT_LT(plant.raycast(Eigen::Vector3d(0, 0, 2), Eigen::Vector3d::UnitZ(), 10), 0.0);
  EXPECT_LT(plant.raycast(Eigen::Vector3d(0, 0, 2), -Eigen::Vector3d::UnitZ(), 1.0), 0.0);
}

TEST(Plant, StandsOnTheStep20Block) {
  Plant plant(scene("step20"));
  plant.reset(1.6, 0.0, 0.0, 0.20);  // wheels on the block top, 0.20 m up
  for (int k = 0; k < 1000; ++k) plant.step();
  const GroundTruth& t = plant.groundTruth();
  EXPECT_NEAR(t.base_position.z(), 0.20 + 0.375, 0.01);
  for (bool c : t.foot_contact) EXPECT_TRUE(c);
  EXPECT_EQ(plant.warningCount(), 0);
}

// The body contact flag and its count: none while standing on the wheels; a robot dropped
// on its side touches the floor with its body; reset() clears the count.
TEST(Plant, BodyContactIsSeenAndCounted) {
  Plant plant(scene("flat"));
  for (int k = 0; k < 500; ++k) plant.step();
  EXPECT_FALSE(plant.groundTruth().body_contact);
  EXPECT_EQ(plant.groundTruth().body_contact_periods, 0);
  plant.reset(0.0, 0.0, 0.0, 0.3);
  mjData* d = plant.mujocoData();
  d->qpos[3] = std::cos(0.25 * M_PI);  // rolled 90 deg about x: lands on its side
  d->qpos[4] = std::sin(0.25 * M_PI);
  d->qpos[5] = d->qpos[6] = 0.0;
  mj_forward(plant.mujocoModel(), d);
  long touching = 0;
  for (int k = 0; k < 1500; ++k) {
    plant.step();
    touching += plant.groundTruth().body_contact ? 1 : 0;
  }
  EXPECT_GT(touching, 500);
  EXPECT_EQ(plant.groundTruth().body_contact_periods, touching);
  plant.reset();
  EXPECT_EQ(plant.groundTruth().body_contact_periods, 0);
}

TEST(Plant, SensorsMatchGroundTruthAtRest) {
  Plant plant(scene("flat"));
  for (int k = 0; k < 500; ++k) plant.step();
  const SensorReadings& s = plant.sensors();
  const GroundTruth& t = plant.groundTruth();
  EXPECT_NEAR((s.joint_position - t.joint_position).norm(), 0.0, 1e-4);
  EXPECT_NEAR(s.imu_acceleration.z(), 9.81, 0.05);  // specific force: +g at rest
  EXPECT_NEAR(s.imu_angular_velocity.norm(), 0.0, 1e-3);
  EXPECT_NEAR(s.imu_orientation.angularDistance(t.base_orientation), 0.0, 1e-3);
  for (int leg = 0; leg < plant.layout().numLegs(); ++leg) {
    EXPECT_TRUE(s.foot_contact[static_cast<std::size_t>(leg)])
        << plant.layout().legs[static_cast<std::size_t>(leg)].name;
    EXPECT_NEAR(s.foot_normal_force[static_cast<std::size_t>(leg)],
                t.foot_force[static_cast<std::size_t>(leg)].z(), 1.0);
  }
}

// Standing on flat ground: each wheel is pushed at its lowest point (the ground, under its
// centre), straight up with the share of the weight it carries; a wheel in the air is
// pushed nowhere (its contact point is its centre, its force zero).
TEST(Plant, ContactPointIsUnderTheWheelOnFlatGround) {
  Plant plant(scene("flat"));
  for (int k = 0; k < 500; ++k) plant.step();
  const GroundTruth& t = plant.groundTruth();
  double weight = 0.0;
  for (int leg = 0; leg < plant.layout().numLegs(); ++leg) {
    const auto l = static_cast<std::size_t>(leg);
    const std::string& name = plant.layout().legs[l].name;
    ASSERT_TRUE(t.foot_contact[l]) << name;
    EXPECT_NEAR(t.contact_point[l].z(), 0.0, 2e-3) << name;  // MuJoCo's soft contact
    EXPECT_NEAR(t.contact_point[l].x(), t.wheel_center[l].x(), 2e-3) << name;
    EXPECT_NEAR(t.contact_point[l].y(), t.wheel_center[l].y(), 2e-3) << name;
    EXPECT_NEAR(t.wheel_center[l].z() - t.contact_point[l].z(), plant.wheelRadius(leg), 3e-3)
        << name;
    EXPECT_GT(t.foot_force[l].z(), 1.0) << name;
    EXPECT_LT(t.foot_force[l].head<2>().norm(), 0.05 * t.foot_force[l].z()) << name;
    weight += t.foot_force[l].z();
  }
  EXPECT_NEAR(weight, plant.totalMass() * 9.81, 0.02 * plant.totalMass() * 9.81);
  // Lifted: no contact, the point is the wheel centre.
  mjData* d = plant.mujocoData();
  d->qpos[2] += 1.0;
  d->qvel[2] = 0.0;
  mj_forward(plant.mujocoModel(), d);
  plant.step();
  for (int leg = 0; leg < plant.layout().numLegs(); ++leg) {
    const auto l = static_cast<std::size_t>(leg);
    EXPECT_FALSE(t.foot_contact[l]);
    EXPECT_EQ(t.contact_point[l], t.wheel_center[l]);
    EXPECT_EQ(t.foot_force[l].norm(), 0.0);
  }
}

TEST(Plant, StepDoesNotAllocate) {
  Plant plant(scene("step20"));
  PlantCommand command = plant.nominalCommand();
  command.wheel_velocity.setConstant(2.0);
  plant.step();
  test::AllocationGuard guard;
  for (int k = 0; k < 200; ++k) {
    plant.setCommand(command);
    plant.step();
    const double d = plant.raycast(Eigen::Vector3d(0, 0, 2), -Eigen::Vector3d::UnitZ(), 10);
    EXPECT_GT(d, 0.0);
  }
  EXPECT_EQ(guard.count(), 0u);
}

TEST(Plant, Deterministic) {
  const auto run = [] {
    Plant plant(scene("flat"));
    PlantCommand command = plant.nominalCommand();
    command.wheel_velocity << 3.0, 5.0, 3.0, 5.0;
    plant.setCommand(command);
    for (int k = 0; k < 1000; ++k) plant.step();
    return plant.groundTruth();
  };
  const GroundTruth a = run();
  const GroundTruth b = run();
  EXPECT_EQ(a.base_position, b.base_position);
  EXPECT_EQ(a.joint_position, b.joint_position);
}

TEST(PlantErrors, NonFiniteCommandIsRefused) {
  Plant plant(scene("flat"));
  PlantCommand command = plant.nominalCommand();
  command.wheel_velocity.setConstant(1.0);
  plant.setCommand(command);
  for (int entry = 0; entry < 2; ++entry) {
    PlantCommand bad = command;
    if (entry == 0) {
      bad.joint_position(3) = std::numeric_limits<double>::quiet_NaN();
    } else {
      bad.wheel_velocity(2) = std::numeric_limits<double>::infinity();
    }
    try {
      plant.setCommand(bad);
      FAIL() << "non-finite command accepted";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(entry == 0 ? "joint position target 3"
                                                      : "wheel velocity target 2"),
                std::string::npos)
          << e.what();
    }
  }
  // The previous command still drives the robot: the wheels keep their 1 rad/s target.
  EXPECT_EQ(plant.command().wheel_velocity, command.wheel_velocity);
  for (int k = 0; k < 500; ++k) plant.step();
  EXPECT_NEAR(plant.sensors().wheel_velocity(0), 1.0, 0.1);
  EXPECT_THROW(plant.reset(std::numeric_limits<double>::quiet_NaN()), std::invalid_argument);
}

TEST(PlantErrors, DivergenceIsReportedNotHidden) {
  Plant plant(scene("flat"));
  for (int k = 0; k < 100; ++k) plant.step();
  // A state MuJoCo cannot integrate: it resets the data and warns; step() must say so
  // instead of returning a robot teleported back to its initial pose.
  for (int round = 0; round < 2; ++round) {  // the second time without reset() in between
    plant.mujocoData()->qvel[0] = std::numeric_limits<double>::quiet_NaN();
    try {
      plant.step();
      FAIL() << "divergence not reported (round " << round << ")";
    } catch (const SimError& e) {
      EXPECT_NE(std::string(e.what()).find("diverged"), std::string::npos) << e.what();
    }
    for (int k = 0; k < 10; ++k) plant.step();
  }
  plant.reset();
  for (int k = 0; k < 100; ++k) plant.step();
  EXPECT_EQ(plant.warningCount(), 0);
  EXPECT_TRUE(plant.groundTruth().base_position.allFinite());
}

std::string writeTemp(const std::string& name, const std::string& text) {
  const std::string path = ::testing::TempDir() + name;
  std::ofstream(path) << text;
  return path;
}

void expectLoadError(const std::string& robot_file, const std::string& needle) {
  PlantOptions options;
  options.robot_file = robot_file;
  try {
    Plant plant(SceneConfig{}, options);
    FAIL() << "no error loading " << robot_file;
  } catch (const SimError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(robot_file), std::string::npos) << what;
    EXPECT_NE(what.find(needle), std::string::npos) << what;
  }
}

TEST(PlantErrors, MissingFile) { expectLoadError("/nonexistent/robot.xml", "No such file"); }

TEST(PlantErrors, NotARegularFileIsRefusedWithoutReading) {
  const std::string fifo = ::testing::TempDir() + "robot_fifo.xml";
  std::remove(fifo.c_str());
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  expectLoadError(fifo, "FIFO");  // opening it for reading would block forever
  std::remove(fifo.c_str());
  expectLoadError(::testing::TempDir(), "");
  expectLoadError("/dev/zero", "not a regular file");
}

std::string robotText() {
  std::ifstream in(defaultRobotFile());
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

/// `text` with the first (or last) occurrence of `from` replaced by `to`; fails the test
/// if `from` is not there.
std::string replaced(std::string text, const std::string& from, const std::string& to,
                     bool last = false) {
  const std::size_t at = last ? text.rfind(from) : text.find(from);
  if (at == std::string::npos) {
    ADD_FAILURE() << "'" << from << "' is not in the robot file";
    return text;
  }
  return text.replace(at, from.size(), to);
}

/// Loads step20 with the robot file: the floor and the block are there and the robot
/// stands on the floor at its nominal height.
void expectSceneIntact(const PlantOptions& options) {
  Plant plant(scene("step20"), options);
  const mjModel* m = plant.mujocoModel();
  EXPECT_GE(mj_name2id(m, mjOBJ_GEOM, "floor"), 0);
  EXPECT_GE(mj_name2id(m, mjOBJ_GEOM, "block0"), 0);
  EXPECT_NEAR(plant.raycast(Eigen::Vector3d(1.5, 0, 2), -Eigen::Vector3d::UnitZ(), 10), 1.8, 1e-9);
  for (int k = 0; k < 200; ++k) plant.step();
  EXPECT_NEAR(plant.groundTruth().base_position.z(), 0.375, 0.01);
  EXPECT_EQ(plant.warningCount(), 0);
}

// The terrain used to be spliced in before the last "</worldbody>" of the text: anything
// that looks like that tag without being it lost the terrain (the robot fell through).
TEST(PlantComposition, TagLookalikesInCommentsCdataAndAttributes) {
  const std::string text = robotText();
  const std::vector<std::pair<std::string, std::string>> variants = {
      {"comment at the end", replaced(text, "</mujoco>", "<!-- </worldbody> -->\n</mujoco>", true)},
      {"comment in the worldbody",
       replaced(text, "  </worldbody>", "  <!-- </worldbody><worldbody> -->\n  </worldbody>")},
      {"CDATA", replaced(text, "</mujoco>", "<![CDATA[ </worldbody> ]]>\n</mujoco>", true)},
      {"attribute text",
       replaced(text, "<site name=\"imu\" pos=\"0 0 0\"/>",
                "<site name=\"imu\" pos=\"0 0 0\"/><site name=\"a>b &lt;/worldbody&gt;\"/>")},
      {"XML declaration", "<?xml version=\"1.0\" encoding=\"utf-8\"?>\n" + text},
      {"no worldbody end tag at all",  // <worldbody/> of an empty robot is still XML
       replaced(text, "</mujoco>", "<worldbody/>\n</mujoco>", true)},
  };
  for (const auto& [name, xml] : variants) {
    SCOPED_TRACE(name);
    const std::string path = writeTemp("lookalike.xml", xml);
    PlantOptions from_file;
    from_file.robot_file = path;
    expectSceneIntact(from_file);
    PlantOptions from_text;
    from_text.robot_file = "/not/read/robot.xml";
    from_text.robot_xml = xml;
    expectSceneIntact(from_text);
  }
}

// The robot's relative paths (its own includes, assets) resolve from its directory, not
// from the working directory; odd characters in the path are no problem.
TEST(PlantComposition, RobotIncludesAndPathsResolveFromItsDirectory) {
  const std::string dir = ::testing::TempDir() + "robot dir & <x> \"q\"/";
  ::mkdir(dir.c_str(), 0700);
  ::mkdir((dir + "parts").c_str(), 0700);
  const std::string text = robotText();
  const std::size_t a = text.find("  <actuator>");
  const std::size_t b = text.find("</actuator>") + std::string("</actuator>").size();
  ASSERT_NE(a, std::string::npos);
  std::ofstream(dir + "parts/actuators.xml") << "<mujoco>\n"
                                             << text.substr(a, b - a) << "\n</mujoco>\n";
  // A mesh asset under the robot's meshdir: a binary STL tetrahedron of 5 cm.
  ::mkdir((dir + "meshes").c_str(), 0700);
  {
    std::ofstream stl(dir + "meshes/tetra.stl", std::ios::binary);
    const std::string header(80, ' ');
    stl.write(header.data(), 80);
    const std::uint32_t count = 4;
    stl.write(reinterpret_cast<const char*>(&count), 4);
    const float v[4][3] = {{0, 0, 0}, {0.05f, 0, 0}, {0, 0.05f, 0}, {0, 0, 0.05f}};
    const int faces[4][3] = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
    for (const auto& f : faces) {
      const float normal[3] = {0, 0, 0};
      stl.write(reinterpret_cast<const char*>(normal), 12);
      for (int k : f) stl.write(reinterpret_cast<const char*>(v[k]), 12);
      const std::uint16_t attribute = 0;
      stl.write(reinterpret_cast<const char*>(&attribute), 2);
    }
  }
  std::string main_text =
      text.substr(0, a) + "  <include file=\"parts/actuators.xml\"/>" + text.substr(b);
  main_text = replaced(main_text, "<compiler ", "<compiler meshdir=\"meshes\" ");
  main_text = replaced(main_text, "  <worldbody>",
                       "  <asset><mesh name=\"tetra\" file=\"tetra.stl\"/></asset>\n  <worldbody>");
  main_text = replaced(main_text, "<site name=\"imu\" pos=\"0 0 0\"/>",
                       "<site name=\"imu\" pos=\"0 0 0\"/><geom name=\"tetra\" type=\"mesh\" "
                       "mesh=\"tetra\" contype=\"0\"/>");
  const std::string robot = dir + "robot & \"main\".xml";
  std::ofstream(robot) << main_text;
  PlantOptions options;
  options.robot_file = robot;
  expectSceneIntact(options);
  Plant plant(SceneConfig{}, options);
  EXPECT_EQ(plant.mujocoModel()->nu, 16);
  EXPECT_EQ(plant.mujocoModel()->nmesh, 1);
}

TEST(PlantComposition, TerrainNameClashNamesSceneAndRobot) {
  const std::string path = writeTemp(
      "clash.xml",
      replaced(robotText(), "<site name=\"imu\" pos=\"0 0 0\"/>",
               "<site name=\"imu\" pos=\"0 0 0\"/><geom name=\"block0\" size=\"0.01\"/>"));
  PlantOptions options;
  options.robot_file = path;
  try {
    Plant plant(scene("step20"), options);
    FAIL() << "no error";
  } catch (const SimError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("scene step20 of scene config '"), std::string::npos) << what;
    EXPECT_NE(what.find("step20.yaml' with robot model '" + path + "'"), std::string::npos) << what;
    EXPECT_NE(what.find("block0"), std::string::npos) << what;
  }
}

// Wrong robot structure: every element the plant reads is checked for kind, not only name.
TEST(PlantErrors, WrongStructureNamesTheElement) {
  const std::string text = robotText();
  const std::vector<std::pair<std::string, std::string>> cases = {
      {replaced(replaced(text, "<joint name=\"LF_knee\" class=\"knee\"/>",
                         "<joint name=\"LF_knee\" class=\"knee\"/><joint name=\"LF_extra\" "
                         "type=\"ball\"/>"),
                "qpos=\"0 0 0.375 1 0 0 0  0 0.05 0 ",
                "qpos=\"0 0 0.375 1 0 0 0  0 0.05 1 0 0 0 0 "),
       "joint 'LF_extra' of leg 'LF_wheel' must be a hinge or a slide joint"},
      {replaced(text, "<joint name=\"RR_wheel\" class=\"drive\"/>",
                "<joint name=\"RR_wheel\" class=\"drive\" type=\"slide\"/>"),
       "body 'RR_wheel' (a drive wheel) needs one hinge joint, its axle"},
      {replaced(text, "name=\"LF_hip_servo\" joint=\"LF_hip\"",
                "name=\"LF_hip_servo\" joint=\"MF_hip\""),
       "joint 'LF_hip' has no actuator"},
      {replaced(
           replaced(text, "</actuator>", "<position name=\"extra\" joint=\"LF_hip\"/></actuator>"),
           "0 0.05 0 0 0 0\"/>", "0 0.05 0 0 0 0 0\"/>"),
       "joint 'LF_hip' has two actuators, 'LF_hip_servo' and 'extra'"},
      {replaced(text, "<jointpos name=\"LF_hip_pos\" joint=\"LF_hip\"/>",
                "<jointvel name=\"LF_hip_pos\" joint=\"LF_hip\"/>"),
       "no sensor for jointpos of joint 'LF_hip'"},
      {replaced(text, "<jointvel name=\"RR_wheel_vel\" joint=\"RR_wheel\"/>",
                "<jointvel name=\"RR_wheel_vel\" joint=\"LR_wheel\"/>"),
       "two sensors of the same kind for jointvel of drive wheel joint 'LR_wheel': "
       "'LR_wheel_vel' and 'RR_wheel_vel'"},
      {replaced(text, "<touch name=\"MF_touch\" site=\"MF_touch\"/>",
                "<accelerometer name=\"MF_touch\" site=\"MF_touch\"/>"),
       "no sensor for touch on a site of body 'MF_wheel'"},
      {replaced(text, "<gyro name=\"imu_gyro\" site=\"imu\"/>",
                "<velocimeter name=\"imu_gyro\" site=\"imu\"/>"),
       "no sensor for the IMU's gyro"},
      {replaced(text, "<geom name=\"LF_wheel_geom\" type=\"sphere\" size=\"0.075\"",
                "<geom name=\"LF_wheel_geom\" type=\"box\" size=\"0.075 0.075 0.075\""),
       "body 'LF_wheel' (a wheel) needs a sphere geom, the wheel"},
      {replaced(text, "<body name=\"LF_wheel\"", "<body name=\"LF_wheel_x\""),
       "no body named 'LF_wheel' (a contact frame of the robot)"},
      {replaced(text, "<key name=\"nominal\"", "<key name=\"other\""),
       "no keyframe named 'nominal'"},
      {replaced(text, "timestep=\"0.001\"", "timestep=\"0.0000001\""),
       "timestep 1e-07 s is too small: 10000 physics steps per control period of 0.001 s; "
       "valid range: 1 to 1000"},
      {replaced(text, "<key name=\"nominal\" qpos=\"0 0 0.375",
                "<key name=\"nominal\" qpos=\"0 0 nan"),
       "keyframe 'nominal' holds a non-finite qpos"},
      {replaced(text, "<key name=\"nominal\" qpos=\"0 0 0.375",
                "<key name=\"nominal\" qpos=\"0 0 1e300"),
       "body 'base' is not within 1 km of the origin at the nominal pose"},
      {replaced(text, "size=\"0.45 0.25 0.08\"", "size=\"1e30 0.25 0.08\""),
       "geom 'base_box' has a bounding radius of 1e+30 m; valid range: up to 100 m"},
      {"<robot name=\"urdf\"/>", "MuJoCo: "},
      {"", "the file is empty"},
  };
  for (const auto& [xml, needle] : cases) {
    SCOPED_TRACE(needle);
    expectLoadError(writeTemp("structure.xml", xml), needle);
  }
}

TEST(PlantErrors, NonFiniteOrImpossibleOptions) {
  for (double period : {std::numeric_limits<double>::quiet_NaN(), 0.0, -0.001, 0.0015, 10.0}) {
    PlantOptions options;
    options.control_period = period;
    EXPECT_THROW(Plant plant(SceneConfig{}, options), SimError) << period;
  }
  PlantOptions options;
  options.contact_threshold = std::numeric_limits<double>::infinity();
  EXPECT_THROW(Plant plant(SceneConfig{}, options), SimError);
}

// The first block must be clear of the robot, whose front comes from the loaded model.
TEST(PlantStart, BlockMustClearTheRobotsFront) {
  const Plant flat(SceneConfig{});
  EXPECT_NEAR(flat.frontExtent(), 0.45, 1e-9);  // the base box: 0.45 m half length
  EXPECT_NEAR(flat.minStartX(), 0.45 + Plant::kStartClearance, 1e-9);
  for (const char* kind : {"step20", "stairs2"}) {
    SceneConfig c = scene(kind);
    for (double start_x : {0.0, 0.2, flat.minStartX() - 1e-3}) {
      setSceneNumber(c, "start_x", start_x);
      try {
        Plant plant(c);
        ADD_FAILURE() << "no error for start_x " << start_x;
      } catch (const SimError& e) {
        const std::string what = e.what();
        EXPECT_NE(what.find("start_x"), std::string::npos) << what;
        EXPECT_NE(what.find("start_x >= 0.500 m"), std::string::npos) << what;
      }
    }
    setSceneNumber(c, "start_x", flat.minStartX() + 1e-3);
    Plant plant(c);
    for (int k = 0; k < 200; ++k) plant.step();
    EXPECT_NEAR(plant.groundTruth().base_position.z(), 0.375, 0.01);
    for (const Eigen::Vector3d& f : plant.groundTruth().foot_force) EXPECT_GE(f.z(), 0.0);
  }
  // A longer robot needs more room: the bound is the model's, not a constant.
  PlantOptions longer;
  longer.robot_xml = replaced(robotText(), "size=\"0.45 0.25 0.08\"", "size=\"0.7 0.25 0.08\"");
  EXPECT_NEAR(Plant(SceneConfig{}, longer).frontExtent(), 0.7, 1e-9);
  SceneConfig c = scene("step20");
  setSceneNumber(c, "start_x", 0.6);
  EXPECT_NO_THROW(Plant plant(c));
  EXPECT_THROW(Plant plant(c, longer), SimError);
}

TEST(PlantErrors, MalformedXml) {
  const std::string path = writeTemp("malformed.xml", "<mujoco><worldbody><body>\n</mujoco>\n");
  expectLoadError(path, "MuJoCo: ");
}

TEST(PlantErrors, InvalidMjcf) {
  const std::string path =
      writeTemp("invalid.xml",
                "<mujoco><worldbody><geom type=\"sphere\" size=\"-1\" bogus=\"2\"/>"
                "</worldbody></mujoco>\n");
  expectLoadError(path, "bogus");
}

TEST(PlantErrors, NotTheRobot) {
  const std::string path =
      writeTemp("other.xml",
                "<mujoco><option timestep=\"0.001\"/><worldbody><body "
                "name=\"base\"><freejoint/><geom type=\"sphere\" size=\"0.1\"/>"
                "</body></worldbody></mujoco>\n");
  expectLoadError(path, "no body named 'LF_wheel'");
}

/// A wheeled quadruped of our own: four legs of three hinges (hip abduction about x, hip and
/// knee flexion about y) and a driven wheel each, legs FL FR HL HR.
std::string quadrupedMjcf() {
  std::string legs, actuators, sensors, qpos, ctrl;
  const char* names[4] = {"FL", "FR", "HL", "HR"};
  const double xs[4] = {0.3, 0.3, -0.3, -0.3}, ys[4] = {0.15, -0.15, 0.15, -0.15};
  for (int l = 0; l < 4; ++l) {
    const std::string n = names[l];
    char pos[64];
    std::snprintf(pos, sizeof pos, "%g %g 0", xs[l], ys[l]);
    legs += "<body name=\"" + n + "_hip\" pos=\"" + pos + "\"><joint name=\"" + n +
            "_haa\" axis=\"1 0 0\" range=\"-0.5 0.5\" damping=\"20\"/>"
            "<inertial pos=\"0 0 0\" mass=\"1\" diaginertia=\"0.002 0.002 0.002\"/>"
            "<body name=\"" +
            n + "_thigh\"><joint name=\"" + n +
            "_hfe\" axis=\"0 1 0\" "
            "range=\"-1.5 1.5\" damping=\"20\"/><inertial pos=\"0 0 -0.15\" mass=\"1.5\" "
            "diaginertia=\"0.01 0.01 0.001\"/><geom type=\"capsule\" fromto=\"0 0 0 0 0 -0.3\" "
            "size=\"0.03\"/><body name=\"" +
            n + "_shank\" pos=\"0 0 -0.3\"><joint name=\"" + n +
            "_kfe\" axis=\"0 1 0\" range=\"-2.5 0\" damping=\"20\"/><inertial pos=\"0 0 -0.15\" "
            "mass=\"1\" diaginertia=\"0.008 0.008 0.001\"/><body name=\"" +
            n + "_wheel\" pos=\"0 0 -0.3\"><joint name=\"" + n +
            "_wheel\" axis=\"0 1 0\" "
            "damping=\"0\" armature=\"0.01\"/><inertial pos=\"0 0 0\" mass=\"0.5\" "
            "diaginertia=\"0.001 0.002 0.001\"/><geom type=\"sphere\" size=\"0.08\"/><site "
            "name=\"" +
            n + "_touch\" size=\"0.09\"/></body></body></body></body>";
    for (const char* j : {"_haa", "_hfe", "_kfe"}) {
      actuators += "<position joint=\"" + n + j + "\" kp=\"500\"/>";
      sensors += "<jointpos joint=\"" + n + j + "\"/><jointvel joint=\"" + n + j + "\"/>";
    }
    actuators += "<velocity joint=\"" + n + "_wheel\" kv=\"5\" ctrlrange=\"-30 30\"/>";
    sensors += "<jointpos joint=\"" + n + "_wheel\"/><jointvel joint=\"" + n +
               "_wheel\"/><touch site=\"" + n + "_touch\"/>";
    qpos += " 0 0 0 0";
    ctrl += " 0 0 0 0";
  }
  return "<mujoco><compiler autolimits=\"true\"/><option timestep=\"0.001\"/><default><geom "
         "contype=\"1\" conaffinity=\"0\" "
         "group=\"1\"/></default><worldbody><body name=\"base\" pos=\"0 0 0.68\"><freejoint/>"
         "<inertial pos=\"0 0 0\" mass=\"30\" diaginertia=\"0.3 0.8 1\"/><geom type=\"box\" "
         "size=\"0.35 0.12 0.08\"/><site name=\"imu\"/>" +
         legs + "</body></worldbody><actuator>" + actuators + "</actuator><sensor>" + sensors +
         "<accelerometer site=\"imu\"/><gyro site=\"imu\"/><framequat objtype=\"site\" "
         "objname=\"imu\"/></sensor><keyframe><key name=\"nominal\" qpos=\"0 0 0.68 1 0 0 0" +
         qpos + "\" ctrl=\"" + ctrl + "\"/></keyframe></mujoco>";
}

// Any number of legs and joints per leg, wheels driven or not: the layout comes from the
// MJCF and the contact frames, the logs' columns from the names.
TEST(PlantLayout, AnyRobotFromItsMjcfAndContactFrames) {
  PlantOptions options;
  options.robot_file = "/not/read/quadruped.xml";
  options.robot_xml = quadrupedMjcf();
  options.contact_frames = {"FL_wheel", "FR_wheel", "HL_wheel", "HR_wheel"};
  options.drive_wheels = {"FR_wheel", "FL_wheel", "HL_wheel", "HR_wheel"};
  Plant plant(SceneConfig{}, options);
  const PlantLayout& layout = plant.layout();
  ASSERT_EQ(layout.numLegs(), 4);
  ASSERT_EQ(layout.numJoints(), 12);
  ASSERT_EQ(layout.numDriveWheels(), 4);
  EXPECT_EQ(layout.legs[1].name, "FR");
  EXPECT_EQ(layout.joints[3].name, "FR_haa");
  EXPECT_EQ(layout.legs[3].joints, (std::vector<int>{9, 10, 11}));
  EXPECT_EQ(plant.nominalCommand().joint_position.size(), 12);
  EXPECT_EQ(plant.sensors().foot_contact.size(), 4u);
  EXPECT_NEAR(plant.wheelRadius(2), 0.08, 1e-12);
  EXPECT_NEAR(plant.hipPosition(3).x(), -0.3, 1e-12);
  const std::string header = csvHeader(layout);
  for (const char* column : {"q_HR_kfe[rad]", "cmd_FL_haa[rad]", "wheel_vel_HL[rad/s]",
                             "contact_FR[0/1]", "foot_z_HR[m]"}) {
    EXPECT_NE(header.find(column), std::string::npos) << column;
  }
  // It stands on its wheels, and rolls forward on them.
  DriveController::Params p;
  p.speed = 0.3;
  p.start_time = 0.5;
  DriveController drive(plant, p);
  runScenario(plant, drive, 2.0);
  const GroundTruth& t = plant.groundTruth();
  EXPECT_GT(t.base_position.x(), 0.2);
  EXPECT_NEAR(t.base_position.y(), 0.0, 0.02);
  EXPECT_GT(t.base_position.z(), 0.5);
  for (const bool contact : t.foot_contact) EXPECT_TRUE(contact);
  // A command of another robot's size is refused, the previous one kept.
  PlantCommand wrong = plant.nominalCommand();
  wrong.wheel_velocity.resize(2);
  EXPECT_THROW(plant.setCommand(wrong), std::invalid_argument);
}

TEST(PlantErrors, BadSceneParameter) {
  SceneConfig c = loadScene("step20");
  setSceneNumber(c, "step1_height", -0.2);
  EXPECT_THROW(Plant plant(c), SimError);
}

}  // namespace
}  // namespace rollstep::sim
