// The sensor noise model: its YAML file, its statistics, its seed, and the plant with it.
#include "rollstep/sim/sensor_model.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <stdexcept>
#include <string>

#include "common/alloc_counter.hpp"
#include "rollstep/estimation/invariant_ekf.hpp"
#include "rollstep/sim/plant.hpp"
#include "rollstep/sim/robot_folder.hpp"

namespace rollstep::sim {
namespace {

const std::string kConfig =
    std::string(ROLLSTEP_TEST_DATA_DIR) + "/../../robots/tachyon3/sensors.yaml";

void expectError(const std::string& text, const std::string& fragment) {
  try {
    parseSensorNoiseConfig(text, "test.yaml");
    ADD_FAILURE() << "no error for:\n" << text;
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos)
        << "message: " << e.what() << "\nexpected: " << fragment;
  }
}

TEST(SensorNoiseConfig, ShippedFileHoldsTheDefaults) {
  const SensorNoiseConfig file = loadSensorNoiseConfig(kConfig);
  EXPECT_EQ(file.toYaml(), SensorNoiseConfig{}.toYaml());
}

TEST(SensorNoiseConfig, EveryRobotsEstimatorModelsItsSensors) {
  // The estimator's noise model of each robot folder (estimation.yaml) is the noise its
  // simulated sensors have (sensors.yaml, else the defaults): a tuning copied from another
  // robot with other sensors shows here.
  int robots = 0;
  for (const auto& entry : std::filesystem::directory_iterator(ROLLSTEP_ROBOTS_DIR)) {
    if (!std::filesystem::is_regular_file(entry.path() / "estimation.yaml")) continue;
    const RobotFolder folder = findRobotFolder(entry.path().string());
    const SensorNoiseConfig sensors =
        folder.sensors.empty() ? SensorNoiseConfig{} : loadSensorNoiseConfig(folder.sensors);
    const estimation::InekfSettings est =
        estimation::loadInekfSettings((entry.path() / "estimation.yaml").string());
    SCOPED_TRACE(entry.path().string());
    EXPECT_EQ(est.gyro_noise, sensors.gyro_noise_density);
    EXPECT_EQ(est.accel_noise, sensors.accel_noise_density);
    EXPECT_EQ(est.gyro_bias_walk, sensors.gyro_bias_random_walk);
    EXPECT_EQ(est.accel_bias_walk, sensors.accel_bias_random_walk);
    EXPECT_EQ(est.joint_velocity_noise, sensors.joint_velocity_noise);
    EXPECT_EQ(est.wheel_velocity_noise, sensors.wheel_velocity_noise);
    ++robots;
  }
  EXPECT_GE(robots, 2);
}

TEST(SensorNoiseConfig, RoundTripAndPartialFiles) {
  SensorNoiseConfig c;
  c.seed = 42;
  c.gyro_noise_density = 1e-3;
  c.force_threshold = 30.0;
  EXPECT_EQ(parseSensorNoiseConfig(c.toYaml(), "x").toYaml(), c.toYaml());
  const SensorNoiseConfig p = parseSensorNoiseConfig("imu:\n  gyro_initial_bias: 0.01\n", "x");
  EXPECT_EQ(p.gyro_initial_bias, 0.01);
  EXPECT_EQ(p.accel_noise_density, SensorNoiseConfig{}.accel_noise_density);
}

TEST(SensorNoiseConfig, ErrorsNameFileLineAndKey) {
  expectError("imu:\n  gyro_nois_density: 1\n",
              "test.yaml': line 2: unknown key 'imu.gyro_nois_density' (known in imu: ");
  expectError("seed: 1\nbogus: 2\n", "line 2: unknown key 'bogus'");
  expectError("imu:\n  gyro_noise_density: -1\n", "line 2: imu.gyro_noise_density: -1 is outside");
  expectError("imu:\n  gyro_noise_density: .nan\n",
              "line 2: imu.gyro_noise_density: .nan is outside [0, 1]");
  expectError(
      "encoders:\n  wheel_velocity_noise: \"0.1\"\n",
      "line 2: encoders.wheel_velocity_noise: '0.1' is not a number (it is quoted or tagged)");
  expectError("contact_flags: 3\n", "line 1: contact_flags: expected a mapping");
  expectError("seed: 1\nseed: 2\n", "line 2: seed: given twice (first on line 1)");
  expectError("seed: 1.5\n", "seed: must be a non-negative integer");
  expectError("imu: [1, 2\n", "test.yaml'");
  EXPECT_THROW(loadSensorNoiseConfig("/nonexistent/sensors.yaml"), std::runtime_error);
}

/// The default robot's layout (Tachyon 3: six legs of a hinge and a slide, four drive wheels).
const PlantLayout& defaultLayout() {
  static const Plant plant{SceneConfig{}};
  return plant.layout();
}

SensorReadings idealAtRest() {
  SensorReadings r;
  r.resize(defaultLayout());
  r.imu_acceleration = Eigen::Vector3d(0, 0, 9.81);
  for (double& f : r.foot_normal_force) f = 100.0;
  r.joint_position.setConstant(0.123456789);
  r.wheel_velocity.setConstant(3.0);
  return r;
}

// White noise of the documented density and a bias that starts at the seed's draw and walks.
TEST(SensorModel, ImuNoiseHasTheConfiguredStatistics) {
  SensorNoiseConfig c;
  c.gyro_bias_random_walk = 0.0;
  c.accel_bias_random_walk = 0.0;
  const double dt = 1e-3;
  SensorModel model(c, dt, defaultLayout());
  const Eigen::Vector3d bg = model.gyroBias(), ba = model.accelBias();
  EXPECT_GT(bg.norm(), 0.0);
  const int n = 20000;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero(), sum2 = Eigen::Vector3d::Zero();
  for (int k = 0; k < n; ++k) {
    SensorReadings r = idealAtRest();
    model.apply(r);
    const Eigen::Vector3d e = r.imu_angular_velocity - bg;
    sum += e;
    sum2 += e.cwiseProduct(e);
    EXPECT_NEAR(r.imu_acceleration.z(), 9.81 + ba.z(), 6.0 * c.accel_noise_density / std::sqrt(dt));
  }
  const double expected = c.gyro_noise_density / std::sqrt(dt);
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(sum[i] / n, 0.0, 5.0 * expected / std::sqrt(n));
    EXPECT_NEAR(std::sqrt(sum2[i] / n), expected, 0.03 * expected);
  }
}

TEST(SensorModel, BiasRandomWalkGrowsLikeTheSquareRootOfTime) {
  SensorNoiseConfig c;
  c.gyro_initial_bias = 0.0;
  c.gyro_bias_random_walk = 1e-3;
  const int runs = 200, steps = 1000;  // 1 s each
  double var = 0.0;
  for (int s = 0; s < runs; ++s) {
    c.seed = s;
    SensorModel model(c, 1e-3, defaultLayout());
    for (int k = 0; k < steps; ++k) {
      SensorReadings r = idealAtRest();
      model.apply(r);
    }
    var += model.gyroBias().squaredNorm() / 3.0;
  }
  // Var(b(1 s)) = rw^2 * 1 s; 600 samples: +-15 % at 3 sigma.
  EXPECT_NEAR(std::sqrt(var / runs), 1e-3, 0.15e-3);
}

TEST(SensorModel, EncodersAreQuantised) {
  SensorNoiseConfig c;
  SensorModel model(c, 1e-3, defaultLayout());
  SensorReadings r = idealAtRest();
  model.apply(r);
  for (const PlantLayout::Leg& leg : defaultLayout().legs) {
    const double hip = r.joint_position[leg.joints[0]], knee = r.joint_position[leg.joints[1]];
    EXPECT_NEAR(std::remainder(hip, c.hip_resolution), 0.0, 1e-12);
    EXPECT_NEAR(std::remainder(knee, c.knee_resolution), 0.0, 1e-15);
    EXPECT_LE(std::abs(hip - 0.123456789), 0.5 * c.hip_resolution + 1e-15);
    EXPECT_LE(std::abs(knee - 0.123456789), 0.5 * c.knee_resolution + 1e-15);
  }
}

// Far from the threshold the flag is certain; at the threshold it chatters (about half on).
TEST(SensorModel, ContactFlagsChatterNearTheThreshold) {
  SensorNoiseConfig c;
  SensorModel model(c, 1e-3, defaultLayout());
  int on_far = 0, on_near = 0, flips = 0;
  bool last = false;
  const int n = 4000;
  for (int k = 0; k < n; ++k) {
    SensorReadings r = idealAtRest();
    r.foot_normal_force[0] = c.force_threshold + 10.0 * c.force_noise;
    r.foot_normal_force[1] = c.force_threshold;
    model.apply(r);
    on_far += r.foot_contact[0];
    on_near += r.foot_contact[1];
    if (k > 0 && r.foot_contact[1] != last) ++flips;
    last = r.foot_contact[1];
  }
  EXPECT_EQ(on_far, n);
  EXPECT_NEAR(on_near, n / 2, n / 10);
  EXPECT_GT(flips, n / 4);
}

TEST(SensorModel, SeedReproducesAndApplyDoesNotAllocate) {
  SensorNoiseConfig c;
  c.seed = 7;
  SensorModel a(c, 1e-3, defaultLayout()), b(c, 1e-3, defaultLayout());
  c.seed = 8;
  SensorModel other(c, 1e-3, defaultLayout());
  SensorReadings ra = idealAtRest(), rb = idealAtRest(), ro = idealAtRest();
  {
    test::AllocationGuard guard;
    for (int k = 0; k < 100; ++k) {
      a.apply(ra);
      b.apply(rb);
      other.apply(ro);
    }
    EXPECT_EQ(guard.count(), 0u);
  }
  EXPECT_EQ(ra.imu_angular_velocity, rb.imu_angular_velocity);
  EXPECT_EQ(ra.joint_velocity, rb.joint_velocity);
  EXPECT_NE(ra.imu_angular_velocity, ro.imu_angular_velocity);
  a.reset();
  SensorReadings r1 = idealAtRest(), r2 = idealAtRest();
  SensorModel fresh(a.config(), 1e-3, defaultLayout());
  a.apply(r1);
  fresh.apply(r2);
  EXPECT_EQ(r1.imu_acceleration, r2.imu_acceleration);
  EXPECT_THROW(SensorModel(c, 0.0, defaultLayout()), std::invalid_argument);
}

// In the plant: the readings are the ideal ones corrupted (ground truth untouched), and the
// same seed gives the same run.
TEST(SensorModel, PlantReadingsAreNoisyAndReproducible) {
  PlantOptions options;
  options.sensor_noise = SensorNoiseConfig{};
  Plant noisy(SceneConfig{}, options), again(SceneConfig{}, options), ideal(SceneConfig{});
  ASSERT_NE(noisy.sensorModel(), nullptr);
  EXPECT_EQ(ideal.sensorModel(), nullptr);
  for (int k = 0; k < 200; ++k) {
    noisy.step();
    again.step();
    ideal.step();
  }
  const SensorReadings& n = noisy.sensors();
  const SensorReadings& i = ideal.sensors();
  EXPECT_EQ(n.imu_angular_velocity, again.sensors().imu_angular_velocity);
  EXPECT_EQ(n.joint_position, again.sensors().joint_position);
  EXPECT_NE(n.imu_angular_velocity, i.imu_angular_velocity);
  EXPECT_NEAR(
      (n.imu_angular_velocity - i.imu_angular_velocity - noisy.sensorModel()->gyroBias()).norm(),
      0.0, 6.0 * std::sqrt(3.0) * 2.4e-4 / std::sqrt(1e-3));
  EXPECT_EQ(noisy.groundTruth().joint_position, ideal.groundTruth().joint_position);
  for (const bool contact : n.foot_contact) EXPECT_TRUE(contact);
}

}  // namespace
}  // namespace rollstep::sim
