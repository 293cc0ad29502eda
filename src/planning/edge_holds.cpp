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

/// The part [lo, hi] of the line p + d e inside `region` (lo > hi: none).
void lineInterval(const ConvexRegion& region, const Eigen::Vector2d& p, const Eigen::Vector2d& e,
                  double& lo, double& hi) {
  lo = -std::numeric_limits<double>::infinity();
  hi = std::numeric_limits<double>::infinity();
  region.clipLine(p, e, lo, hi);
}

/// The edge a touch-down foothold p (at time t, travel direction e) is near: the surface it
/// leaves (`here`: the region containing p, or in a gap the one just behind p along the
/// travel) and the next one the travel enters past that surface's end (`next`, within
/// kNextRegionReach). `exit` is the signed distance along e from p to the end of `here`
/// (negative: p is past it, in the gap), `entry` the distance to the start of `next`.
/// False when there is no such pair.
struct Edge {
  int here = -1, next = -1;
  double exit = 0.0, entry = 0.0, rise = 0.0;
};
bool edgeAt(const FootReferencePlanner& feet, const Eigen::Vector2d& p, const Eigen::Vector2d& e,
            double t, Edge& edge) {
  const TerrainModel& terrain = feet.terrain();
  const int chosen = feet.footholdRegion(p, t);
  if (chosen < 0) return false;
  if (terrain.region(chosen).contains(p)) {
    edge.here = chosen;
    edge.exit = exitDistance(terrain.region(chosen), p, e);
  } else {
    // In a gap: the surface behind it, the one the ray back along the travel enters first.
    edge.here = terrain.regionAhead(p, -e, kNextRegionReach);
    if (edge.here < 0) return false;
    double lo = 0.0, hi = 0.0;
    lineInterval(terrain.region(edge.here), p, e, lo, hi);
    if (!(lo <= hi) || hi > 0.0 || hi < -kNextRegionReach) return false;  // not behind p
    edge.exit = hi;
  }
  if (!std::isfinite(edge.exit)) return false;
  const Eigen::Vector2d past = p + (edge.exit + 1e-6) * e;
  edge.next = terrain.regionAhead(past, e, kNextRegionReach);
  if (edge.next < 0 || edge.next == edge.here) return false;
  double lo = 0.0, hi = 0.0;
  lineInterval(terrain.region(edge.next), p, e, lo, hi);
  if (!(lo <= hi) || lo < edge.exit - 1e-9 || lo > edge.exit + kNextRegionReach) return false;
  edge.entry = lo;
  const Eigen::Vector2d at_exit = p + edge.exit * e;
  edge.rise =
      terrain.region(edge.next).heightAt(p + lo * e) - terrain.region(edge.here).heightAt(at_exit);
  return true;
}

/// How long the gait must wait for `foot`'s touch-down at t_td (see the header): before a
/// step down, until its foothold is past the end of the surface it leaves and at most
/// config.reach short of the lower one; short of a step up, until it is config.setback
/// short of its region's end (unless the foot's next touch-down, a gait `period` later,
/// still lands on that surface), or from the gap before the riser, until it is at most
/// config.up_reach short of the step's region. 0 when none applies or the wait would
/// exceed that kind's longest hold.
double edgeWait(const FootReferencePlanner& feet, const EdgeHoldConfig& config, int foot,
                double t_td, double period) {
  if (feet.terrain().size() == 0) return 0.0;
  double wait = 0.0, max_wait = 0.0;
  Edge edge;
  bool down = false, in_gap = false;
  // The base reference may change speed over the wait (a command schedule): a few
  // corrections, each from the foothold the last one reached.
  for (int pass = 0; pass < 4; ++pass) {
    const double t = t_td + wait;
    const Eigen::Vector2d v = feet.travelVelocity(t);
    const double speed = v.norm();
    if (!(speed > 1e-6)) return 0.0;
    const Eigen::Vector2d e = v / speed;
    const Eigen::Vector2d p = feet.nominalFoothold(foot, t);
    double exit = 0.0, entry = 0.0;
    if (pass == 0) {
      if (!edgeAt(feet, p, e, t, edge)) return 0.0;
      if (edge.rise < -config.min_step) {
        down = true;
        max_wait = config.max_down_hold;
      } else if (edge.rise > config.min_step) {
        max_wait = config.max_up_hold;
        in_gap = edge.exit < 0.0;
        if (in_gap && !(config.up_reach > 0.0)) return 0.0;
        // Short of a riser by more than a stride: the foot's next touch-down still lands on
        // this surface, and that swing, not this one, climbs (from nearer the riser; it is
        // held if it needs to be). A hold here would stand every foot for more than a
        // stride of travel (a trot whose stride is short against max_up_hold's travel).
        if (!in_gap && (feet.nominalFoothold(foot, t + period) - p).dot(e) < edge.exit) {
          return 0.0;
        }
      } else {
        return 0.0;
      }
      if (!(max_wait > 0.0)) return 0.0;
      exit = edge.exit;
      entry = edge.entry;
    } else {
      // The same edge, from the foothold the wait has reached so far.
      const TerrainModel& terrain = feet.terrain();
      double lo = 0.0, hi = 0.0;
      lineInterval(terrain.region(edge.here), p, e, lo, hi);
      exit = lo <= hi ? hi : -std::numeric_limits<double>::infinity();
      lineInterval(terrain.region(edge.next), p, e, lo, hi);
      entry = lo;
    }
    double remaining = 0.0;
    if (down) {
      remaining = std::max(exit + 1e-6, entry - config.reach);
    } else if (in_gap) {
      remaining = entry - config.up_reach;
    } else {
      if (!(exit >= 0.0)) break;  // past the setback already (a faster base)
      remaining = exit - config.setback;
    }
    // The foothold rule must put the held foothold on the step below (above).
    if (pass == 0 && (down || in_gap) && remaining > 0.0 &&
        feet.footholdRegion(p + remaining * e, t) != edge.next) {
      return 0.0;
    }
    if (remaining <= 1e-6) break;
    wait += remaining / speed;
    if (wait > max_wait) return 0.0;
  }
  return wait;
}

/// Whether a hold of `duration` in the all-stance phase before the lift-off at gait time
/// tau_lo (phase j of period k) carries the body further than config.stance_stroke over a
/// stance foot stopped at a riser ahead of it: each foot in stance through the hold keeps
/// its touch-down's foothold, rolls with the base up to the end of its region (the regions
/// bound the wheel centres) and stands there while the body passes over it until its
/// lift-off, which the hold delays by `duration`.
bool overrunsStanceStroke(const Gait& gait, const FootReferencePlanner& feet,
                          const EdgeHoldConfig& config, const GaitClock& clock, double k, int j,
                          double duration) {
  if (!(config.stance_stroke > 0.0)) return false;
  const std::vector<double>& starts = gait.phaseStarts();
  const std::vector<int>& modes = gait.phaseModes();
  const int n = static_cast<int>(starts.size());
  const double period = gait.period();
  // Gait time of the start of phase i of period kk (i may run past either end).
  const auto phaseStart = [&](double kk, int i) {
    const int wrapped = ((i % n) + n) % n;
    return (kk + std::floor(static_cast<double>(i) / n)) * period +
           starts[static_cast<std::size_t>(wrapped)];
  };
  const int held = modes[static_cast<std::size_t>((j + n - 1) % n)];
  for (int foot = 0; foot < feet.numFeet(); ++foot) {
    if (!inContact(held, foot)) continue;
    // Its touch-down: the start of the first phase of the run of stance phases before j.
    int first = j - 1;
    for (int m = 0;
         m < n && inContact(modes[static_cast<std::size_t>(((first - 1) % n + n) % n)], foot);
         ++m) {
      --first;
    }
    // Its lift-off: the first phase from j on without it.
    int last = j;
    for (int m = 0; m < n && inContact(modes[static_cast<std::size_t>(last % n)], foot); ++m) {
      ++last;
    }
    const double t_td = clock.loopTime(phaseStart(k, first));
    const double t_lift = clock.loopTime(phaseStart(k, last)) + duration;
    const Eigen::Vector2d v = feet.travelVelocity(t_td);
    const double speed = v.norm();
    if (!(speed > 1e-6)) continue;
    const Eigen::Vector2d e = v / speed;
    const Eigen::Vector2d p = feet.nominalFoothold(foot, t_td);
    Edge edge;
    if (!edgeAt(feet, p, e, t_td, edge) || !(edge.rise > config.min_step) || edge.exit < 0.0) {
      continue;
    }
    const double travel = (feet.nominalFoothold(foot, t_lift) - p).dot(e);
    if (travel - edge.exit > config.stance_stroke) return true;
  }
  return false;
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
          need = std::max(need, edgeWait(feet, config, foot, t_lo + (tau_td - tau_lo), period));
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
      if (overrunsStanceStroke(gait, feet, config, clock, k, j, need)) continue;
      clock.addHold(start, need);
    }
  }
}

}  // namespace rollstep::planning
