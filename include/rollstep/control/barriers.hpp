#pragma once
// Geometry of the CBF-QP baseline's barriers (DESIGN.md section 6; cbf_qp.hpp):
//
// - Leg/terrain collision. The terrain's solids are the prisms under its regions: region r
//   bounds {(x, y) inside its polygon, z below its surface plane}. The Euclidean distance of
//   a point to such a prism is not twice differentiable at the prism's edges (and the
//   "height of the terrain under the point" used by the region-plane clearance jumps there),
//   which a second-order barrier cannot live with. smoothPrismDistance is the analytic
//   smoothing: with the signed distances s_f = n_f . p - o_f of the point to the planes of
//   the prism's faces (the top plane, unit normal; each vertical side, outward), the largest
//   of which is the prism's exact distance inside it and in front of a face,
//       d(p) = (1/k) log sum_f exp(k s_f)          (log-sum-exp smooth maximum)
//   is smooth (C-infinity) and max_f s_f <= d(p) <= max_f s_f + log(nf)/k (nf faces). In
//   front of a face (the largest s_f ahead of the others by a gap) d tends to the true
//   distance exponentially, as exp(-k gap). Everywhere max_f s_f <= the true distance, so d
//   can exceed the true distance by at most log(nf)/k, near an edge, where the smoothing
//   rounds the corner: collision_clearance >= log(nf)/k keeps the barrier conservative.
// - Static stability: the support polygon, the convex hull of the support feet's ground
//   points (x, y).
//
// Plain functions; nothing allocates.
#include <Eigen/Core>

#include "rollstep/planning/terrain.hpp"

namespace rollstep::control {

/// Smoothed distance of a point to a terrain prism, with its gradient and Hessian w.r.t. the
/// point (world frame).
struct SmoothDistance {
  double value = 0.0;
  Eigen::Vector3d gradient = Eigen::Vector3d::Zero();
  Eigen::Matrix3d hessian = Eigen::Matrix3d::Zero();
};

/// d(p) of the file comment for the prism under `region` with sharpness k > 0 [1/m].
SmoothDistance smoothPrismDistance(const planning::ConvexRegion& region, const Eigen::Vector3d& p,
                                   double k);
/// max_f s_f of the file comment (the unsmoothed face distance; the exact distance inside the
/// prism and in front of a face).
double prismFaceDistance(const planning::ConvexRegion& region, const Eigen::Vector3d& p);
/// The exact Euclidean distance of p to the prism (0 inside), for a region whose surface is
/// horizontal.
double prismDistance(const planning::ConvexRegion& region, const Eigen::Vector3d& p);

/// Convex hull of n <= 64 points (any order): the indices of its vertices,
/// counter-clockwise, collinear and repeated points dropped, into hull[0..count); `hull`
/// holds at least n + 1 entries. Returns the count, 0 when there is no polygon (n < 3, all
/// points collinear, n > 64).
int convexHull(const Eigen::Vector2d* points, int n, int* hull);

}  // namespace rollstep::control
