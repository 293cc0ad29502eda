#pragma once
// The terrain scan shared by the planning rules that look for a step along a direction of
// travel (the speed rule's slow-down, the sideways hold): the heights under a body point
// sampled every kScanSpacing along a line.
#include <Eigen/Core>
#include <algorithm>
#include <limits>

#include "rollstep/lie/se3.hpp"
#include "rollstep/planning/terrain.hpp"
#include "surface_plane.hpp"

namespace rollstep::planning::detail {

/// [m] finer than any foothold region a wheel stands on.
inline constexpr double kScanSpacing = 0.02;

/// A body point (x, y in the base frame) on the ground plane at `pose`, in world x, y.
inline Eigen::Vector2d worldPoint(const lie::SE3& pose, const Eigen::Vector2d& body) {
  return pose.act(Eigen::Vector3d(body.x(), body.y(), 0.0)).head<2>();
}

struct HeightRange {
  double lo = std::numeric_limits<double>::infinity();
  double hi = -std::numeric_limits<double>::infinity();
};

/// The lowest and highest terrain height at w + d e for d = from, from + kScanSpacing, ...
/// up to `to` (e a unit world direction; none when from > to: lo = inf, hi = -inf).
inline HeightRange heightRangeAlong(const TerrainModel& terrain, const Eigen::Vector2d& w,
                                    const Eigen::Vector2d& e, double from, double to) {
  HeightRange r;
  for (double d = from; d <= to + 1e-9; d += kScanSpacing) {
    const double h = terrain.heightAt(w + d * e);
    r.lo = std::min(r.lo, h);
    r.hi = std::max(r.hi, h);
  }
  return r;
}

/// Same, each height less the rise of `plane` (the surface a foot stands on, extended) from
/// w: a slope is no step, a riser on it or its crest still is (level: the heights themselves).
inline HeightRange heightRangeAlong(const TerrainModel& terrain, const Eigen::Vector2d& w,
                                    const Eigen::Vector2d& e, double from, double to,
                                    const SurfacePlane& plane) {
  HeightRange r;
  for (double d = from; d <= to + 1e-9; d += kScanSpacing) {
    const Eigen::Vector2d q = w + d * e;
    const double h = terrain.heightAt(q) - plane.riseTo(q);
    r.lo = std::min(r.lo, h);
    r.hi = std::max(r.hi, h);
  }
  return r;
}

}  // namespace rollstep::planning::detail
