#pragma once
// The speed rule (planning/speed_adaptation.hpp) for one robot and one set of settings: the
// limits it needs, from the robot's model (the knees' velocity limit, the hips' sweep), and
// the trot timed for a command schedule. Used where the controller is configured
// (sim::NmpcController: the gait; ControlPipeline: the schedule slowed down near steps).
#include <vector>

#include "rollstep/centroidal/ocp_settings.hpp"
#include "rollstep/model/model.hpp"
#include "rollstep/planning/base_reference.hpp"
#include "rollstep/planning/speed_adaptation.hpp"

namespace rollstep::control {

/// The rule's limits: knee_speed = swing_knee_speed_share x the lowest velocity limit of a
/// prismatic joint between the base and a contact frame (without one: of a revolute joint,
/// times the leg's length); rise = max_step_height + swing_clearance; stance_stroke =
/// stance_stroke_share x the smallest sweep of a leg, 2 L sin(half the range of its hip,
/// the revolute joint with finite limits nearest the base), L the hip-to-contact distance
/// at `nominal_joints`; apex_margin, max_duty from the settings (swing_apex_margin,
/// trot_duty). Throws std::invalid_argument naming the frame when a contact has no joint
/// with finite limits between it and the base.
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

}  // namespace rollstep::control
