#include "rollstep/control/speed_rule.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "rollstep/model/data.hpp"
#include "rollstep/model/kinematics.hpp"

namespace rollstep::control {

namespace {

/// |axis . e_y| at or above this (45 deg): a revolute joint that moves its foot in the
/// base's x-z plane (a hip or knee flexion joint, not an abduction joint).
constexpr double kSagittalAxis = 0.7071067811865476;

/// The model's configuration at the origin, upright, with the joints at `nominal_joints`.
Eigen::VectorXd nominalConfiguration(const model::Model& model,
                                     const Eigen::VectorXd& nominal_joints) {
  if (nominal_joints.size() != model.nj) {
    throw std::invalid_argument("speed rule: nominal_joints has " +
                                std::to_string(nominal_joints.size()) + " entries, the model " +
                                std::to_string(model.nj) + " joints");
  }
  Eigen::VectorXd q(model.nq);
  // Origin, identity quaternion (x, y, z, w), the joints.
  q << Eigen::Vector3d::Zero(), 0.0, 0.0, 0.0, 1.0, nominal_joints;
  return q;
}

/// The longest distance from body `hip`'s joint to the contact frame `f` the joints between
/// them reach inside their limits (the hip itself at its nominal angle): each joint with
/// finite limits tried at evenly spaced positions over its range (a grid over the joints,
/// coarser for longer chains), the others at nominal.
double longestReach(const model::Model& model, const Eigen::VectorXd& nominal_joints, int hip,
                    model::FrameIndex f) {
  std::vector<int> joints;  // joint indices strictly below the hip
  for (int b = model.frames[static_cast<std::size_t>(f)].body; b != hip;
       b = model.bodies[static_cast<std::size_t>(b)].parent) {
    const int j = model.bodies[static_cast<std::size_t>(b)].idxV - model.nvBase;
    if (std::isfinite(model.lowerPositionLimit[j]) && std::isfinite(model.upperPositionLimit[j])) {
      joints.push_back(j);
    }
  }
  // 33 positions per joint for up to two joints, fewer for more (at most ~10^4 poses a leg).
  const int per_joint = joints.size() <= 2 ? 33 : (joints.size() <= 4 ? 9 : 3);
  model::Data data(model);
  Eigen::VectorXd q = nominalConfiguration(model, nominal_joints);
  std::vector<int> index(joints.size(), 0);
  double longest = 0.0;
  for (;;) {
    for (std::size_t k = 0; k < joints.size(); ++k) {
      const int j = joints[k];
      const double share = static_cast<double>(index[k]) / (per_joint - 1);
      q[7 + j] = model.lowerPositionLimit[j] +
                 share * (model.upperPositionLimit[j] - model.lowerPositionLimit[j]);
    }
    model::forwardKinematics(model, data, q);
    model::updateFramePlacements(model, data);
    longest = std::max(
        longest,
        (data.opf[static_cast<std::size_t>(f)] - data.opb[static_cast<std::size_t>(hip)]).norm());
    std::size_t k = 0;
    while (k < index.size() && ++index[k] == per_joint) index[k++] = 0;
    if (k == index.size()) break;
  }
  return longest;
}

}  // namespace

planning::SpeedAdaptationLimits speedRuleLimits(const model::Model& model,
                                                const std::vector<std::string>& contact_frames,
                                                const Eigen::VectorXd& nominal_joints,
                                                const centroidal::OcpSettings& settings) {
  model::Data data(model);
  model::forwardKinematics(model, data, nominalConfiguration(model, nominal_joints));
  model::updateFramePlacements(model, data);
  const double inf = std::numeric_limits<double>::infinity();
  double vertical_speed = inf, sweep = inf;
  for (const std::string& name : contact_frames) {
    const model::FrameIndex f = model.getFrameId(name);
    const Eigen::Vector3d foot = data.opf[static_cast<std::size_t>(f)];
    int hip = -1;
    double leg_vertical_speed = 0.0;
    for (int b = model.frames[static_cast<std::size_t>(f)].body; b > 0;
         b = model.bodies[static_cast<std::size_t>(b)].parent) {
      const model::Body& body = model.bodies[static_cast<std::size_t>(b)];
      const int j = body.idxV - model.nvBase;
      if (!std::isfinite(model.lowerPositionLimit[j]) ||
          !std::isfinite(model.upperPositionLimit[j])) {
        continue;
      }
      // The base is upright at the origin: world axes are the base's.
      const Eigen::Vector3d axis = data.oRb[static_cast<std::size_t>(b)] * body.axis;
      if (body.type == model::JointType::Prismatic) {
        leg_vertical_speed += std::abs(axis.z()) * model.velocityLimit[j];
      } else if (std::abs(axis.y()) >= kSagittalAxis) {
        // Swings the foot fore and aft and up and down: dz/dq = (axis x r).z.
        const Eigen::Vector3d r = foot - data.opb[static_cast<std::size_t>(b)];
        leg_vertical_speed += std::abs(axis.cross(r).z()) * model.velocityLimit[j];
        hip = b;  // the last one found is the nearest the base
      }
    }
    if (hip < 0) {
      throw std::invalid_argument("speedRuleLimits: contact frame '" + name +
                                  "' has no revolute joint with finite limits about the base's "
                                  "y axis above it");
    }
    vertical_speed = std::min(vertical_speed, leg_vertical_speed);
    const model::Body& h = model.bodies[static_cast<std::size_t>(hip)];
    const int j = h.idxV - model.nvBase;
    const Eigen::Vector3d hip_to_foot = foot - data.opb[static_cast<std::size_t>(hip)];
    const double length = hip_to_foot.norm();
    // The hip turns from its nominal angle towards either limit, as far as the rest of the
    // leg, stretched to its longest, still reaches the ground at the nominal foot height.
    const double reach = longestReach(model, nominal_joints, hip, f);
    const double ground_angle =
        reach > std::abs(hip_to_foot.z()) ? std::acos(std::abs(hip_to_foot.z()) / reach) : 0.0;
    const double q0 = nominal_joints[j];
    const double forward = std::min({model.upperPositionLimit[j] - q0, ground_angle, M_PI / 2});
    const double backward = std::min({q0 - model.lowerPositionLimit[j], ground_angle, M_PI / 2});
    sweep = std::min(
        sweep, length * (std::sin(std::max(forward, 0.0)) + std::sin(std::max(backward, 0.0))));
  }
  planning::SpeedAdaptationLimits limits;
  limits.knee_speed = settings.swing_knee_speed_share * vertical_speed;
  limits.rise = settings.max_step_height + settings.swing_clearance;
  limits.apex_margin = settings.swing_apex_margin;
  limits.stance_stroke = settings.stance_stroke_share * sweep;
  limits.max_duty = std::max(settings.trot_duty, limits.min_duty);
  return limits;
}

double turnRadius(const model::Model& model, const std::vector<std::string>& contact_frames,
                  const Eigen::VectorXd& nominal_joints) {
  model::Data data(model);
  model::forwardKinematics(model, data, nominalConfiguration(model, nominal_joints));
  model::updateFramePlacements(model, data);
  double r = 0.0;
  for (const std::string& name : contact_frames) {
    r = std::max(r, data.opf[static_cast<std::size_t>(model.getFrameId(name))].head<2>().norm());
  }
  return r;
}

planning::TrotTiming trotTimingFor(const planning::SpeedAdaptationLimits& limits,
                                   const std::vector<planning::TimedBaseCommand>& schedule,
                                   double turn_radius) {
  return planning::adaptTrotToSpeed(planning::maxCommandSpeed(schedule, turn_radius), limits);
}

std::optional<planning::TrotTiming> timeTrotForSchedule(
    centroidal::OcpSettings& settings, const centroidal::RobotOcpDescription& robot,
    planning::GaitKind gait, const std::vector<planning::TimedBaseCommand>& schedule) {
  if (!settings.speed_adaptation || gait != planning::GaitKind::Trot) return std::nullopt;
  const model::Model model = model::buildModelFromUrdfFile(robot.urdf);
  const planning::SpeedAdaptationLimits limits =
      speedRuleLimits(model, robot.contact_frames, robot.nominal_joint_positions, settings);
  const planning::TrotTiming timing = trotTimingFor(
      limits, schedule, turnRadius(model, robot.contact_frames, robot.nominal_joint_positions));
  settings.edge_hold_stance_stroke = limits.stance_stroke;
  settings.gait_period = timing.period;
  settings.trot_duty = timing.duty;
  settings.step_up_max_hold = std::min(settings.step_up_max_hold, timing.max_edge_hold);
  settings.step_down_max_hold = std::min(settings.step_down_max_hold, timing.max_edge_hold);
  return timing;
}

}  // namespace rollstep::control
