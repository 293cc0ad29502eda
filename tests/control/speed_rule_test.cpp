// The speed rule's limits from the robot model (Tachyon 3): the knees' velocity limit, the
// narrowest hip's sweep at the nominal leg length, the turn radius; and the trot it times.
#include "rollstep/control/speed_rule.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "rollstep/centroidal/ocp_settings.hpp"

namespace {

using namespace rollstep;

struct Tachyon3 {
  centroidal::RobotOcpDescription robot = centroidal::loadRobotOcpDescription(
      std::string(ROLLSTEP_ROBOTS_DIR) + "/tachyon3/centroidal.yaml");
  model::Model model = model::buildModelFromUrdfFile(robot.urdf);
};

TEST(SpeedRule, LimitsComeFromTheRobotModel) {
  const Tachyon3 t;
  centroidal::OcpSettings s;
  s.swing_clearance = 0.03;
  s.max_step_height = 0.2;
  s.swing_knee_speed_share = 0.75;
  s.stance_stroke_share = 1.0;
  s.trot_duty = 0.6;
  s.swing_apex_margin = 0.2;
  const planning::SpeedAdaptationLimits l =
      control::speedRuleLimits(t.model, t.robot.contact_frames, t.robot.nominal_joint_positions, s);
  // The URDF: knees (prismatic) 0.8 m/s; the middle legs' hips +-0.436 rad, the corner legs'
  // +-0.785; hip to wheel centre 0.1 + 0.05 (nominal knee) + 0.1 m.
  EXPECT_NEAR(l.knee_speed, 0.75 * 0.8, 1e-12);
  EXPECT_NEAR(l.rise, 0.23, 1e-12);
  EXPECT_NEAR(l.stance_stroke, 2 * 0.25 * std::sin(0.436332312999), 1e-9);
  EXPECT_EQ(l.max_duty, 0.6);
  EXPECT_EQ(l.apex_margin, 0.2);
  // The turn radius: the corner wheels, (0.33, 0.22) from the centre.
  EXPECT_NEAR(control::turnRadius(t.model, t.robot.contact_frames, t.robot.nominal_joint_positions),
              std::hypot(0.33, 0.22), 1e-9);
  // The trot for a schedule is timed for its fastest command (backwards counts alike).
  const planning::TrotTiming slow = control::trotTimingFor(l, {{0.0, {0.15, 0.0, 0.0}}}, 0.4);
  EXPECT_NEAR(slow.swing, 1.5 * 0.23 / (0.8 * 0.6), 1e-12);
  EXPECT_NEAR(slow.duty, 0.6, 1e-12);
  const planning::TrotTiming there_and_back =
      control::trotTimingFor(l, {{0.0, {0.15, 0.0, 0.0}}, {10.0, {-0.4, 0.0, 0.0}}}, 0.4);
  EXPECT_TRUE(there_and_back.speed_limited);
  EXPECT_NEAR(there_and_back.duty, 0.5, 1e-12);
  // Twice the stroke share: twice the step speed limit.
  s.stance_stroke_share = 2.0;
  const planning::SpeedAdaptationLimits l2 =
      control::speedRuleLimits(t.model, t.robot.contact_frames, t.robot.nominal_joint_positions, s);
  EXPECT_NEAR(planning::adaptTrotToSpeed(0.0, l2).step_speed_limit,
              2.0 * planning::adaptTrotToSpeed(0.0, l).step_speed_limit, 1e-12);
}

TEST(SpeedRule, TimesTheTrotAndBoundsTheEdgeHolds) {
  const Tachyon3 t;
  centroidal::OcpSettings s;
  const std::vector<planning::TimedBaseCommand> schedule{{0.0, {0.267, 0.0, 0.0}}};
  const auto timing = control::timeTrotForSchedule(s, t.robot, planning::GaitKind::Trot, schedule);
  ASSERT_TRUE(timing.has_value());
  const planning::SpeedAdaptationLimits l =
      control::speedRuleLimits(t.model, t.robot.contact_frames, t.robot.nominal_joint_positions, s);
  EXPECT_EQ(s.gait_period, timing->period);
  EXPECT_EQ(s.edge_hold_stance_stroke, l.stance_stroke);
  EXPECT_LE(s.step_down_max_hold, timing->max_edge_hold);
  // Without the rule nothing is timed and the holds are not bounded by a stroke.
  centroidal::OcpSettings fixed;
  fixed.speed_adaptation = false;
  EXPECT_FALSE(
      control::timeTrotForSchedule(fixed, t.robot, planning::GaitKind::Trot, schedule).has_value());
  EXPECT_EQ(fixed.edge_hold_stance_stroke, 0.0);
}

TEST(SpeedRule, RevoluteLegsCountTheirFlexionJoints) {
  // wheelquad (robots/wheelquad/wheelquad.md): per leg abduction (about x), flexion and knee
  // (about y), 12 rad/s each; at the nominal posture (0, 0.8, -1.6) the wheel is under the
  // flexion axis, the knee 0.3 sin(0.8) behind it. Only the knee raises the foot there; the
  // abduction joint counts neither for the speed nor as the hip.
  const centroidal::RobotOcpDescription robot = centroidal::loadRobotOcpDescription(
      std::string(ROLLSTEP_ROBOTS_DIR) + "/wheelquad/centroidal.yaml");
  const model::Model model = model::buildModelFromUrdfFile(robot.urdf);
  centroidal::OcpSettings s;
  s.swing_knee_speed_share = 0.75;
  const planning::SpeedAdaptationLimits l =
      control::speedRuleLimits(model, robot.contact_frames, robot.nominal_joint_positions, s);
  EXPECT_NEAR(l.knee_speed, 0.75 * 12.0 * 0.3 * std::sin(0.8), 1e-9);
  // Flexion range [-1, 2.5] rad, 1.7 and 1.8 rad from the nominal 0.8: the joint limits do
  // not bound the sweep, the leg's length does. Its wheel 0.6 cos(0.8) below the flexion
  // axis, the leg stretched to its longest (knee at its -0.5 rad limit: 0.6 cos(0.25)) still
  // reaches that depth with the hip turned acos(cos(0.8) / cos(0.25)) either way; at the
  // nominal length L = 0.6 cos(0.8) that is a sweep of 2 L sin of it (not 2 L, where the
  // wheel would be at the hip's height).
  const double depth = 0.6 * std::cos(0.8);
  const double turn = std::acos(std::cos(0.8) / std::cos(0.25));
  EXPECT_NEAR(l.stance_stroke, 2.0 * depth * std::sin(turn), 1e-9);
  EXPECT_LT(l.stance_stroke, 0.6);
  EXPECT_NEAR(control::turnRadius(model, robot.contact_frames, robot.nominal_joint_positions),
              std::hypot(0.3, 0.2), 1e-9);
}

TEST(SpeedRule, RefusesAWrongPosture) {
  const Tachyon3 t;
  EXPECT_THROW(control::speedRuleLimits(t.model, t.robot.contact_frames, Eigen::VectorXd::Zero(3),
                                        centroidal::OcpSettings{}),
               std::invalid_argument);
}

}  // namespace
