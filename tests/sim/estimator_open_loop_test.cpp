// The state estimator open loop on simulation data (issue 13): the plant with its sensor
// noise model drives on its wheels under DriveController (hips and knees held), the filter
// runs on the noisy readings, ground truth judges it. Consistency (NEES inside its
// chi-square band on average over seeded runs), bias convergence, and the rolling-contact
// model against the naive "stance foot is fixed" one.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "rollstep/centroidal/ocp_settings.hpp"
#include "rollstep/centroidal/robot.hpp"
#include "rollstep/lie/so3.hpp"
#include "rollstep/model/model.hpp"
#include "rollstep/sim/estimator_source.hpp"
#include "rollstep/sim/plant.hpp"
#include "rollstep/sim/scenario.hpp"
#include "rollstep/sim/simple_controllers.hpp"

namespace rollstep::sim {
namespace {

struct Robot {
  std::shared_ptr<const centroidal::CentroidalRobot> robot;
  std::vector<int> joint_map;
};

Robot tachyon3(const Plant& plant) {
  const centroidal::RobotOcpDescription d = centroidal::loadRobotOcpDescription(
      std::string(ROLLSTEP_ROBOTS_DIR) + "/tachyon3/centroidal.yaml");
  auto model = std::make_shared<const model::Model>(model::buildModelFromUrdfFile(d.urdf));
  std::vector<centroidal::ContactDescription> contacts;
  for (const std::string& f : d.contact_frames) {
    bool drive = false;
    for (const std::string& w : d.drive_wheels) drive = drive || w == f;
    contacts.push_back({f, drive});
  }
  Robot r;
  r.robot = std::make_shared<const centroidal::CentroidalRobot>(
      model, contacts, std::vector<std::array<int, 2>>{}, d.contact_offset);
  for (const std::string& name : model->jointNames) {
    r.joint_map.push_back(plant.layout().jointIndex(name));
  }
  return r;
}

struct OpenLoopRun {
  double distance = 0.0;        ///< [m] travelled (path length, ground truth)
  double position_error = 0.0;  ///< [m] horizontal, at the end
  double yaw_error_deg = 0.0;   ///< at the end
  double along_error = 0.0;     ///< [m] estimate - truth along world x, at the end
  double mean_nees = 0.0;       ///< of (phi, dv), over the run after the first second
  Eigen::Vector3d gyro_bias_error = Eigen::Vector3d::Zero();  ///< at the end
  Eigen::Vector3d gyro_bias_sigma = Eigen::Vector3d::Zero();  ///< filter's, at the end
  Eigen::Vector3d initial_gyro_bias = Eigen::Vector3d::Zero();
  double accel_bias_z_error = 0.0, accel_bias_z_sigma = 0.0, initial_accel_bias_z = 0.0;
  estimation::EstimatorCounters counters;
};

OpenLoopRun runOpenLoop(double duration, double speed, double turn_speed, int seed, bool rolling) {
  PlantOptions options;
  SensorNoiseConfig noise;
  noise.seed = seed;
  options.sensor_noise = noise;
  Plant plant(SceneConfig{}, options);
  static const Robot robot = tachyon3(plant);
  DriveController::Params params;
  params.speed = speed;
  params.turn_speed = turn_speed;
  params.acceleration = 0.5;
  params.start_time = 0.5;
  DriveController drive(plant, params);
  estimation::InekfSettings settings =
      estimation::loadInekfSettings(std::string(ROLLSTEP_ROBOTS_DIR) + "/tachyon3/estimation.yaml");
  settings.rolling = rolling;
  EstimatorSource source(plant, *robot.robot, robot.joint_map, settings);
  control::RobotState state = control::RobotState::zero(robot.robot->nj());
  OpenLoopRun out;
  out.initial_gyro_bias = plant.sensorModel()->gyroBias();
  out.initial_accel_bias_z = plant.sensorModel()->accelBias().z();
  PlantCommand command = plant.command();
  const GroundTruth& g = plant.groundTruth();
  const long steps = std::lround(duration / plant.controlPeriod());
  Eigen::Vector3d last = g.base_position;
  double nees = 0.0;
  long samples = 0;
  for (long k = 0; k < steps; ++k) {
    source.read(plant.time(), plant.sensors(), state);
    drive.compute(plant.time(), plant.sensors(), command);
    plant.setCommand(command);
    // NEES of the state at the sensors' time (the readings are of the last step).
    const estimation::InvariantEkf& f = source.filter();
    if (plant.time() > 1.0) {
      const Eigen::Matrix3d dR = g.base_orientation.toRotationMatrix() * f.rotation().transpose();
      const Eigen::Vector3d phi = lie::logSO3(Eigen::Quaterniond(dR));
      Eigen::Matrix<double, 6, 1> e;
      e.head<3>() = phi;
      e.tail<3>() = lie::leftJacobianInverseSO3(phi) * (g.base_linear_velocity - dR * f.velocity());
      Eigen::Matrix<double, 6, 6> P;
      P << f.covariance().block<3, 3>(0, 0), f.covariance().block<3, 3>(0, 3),
          f.covariance().block<3, 3>(3, 0), f.covariance().block<3, 3>(3, 3);
      nees += e.dot(P.ldlt().solve(e));
      ++samples;
    }
    plant.step();
    out.distance += (g.base_position - last).head<2>().norm();
    last = g.base_position;
  }
  source.read(plant.time(), plant.sensors(), state);
  const estimation::InvariantEkf& f = source.filter();
  out.position_error = (f.position() - g.base_position).head<2>().norm();
  out.along_error = f.position().x() - g.base_position.x();
  double dyaw = yawOf(f.orientation()) - yawOf(g.base_orientation);
  dyaw = std::remainder(dyaw, 2.0 * M_PI);
  out.yaw_error_deg = std::abs(dyaw) * 180.0 / M_PI;
  out.mean_nees = samples > 0 ? nees / samples : 0.0;
  out.gyro_bias_error = f.gyroBias() - plant.sensorModel()->gyroBias();
  out.gyro_bias_sigma = f.covariance().diagonal().segment<3>(9).cwiseSqrt();
  out.accel_bias_z_error = f.accelBias().z() - plant.sensorModel()->accelBias().z();
  out.accel_bias_z_sigma = std::sqrt(f.covariance()(14, 14));
  out.counters = f.counters();
  return out;
}

std::string describe(const OpenLoopRun& r) {
  char text[400];
  std::snprintf(text, sizeof text,
                "distance %.2f m, position error %.3f m (%.2f %%, along x %.3f m), yaw error %.3f "
                "deg, mean NEES "
                "%.2f, gyro bias error (%.2e %.2e %.2e) sigma (%.1e %.1e %.1e), contacts used "
                "%llu rejected %llu",
                r.distance, r.position_error, 100.0 * r.position_error / std::max(r.distance, 1e-9),
                r.along_error, r.yaw_error_deg, r.mean_nees, r.gyro_bias_error.x(),
                r.gyro_bias_error.y(), r.gyro_bias_error.z(), r.gyro_bias_sigma.x(),
                r.gyro_bias_sigma.y(), r.gyro_bias_sigma.z(),
                static_cast<unsigned long long>(r.counters.contacts_used),
                static_cast<unsigned long long>(r.counters.contacts_rejected));
  return text;
}

// Rolling at 0.5 m/s the stance wheels' contact points move with the wheels; a filter that
// holds them still sees a robot that barely moves. The rolling-contact model tracks it.
TEST(EstimatorOpenLoop, RollingContactsTrackWhereFixedFeetDrift) {
  const OpenLoopRun rolling = runOpenLoop(12.0, 0.5, 0.0, 1, true);
  const OpenLoopRun naive = runOpenLoop(12.0, 0.5, 0.0, 1, false);
  std::printf("rolling-contact model: %s\nnaive fixed-foot model: %s\n", describe(rolling).c_str(),
              describe(naive).c_str());
  RecordProperty("rolling_drift_percent",
                 std::to_string(100.0 * rolling.position_error / rolling.distance));
  RecordProperty("naive_drift_percent",
                 std::to_string(100.0 * naive.position_error / naive.distance));
  ASSERT_GT(rolling.distance, 4.5);
  EXPECT_LT(rolling.position_error, 0.02 * rolling.distance) << describe(rolling);
  EXPECT_LT(rolling.yaw_error_deg, 2.0) << describe(rolling);
  EXPECT_GT(naive.position_error, 0.2 * naive.distance) << describe(naive);
}

// NEES of (orientation, velocity), 6 dof, averaged over the run (after the first second)
// and over seeded runs of a drive with a turn: inside the two-sided 95 % chi-square band of
// the mean of M * 6 dof.
TEST(EstimatorOpenLoop, NeesInsideItsChiSquareBand) {
  const int runs = 4;
  double sum = 0.0;
  for (int s = 0; s < runs; ++s) {
    const OpenLoopRun r = runOpenLoop(6.0, 0.4, 0.05, 10 + s, true);
    std::printf("seed %d: %s\n", 10 + s, describe(r).c_str());
    sum += r.mean_nees;
  }
  const double mean = sum / runs;
  // chi2(24 dof): 2.5 % 12.40, 97.5 % 39.36; divided by M = 4.
  RecordProperty("mean_nees", std::to_string(mean));
  EXPECT_GT(mean, 12.40 / runs);
  EXPECT_LT(mean, 39.36 / runs);
}

// The gyroscope bias (observable through the stance legs' lever arms) and the vertical
// accelerometer bias (through gravity) converge to the sensors' true biases.
TEST(EstimatorOpenLoop, BiasesConverge) {
  const OpenLoopRun r = runOpenLoop(10.0, 0.3, 0.05, 3, true);
  std::printf("%s\ninitial gyro bias (%.2e %.2e %.2e), accel bias z %.3f, error %.4f sigma %.4f\n",
              describe(r).c_str(), r.initial_gyro_bias.x(), r.initial_gyro_bias.y(),
              r.initial_gyro_bias.z(), r.initial_accel_bias_z, r.accel_bias_z_error,
              r.accel_bias_z_sigma);
  for (int i = 0; i < 3; ++i) {
    EXPECT_LT(std::abs(r.gyro_bias_error[i]), 3.0 * r.gyro_bias_sigma[i] + 1e-5) << describe(r);
  }
  EXPECT_LT(r.gyro_bias_error.norm(), 0.3 * r.initial_gyro_bias.norm()) << describe(r);
  EXPECT_LT(std::abs(r.accel_bias_z_error), 0.3 * std::abs(r.initial_accel_bias_z)) << describe(r);
}

}  // namespace
}  // namespace rollstep::sim
