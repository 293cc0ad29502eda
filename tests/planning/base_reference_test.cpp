// Base reference: straight, turning and climbing; the pose on SE(3) against the
// integrated body-frame command; heights following the terrain; bad input; no
// allocation.
#include "rollstep/planning/base_reference.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "common/alloc_counter.hpp"
#include "rollstep/lie/se3.hpp"

namespace {

using Eigen::Vector2d;
using Eigen::Vector3d;
using namespace rollstep;
using planning::BaseReference;
using planning::BaseReferenceConfig;
using planning::BaseVelocityCommand;

const planning::TerrainBox kFloor{-5.0, 10.0, -3.0, 3.0, 0.0};

double yawOf(const lie::SE3& x) {
  const Eigen::Matrix3d r = x.rotation.toRotationMatrix();
  return std::atan2(r(1, 0), r(0, 0));
}

lie::SE3 startPose(double x, double y, double yaw) {
  return lie::SE3(Vector3d(x, y, 0.9),
                  Eigen::Quaterniond(Eigen::AngleAxisd(yaw, Vector3d::UnitZ())) *
                      Eigen::Quaterniond(Eigen::AngleAxisd(0.2, Vector3d::UnitX())));
}

TEST(BaseReference, StraightAlongTheHeading) {
  const planning::TerrainModel flat = planning::terrainFromBoxes(kFloor, 0.05, {});
  BaseReference ref(flat, {0.375, {Vector2d::Zero()}});
  const double yaw = 0.4;
  ref.reset(2.0, startPose(1.0, -0.5, yaw), {0.5, 0.0, 0.0});
  for (double t : {2.0, 2.7, 4.0}) {
    const lie::SE3 p = ref.poseAt(t);
    const double s = 0.5 * (t - 2.0);
    EXPECT_NEAR(p.translation.x(), 1.0 + s * std::cos(yaw), 1e-12);
    EXPECT_NEAR(p.translation.y(), -0.5 + s * std::sin(yaw), 1e-12);
    EXPECT_NEAR(p.translation.z(), 0.05 + 0.375, 1e-12);
    // Roll and pitch of the start are dropped; the yaw is kept.
    EXPECT_TRUE(
        p.rotation.isApprox(Eigen::Quaterniond(Eigen::AngleAxisd(yaw, Vector3d::UnitZ())), 1e-12));
  }
  // Lateral command: moves along the body's y.
  ref.reset(0.0, startPose(0.0, 0.0, M_PI / 2), {0.0, 0.2, 0.0});
  EXPECT_TRUE(ref.poseAt(1.0).translation.head<2>().isApprox(Vector2d(-0.2, 0.0), 1e-12));
  EXPECT_TRUE(ref.twist().isApprox((lie::Vector6d() << 0, 0.2, 0, 0, 0, 0).finished()));
}

TEST(BaseReference, TurningFollowsACircleAndMatchesIntegration) {
  const planning::TerrainModel flat = planning::terrainFromBoxes(kFloor, 0.0, {});
  BaseReference ref(flat, {0.375, {Vector2d::Zero()}});
  const double v = 0.4, w = 0.5;
  ref.reset(0.0, startPose(0.0, 0.0, 0.0), {v, 0.0, w});
  // Circle of radius v / w centred at (0, v / w).
  const double radius = v / w;
  for (double t = 0.0; t < 10.0; t += 0.37) {
    const lie::SE3 p = ref.poseAt(t);
    EXPECT_NEAR(p.translation.x(), radius * std::sin(w * t), 1e-12);
    EXPECT_NEAR(p.translation.y(), radius * (1.0 - std::cos(w * t)), 1e-12);
    EXPECT_NEAR(std::remainder(yawOf(p) - w * t, 2 * M_PI), 0.0, 1e-12);
  }
  // Against explicit integration of the body-frame command in small steps on SE(3).
  lie::SE3 x = ref.planarPoseAt(0.0);
  const double h = 1e-3;
  for (int k = 0; k < 3000; ++k) x = lie::plus(x, h * ref.twist());
  EXPECT_TRUE(x.isApprox(ref.planarPoseAt(3.0), 1e-9));
  // The world velocity is the body command rotated by the yaw.
  const double t = 2.3, e = 1e-6;
  const Vector3d vel = (ref.poseAt(t + e).translation - ref.poseAt(t - e).translation) / (2 * e);
  const Vector3d body = ref.poseAt(t).rotation.conjugate() * vel;
  EXPECT_NEAR(body.x(), v, 1e-7);
  EXPECT_NEAR(body.y(), 0.0, 1e-7);
}

TEST(BaseReference, ClimbingFollowsTheTerrain) {
  const planning::TerrainModel step =
      planning::terrainFromBoxes(kFloor, 0.0, {{1.0, 2.2, -3.0, 3.0, 0.20}});
  // Under the base only: the height steps at the edge.
  BaseReference centre(step, {0.375, {Vector2d::Zero()}});
  centre.reset(0.0, startPose(0.0, 0.0, 0.0), {0.5, 0.0, 0.0});
  EXPECT_NEAR(centre.poseAt(1.9).translation.z(), 0.375, 1e-12);  // x = 0.95
  EXPECT_NEAR(centre.poseAt(2.1).translation.z(), 0.575, 1e-12);  // x = 1.05
  EXPECT_NEAR(centre.poseAt(4.5).translation.z(), 0.375, 1e-12);  // x = 2.25, off the block
  // Under six nominal feet (the test plays the robot: rows at x = +-0.33, y = 0, +-0.22):
  // the height rises by half the step per row that crosses the edge.
  BaseReferenceConfig feet{
      0.375,
      {{0.33, 0.22}, {0.33, 0.0}, {0.33, -0.22}, {-0.33, 0.22}, {-0.33, 0.0}, {-0.33, -0.22}}};
  BaseReference avg(step, feet);
  avg.reset(0.0, startPose(0.0, 0.0, 0.0), {0.5, 0.0, 0.0});
  EXPECT_NEAR(avg.poseAt(1.0).translation.z(), 0.375, 1e-12);        // x = 0.5: none on it
  EXPECT_NEAR(avg.poseAt(1.6).translation.z(), 0.375 + 0.1, 1e-12);  // x = 0.8: front row
  EXPECT_NEAR(avg.poseAt(3.0).translation.z(), 0.575, 1e-12);        // x = 1.5: all
  EXPECT_NEAR(avg.poseAt(3.8).translation.z(), 0.375 + 0.1, 1e-12);  // x = 1.9: rear row
  // Monotone up while climbing.
  double prev = -1.0;
  for (double t = 0.0; t < 3.0; t += 0.01) {
    const double z = avg.poseAt(t).translation.z();
    EXPECT_GE(z, prev);
    prev = z;
  }
  EXPECT_TRUE(avg.worldPoint({0.33, 0.22}, 2.0).isApprox(Vector2d(1.33, 0.22), 1e-12));
}

TEST(BaseReference, EnvelopeRisesBeforeAStepUpAndComesDownAfterAStepDown) {
  // Shrunk by 0.085 m like the scenes' regions: a gap of 0.17 m at each edge.
  const planning::TerrainModel step =
      planning::terrainFromBoxes(kFloor, 0.0, {{1.0, 2.2, -3.0, 3.0, 0.20}}, 0.085);
  // Full height within 0.25 m, a grade of 0.5 beyond.
  BaseReferenceConfig feet{0.375, {{0.33, 0.0}, {-0.33, 0.0}}, 0.25, 0.5};
  BaseReference ref(step, feet);
  ref.reset(0.0, startPose(0.0, 0.0, 0.0), {0.5, 0.0, 0.0});
  const auto z = [&](double x) { return ref.poseAt(x / 0.5).translation.z() - 0.375; };
  // The block's region begins at 1.085: the front foot (base + 0.33) 0.65 m before it sees
  // nothing, then the ramp up to the full 0.2 m when the foot is 0.25 m before it.
  const double up = 1.085 - 0.33;
  EXPECT_NEAR(z(0.0), 0.0, 1e-12);
  EXPECT_NEAR(z(up - 0.7), 0.0, 1e-12);
  EXPECT_NEAR(z(up - 0.55), 0.2 - 0.5 * 0.3, 1e-12);
  EXPECT_NEAR(z(up - 0.4), 0.2 - 0.5 * 0.15, 1e-12);
  // Full height from 0.25 m before the block (front foot) to 0.25 m after its last point
  // (rear foot at base - 0.33 beyond the region's end 2.115).
  const double down = 2.115 + 0.33;
  for (double x = up - 0.25; x <= down + 0.25; x += 0.01) {
    EXPECT_NEAR(z(x), 0.2, 1e-9) << "x " << x;
  }
  EXPECT_NEAR(z(down + 0.35), 0.2 - 0.5 * 0.1, 1e-12);
  EXPECT_NEAR(z(down + 0.7), 0.0, 1e-12);
  // Never below the mean rule, continuous (a ramp, no jump) along the way.
  BaseReference mean(step, {0.375, {{0.33, 0.0}, {-0.33, 0.0}}});
  mean.reset(0.0, startPose(0.0, 0.0, 0.0), {0.5, 0.0, 0.0});
  double prev = z(0.0);
  for (double x = 0.0; x < 3.5; x += 0.005) {
    EXPECT_GE(z(x) + 1e-12, mean.poseAt(x / 0.5).translation.z() - 0.375);
    EXPECT_LE(std::abs(z(x) - prev), 0.5 * 0.005 + 1e-9) << "x " << x;
    prev = z(x);
  }
  // Standing still: no direction of travel, the highest terrain under the samples.
  ref.reset(0.0, startPose(0.6, 0.0, 0.0), {0.0, 0.0, 0.0});
  EXPECT_NEAR(ref.poseAt(3.0).translation.z(), 0.375, 1e-12);
  ref.reset(0.0, startPose(0.8, 0.0, 0.0), {0.0, 0.0, 0.0});  // front foot on the block
  EXPECT_NEAR(ref.poseAt(3.0).translation.z(), 0.575, 1e-12);
}

TEST(BaseReference, OnASlopeTheBodyStandsItsNominalHeightAboveTheSurfaceAtItsCentre) {
  // An 8 deg plane rising along +x: the wheels follow it, so neither the front feet's
  // higher ground nor the plane's rise within the reach ahead lifts the body (that
  // overextended the rear legs up a ramp); up, down and across the slope.
  const double grade = std::tan(8.0 * M_PI / 180.0);
  const Vector3d n = Vector3d(-grade, 0.0, 1.0).normalized();
  const planning::TerrainModel slope({planning::ConvexRegion::fromPolygon(
      {{-5.0, -5.0}, {10.0, -5.0}, {10.0, 5.0}, {-5.0, 5.0}}, 0.0, n)});
  BaseReferenceConfig feet{
      0.375, {{0.33, 0.22}, {0.33, -0.22}, {-0.33, 0.22}, {-0.33, -0.22}}, 0.45, 0.5};
  for (const double yaw : {0.0, M_PI, 0.5 * M_PI}) {
    BaseReference ref(slope, feet);
    ref.reset(0.0, startPose(0.0, 0.0, yaw), {0.5, 0.0, 0.0});
    for (double t = 0.0; t < 4.0; t += 0.25) {
      const lie::SE3 p = ref.poseAt(t);
      EXPECT_NEAR(p.translation.z() - 0.375, slope.heightAt(p.translation.head<2>()), 1e-9)
          << "yaw " << yaw << " t " << t;
    }
  }
  // Level ground keeps the plain envelope (the step test above), bit for bit: a level
  // plane gives exactly its height.
  const planning::TerrainModel level({planning::ConvexRegion::fromPolygon(
      {{-5.0, -5.0}, {10.0, -5.0}, {10.0, 5.0}, {-5.0, 5.0}}, 0.1)});
  BaseReference flat(level, feet);
  flat.reset(0.0, startPose(0.0, 0.0, 0.0), {0.5, 0.0, 0.0});
  EXPECT_EQ(flat.poseAt(1.0).translation.z(), 0.375 + 0.1);
}

TEST(BaseReference, VelocityCarriesTheRateOfTheHeightRamp) {
  const planning::TerrainModel step =
      planning::terrainFromBoxes(kFloor, 0.0, {{1.0, 2.2, -3.0, 3.0, 0.20}}, 0.085);
  BaseReferenceConfig config{0.375, {{0.33, 0.0}, {-0.33, 0.0}}, 0.25, 0.5};
  config.height_rate = true;
  BaseReference ref(step, config);
  const double speed = 0.4;
  ref.reset(0.0, startPose(0.0, 0.0, 0.0), {speed, 0.0, 0.0});
  const double up = 1.085 - 0.33;  // front foot at the block's region (previous test)
  const double down = 2.115 + 0.33;
  const auto at = [&](double x) { return x / speed; };
  // The planar part is the command's, whatever the height does.
  for (const double x : {0.0, up - 0.5, up, down + 0.4}) {
    const lie::Vector6d v = ref.velocityAt(at(x));
    EXPECT_EQ(v[0], speed);
    EXPECT_EQ(v[1], 0.0);
    EXPECT_EQ(v[5], 0.0);
  }
  // Level before the ramp and on the block; grade x speed on the ramps, up then down.
  EXPECT_NEAR(ref.velocityAt(at(up - 0.8)).z(), 0.0, 1e-12);
  EXPECT_NEAR(ref.velocityAt(at(up - 0.45)).z(), 0.5 * speed, 1e-9);
  EXPECT_NEAR(ref.velocityAt(at(up + 0.5)).z(), 0.0, 1e-9);
  EXPECT_NEAR(ref.velocityAt(at(down + 0.45)).z(), -0.5 * speed, 1e-9);
  EXPECT_NEAR(ref.velocityAt(at(down + 0.9)).z(), 0.0, 1e-12);
  // Everywhere it is the rate of poseAt's height (central differences; the kinks of the
  // ramp are where the two may differ, by at most the grade x speed).
  const double h = 1e-4;
  for (double x = 0.0; x < 3.5; x += 0.013) {
    const double rate =
        (ref.poseAt(at(x) + h).translation.z() - ref.poseAt(at(x) - h).translation.z()) / (2 * h);
    EXPECT_NEAR(ref.velocityAt(at(x)).z(), rate, 0.5 * speed + 1e-9) << "x " << x;
    const bool near_kink = std::abs(x - (up - 0.65)) < 0.02 || std::abs(x - (up - 0.25)) < 0.02 ||
                           std::abs(x - (down + 0.25)) < 0.02 || std::abs(x - (down + 0.65)) < 0.02;
    if (!near_kink) {
      EXPECT_NEAR(ref.velocityAt(at(x)).z(), rate, 1e-6) << "x " << x;
    }
  }
  // Off, or without a ramp (height_reach 0: the height steps at an edge), no vertical rate.
  config.height_rate = false;
  BaseReference off(step, config);
  off.reset(0.0, startPose(0.0, 0.0, 0.0), {speed, 0.0, 0.0});
  EXPECT_EQ(off.velocityAt(at(up - 0.45)), off.twistAt(at(up - 0.45)));
  BaseReferenceConfig mean_config{0.375, {{0.33, 0.0}, {-0.33, 0.0}}};
  mean_config.height_rate = true;
  BaseReference mean(step, mean_config);
  mean.reset(0.0, startPose(0.0, 0.0, 0.0), {speed, 0.0, 0.0});
  for (double x = 0.0; x < 3.5; x += 0.013) EXPECT_EQ(mean.velocityAt(at(x)).z(), 0.0);
}

TEST(BaseReference, CommandScheduleChainsTheSegments) {
  const planning::TerrainModel flat = planning::terrainFromBoxes(kFloor, 0.0, {});
  BaseReference ref(flat, {0.375, {Vector2d::Zero()}});
  ref.resetSchedule(1.0, startPose(0.5, 0.0, 0.0),
                    std::vector<planning::TimedBaseCommand>{
                        {0.0, {0.2, 0.0, 0.0}}, {2.0, {0.0, 0.0, 0.5}}, {4.0, {-0.1, 0.0, 0.0}}});
  EXPECT_NEAR(ref.poseAt(2.0).translation.x(), 0.7, 1e-12);
  EXPECT_NEAR(ref.poseAt(3.0).translation.x(), 0.9, 1e-12);  // end of segment 0
  EXPECT_NEAR(ref.poseAt(4.0).translation.x(), 0.9, 1e-12);  // turning on the spot
  EXPECT_NEAR(yawOf(ref.poseAt(5.0)), 1.0, 1e-12);
  const lie::SE3 p = ref.poseAt(6.0);  // 1 s backwards along the heading 1 rad
  EXPECT_NEAR(p.translation.x(), 0.9 - 0.1 * std::cos(1.0), 1e-12);
  EXPECT_NEAR(p.translation.y(), -0.1 * std::sin(1.0), 1e-12);
  EXPECT_DOUBLE_EQ(ref.twistAt(2.9)[0], 0.2);
  EXPECT_DOUBLE_EQ(ref.twistAt(3.5)[5], 0.5);
  EXPECT_DOUBLE_EQ(ref.twistAt(7.0)[0], -0.1);
  EXPECT_DOUBLE_EQ(ref.twistAt(0.0)[0], 0.2);  // before the start: the first segment
  const auto bad = [&](std::vector<planning::TimedBaseCommand> s, const std::string& what) {
    try {
      ref.resetSchedule(0.0, lie::SE3(), s);
      ADD_FAILURE() << "no exception, expected " << what;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
    }
  };
  bad({}, "schedule.size() = 0");
  bad({{0.5, {}}}, "schedule[0].time = 0.5");
  bad({{0.0, {}}, {0.0, {}}}, "schedule[1].time = 0 (times must increase)");
  bad({{0.0, {}}, {1.0, {std::numeric_limits<double>::quiet_NaN(), 0.0, 0.0}}},
      "schedule[1].v_x = nan");
}

TEST(BaseReference, FollowKeepsTheReferenceOnALeashOfTheRobot) {
  const planning::TerrainModel step =
      planning::terrainFromBoxes(kFloor, 0.0, {{1.0, 2.2, -3.0, 3.0, 0.20}});
  BaseReference ref(step, {0.375, {Vector2d::Zero()}});
  const std::vector<planning::TimedBaseCommand> schedule{{0.0, {0.2, 0.0, 0.1}},
                                                         {3.0, {-0.1, 0.05, 0.0}}};
  ref.resetSchedule(0.0, startPose(0.0, 0.0, 0.0), schedule);
  BaseReference open_loop(step, {0.375, {Vector2d::Zero()}});
  open_loop.resetSchedule(0.0, startPose(0.0, 0.0, 0.0), schedule);

  // Within the leash: nothing moves.
  const lie::SE3 at2 = ref.poseAt(2.0);
  lie::SE3 robot(at2.translation + Vector3d(-0.03, 0.02, 0.1), at2.rotation);
  EXPECT_FALSE(ref.follow(2.0, robot, 0.05, 0.1));
  EXPECT_TRUE(ref.correction().translation.isZero(0.0));

  // 0.3 m behind and 0.2 rad off: the reference at t comes to 0.05 m ahead of the robot
  // along the same direction, and 0.1 rad off in yaw, the same side.
  const Eigen::Quaterniond yaw_off(Eigen::AngleAxisd(-0.2, Vector3d::UnitZ()));
  robot = lie::SE3(at2.translation - at2.rotation * Vector3d(0.3, 0.0, 0.0) + Vector3d(0, 0, 0.1),
                   at2.rotation * yaw_off);
  EXPECT_TRUE(ref.follow(2.0, robot, 0.05, 0.1));
  const lie::SE3 moved = ref.poseAt(2.0);
  const Vector2d lead = moved.translation.head<2>() - robot.translation.head<2>();
  EXPECT_NEAR(lead.norm(), 0.05, 1e-12);
  EXPECT_NEAR(lead.normalized().dot((at2.translation - robot.translation).head<2>().normalized()),
              1.0, 1e-9);
  EXPECT_NEAR(std::remainder(yawOf(moved) - yawOf(robot), 2 * M_PI), 0.1, 1e-12);
  // The whole reference moved rigidly: the same motion at every time, both segments; the
  // local command is unchanged, and the height follows the terrain under the moved pose.
  const lie::SE3 c = ref.correction();
  for (double t : {0.0, 1.0, 2.5, 4.0, 6.0}) {
    const lie::SE3 expected = c * open_loop.planarPoseAt(t);
    EXPECT_TRUE(ref.planarPoseAt(t).translation.isApprox(expected.translation, 1e-12));
    EXPECT_TRUE(ref.planarPoseAt(t).rotation.isApprox(expected.rotation, 1e-12));
    EXPECT_TRUE(ref.twistAt(t).isApprox(open_loop.twistAt(t)));
    const Vector2d xy = ref.planarPoseAt(t).translation.head<2>();
    EXPECT_NEAR(ref.poseAt(t).translation.z(), step.heightAt(xy) + 0.375, 1e-12);
  }
  // Only the distance on the leash (yaw free), and only the yaw.
  ref.resetSchedule(0.0, startPose(0.0, 0.0, 0.0), schedule);
  EXPECT_TRUE(ref.follow(2.0, robot, 0.05, 0.0));
  EXPECT_NEAR(std::remainder(yawOf(ref.poseAt(2.0)) - yawOf(at2), 2 * M_PI), 0.0, 1e-12);
  ref.resetSchedule(0.0, startPose(0.0, 0.0, 0.0), schedule);
  EXPECT_TRUE(ref.follow(2.0, robot, 0.0, 0.1));
  EXPECT_TRUE(ref.poseAt(2.0).translation.isApprox(at2.translation, 1e-12));
  EXPECT_NEAR(std::remainder(yawOf(ref.poseAt(2.0)) - yawOf(robot), 2 * M_PI), 0.1, 1e-12);

  // Another copy takes the correction; a reset drops it; bad values are refused.
  ref.resetSchedule(0.0, startPose(0.0, 0.0, 0.0), schedule);
  ASSERT_TRUE(ref.follow(2.0, robot, 0.05, 0.1));
  EXPECT_TRUE(open_loop.setCorrection(ref.correction()));
  EXPECT_TRUE(open_loop.poseAt(3.5).translation.isApprox(ref.poseAt(3.5).translation, 1e-12));
  lie::SE3 bad = ref.correction();
  bad.translation.x() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(open_loop.setCorrection(bad));
  EXPECT_TRUE(open_loop.poseAt(3.5).translation.isApprox(ref.poseAt(3.5).translation, 1e-12));
  ref.resetSchedule(0.0, startPose(0.0, 0.0, 0.0), schedule);
  EXPECT_TRUE(ref.poseAt(2.0).translation.isApprox(at2.translation, 1e-12));
  EXPECT_THROW(ref.follow(std::numeric_limits<double>::quiet_NaN(), robot, 0.05, 0.1),
               std::invalid_argument);
  robot.translation.y() = std::numeric_limits<double>::infinity();
  EXPECT_THROW(ref.follow(2.0, robot, 0.05, 0.1), std::invalid_argument);

  // No allocation.
  robot.translation.y() = 0.0;
  test::AllocationGuard guard;
  for (int k = 0; k < 100; ++k) ref.follow(0.02 * k, robot, 0.05, 0.1);
  EXPECT_EQ(guard.count(), 0u);
}

TEST(BaseReference, LateralLeashKeepsOnlyTheSidewaysOffset) {
  const planning::TerrainModel flat = planning::terrainFromBoxes(kFloor, 0.0, {});
  BaseReference ref(flat, {0.375, {Vector2d::Zero()}});
  // Heading 30 deg, 0.15 m/s forward and 0.1 m/s to the left.
  const double heading = M_PI / 6.0;
  ref.reset(0.0, startPose(0.0, 0.0, heading), {0.15, 0.1, 0.0});
  const lie::SE3 at4 = ref.planarPoseAt(4.0);
  const Vector2d ahead(std::cos(heading), std::sin(heading));
  const Vector2d across(-std::sin(heading), std::cos(heading));
  // The robot 0.3 m behind and 0.2 m to the right of its reference (it lags sideways).
  const Vector2d robot_xy = at4.translation.head<2>() - 0.3 * ahead - 0.2 * across;
  const lie::SE3 robot(Vector3d(robot_xy.x(), robot_xy.y(), 0.4), at4.rotation);
  // Within the sideways leash: nothing moves.
  EXPECT_FALSE(ref.follow(4.0, robot, 0.0, 0.0, 0.25));
  EXPECT_TRUE(ref.correction().translation.isZero(0.0));
  // Beyond it: the reference comes to 0.05 m aside of the robot, still 0.3 m ahead of it,
  // its heading unchanged, and at every other time moved by the same translation.
  EXPECT_TRUE(ref.follow(4.0, robot, 0.0, 0.0, 0.05));
  const Vector2d lead = ref.planarPoseAt(4.0).translation.head<2>() - robot_xy;
  EXPECT_NEAR(lead.dot(across), 0.05, 1e-12);
  EXPECT_NEAR(lead.dot(ahead), 0.3, 1e-12);
  EXPECT_NEAR(yawOf(ref.planarPoseAt(4.0)), heading, 1e-12);
  const Vector2d shift = -0.15 * across;
  for (double t : {0.0, 2.0, 7.0}) {
    BaseReference open_loop(flat, {0.375, {Vector2d::Zero()}});
    open_loop.reset(0.0, startPose(0.0, 0.0, heading), {0.15, 0.1, 0.0});
    EXPECT_TRUE(ref.planarPoseAt(t).translation.head<2>().isApprox(
        open_loop.planarPoseAt(t).translation.head<2>() + shift, 1e-12));
  }
  // The robot to the left of the reference: the leash pulls the other way.
  ref.reset(0.0, startPose(0.0, 0.0, heading), {0.15, 0.1, 0.0});
  const Vector2d left_xy = at4.translation.head<2>() + 0.12 * across;
  EXPECT_TRUE(ref.follow(4.0, lie::SE3(Vector3d(left_xy.x(), left_xy.y(), 0.4), at4.rotation), 0.0,
                         0.0, 0.05));
  EXPECT_NEAR((ref.planarPoseAt(4.0).translation.head<2>() - left_xy).dot(across), -0.05, 1e-12);
  // With the planar leash as well: the sideways one first, then the distance.
  ref.reset(0.0, startPose(0.0, 0.0, heading), {0.15, 0.1, 0.0});
  EXPECT_TRUE(ref.follow(4.0, robot, 0.1, 0.0, 0.05));
  const Vector2d both = ref.planarPoseAt(4.0).translation.head<2>() - robot_xy;
  EXPECT_NEAR(both.norm(), 0.1, 1e-12);
  EXPECT_NEAR(both.normalized().dot((0.3 * ahead + 0.05 * across).normalized()), 1.0, 1e-12);
  EXPECT_THROW(ref.follow(4.0, robot, 0.0, 0.0, std::numeric_limits<double>::infinity()),
               std::invalid_argument);
}

TEST(BaseReference, BadInputThrowsNamingTheParameter) {
  const planning::TerrainModel flat = planning::terrainFromBoxes(kFloor, 0.0, {});
  auto expectNaming = [](auto f, const std::string& what) {
    try {
      f();
      ADD_FAILURE() << "no exception, expected " << what;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
    }
  };
  expectNaming(
      [&] {
        BaseReference(flat, {std::numeric_limits<double>::quiet_NaN(), {Vector2d::Zero()}});
      },
      "nominal_height = nan");
  expectNaming([&] { BaseReference(flat, {0.3, {}}); }, "height_samples.size() = 0");
  expectNaming(
      [&] {
        BaseReference(flat, {0.3, {Vector2d::Zero()}, -1.0, 0.0});
      },
      "height_reach = -1");
  expectNaming(
      [&] {
        BaseReference(flat, {0.3, {Vector2d(0, std::numeric_limits<double>::infinity())}});
      },
      "height_samples[0].y = inf");
  BaseReference ref(flat, {0.3, {Vector2d::Zero()}});
  expectNaming(
      [&] {
        ref.reset(0.0, lie::SE3(), {std::numeric_limits<double>::quiet_NaN(), 0, 0});
      },
      "command.v_x = nan");
  expectNaming(
      [&] {
        ref.reset(0.0, lie::SE3(), {0, 0, std::numeric_limits<double>::infinity()});
      },
      "command.yaw_rate = inf");
  expectNaming(
      [&] {
        ref.reset(std::numeric_limits<double>::quiet_NaN(), lie::SE3(), BaseVelocityCommand{});
      },
      "t0 = nan");
}

TEST(BaseReference, QueriesDoNotAllocate) {
  const planning::TerrainModel step =
      planning::terrainFromBoxes(kFloor, 0.0, {{1.0, 2.2, -3.0, 3.0, 0.20}});
  BaseReference ref(step, {0.375, {{0.33, 0.0}, {-0.33, 0.0}}});
  BaseReferenceConfig ramp{0.375, {{0.33, 0.0}, {-0.33, 0.0}}, 0.25, 0.5};
  ramp.height_rate = true;
  BaseReference rate(step, ramp);
  test::AllocationGuard guard;
  double sum = 0.0;
  for (int k = 0; k <= 100; ++k) {
    ref.reset(0.01 * k, startPose(0.0, 0.0, 0.1), {0.5, 0.0, 0.1});
    rate.reset(0.01 * k, startPose(0.0, 0.0, 0.1), {0.5, 0.0, 0.1});
    sum += ref.poseAt(0.015 * k).translation.z() + ref.worldPoint({0.3, 0.2}, 0.1).x() +
           rate.velocityAt(0.015 * k).x();
  }
  EXPECT_EQ(guard.count(), 0u);
  EXPECT_GT(sum, 0.0);
}

}  // namespace
