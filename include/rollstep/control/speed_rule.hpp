#pragma once
// The speed rule (planning/speed_adaptation.hpp) for one robot and one set of settings: the
// limits it needs, from the robot's model (the legs' vertical speed, the hips' sweep), and
// the trot timed for a command schedule. Used where the controller is configured
// (sim::NmpcController: the gait; ControlPipeline: the schedule slowed down near steps).
#include <optional>
#include <vector>

#include "rollstep/centroidal/ocp_settings.hpp"
#include "rollstep/model/model.hpp"
#include "rollstep/planning/base_reference.hpp"
#include "rollstep/planning/gait.hpp"
#include "rollstep/planning/speed_adaptation.hpp"

namespace rollstep::control {

/// The rule's limits, from the legs at `nominal_joints` (base upright at the origin):
/// knee_speed = swing_knee_speed_share x the smallest over the legs of the foot's vertical
/// speed when each of its sagittal joints moves at its velocity limit (the joints with finite
/// limits between the base and the contact frame: prismatic ones |axis_z| v_max, revolute
/// ones about an axis within 45 deg of the base's y |(axis x r)_z| v_max, r from the joint
/// to the contact frame; abduction joints do not count); rise = max_step_height +
/// swing_clearance; stance_stroke = stance_stroke_share x the smallest sweep of a leg,
/// L (sin a+ + sin a-), L the distance from its hip (the sagittal revolute joint nearest the
/// base) to the contact frame, a+ and a- the hip's turns from its nominal angle to its
/// limits, each at most 90 deg and at most acos(h / L_max), the angle at which the leg
/// stretched to its longest inside the joint limits (L_max) still reaches the ground at the
/// nominal foot depth h below the hip; apex_margin, max_duty from the settings (swing_apex_margin,
/// trot_duty). Throws std::invalid_argument naming the frame when a contact has no
/// sagittal revolute joint with finite limits between it and the base.
planning::SpeedAdaptationLimits speedRuleLimits(const model::Model& model,
                                                const std::vector<std::string>& contact_frames,
                                                const Eigen::VectorXd& nominal_joints,
                                                const centroidal::OcpSettings& settings);

/// The turn radius the rule counts a yaw rate with [m]: the farthest contact frame from the
/// base centre at `nominal_joints`, seen from above.
double turnRadius(const model::Model& model, const std::vector<std::string>& contact_frames,
                  const Eigen::VectorXd& nominal_joints);

/// The trot timed by the rule for the fastest command of `schedule`.
planning::TrotTiming trotTimingFor(const planning::SpeedAdaptationLimits& limits,
                                   const std::vector<planning::TimedBaseCommand>& schedule,
                                   double turn_radius);

/// The OCP settings timed for `schedule` by the speed rule: with ocp.speed_adaptation and a
/// trot, gait_period and trot_duty from trotTimingFor (the schedule's fastest command), the
/// edge waits capped at the timing's max_edge_hold and kept from carrying the body further
/// than the stance stroke over a foot stopped at a riser (edge_hold_stance_stroke); returns
/// that timing. Otherwise the
/// settings are left as they are and nothing is returned. Loads the robot's URDF
/// (not real-time).
std::optional<planning::TrotTiming> timeTrotForSchedule(
    centroidal::OcpSettings& settings, const centroidal::RobotOcpDescription& robot,
    planning::GaitKind gait, const std::vector<planning::TimedBaseCommand>& schedule);

}  // namespace rollstep::control
