#include "rollstep/planning/contact_planner.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace rollstep::planning {

Gait makeGait(GaitKind kind, int num_feet, const GaitTiming& timing, const GaitGroups& groups) {
  switch (kind) {
    case GaitKind::Standing:
      return Gait::standing(num_feet, timing.period);
    case GaitKind::Rolling:
      return Gait::rolling(num_feet, timing.period);
    case GaitKind::Trot:
      if (groups.trot_a == 0 || groups.trot_b == 0) {
        throw std::invalid_argument("makeGait: a trot needs both groups of feet");
      }
      return Gait::trot(num_feet, timing.period, timing.trot_duty, groups.trot_a, groups.trot_b);
    case GaitKind::StaticWalk:
      if (groups.walk_order.empty()) {
        throw std::invalid_argument("makeGait: a static walk needs its order of feet");
      }
      return Gait::staticWalk(num_feet, timing.walk_period, timing.walk_duty, groups.walk_order);
    case GaitKind::Custom:
      break;
  }
  throw std::invalid_argument("makeGait: a custom gait needs its table (Gait::fromTable)");
}

ContactPlanner::ContactPlanner(const ContactPlannerSettings& settings, NominalStance stance,
                               Gait gait, TerrainModel terrain, int region_edge_capacity)
    : settings_(settings), stance_(std::move(stance)) {
  if (region_edge_capacity < 0) {
    throw std::invalid_argument("ContactPlanner: region_edge_capacity = " +
                                std::to_string(region_edge_capacity) + " must be >= 0");
  }
  if (gait.numFeet() != numFeet()) {
    throw std::invalid_argument("ContactPlanner: the gait has " + std::to_string(gait.numFeet()) +
                                " feet, the nominal stance " + std::to_string(numFeet()));
  }
  terrain_ = std::make_unique<TerrainModel>(std::move(terrain));
  region_edge_capacity_ = std::max(region_edge_capacity, terrain_->maxEdges());
  has_regions_ = terrain_->size() > 0;
  BaseReferenceConfig base_config;
  base_config.nominal_height = stance_.height;
  base_config.height_samples = stance_.feet;  // the body rises as the feet climb
  base_config.height_reach = settings.base_height_reach;
  base_config.height_slope = settings.base_height_slope;
  base_config.height_rate = settings.base_height_rate;
  base_ = std::make_unique<BaseReference>(*terrain_, base_config);
  FootReferenceConfig foot_config;
  foot_config.nominal_feet = stance_.feet;
  foot_config.swing_clearance = settings.swing_clearance;
  foot_config.swing_apex_margin = settings.swing_apex_margin;
  foot_config.gap_reach = settings.foothold_gap_reach;
  foot_config.foot_height_offset = stance_.foot_height_offset;
  feet_ = std::make_unique<FootReferencePlanner>(*terrain_, *base_, foot_config);
  scheduler_ = std::make_unique<GaitScheduler>(std::move(gait), settings.horizon);
  const std::size_t nc = static_cast<std::size_t>(numFeet());
  settled_stance_.assign(nc, std::numeric_limits<double>::quiet_NaN());
  landings_.assign(nc, LandingPlan{});
  reset(0.0, lie::SE3::Identity(), BaseVelocityCommand{});
}

void ContactPlanner::reset(double t0, const lie::SE3& start, const BaseVelocityCommand& command) {
  base_->reset(t0, start, command);
  feet_->clearAnchors();
  std::fill(settled_stance_.begin(), settled_stance_.end(),
            std::numeric_limits<double>::quiet_NaN());
  for (LandingPlan& plan : landings_) plan.valid = false;
  clock_.clear();
}

void ContactPlanner::resetSchedule(double t0, const lie::SE3& start,
                                   const std::vector<TimedBaseCommand>& schedule) {
  base_->resetSchedule(t0, start, schedule);
  feet_->clearAnchors();
  std::fill(settled_stance_.begin(), settled_stance_.end(),
            std::numeric_limits<double>::quiet_NaN());
  for (LandingPlan& plan : landings_) plan.valid = false;
  clock_.clear();
}

int ContactPlanner::scheduleCapacity() const { return scheduler_->requiredCapacity() + numFeet(); }

void ContactPlanner::planSchedule(double t0, ocp::ModeSchedule& out) {
  planEdgeHolds(scheduler_->gait(), *feet_, settings_.edge_holds, t0, settings_.horizon, clock_);
  scheduler_->fill(t0, settings_.horizon, out, clock_);
}

void ContactPlanner::fillSchedule(double t0, double horizon, ocp::ModeSchedule& out) {
  scheduler_->fill(t0, horizon, out, clock_);
}

void ContactPlanner::anchorStanceFeet(const ocp::ModeSchedule& schedule, double t,
                                      const Eigen::Matrix3Xd& feet) noexcept {
  if (!settings_.anchor_stance_feet && !settings_.latch_touchdowns) return;
  if (feet.cols() != numFeet() || !feet.allFinite() || !std::isfinite(t)) return;
  if (schedule.modes().empty()) return;
  if (settings_.latch_touchdowns) {
    for (int i = 0; i < numFeet(); ++i) {
      const FootPhase phase = footPhase(schedule, i, t);
      if (!phase.stance && phase.bounded()) feet_->latchTouchdown(i, phase.touchdown);
    }
  }
  if (!settings_.anchor_stance_feet) return;
  for (int i = 0; i < numFeet(); ++i) {
    const double start = FootReferencePlanner::stanceStartAt(schedule, i, t);
    if (std::isnan(start)) continue;  // in swing: its lift-off anchor stays
    feet_->anchorStance(i, start, feet.col(i).head<2>());
  }
}

int ContactPlanner::landLateFeet(ocp::ModeSchedule& schedule, double t,
                                 const Eigen::Matrix3Xd& feet) noexcept {
  const double tolerance = settings_.late_touchdown_tolerance;
  if (tolerance <= 0.0) return 0;
  const int nc = numFeet();
  if (feet.cols() != nc || !feet.allFinite() || !std::isfinite(t) || schedule.modes().empty()) {
    for (int i = 0; i < nc; ++i) feet_->clearLanding(i);
    return 0;
  }
  int late = 0;
  for (int i = 0; i < nc; ++i) {
    const std::size_t fi = static_cast<std::size_t>(i);
    const double start = FootReferencePlanner::stanceStartAt(schedule, i, t);
    // In swing, or a stance that began before the schedule (nothing to delay).
    if (!std::isfinite(start)) {
      feet_->clearLanding(i);
      continue;
    }
    if (std::abs(settled_stance_[fi] - start) <= 1e-6) {
      feet_->clearLanding(i);
      continue;
    }
    const FootPhase swing =
        footPhase(schedule, i, std::nextafter(start, -std::numeric_limits<double>::infinity()));
    const double duration = swing.bounded() ? start - swing.liftoff : 0.0;
    const double surface = feet_->query(schedule, i, t).z_ref;  // the stance's, + offset
    const double z = feet(2, i);
    if (z <= surface + tolerance || t >= start + settings_.late_touchdown_max_delay * duration) {
      settled_stance_[fi] = start;  // landed, or too late: the stance goes on as scheduled
      feet_->clearLanding(i);
      continue;
    }
    // The descent planned at the first call that found this stance late stays (a reference
    // re-planned from the measured height at every call would always start at rest); only
    // a foot still up at its landing time gets a new one, from where it is.
    LandingPlan& plan = landings_[fi];
    if (!plan.valid || std::abs(plan.stance - start) > 1e-6 || t >= plan.landing) {
      plan.valid = true;
      plan.stance = start;
      plan.from = t;
      plan.z_from = z;
      plan.landing = t + std::max(settings_.late_touchdown_min_time,
                                  (z - surface) / settings_.late_touchdown_speed);
    }
    if (!delayTouchdown(schedule, i, start, plan.landing)) {
      settled_stance_[fi] = start;  // no room in the stance: as scheduled
      feet_->clearLanding(i);
      continue;
    }
    feet_->setLanding(i, start, plan.from, plan.z_from, plan.landing, surface);
    late |= 1 << i;
  }
  return late;
}

bool ContactPlanner::followRobot(double t, const lie::SE3& base_pose, double max_distance,
                                 double max_yaw, double max_lateral) {
  return base_->follow(t, base_pose, max_distance, max_yaw, max_lateral);
}

bool ContactPlanner::setReferenceCorrection(const lie::SE3& correction) noexcept {
  return base_->setCorrection(correction);
}

bool ContactPlanner::acceptsTerrain(const TerrainModel& terrain) const noexcept {
  return (terrain.size() > 0) == has_regions_ && terrain.maxEdges() <= region_edge_capacity_;
}

bool ContactPlanner::swapTerrain(TerrainModel& terrain) noexcept {
  if (!acceptsTerrain(terrain)) return false;
  terrain_->swap(terrain);
  return true;
}

}  // namespace rollstep::planning
