// The reactive planner of the CBF-QP baseline (reactive_planner.hpp).
#include "rollstep/control/reactive_planner.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace rollstep::control {

namespace {

/// Swings and surfaces count as level below this height difference [m].
constexpr double kLevelTolerance = 1e-3;
/// A swing has landed when its wheel centre is this close above its surface [m].
constexpr double kLandingTolerance = 0.01;

double yawOfQuaternion(const Eigen::VectorXd& q) {
  const Eigen::Quaterniond r(q[6], q[3], q[4], q[5]);
  const Eigen::Vector3d x = r.normalized() * Eigen::Vector3d::UnitX();
  return std::atan2(x.y(), x.x());
}

/// The point of `region`'s polygon nearest to p (p itself inside).
Eigen::Vector2d closestPoint(const planning::ConvexRegion& region, const Eigen::Vector2d& p) {
  if (region.contains(p)) return p;
  Eigen::Vector2d best = region.vertices.front();
  double best_d2 = std::numeric_limits<double>::infinity();
  const size_t n = region.vertices.size();
  for (size_t k = 0; k < n; ++k) {
    const Eigen::Vector2d& a = region.vertices[k];
    const Eigen::Vector2d& b = region.vertices[(k + 1) % n];
    const Eigen::Vector2d ab = b - a;
    const double s = std::clamp((p - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
    const Eigen::Vector2d c = a + s * ab;
    const double d2 = (p - c).squaredNorm();
    if (d2 < best_d2) {
      best_d2 = d2;
      best = c;
    }
  }
  return best;
}

void check(bool ok, const char* what) {
  if (!ok) throw std::invalid_argument(std::string("ReactivePlanner: ") + what);
}

}  // namespace

ReactivePlanner::ReactivePlanner(const centroidal::LoadedRobot& robot,
                                 const planning::ContactPlanner& contacts,
                                 const planning::TerrainModel& collision_terrain,
                                 const BaselineSettings& settings)
    : robot_(&robot), contacts_(&contacts), solids_(&collision_terrain), settings_(settings) {
  check(settings.gait_period > 0.0 && std::isfinite(settings.gait_period),
        "baseline.gait_period must be finite and > 0");
  check(settings.trot_duty > 0.5 && settings.trot_duty < 1.0,
        "baseline.trot_duty must be in (0.5, 1)");
  check(settings.swing_clearance >= 0.0 && settings.foothold_lookahead >= 0.0 &&
            settings.height_lookahead >= 0.0 && settings.height_offset >= 0.0 &&
            settings.max_height_rate > 0.0 && settings.position_leash >= 0.0,
        "baseline lengths must be >= 0 and max_height_rate > 0");
  planning::BaseReferenceConfig base_config;
  base_config.nominal_height = contacts.stance().height;
  base_config.height_samples = contacts.stance().feet;
  base_ = std::make_unique<planning::BaseReference>(contacts.terrain(), base_config);
  planning::FootReferenceConfig foot_config;
  foot_config.nominal_feet = contacts.stance().feet;
  foot_config.swing_clearance = settings.swing_clearance;
  foot_config.foot_height_offset = robot.robot->contactOffset();
  foot_config.level_tolerance = kLevelTolerance;
  feet_ = std::make_unique<planning::FootReferencePlanner>(contacts.terrain(), *base_, foot_config);
  scheduler_ = std::make_unique<planning::GaitScheduler>(contacts.gait(), 0.0);
  schedule_ = ocp::ModeSchedule(scheduler_->requiredCapacity());
  const int nc = robot.robot->nc();
  swings_.assign(static_cast<size_t>(nc), Swing{});
  stance_region_.assign(static_cast<size_t>(nc), -1);
  if (contacts.gait().kind() == planning::GaitKind::Trot) {
    support_preview_ = (settings.trot_duty - 0.5) * settings.gait_period;
  }
}

ReactivePlan ReactivePlanner::makePlan() const {
  const centroidal::CentroidalRobot& r = *robot_->robot;
  ReactivePlan p;
  p.q = Eigen::VectorXd::Zero(r.nq());
  p.q[6] = 1.0;
  p.v = Eigen::VectorXd::Zero(r.nv());
  p.foot_position = Eigen::Matrix3Xd::Zero(3, r.nc());
  p.foot_velocity = Eigen::Matrix3Xd::Zero(3, r.nc());
  p.regions.assign(static_cast<size_t>(r.nc()), FootRegionPlan{});
  return p;
}

void ReactivePlanner::reset(double t, const Eigen::VectorXd& q,
                            const planning::BaseVelocityCommand& command) {
  command_ = command;
  yaw_ref_ = yawOfQuaternion(q);
  yaw_time_ = t;
  height_ref_ = q[2];
  height_time_ = t;
  xy_ref_ = q.head<2>();
  xy_time_ = t;
  for (Swing& s : swings_) s.planned = false;
  std::fill(stance_region_.begin(), stance_region_.end(), -1);
}

Eigen::Vector2d ReactivePlanner::footholdFor(int i, double t_td, int& region, double& shift) const {
  return footholdOn(contacts_->terrain(), i, t_td, region, shift);
}

void ReactivePlanner::remapRegions(const planning::TerrainModel& old_terrain) noexcept {
  const planning::TerrainModel& terrain = contacts_->terrain();
  for (size_t fi = 0; fi < swings_.size(); ++fi) {
    Swing& swing = swings_[fi];
    stance_region_[fi] = -1;
    if (!swing.planned) continue;
    Eigen::Vector2d goal = swing.start;
    if (swing.region >= 0 && swing.region < old_terrain.size()) {
      int region = swing.region;
      double shift = swing.shift;
      goal = footholdOn(old_terrain, static_cast<int>(fi), swing.touchdown, region, shift);
      swing.region = terrain.regionAt(goal);
    } else {
      swing.region = -1;
    }
    swing.liftoff_prism = solids_->regionAt(swing.start);
    swing.touchdown_prism = solids_->regionAt(goal);
  }
}

Eigen::Vector2d ReactivePlanner::footholdOn(const planning::TerrainModel& terrain, int i,
                                            double t_td, int& region, double& shift) const {
  const Eigen::Vector2d nominal = feet_->nominalFoothold(i, t_td);
  if (terrain.size() == 0) return nominal;
  const double speed = std::hypot(command_.v_x, command_.v_y);
  Eigen::Vector2d dir = Eigen::Vector2d::Zero();
  if (speed > 1e-9) {
    const double c = std::cos(yaw_ref_), s = std::sin(yaw_ref_);
    dir = Eigen::Vector2d((c * command_.v_x - s * command_.v_y) / speed,
                          (s * command_.v_x + c * command_.v_y) / speed);
  }
  if (region < 0) {
    region = terrain.regionAt(nominal);
    shift = 0.0;
    // The surface foothold_lookahead ahead, if it is higher or lower, takes the foot.
    if (speed > 1e-9 && settings_.foothold_lookahead > 0.0) {
      const int ahead = terrain.regionAt(nominal + settings_.foothold_lookahead * dir);
      const double rise = ahead >= 0 ? terrain.region(ahead).heightAt(nominal) -
                                           terrain.region(region).heightAt(nominal)
                                     : 0.0;
      if (ahead >= 0 && ahead != region && std::abs(rise) > kLevelTolerance) {
        region = ahead;
        if (rise < 0.0) shift = settings_.descent_offset;
      }
    }
  }
  return closestPoint(terrain.region(region), nominal + shift * dir);
}

void ReactivePlanner::plan(double t, const Eigen::VectorXd& q_meas, const Eigen::VectorXd& q_int,
                           const Eigen::Matrix3Xd& foot_positions, ReactivePlan& out) noexcept {
  const centroidal::CentroidalRobot& r = *robot_->robot;
  const planning::TerrainModel& terrain = contacts_->terrain();
  const int nc = r.nc();
  const double offset = r.contactOffset();
  const double dt_yaw = t - yaw_time_;
  yaw_ref_ += command_.yaw_rate * dt_yaw;
  yaw_time_ = t;

  // Anchor the base reference at the measured planar pose.
  const double yaw_meas = yawOfQuaternion(q_meas);
  const lie::SE3 anchor(Eigen::Vector3d(q_meas[0], q_meas[1], 0.0),
                        Eigen::Quaterniond(Eigen::AngleAxisd(yaw_meas, Eigen::Vector3d::UnitZ())));
  base_->reset(t, anchor, command_);

  // Gait.
  scheduler_->fill(t, 0.0, schedule_);
  out.mode = schedule_.modeAt(t);
  out.support_mask = out.mode & schedule_.modeAt(t + support_preview_);

  // Body height: the highest terrain under the footholds and ahead of them.
  const double speed = std::hypot(command_.v_x, command_.v_y);
  Eigen::Vector2d dir = Eigen::Vector2d::Zero();
  if (speed > 1e-9) {
    const double c = std::cos(yaw_ref_), s = std::sin(yaw_ref_);
    dir = Eigen::Vector2d((c * command_.v_x - s * command_.v_y) / speed,
                          (s * command_.v_x + c * command_.v_y) / speed);
  }
  double high = -std::numeric_limits<double>::infinity(), low = -high;
  for (int i = 0; i < nc; ++i) {
    const Eigen::Vector2d p = feet_->nominalFoothold(i, t);
    for (const double ahead : {0.0, settings_.height_lookahead}) {
      const double h = terrain.heightAt(p + ahead * dir, 0.0);
      high = std::max(high, h);
      low = std::min(low, h);
    }
  }
  out.terrain_high = high;
  out.terrain_low = low;
  const double target = contacts_->stance().height + high +
                        (high - low > kLevelTolerance ? settings_.height_offset : 0.0);
  const double dt_h = std::max(0.0, t - height_time_);
  height_time_ = t;
  const double step = std::clamp(target - height_ref_, -settings_.max_height_rate * dt_h,
                                 settings_.max_height_rate * dt_h);
  height_ref_ += step;
  const double height_rate =
      std::abs(target - height_ref_) > 1e-9 ? std::copysign(settings_.max_height_rate, step) : 0.0;

  // Base reference: the state's x, y (or the command's, leashed to it); planned height;
  // level at the yaw reference.
  const Eigen::Quaterniond orientation(Eigen::AngleAxisd(yaw_ref_, Eigen::Vector3d::UnitZ()));
  const Eigen::Vector2d xy_int(q_int[0], q_int[1]);
  Eigen::Vector2d base_xy = xy_int;
  // Only on level ground: where the terrain under and ahead of the feet differs, the
  // baseline stays myopic (a robot held at a step is not pushed on).
  if (settings_.position_leash > 0.0 && high - low <= kLevelTolerance) {
    const Eigen::Vector3d v_command =
        orientation * Eigen::Vector3d(command_.v_x, command_.v_y, 0.0);
    xy_ref_ += std::max(0.0, t - xy_time_) * v_command.head<2>();
    Eigen::Vector2d lead = xy_ref_ - xy_int;
    const double distance = lead.norm();
    if (!(distance <= settings_.position_leash)) {
      lead = distance > 0.0 && std::isfinite(distance)
                 ? Eigen::Vector2d(lead * (settings_.position_leash / distance))
                 : Eigen::Vector2d::Zero();
    }
    xy_ref_ = xy_int + lead;
    base_xy = xy_ref_;
  } else {
    // Off level ground the leash restarts from the state when the ground levels again: a
    // lead kept from before a step lies far behind the robot by then, and clamped to the
    // leash it pulled the base reference a leash's length back (past the step).
    xy_ref_ = xy_int;
  }
  xy_time_ = t;
  out.q.head<3>() = Eigen::Vector3d(base_xy.x(), base_xy.y(), height_ref_);
  out.q.segment<4>(3) = orientation.coeffs();  // x y z w
  out.q.tail(r.nj()) = robot_->description.nominal_joint_positions;
  // Twist in the LOCAL frame of the internal state's orientation.
  const Eigen::Quaterniond q_rot(q_int[6], q_int[3], q_int[4], q_int[5]);
  const Eigen::Matrix3d R = q_rot.normalized().toRotationMatrix();
  const Eigen::Vector3d v_world = orientation * Eigen::Vector3d(command_.v_x, command_.v_y, 0.0) +
                                  Eigen::Vector3d(0.0, 0.0, height_rate);
  out.v.setZero();
  out.v.head<3>() = R.transpose() * v_world;
  out.v.segment<3>(3) = R.transpose() * Eigen::Vector3d(0.0, 0.0, command_.yaw_rate);

  // Feet.
  for (int i = 0; i < nc; ++i) {
    const size_t fi = static_cast<size_t>(i);
    const planning::FootPhase phase = planning::footPhase(schedule_, i, t);
    FootRegionPlan& regions = out.regions[fi];
    regions = FootRegionPlan{};
    Swing& swing = swings_[fi];
    // Late touch-down: a swing whose wheel is still above its surface at the scheduled
    // touch-down (the knee's velocity limit, or the collision barrier holding it above an
    // edge) goes on as a swing, straight down to the surface, for at most half a swing.
    bool late = false;
    if (phase.stance && swing.planned) {
      const double z_td = swing.spline.position(swing.touchdown);
      late = foot_positions(2, i) > z_td + kLandingTolerance &&
             t < swing.touchdown + 0.5 * (swing.touchdown - swing.liftoff);
      if (late) {
        int region = swing.region;
        double shift = swing.shift;
        const Eigen::Vector2d goal = footholdFor(i, t, region, shift);
        out.foot_position.col(i) << goal, z_td;
        out.foot_velocity.col(i) << v_world.head<2>(), 0.0;
        out.mode &= ~(1 << i);
        out.support_mask &= ~(1 << i);
        regions.region = swing.region;
        regions.support_prism = swing.touchdown_prism;
        continue;
      }
    }
    if (!phase.stance && phase.bounded()) {
      if (!swing.planned || swing.liftoff != phase.liftoff) {
        // A new swing: from where the foot is, to the foothold of its touch-down.
        swing.planned = true;
        swing.liftoff = phase.liftoff;
        swing.touchdown = phase.touchdown;
        swing.start = foot_positions.col(i).head<2>();
        swing.region = -1;
        const Eigen::Vector2d goal = footholdFor(i, phase.touchdown, swing.region, swing.shift);
        const double z_td =
            (swing.region >= 0 ? terrain.region(swing.region).heightAt(goal) : 0.0) + offset;
        swing.liftoff_prism = solids_->regionAt(swing.start);
        swing.touchdown_prism = solids_->regionAt(goal);
        swing.spline = planning::SwingHeightSpline(
            phase.liftoff, phase.touchdown, foot_positions(2, i), z_td, settings_.swing_clearance);
      }
      int region = swing.region;
      double shift = swing.shift;
      const Eigen::Vector2d goal = footholdFor(i, swing.touchdown, region, shift);
      const double T = swing.touchdown - swing.liftoff;
      const double s = std::clamp((t - swing.liftoff) / T, 0.0, 1.0);
      const double blend = s * s * (3.0 - 2.0 * s), rate = 6.0 * s * (1.0 - s) / T;
      double z = 0.0, z_dot = 0.0;
      swing.spline.evaluate(t, z, z_dot);
      out.foot_position.col(i) << swing.start + blend * (goal - swing.start), z;
      // The goal moves with the robot (re-anchored every tick) at the commanded velocity.
      out.foot_velocity.col(i) << rate * (goal - swing.start) + blend * v_world.head<2>(), z_dot;
      stance_region_[fi] = -1;  // the stance that follows takes the region it lands in
      regions.region = swing.region;
      regions.support_prism = s < 0.5 ? swing.liftoff_prism : swing.touchdown_prism;
    } else {
      // Stance (or a swing the schedule does not bound: held as a stance).
      swing.planned = false;
      if (stance_region_[fi] < 0 && terrain.size() > 0) {
        stance_region_[fi] = terrain.regionAt(foot_positions.col(i).head<2>());
      }
      const int region = stance_region_[fi];
      const Eigen::Vector2d nominal = feet_->nominalFoothold(i, t);
      const Eigen::Vector2d xy =
          region >= 0 ? closestPoint(terrain.region(region), nominal) : nominal;
      const double ground = region >= 0 ? terrain.region(region).heightAt(xy) : 0.0;
      out.foot_position.col(i) << xy, ground + offset;
      out.foot_velocity.col(i) << v_world.head<2>(), 0.0;
      regions.region = region;
    }
  }
}

}  // namespace rollstep::control
