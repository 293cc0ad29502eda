#include "rollstep/planning/foot_reference.hpp"

#include <cmath>
#include <limits>
#include <string>
#include <utility>

#include "check.hpp"

namespace rollstep::planning {

namespace {

/// Start time of the stance phase of `foot` with phase index `phase` of `schedule` (the
/// touch-down that began it), or -inf when it began before the schedule's first switch.
double stanceStart(const ocp::ModeSchedule& schedule, int foot, int phase) {
  const std::vector<int>& modes = schedule.modes();
  int j = phase;
  while (j > 0 && inContact(modes[static_cast<std::size_t>(j) - 1], foot)) --j;
  return j > 0 ? schedule.switchingTimes()[static_cast<std::size_t>(j) - 1]
               : -std::numeric_limits<double>::infinity();
}

}  // namespace

FootReferencePlanner::FootReferencePlanner(const TerrainModel& terrain, const BaseReference& base,
                                           FootReferenceConfig config)
    : terrain_(&terrain), base_(&base), config_(std::move(config)) {
  const char* where = "FootReferencePlanner";
  const std::size_t n = config_.nominal_feet.size();
  if (n < 1 || n > static_cast<std::size_t>(kMaxFeet)) {
    detail::fail(where, "nominal_feet.size()", n, "must be in [1, 16]");
  }
  for (std::size_t k = 0; k < n; ++k) {
    const std::string name = "nominal_feet[" + std::to_string(k) + "]";
    detail::checkFinite(where, (name + ".x").c_str(), config_.nominal_feet[k].x());
    detail::checkFinite(where, (name + ".y").c_str(), config_.nominal_feet[k].y());
  }
  detail::checkNonNegative(where, "swing_clearance", config_.swing_clearance);
  detail::checkFinite(where, "foot_height_offset", config_.foot_height_offset);
  detail::checkNonNegative(where, "level_tolerance", config_.level_tolerance);
}

Eigen::Vector2d FootReferencePlanner::nominalFoothold(int foot, double t) const {
  return base_->worldPoint(config_.nominal_feet[static_cast<std::size_t>(foot)], t);
}

SwingHeightSpline FootReferencePlanner::swingSpline(int foot, double t_liftoff,
                                                    double t_touchdown) const {
  const double z_lo = terrain_->heightAt(nominalFoothold(foot, t_liftoff));
  const double z_td = terrain_->heightAt(nominalFoothold(foot, t_touchdown));
  return SwingHeightSpline(t_liftoff, t_touchdown, z_lo + config_.foot_height_offset,
                           z_td + config_.foot_height_offset, config_.swing_clearance);
}

Eigen::Vector2d FootReferencePlanner::stanceFoothold(const ocp::ModeSchedule& schedule, int foot,
                                                     double t) const {
  const int phase = schedule.phaseAt(t);
  if (!inContact(schedule.modes()[static_cast<std::size_t>(phase)], foot)) {
    return nominalFoothold(foot, t);
  }
  const double start = stanceStart(schedule, foot, phase);
  return nominalFoothold(foot, start > -1e300 ? start : t);
}

FootReference FootReferencePlanner::query(const ocp::ModeSchedule& schedule, int foot,
                                          double t) const {
  FootReference r;
  r.timing = footPhase(schedule, foot, t);
  if (r.timing.stance) {
    const Eigen::Vector2d p = stanceFoothold(schedule, foot, t);
    r.region = terrain_->regionAt(p);
    r.z_ref = terrain_->heightAt(p) + config_.foot_height_offset;
    return r;
  }
  const Eigen::Vector2d p = nominalFoothold(foot, t);
  if (!r.timing.bounded()) {
    r.region = terrain_->regionAt(p);
    r.z_ref = terrain_->heightAt(p) + config_.foot_height_offset + config_.swing_clearance;
    return r;
  }
  // Where the foot stands before lift-off: the foothold of the stance that ends there.
  const Eigen::Vector2d p_lo =
      stanceFoothold(schedule, foot, std::nextafter(r.timing.liftoff, -1e300));
  const Eigen::Vector2d p_td = nominalFoothold(foot, r.timing.touchdown);
  r.region = terrain_->regionAt(p_td);
  r.direction = terrain_->classifySwing(p_lo, p_td, config_.level_tolerance);
  r.swing_region = terrain_->swingRegion(p_lo, p_td, config_.level_tolerance);
  r.swing_region_active = swingRegionActive(r.direction, r.timing.phase);
  const SwingHeightSpline spline(
      r.timing.liftoff, r.timing.touchdown, terrain_->heightAt(p_lo) + config_.foot_height_offset,
      terrain_->heightAt(p_td) + config_.foot_height_offset, config_.swing_clearance);
  spline.evaluate(t, r.z_ref, r.z_dot_ref);
  return r;
}

}  // namespace rollstep::planning
