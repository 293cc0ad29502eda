// The plant: loading, conventions, sensors, raycast, errors, no allocation.
#include "rollstep/sim/plant.hpp"

#include <gtest/gtest.h>
#include <mujoco/mujoco.h>

#include <cstdio>
#include <fstream>
#include <limits>
#include <stdexcept>
#include <string>

#include "common/alloc_counter.hpp"

namespace rollstep::sim {
namespace {

SceneConfig scene(SceneKind kind) {
  SceneConfig c;
  c.kind = kind;
  return c;
}

TEST(Plant, LoadsEveryScene) {
  for (SceneKind k : {SceneKind::kFlat, SceneKind::kStep20, SceneKind::kStairs2}) {
    Plant plant(scene(k));
    EXPECT_NEAR(plant.totalMass(), 60.4, 1e-9);
    EXPECT_DOUBLE_EQ(plant.time(), 0.0);
    EXPECT_EQ(plant.physicsStepsPerControl(), 1);
  }
}

TEST(Plant, NominalPostureAndConventions) {
  Plant plant(scene(SceneKind::kFlat));
  const GroundTruth& t = plant.groundTruth();
  EXPECT_NEAR(t.base_position.z(), 0.375, 1e-12);
  for (int leg = 0; leg < kNumLegs; ++leg) {
    EXPECT_NEAR(plant.nominalCommand().joint_position[hipIndex(leg)], 0.0, 1e-12);
    EXPECT_NEAR(plant.nominalCommand().joint_position[kneeIndex(leg)], 0.05, 1e-12);
    EXPECT_NEAR(t.joint_position[kneeIndex(leg)], 0.05, 1e-12);
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
  // Drive wheels are LF, RF, LR, RR.
  EXPECT_STREQ(kLegNames[static_cast<std::size_t>(kDriveWheelLegs[1])], "RF");
}

TEST(Plant, ResetPlacesTheBase) {
  Plant plant(scene(SceneKind::kFlat));
  plant.reset(1.0, -2.0, 0.5);
  const GroundTruth& t = plant.groundTruth();
  EXPECT_NEAR(t.base_position.x(), 1.0, 1e-12);
  EXPECT_NEAR(t.base_position.y(), -2.0, 1e-12);
  const Eigen::Vector3d x = t.base_orientation * Eigen::Vector3d::UnitX();
  EXPECT_NEAR(std::atan2(x.y(), x.x()), 0.5, 1e-12);
}

TEST(Plant, RaycastSeesTerrainOnly) {
  SceneConfig c = scene(SceneKind::kStep20);
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
  Plant plant(scene(SceneKind::kStep20));
  plant.reset(1.6, 0.0, 0.0, 0.20);  // wheels on the block top, 0.20 m up
  for (int k = 0; k < 1000; ++k) plant.step();
  const GroundTruth& t = plant.groundTruth();
  EXPECT_NEAR(t.base_position.z(), 0.20 + 0.375, 0.01);
  for (bool c : t.foot_contact) EXPECT_TRUE(c);
  EXPECT_EQ(plant.warningCount(), 0);
}

TEST(Plant, SensorsMatchGroundTruthAtRest) {
  Plant plant(scene(SceneKind::kFlat));
  for (int k = 0; k < 500; ++k) plant.step();
  const SensorReadings& s = plant.sensors();
  const GroundTruth& t = plant.groundTruth();
  EXPECT_NEAR((s.joint_position - t.joint_position).norm(), 0.0, 1e-4);
  EXPECT_NEAR(s.imu_acceleration.z(), 9.81, 0.05);  // specific force: +g at rest
  EXPECT_NEAR(s.imu_angular_velocity.norm(), 0.0, 1e-3);
  EXPECT_NEAR(s.imu_orientation.angularDistance(t.base_orientation), 0.0, 1e-3);
  for (int leg = 0; leg < kNumLegs; ++leg) {
    EXPECT_TRUE(s.foot_contact[static_cast<std::size_t>(leg)])
        << kLegNames[static_cast<std::size_t>(leg)];
    EXPECT_NEAR(s.foot_normal_force[static_cast<std::size_t>(leg)],
                t.foot_force[static_cast<std::size_t>(leg)].z(), 1.0);
  }
}

TEST(Plant, StepDoesNotAllocate) {
  Plant plant(scene(SceneKind::kStep20));
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
    Plant plant(scene(SceneKind::kFlat));
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
  Plant plant(scene(SceneKind::kFlat));
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
  Plant plant(scene(SceneKind::kFlat));
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
  expectLoadError(path, "no joint named 'LF_hip'");
}

TEST(PlantErrors, BadSceneParameter) {
  SceneConfig c;
  c.kind = SceneKind::kStep20;
  c.step1_height = -0.2;
  EXPECT_THROW(Plant plant(c), SimError);
}

}  // namespace
}  // namespace rollstep::sim
