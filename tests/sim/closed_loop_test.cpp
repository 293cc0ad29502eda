// Proof that the plant is right: closed-loop runs in MuJoCo (issue 2).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "rollstep/sim/plant.hpp"
#include "rollstep/sim/scenario.hpp"
#include "rollstep/sim/simple_controllers.hpp"

namespace rollstep::sim {
namespace {

constexpr double kGravity = 9.81;
constexpr double kDeg = M_PI / 180.0;

double weight(const Plant& plant) { return plant.totalMass() * kGravity; }

double normalForceSum(const GroundTruth& t) {
  double sum = 0.0;
  for (const Eigen::Vector3d& f : t.foot_force) sum += f.z();
  return sum;
}

// Stand at the nominal posture for 10 s on flat: base height within 1 cm of 0.375 m
// (minus contact penetration), drift < 1 cm, six wheels in contact, contact normal
// forces sum to the weight within 2 %.
TEST(ClosedLoop, StandTenSeconds) {
  Plant plant(SceneConfig{});
  StandController stand(plant.nominalCommand());
  const RunSummary s = runScenario(plant, stand, 10.0);
  const GroundTruth& t = plant.groundTruth();
  // Penetration: the lowest wheel centre is below its radius.
  double penetration = 0.0;
  for (int leg = 0; leg < plant.layout().numLegs(); ++leg) {
    penetration = std::max(
        penetration, plant.wheelRadius(leg) - t.wheel_center[static_cast<std::size_t>(leg)].z());
  }
  RecordProperty("base_height", std::to_string(t.base_position.z()));
  RecordProperty("penetration", std::to_string(penetration));
  std::printf(
      "stand: base z %.5f m, penetration %.5f m, drift %.5f m, normal sum %.2f N, weight %.2f N\n",
      t.base_position.z(), penetration, (t.base_position - s.start_position).head<2>().norm(),
      normalForceSum(t), weight(plant));
  EXPECT_NEAR(t.base_position.z(), 0.375 - penetration, 0.01);
  EXPECT_LT((t.base_position - s.start_position).head<2>().norm(), 0.01);
  for (int leg = 0; leg < plant.layout().numLegs(); ++leg) {
    EXPECT_TRUE(t.foot_contact[static_cast<std::size_t>(leg)])
        << plant.layout().legs[static_cast<std::size_t>(leg)].name;
    EXPECT_TRUE(plant.sensors().foot_contact[static_cast<std::size_t>(leg)]);
  }
  EXPECT_NEAR(normalForceSum(t), weight(plant), 0.02 * weight(plant));
  EXPECT_EQ(s.warnings, 0);
}

// Drive straight 2 m at 0.5 m/s, joints held: lateral drift < 5 cm, heading change
// < 2 deg, speed within 5 % after 1 s.
TEST(ClosedLoop, DriveStraightTwoMetres) {
  Plant plant(SceneConfig{});
  DriveController::Params p;
  p.speed = 0.5;
  DriveController drive(plant, p);
  const GroundTruth& t = plant.groundTruth();
  double worst_speed_error = 0.0;
  int steps = 0;
  while (t.base_position.x() < 2.0 && plant.time() < 8.0) {
    PlantCommand command;
    drive.compute(plant.time(), plant.sensors(), command);
    plant.setCommand(command);
    plant.step();
    ++steps;
    if (plant.time() >= 1.0) {
      const double forward = (t.base_orientation.conjugate() * t.base_linear_velocity).x();
      worst_speed_error = std::max(worst_speed_error, std::abs(forward - 0.5));
    }
  }
  const double yaw = std::abs(yawOf(t.base_orientation));
  std::printf(
      "drive: reached x %.3f at t %.3f s, lateral %.4f m, yaw %.3f deg, worst speed error %.4f "
      "m/s\n",
      t.base_position.x(), plant.time(), t.base_position.y(), yaw / kDeg, worst_speed_error);
  EXPECT_GE(t.base_position.x(), 2.0);
  EXPECT_LT(std::abs(t.base_position.y()), 0.05);
  EXPECT_LT(yaw, 2.0 * kDeg);
  EXPECT_LT(worst_speed_error, 0.05 * 0.5);
  EXPECT_EQ(plant.warningCount(), 0);
}

// Turn in place with opposite wheel speeds (left wheels back, right wheels forward at
// surface speed u). The four drive wheels sit at (+-a, +-b); their hinges only let them
// roll along x, so while the body turns they must also slide sideways. With equal loads
// and isotropic Coulomb friction the yaw rate that balances their friction moments is
//     yaw rate = u b / (a^2 + b^2)        (skid-steer kinematic prediction),
// with u = r * (mean measured wheel speed), i.e. from the encoders. (The naive
// differential-drive value u / b would need the corner wheels to roll sideways.) The
// omni wheels, on the centre line, must roll sideways freely: their sideways contact
// force stays a small share of their normal force.
TEST(ClosedLoop, TurnInPlace) {
  Plant plant(SceneConfig{});
  DriveController::Params p;
  p.speed = 0.0;
  p.turn_speed = 0.2;
  DriveController drive(plant, p);
  const double a = std::abs(plant.hipPosition(0).x());
  const double b = std::abs(plant.hipPosition(0).y());
  const double r = plant.wheelRadius(0);
  runScenario(plant, drive, 1.0);  // spin up

  const GroundTruth& t = plant.groundTruth();
  const Eigen::Vector3d start = t.base_position;
  double yaw_rate_sum = 0.0, wheel_speed_sum = 0.0, worst_omni_ratio = 0.0;
  double omni_lateral_speed_sum = 0.0;
  int lost_contact = 0;
  const int steps = 2000;
  PlantCommand command;
  for (int k = 0; k < steps; ++k) {
    drive.compute(plant.time(), plant.sensors(), command);
    plant.setCommand(command);
    plant.step();
    yaw_rate_sum += t.base_angular_velocity.z();
    const WheelVector& w = plant.sensors().wheel_velocity;  // LF, RF, LR, RR
    wheel_speed_sum += 0.25 * (w[1] + w[3] - w[0] - w[2]);
    for (int leg : {1, 4}) {  // MF, MR
      const Eigen::Vector3d& f = t.foot_force[static_cast<std::size_t>(leg)];
      worst_omni_ratio = std::max(worst_omni_ratio, f.head<2>().norm() / f.z());
    }
    // MF's sideways (base y) velocity: the body's yaw rate times a, through rolling.
    const Eigen::Vector3d v_base = t.base_orientation.conjugate() * t.base_linear_velocity;
    omni_lateral_speed_sum += v_base.y() + t.base_angular_velocity.z() * a;
    for (bool c : t.foot_contact) lost_contact += c ? 0 : 1;
  }
  const double yaw_rate = yaw_rate_sum / steps;
  const double predicted = r * (wheel_speed_sum / steps) * b / (a * a + b * b);
  const double predicted_from_command = p.turn_speed * b / (a * a + b * b);
  const double drift = (t.base_position - start).head<2>().norm();
  std::printf(
      "turn: yaw rate %.4f rad/s, skid-steer prediction %.4f (encoders) %.4f (commands), "
      "differential-drive %.4f; omni tangential/normal %.4f, MF sideways %.4f m/s; "
      "drift %.4f m; contact lost %d samples\n",
      yaw_rate, predicted, predicted_from_command, p.turn_speed / b, worst_omni_ratio,
      omni_lateral_speed_sum / steps, drift, lost_contact);
  EXPECT_NEAR(yaw_rate, predicted, 0.10 * predicted);
  EXPECT_NEAR(yaw_rate, predicted_from_command, 0.10 * predicted_from_command);
  EXPECT_NEAR(omni_lateral_speed_sum / steps, yaw_rate * a, 0.05 * yaw_rate * a);
  EXPECT_LT(worst_omni_ratio, 0.05);
  EXPECT_LT(drift, 0.02);
  EXPECT_EQ(lost_contact, 0);
  EXPECT_EQ(plant.warningCount(), 0);
}

// Raise the body by extending all knees 0.15 m, then lower it again.
TEST(ClosedLoop, RaiseAndLowerKnees) {
  Plant plant(SceneConfig{});
  StandController stand(plant.nominalCommand());
  runScenario(plant, stand, 1.0);
  const GroundTruth& t = plant.groundTruth();
  const double z0 = t.base_position.z();
  const double knee0 = t.joint_position[plant.layout().legs[0].joints[1]];

  // Smooth 1.5 s ramp up, 1 s hold, 1.5 s ramp down, 1 s hold.
  const auto knee_offset = [](double s) {
    const auto smooth = [](double u) {
      u = std::clamp(u, 0.0, 1.0);
      return u * u * (3 - 2 * u);
    };
    return 0.15 * (smooth(s / 1.5) - smooth((s - 2.5) / 1.5));
  };
  const double t0 = plant.time();
  double z_top = 0.0, max_tilt = 0.0, max_xy = 0.0;
  while (plant.time() < t0 + 5.0) {
    PlantCommand command = plant.nominalCommand();
    const double off = knee_offset(plant.time() - t0);
    for (int leg = 0; leg < plant.layout().numLegs(); ++leg)
      command.joint_position[plant.layout().legs[leg].joints[1]] += off;
    plant.setCommand(command);
    plant.step();
    if (std::abs(plant.time() - t0 - 2.5) < 1e-9) z_top = t.base_position.z();
    max_tilt =
        std::max(max_tilt, t.base_orientation.angularDistance(Eigen::Quaterniond::Identity()));
    max_xy = std::max(max_xy, t.base_position.head<2>().norm());
  }
  std::printf("knees: z0 %.4f, top %.4f (rise %.4f), end %.4f, max tilt %.3f deg, max xy %.4f\n",
              z0, z_top, z_top - z0, t.base_position.z(), max_tilt / kDeg, max_xy);
  EXPECT_NEAR(z_top - z0, 0.15, 0.005);
  EXPECT_NEAR(t.base_position.z(), z0, 0.002);
  EXPECT_NEAR(t.joint_position[plant.layout().legs[0].joints[1]], knee0, 0.001);
  EXPECT_LT(max_tilt, 1.0 * kDeg);
  EXPECT_LT(max_xy, 0.01);
  for (bool c : t.foot_contact) EXPECT_TRUE(c);
  EXPECT_EQ(plant.warningCount(), 0);
}

// Robustness: dropped from 0.10 m with the drive wheels spinning at 20 rad/s in the
// air, the robot lands, settles on its six wheels, and MuJoCo stays healthy.
TEST(ClosedLoop, DropWithSpinningWheels) {
  Plant plant(SceneConfig{});
  plant.reset(0.0, 0.0, 0.0, 0.10);
  PlantCommand command = plant.nominalCommand();
  command.wheel_velocity.setConstant(20.0);
  plant.setCommand(command);
  for (int k = 0; k < 100; ++k) plant.step();  // 0.1 s: still in the air
  const GroundTruth& t = plant.groundTruth();
  for (bool c : t.foot_contact) EXPECT_FALSE(c);
  EXPECT_NEAR(t.wheel_velocity[0], 20.0, 0.5);
  command.wheel_velocity.setZero();
  plant.setCommand(command);
  for (int k = 0; k < 3000; ++k) plant.step();
  for (bool c : t.foot_contact) EXPECT_TRUE(c);
  EXPECT_NEAR(t.base_position.z(), 0.375, 0.01);
  EXPECT_LT(t.base_linear_velocity.norm(), 0.01);
  EXPECT_LT(t.wheel_velocity.norm(), 0.01);
  EXPECT_EQ(plant.warningCount(), 0);
}

}  // namespace
}  // namespace rollstep::sim
