// The invariant EKF on generated data with exact kinematics (the Tachyon 3 URDF as a test
// model): settings file, standing still with biased sensors, rolling (rolling-contact model
// versus the naive fixed foot), rejected samples, and an allocation-free tick.
#include "rollstep/estimation/invariant_ekf.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "common/alloc_counter.hpp"
#include "rollstep/model/model.hpp"

namespace rollstep::estimation {
namespace {

const std::string kConfig = std::string(ROLLSTEP_ROBOTS_DIR) + "/tachyon3/estimation.yaml";

const model::Model& testModel() {
  static const model::Model m =
      model::buildModelFromUrdfFile(std::string(ROLLSTEP_ROBOTS_DIR) + "/tachyon3/tachyon3.urdf");
  return m;
}

std::vector<ContactSpec> sixWheels() {
  std::vector<ContactSpec> c;
  for (const char* leg : {"LF", "MF", "RF", "LR", "MR", "RR"}) {
    const bool omni = std::string(leg)[0] == 'M';
    c.push_back({std::string(leg) + "_wheel",
                 omni ? ContactKind::OmniWheel : ContactKind::DriveWheel, 0.075});
  }
  return c;
}

void expectError(const std::string& text, const std::string& fragment) {
  try {
    parseInekfSettings(text, "est.yaml");
    ADD_FAILURE() << "no error for:\n" << text;
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos)
        << "message: " << e.what() << "\nexpected: " << fragment;
  }
}

TEST(InekfSettings, ShippedFileAndRoundTrip) {
  const InekfSettings file = loadInekfSettings(kConfig);
  InekfSettings expected;
  expected.rolling_radius_offset = 0.0016;  // the file's calibration; the rest are defaults
  EXPECT_EQ(toYaml(file), toYaml(expected));
  InekfSettings s;
  s.rolling = false;
  s.gate_recovery_ticks = 7;
  s.contact_velocity_noise = 0.2;
  EXPECT_EQ(toYaml(parseInekfSettings(toYaml(s), "x")), toYaml(s));
}

TEST(InekfSettings, ErrorsNameFileLineAndKey) {
  expectError("contacts:\n  velocty_noise: 1\n",
              "est.yaml': line 2: unknown key 'contacts.velocty_noise' (known in contacts: ");
  expectError("imu:\n  gyro_noise: 0\n", "line 2: imu.gyro_noise: 0 is outside");
  expectError("contacts:\n  rolling: 0.5\n", "contacts.rolling: must be 0 or 1");
  expectError("contacts:\n  gate_recovery_ticks: 2.5\n",
              "line 2: contacts.gate_recovery_ticks: expected an integer, got '2.5'");
  expectError("limits: [1]\n", "line 1: limits: expected a mapping");
  expectError("gravity: 9.81\ngravity: 9.8\n", "line 2: gravity: given twice (first on line 1)");
  EXPECT_THROW(loadInekfSettings("/nonexistent.yaml"), std::runtime_error);
}

TEST(InvariantEkf, ConstructionErrors) {
  EXPECT_THROW(InvariantEkf(testModel(), {{"no_such_frame", ContactKind::Point, 0.0}}, {}),
               std::exception);
  EXPECT_THROW(InvariantEkf(testModel(), {{"LF_wheel", ContactKind::DriveWheel, 0.0}}, {}),
               std::invalid_argument);
  InekfSettings bad;
  bad.contact_velocity_noise = -1.0;
  EXPECT_THROW(InvariantEkf(testModel(), sixWheels(), bad), std::invalid_argument);
  std::vector<ContactSpec> many(kMaxContacts + 1, {"LF_wheel", ContactKind::Point, 0.0});
  EXPECT_THROW(InvariantEkf(testModel(), many, {}), std::invalid_argument);
}

// Generated samples of a robot with straight legs (q_J = 0) moving at a constant world
// velocity v_x on flat ground, wheels rolling (s = v_x / r), sensors biased.
struct Generator {
  Eigen::Vector3d gyro_bias{0.004, -0.003, 0.006};
  Eigen::Vector3d accel_bias{0.0, 0.0, 0.05};
  double v_x = 0.0;
  EstimatorInput at(const InvariantEkf& f, double t) const {
    EstimatorInput in = f.makeInput();
    in.time = t;
    in.gyro = gyro_bias;
    in.accel = Eigen::Vector3d(0, 0, 9.81) + accel_bias;
    for (std::size_t i = 0; i < f.contacts().size(); ++i) {
      in.contact[i] = true;
      in.wheel_velocity[i] = v_x / 0.075;
    }
    return in;
  }
};

TEST(InvariantEkf, StandingStillTheGyroBiasAndVerticalAccelBiasConverge) {
  InvariantEkf f(testModel(), sixWheels(), {});
  f.reset(0.0, Eigen::Quaterniond::Identity(), Eigen::Vector3d(0, 0, 0.4), Eigen::Vector3d::Zero());
  Generator gen;
  for (int k = 0; k <= 10000; ++k) ASSERT_TRUE(f.tick(gen.at(f, 1e-3 * k)));
  EXPECT_LT((f.gyroBias() - gen.gyro_bias).norm(), 2e-4) << f.gyroBias().transpose();
  EXPECT_NEAR(f.accelBias().z(), gen.accel_bias.z(), 5e-3);
  EXPECT_LT(f.velocity().norm(), 1e-3);
  EXPECT_LT((f.position() - Eigen::Vector3d(0, 0, 0.4)).norm(), 5e-3);
  // The bias is what the estimate removes from the gyro: the angular velocity is ~0.
  EXPECT_LT(f.angularVelocity().norm(), 2e-4);
  EXPECT_EQ(f.counters().contacts_rejected, 0u);
}

// Rolling at 0.5 m/s: the rolling-contact model follows; the naive fixed-foot model
// believes the robot stands still and its position lags by the distance travelled.
TEST(InvariantEkf, RollingContactVersusFixedFoot) {
  Generator gen;
  gen.v_x = 0.5;
  gen.gyro_bias.setZero();
  gen.accel_bias.setZero();
  InekfSettings naive_settings;
  naive_settings.rolling = false;
  naive_settings.gate_3dof = 0.0;  // no gate: show the model's answer, not the gate's
  naive_settings.gate_1dof = 0.0;
  InvariantEkf rolling(testModel(), sixWheels(), {});
  InvariantEkf naive(testModel(), sixWheels(), naive_settings);
  for (InvariantEkf* f : {&rolling, &naive}) {
    f->reset(0.0, Eigen::Quaterniond::Identity(), Eigen::Vector3d(0, 0, 0.4),
             Eigen::Vector3d(0.5, 0, 0));
    for (int k = 0; k <= 4000; ++k) f->tick(gen.at(*f, 1e-3 * k));
  }
  EXPECT_NEAR(rolling.velocity().x(), 0.5, 1e-3);
  EXPECT_NEAR(rolling.position().x(), 2.0, 0.01);
  EXPECT_LT(std::abs(naive.velocity().x()), 0.05);
  EXPECT_LT(naive.position().x(), 0.5);
}

// Velocity measurements leave the height unobservable; a map's ground height under the
// stance contacts makes it observable: an estimate started 3 cm high converges (5 cm fail
// the gate at the initial position uncertainty of 1 cm).
TEST(InvariantEkf, GroundHeightsMakeTheHeightObservable) {
  Generator gen;
  gen.gyro_bias.setZero();
  gen.accel_bias.setZero();
  InvariantEkf f(testModel(), sixWheels(), {});
  f.reset(0.0, Eigen::Quaterniond::Identity(), Eigen::Vector3d(0, 0, 0.4), Eigen::Vector3d::Zero());
  for (int k = 0; k <= 10; ++k) f.tick(gen.at(f, 1e-3 * k));
  const double ground = f.contactPoint(0).z();  // the true ground under the true pose
  for (int i = 1; i < 6; ++i) EXPECT_NEAR(f.contactPoint(i).z(), ground, 1e-9);
  for (const bool heights : {false, true}) {
    f.reset(0.0, Eigen::Quaterniond::Identity(), Eigen::Vector3d(0, 0, 0.43),
            Eigen::Vector3d::Zero());
    for (int k = 0; k <= 2000; ++k) {
      EstimatorInput in = gen.at(f, 1e-3 * k);
      if (heights) in.ground_height.fill(ground);
      f.tick(in);
    }
    if (heights) {
      EXPECT_NEAR(f.position().z(), 0.4, 2e-3);
    } else {
      EXPECT_NEAR(f.position().z(), 0.43, 2e-3);
    }
  }
}

// NaN and wildly out-of-range samples are rejected, counted and recorded; the estimate
// stays finite and keeps tracking.
TEST(InvariantEkf, BadSamplesAreRejectedAndTheEstimateStaysFinite) {
  InvariantEkf f(testModel(), sixWheels(), {});
  f.reset(0.0, Eigen::Quaterniond::Identity(), Eigen::Vector3d(0, 0, 0.4), Eigen::Vector3d::Zero());
  Generator gen;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  int k = 0;
  for (; k < 500; ++k) f.tick(gen.at(f, 1e-3 * k));
  EstimatorInput in = gen.at(f, 1e-3 * k++);
  in.gyro.x() = nan;
  EXPECT_FALSE(f.tick(in));
  in = gen.at(f, 1e-3 * k++);
  in.accel.z() = 1e9;
  EXPECT_FALSE(f.tick(in));
  in = gen.at(f, 1e-3 * k++);
  in.joint_position[3] = nan;
  EXPECT_FALSE(f.tick(in));
  in = gen.at(f, 1e-3 * k++);
  in.joint_velocity[0] = 1e6;
  EXPECT_FALSE(f.tick(in));
  in = gen.at(f, 1e-3 * k++);
  in.wheel_velocity[0] = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(f.tick(in));
  in = gen.at(f, 1e-3 * (k - 10));
  EXPECT_FALSE(f.tick(in));  // time running backwards
  EXPECT_EQ(f.counters().imu_rejected, 2u);
  EXPECT_EQ(f.counters().encoder_rejected, 3u);
  EXPECT_EQ(f.counters().time_rejected, 1u);
  ASSERT_EQ(f.events(), 6u);
  EXPECT_EQ(f.event(0).event, EstimatorEvent::ImuRejected);
  EXPECT_EQ(f.event(2).event, EstimatorEvent::EncoderRejected);
  EXPECT_EQ(f.event(5).event, EstimatorEvent::TimeRejected);
  EXPECT_STREQ(toString(f.event(5).event), "time_rejected");
  for (; k < 2000; ++k) ASSERT_TRUE(f.tick(gen.at(f, 1e-3 * k)));
  EXPECT_TRUE(f.finite());
  EXPECT_LT(f.velocity().norm(), 2e-3);
  EXPECT_LT(std::abs(f.position().z() - 0.4), 5e-3);
}

// A contact flag stuck on while the foot swings fast: its innovation fails the gate.
TEST(InvariantEkf, GateRejectsAContactThatMovesAndRecoversWhenAllDisagree) {
  InvariantEkf f(testModel(), sixWheels(), {});
  f.reset(0.0, Eigen::Quaterniond::Identity(), Eigen::Vector3d(0, 0, 0.4), Eigen::Vector3d::Zero());
  Generator gen;
  int k = 0;
  for (; k < 1000; ++k) f.tick(gen.at(f, 1e-3 * k));
  for (int i = 0; i < 100; ++i, ++k) {
    EstimatorInput in = gen.at(f, 1e-3 * k);
    in.joint_velocity[1] = 0.5;  // LF knee extends at 0.5 m/s: the LF wheel moves
    f.tick(in);
  }
  EXPECT_GE(f.counters().contacts_rejected, 100u);
  EXPECT_LT(f.velocity().norm(), 0.01);
  // Every contact says the robot moves at 1 m/s (the estimate says 0): rejected for
  // gate_recovery_ticks, then accepted.
  gen.v_x = 1.0;
  for (int i = 0; i < 200; ++i, ++k) f.tick(gen.at(f, 1e-3 * k));
  EXPECT_GE(f.counters().gate_recoveries, 1u);
  EXPECT_NEAR(f.velocity().x(), 1.0, 0.02);
}

TEST(InvariantEkf, TickDoesNotAllocate) {
  InvariantEkf f(testModel(), sixWheels(), {});
  Generator gen;
  gen.v_x = 0.2;
  std::vector<EstimatorInput> inputs;
  for (int k = 0; k < 200; ++k) inputs.push_back(gen.at(f, 1e-3 * k));
  inputs[50].gyro.x() = std::numeric_limits<double>::quiet_NaN();
  inputs[60].joint_position[0] = 1e9;
  test::AllocationGuard guard;
  for (const EstimatorInput& in : inputs) f.tick(in);
  EXPECT_EQ(guard.count(), 0u);
  EXPECT_TRUE(f.finite());
}

TEST(InekfSettings, EveryRobotsTuningLoads) {
  // Each robot folder's estimation.yaml reads without errors. wheelquad's wheels carry more
  // load than Tachyon 3's (127 N against 99 N) and roll on a smaller effective radius: its
  // own calibration (robots/wheelquad/estimation.yaml), not a copy.
  const InekfSettings tachyon3 =
      loadInekfSettings(std::string(ROLLSTEP_ROBOTS_DIR) + "/tachyon3/estimation.yaml");
  const InekfSettings wheelquad =
      loadInekfSettings(std::string(ROLLSTEP_ROBOTS_DIR) + "/wheelquad/estimation.yaml");
  EXPECT_GT(wheelquad.rolling_radius_offset, tachyon3.rolling_radius_offset);
  EXPECT_EQ(wheelquad.contact_velocity_noise, tachyon3.contact_velocity_noise);
}

}  // namespace
}  // namespace rollstep::estimation
