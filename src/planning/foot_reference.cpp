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
  detail::checkNonNegative(where, "gap_reach", config_.gap_reach);
  if (!(config_.swing_apex_margin > 0.0 && config_.swing_apex_margin <= 0.5)) {
    detail::fail(where, "swing_apex_margin", config_.swing_apex_margin, "must be in (0, 0.5]");
  }
  anchors_.resize(n);
  latches_.resize(n);
  landings_.resize(n);
}

void FootReferencePlanner::anchorStance(int foot, double stance_start,
                                        const Eigen::Vector2d& p) noexcept {
  if (foot < 0 || foot >= numFeet()) return;
  Anchor& a = anchors_[static_cast<std::size_t>(foot)];
  a.valid = p.allFinite() && !std::isnan(stance_start);
  a.start = stance_start;
  a.p = p;
}

void FootReferencePlanner::clearAnchors() noexcept {
  for (Anchor& a : anchors_) a.valid = false;
  for (Latch& l : latches_) l.valid = false;
  for (Landing& l : landings_) l.valid = false;
}

void FootReferencePlanner::setLanding(int foot, double touchdown, double from, double z_from,
                                      double landing, double z_to) noexcept {
  if (foot < 0 || foot >= numFeet()) return;
  Landing& l = landings_[static_cast<std::size_t>(foot)];
  l.valid = std::isfinite(touchdown) && std::isfinite(from) && std::isfinite(z_from) &&
            std::isfinite(landing) && std::isfinite(z_to) && landing > from && landing > touchdown;
  if (!l.valid) return;
  l.touchdown = touchdown;
  l.landing = landing;
  l.from = from;
  l.z_from = z_from;
  l.z_to = z_to;
}

void FootReferencePlanner::clearLanding(int foot) noexcept {
  if (foot < 0 || foot >= numFeet()) return;
  landings_[static_cast<std::size_t>(foot)].valid = false;
}

double FootReferencePlanner::scheduledStart(int foot, double start) const {
  const Landing& l = landings_[static_cast<std::size_t>(foot)];
  return l.valid && std::abs(start - l.landing) <= 1e-6 ? l.touchdown : start;
}

void FootReferencePlanner::latchTouchdown(int foot, double touchdown) noexcept {
  if (foot < 0 || foot >= numFeet()) return;
  Latch& l = latches_[static_cast<std::size_t>(foot)];
  if (!std::isfinite(touchdown) || terrain_->size() == 0) {
    l.valid = false;
    return;
  }
  if (l.valid && std::abs(l.touchdown - touchdown) <= 1e-6) return;  // the first choice stays
  int region = -1;
  Eigen::Vector2d p = footholdAt(foot, touchdown, region);
  if (region < 0 || !p.allFinite()) {
    l.valid = false;
    return;
  }
  // Into the chosen region: the nearest point of its polygon (p itself inside it).
  const ConvexRegion& R = terrain_->region(region);
  p = R.closestPoint(p);
  l.valid = true;
  l.touchdown = touchdown;
  l.p = p;
  l.z = R.heightAt(p);
}

int FootReferencePlanner::latchedRegion(const Latch& l) const {
  // The same surface on this terrain: the nearest region at the latched height; when none
  // is (the surface is gone), the region under the point or the nearest.
  int best = -1;
  double best_d = std::numeric_limits<double>::infinity();
  for (int i = 0; i < terrain_->size(); ++i) {
    const ConvexRegion& R = terrain_->region(i);
    if (std::abs(R.heightAt(l.p) - l.z) > kLatchHeightTolerance) continue;
    const double d = R.distance(l.p);
    if (d < best_d) {
      best_d = d;
      best = i;
    }
  }
  return best >= 0 ? best : terrain_->regionAt(l.p);
}

const FootReferencePlanner::Latch* FootReferencePlanner::latchFor(int foot, double t) const {
  const Latch& l = latches_[static_cast<std::size_t>(foot)];
  return l.valid && std::isfinite(t) && std::abs(l.touchdown - t) <= 1e-6 ? &l : nullptr;
}

const FootReferencePlanner::Anchor* FootReferencePlanner::anchorFor(int foot, double start) const {
  const Anchor& a = anchors_[static_cast<std::size_t>(foot)];
  if (!a.valid) return nullptr;
  const bool same = std::isinf(a.start) || std::isinf(start) ? a.start == start
                                                             : std::abs(a.start - start) <= 1e-6;
  return same ? &a : nullptr;
}

Eigen::Vector2d FootReferencePlanner::stanceFootholdAt(int foot, double start, double t_nominal,
                                                       int& region) const {
  if (const Anchor* a = anchorFor(foot, start)) {
    region = terrain_->regionAt(a->p);
    return a->p;
  }
  if (const Latch* l = latchFor(foot, start)) {
    region = latchedRegion(*l);
    return l->p;
  }
  return footholdAt(foot, t_nominal, region);
}

double FootReferencePlanner::stanceStartAt(const ocp::ModeSchedule& schedule, int foot, double t) {
  const int phase = schedule.phaseAt(t);
  if (!inContact(schedule.modes()[static_cast<std::size_t>(phase)], foot)) {
    return std::numeric_limits<double>::quiet_NaN();
  }
  return stanceStart(schedule, foot, phase);
}

int FootReferencePlanner::footholdRegion(const Eigen::Vector2d& p, double t) const {
  if (config_.gap_reach <= 0.0) return terrain_->regionAt(p);
  return regionOf(p, t, base_->planarPoseAt(t));
}

int FootReferencePlanner::regionOf(const Eigen::Vector2d& p, double t, const lie::SE3& pose) const {
  if (config_.gap_reach <= 0.0) return terrain_->regionAt(p);
  const Eigen::Vector2d e = travelVelocity(t, pose);
  const double speed = e.norm();
  if (speed < 1e-9) return terrain_->regionAt(p);
  return terrain_->regionAhead(p, e / speed, config_.gap_reach);
}

Eigen::Vector2d FootReferencePlanner::travelVelocity(double t, const lie::SE3& pose) const {
  const lie::Vector6d v = base_->twistAt(t);
  return (pose.rotation * Eigen::Vector3d(v[0], v[1], 0.0)).head<2>();
}

Eigen::Vector2d FootReferencePlanner::travelVelocity(double t) const {
  return travelVelocity(t, base_->planarPoseAt(t));
}

Eigen::Vector2d FootReferencePlanner::footholdAt(int foot, double t, int& region) const {
  const lie::SE3 pose = base_->planarPoseAt(t);
  const Eigen::Vector2d& xy = config_.nominal_feet[static_cast<std::size_t>(foot)];
  // As BaseReference::worldPoint(xy, t).
  const Eigen::Vector2d p = pose.act(Eigen::Vector3d(xy.x(), xy.y(), 0.0)).head<2>();
  region = regionOf(p, t, pose);
  return p;
}

double FootReferencePlanner::heightIn(int region, const Eigen::Vector2d& p) const {
  return region < 0 ? 0.0 : terrain_->region(region).heightAt(p);
}

Eigen::Vector2d FootReferencePlanner::nominalFoothold(int foot, double t) const {
  return base_->worldPoint(config_.nominal_feet[static_cast<std::size_t>(foot)], t);
}

SwingHeightSpline FootReferencePlanner::swingSpline(int foot, double t_liftoff,
                                                    double t_touchdown) const {
  const Eigen::Vector2d p_lo = nominalFoothold(foot, t_liftoff);
  const Eigen::Vector2d p_td = nominalFoothold(foot, t_touchdown);
  const double z_lo = heightIn(footholdRegion(p_lo, t_liftoff), p_lo);
  const double z_td = heightIn(footholdRegion(p_td, t_touchdown), p_td);
  return SwingHeightSpline(t_liftoff, t_touchdown, z_lo + config_.foot_height_offset,
                           z_td + config_.foot_height_offset, config_.swing_clearance,
                           config_.swing_apex_margin);
}

Eigen::Vector2d FootReferencePlanner::stanceFoothold(const ocp::ModeSchedule& schedule, int foot,
                                                     double t) const {
  const int phase = schedule.phaseAt(t);
  if (!inContact(schedule.modes()[static_cast<std::size_t>(phase)], foot)) {
    return nominalFoothold(foot, t);
  }
  const double start = scheduledStart(foot, stanceStart(schedule, foot, phase));
  if (const Anchor* a = anchorFor(foot, start)) return a->p;
  if (const Latch* l = latchFor(foot, start)) return l->p;
  return nominalFoothold(foot, start > -1e300 ? start : t);
}

FootReference FootReferencePlanner::query(const ocp::ModeSchedule& schedule, int foot,
                                          double t) const {
  FootReference r;
  r.timing = footPhase(schedule, foot, t);
  if (r.timing.stance) {
    const int phase = schedule.phaseAt(t);
    const double start = scheduledStart(foot, stanceStart(schedule, foot, phase));
    const double t_chosen = start > -1e300 ? start : t;  // stanceFoothold's time
    const Eigen::Vector2d p = stanceFootholdAt(foot, start, t_chosen, r.region);
    r.z_ref = heightIn(r.region, p) + config_.foot_height_offset;
    return r;
  }
  if (!r.timing.bounded()) {
    const Eigen::Vector2d p = footholdAt(foot, t, r.region);
    r.z_ref = heightIn(r.region, p) + config_.foot_height_offset + config_.swing_clearance;
    return r;
  }
  // Where the foot stands before lift-off: the foothold of the stance that ends there.
  const double before = std::nextafter(r.timing.liftoff, -1e300);
  const int lo_phase = schedule.phaseAt(before);
  const double lo_start = inContact(schedule.modes()[static_cast<std::size_t>(lo_phase)], foot)
                              ? scheduledStart(foot, stanceStart(schedule, foot, lo_phase))
                              : before;
  const double t_lo = lo_start > -1e300 ? lo_start : before;  // stanceFoothold's time
  const bool lo_stance = inContact(schedule.modes()[static_cast<std::size_t>(lo_phase)], foot);
  int region_lo = -1;
  const Eigen::Vector2d p_lo = stanceFootholdAt(
      foot, lo_stance ? lo_start : std::numeric_limits<double>::quiet_NaN(), t_lo, region_lo);
  // A delayed landing: the swing as scheduled (its touch-down foothold, direction and
  // region window), its height reference a descent from `from` to the landing.
  const Landing& landing = landings_[static_cast<std::size_t>(foot)];
  const bool delayed = landing.valid && std::abs(r.timing.touchdown - landing.landing) <= 1e-6;
  const double touchdown = delayed ? landing.touchdown : r.timing.touchdown;
  Eigen::Vector2d p_td;
  if (const Latch* l = latchFor(foot, touchdown)) {
    p_td = l->p;
    r.region = latchedRegion(*l);
  } else {
    p_td = footholdAt(foot, touchdown, r.region);
  }
  const double z_lo = heightIn(region_lo, p_lo), z_td = heightIn(r.region, p_td);
  r.direction = classifySwing(z_lo, z_td, config_.level_tolerance);
  r.swing_region = r.direction == SwingDirection::Ascending    ? region_lo
                   : r.direction == SwingDirection::Descending ? r.region
                                                               : -1;
  const double phase =
      delayed ? std::clamp((t - r.timing.liftoff) / (touchdown - r.timing.liftoff), 0.0, 1.0)
              : r.timing.phase;
  r.swing_region_active = swingRegionActive(r.direction, phase);
  if (delayed && t >= landing.from) {
    const double T = landing.landing - landing.from;
    const double s = std::clamp((t - landing.from) / T, 0.0, 1.0);
    const double dz = landing.z_to - landing.z_from;
    r.z_ref = landing.z_from + dz * s * s * (3.0 - 2.0 * s);
    r.z_dot_ref = dz * 6.0 * s * (1.0 - s) / T;
    return r;
  }
  const SwingHeightSpline spline(r.timing.liftoff, touchdown, z_lo + config_.foot_height_offset,
                                 z_td + config_.foot_height_offset, config_.swing_clearance,
                                 config_.swing_apex_margin);
  spline.evaluate(t, r.z_ref, r.z_dot_ref);
  return r;
}

}  // namespace rollstep::planning
