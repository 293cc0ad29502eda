#include "rollstep/planning/edge_holds.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace rollstep::planning {

namespace {

/// [m] How far past a region's edge the next region along the travel is looked for.
constexpr double kNextRegionReach = 0.5;

/// Distance along the unit direction e from p (inside `region`) to the region's boundary;
/// +inf if the ray never leaves it.
double exitDistance(const ConvexRegion& region, const Eigen::Vector2d& p,
                    const Eigen::Vector2d& e) {
  double exit = std::numeric_limits<double>::infinity();
  for (Eigen::Index k = 0; k < region.A.rows(); ++k) {
    const double rate = region.A(k, 0) * e.x() + region.A(k, 1) * e.y();
    if (rate >= -1e-12) continue;  // moving away from (or along) this edge
    const double s = region.A(k, 0) * p.x() + region.A(k, 1) * p.y() + region.b(k);
    exit = std::min(exit, std::max(s, 0.0) / -rate);
  }
  return exit;
}

/// How long the gait must wait for `foot`'s touch-down at t_td (see the header): on the
/// brink of a step down, until it passes the edge by config.overshoot; short of a step up,
/// until it is config.setback short of its region's end. 0 when neither applies or the
/// wait would exceed that kind's longest hold.
double edgeWait(const FootReferencePlanner& feet, const EdgeHoldConfig& config, int foot,
                double t_td) {
  const TerrainModel& terrain = feet.terrain();
  if (terrain.size() == 0) return 0.0;
  double wait = 0.0, max_wait = 0.0;
  int surface = -1;
  bool down = false;
  // The base reference may change speed over the wait (a command schedule): a few
  // corrections, each from the foothold the last one reached.
  for (int pass = 0; pass < 4; ++pass) {
    const double t = t_td + wait;
    const Eigen::Vector2d v = feet.travelVelocity(t);
    const double speed = v.norm();
    if (!(speed > 1e-6)) return 0.0;
    const Eigen::Vector2d e = v / speed;
    const Eigen::Vector2d p = feet.nominalFoothold(foot, t);
    if (surface < 0) {
      // The surface it lands on (not in a gap between regions: there the foothold rule
      // already chooses) and the next one the travel enters past its edge.
      surface = feet.footholdRegion(p, t);
      if (surface < 0 || !terrain.region(surface).contains(p)) return 0.0;
      const ConvexRegion& here = terrain.region(surface);
      const double exit = exitDistance(here, p, e);
      if (!std::isfinite(exit)) return 0.0;
      const Eigen::Vector2d past = p + (exit + 1e-6) * e;
      const int next = terrain.regionAhead(past, e, kNextRegionReach);
      if (next < 0 || next == surface) return 0.0;
      const double rise = terrain.region(next).heightAt(past) - here.heightAt(p);
      if (rise < -config.min_step) {
        down = true;
        max_wait = config.max_down_hold;
        // The foothold rule must put a foothold that far past the edge on the step below.
        const Eigen::Vector2d target = p + (exit + config.overshoot) * e;
        if (feet.footholdRegion(target, t) == surface) return 0.0;
      } else if (rise > config.min_step) {
        max_wait = config.max_up_hold;
      } else {
        return 0.0;
      }
      if (!(max_wait > 0.0)) return 0.0;
    }
    const ConvexRegion& here = terrain.region(surface);
    double remaining = 0.0;
    if (down) {
      if (here.contains(p)) remaining = exitDistance(here, p, e) + config.overshoot;
    } else {
      if (!here.contains(p)) break;  // past the setback already (a faster base)
      remaining = exitDistance(here, p, e) - config.setback;
    }
    if (remaining <= 1e-6) break;
    wait += remaining / speed;
    if (wait > max_wait) return 0.0;
  }
  return wait;
}

}  // namespace

void planEdgeHolds(const Gait& gait, const FootReferencePlanner& feet, const EdgeHoldConfig& config,
                   double t0, double lookahead, GaitClock& clock) noexcept {
  if (!std::isfinite(t0) || !std::isfinite(lookahead)) return;
  const double period = gait.period();
  // fill() reads the schedule from a period before t0 on.
  clock.forgetBefore(t0 - 2.0 * period);
  const double first_start = t0 + config.lead;
  clock.dropHoldsAfter(first_start);
  if (!(config.max_down_hold > 0.0 || config.max_up_hold > 0.0) || gait.switchesPerPeriod() == 0) {
    return;
  }
  const std::vector<double>& starts = gait.phaseStarts();
  const std::vector<int>& modes = gait.phaseModes();
  const int n = static_cast<int>(starts.size());
  const int all = allFeetMask(feet.numFeet());
  const double tau_first = clock.gaitTime(first_start);
  for (double k = std::floor(tau_first / period) - 1.0;; k += 1.0) {
    for (int j = 0; j < n; ++j) {
      const double tau_lo = k * period + starts[static_cast<std::size_t>(j)];
      if (tau_lo <= tau_first) continue;
      const double t_lo = clock.loopTime(tau_lo);
      if (t_lo > t0 + lookahead) return;
      const int before = modes[static_cast<std::size_t>((j + n - 1) % n)];
      const int lifting = before & ~modes[static_cast<std::size_t>(j)];
      if (lifting == 0 || before != all) continue;
      double need = 0.0;
      for (int foot = 0; foot < feet.numFeet(); ++foot) {
        if (!inContact(lifting, foot)) continue;
        // The swing's touch-down: the next phase with the foot in stance (within a period).
        for (int m = 1; m <= n; ++m) {
          const int jm = (j + m) % n;
          if (!inContact(modes[static_cast<std::size_t>(jm)], foot)) continue;
          const double tau_td = (k + static_cast<double>((j + m) / n)) * period +
                                starts[static_cast<std::size_t>(jm)];
          // No hold lies inside a swing: its loop-time length is its gait-time length.
          need = std::max(need, edgeWait(feet, config, foot, t_lo + (tau_td - tau_lo)));
          break;
        }
      }
      if (need <= 0.0) continue;
      // In the middle of the all-stance phase before the lift-off, or as soon after it as
      // the lead and the holds already planned allow.
      const double tau_before = j > 0
                                    ? k * period + starts[static_cast<std::size_t>(j - 1)]
                                    : (k - 1.0) * period + starts[static_cast<std::size_t>(n - 1)];
      double start = std::max(clock.loopTime(0.5 * (tau_before + tau_lo)), first_start);
      if (clock.size() > 0) start = std::max(start, clock.hold(clock.size() - 1).end());
      if (start >= t_lo - 1e-6) continue;
      clock.addHold(start, need);
    }
  }
}

}  // namespace rollstep::planning
