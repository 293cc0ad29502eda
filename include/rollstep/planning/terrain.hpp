#pragma once
// Terrain model: planar convex foothold regions (paper eq. convexRegionConstraint).
//
// A region is a convex polygon in the world (x, y) plane, the plane of its surface
// (height at the polygon's centroid and unit normal, n_z > 0) and the half-planes
// A [x y]^T + b >= 0 of the polygon, one row per edge, rows of unit length pointing
// inwards, so that A p + b is the distance of p to each edge line (positive inside).
// The model is a list of regions, built once (from a scene's ground-truth geometry now,
// from perception later through the same constructor) and queried without allocation.
#include <Eigen/Core>
#include <vector>

#include "rollstep/planning/swing_trajectory.hpp"

namespace rollstep::planning {

/// Signed area of a simple polygon (the shoelace formula): positive counter-clockwise [m^2].
double signedPolygonArea(const std::vector<Eigen::Vector2d>& vertices);

struct ConvexRegion {
  std::vector<Eigen::Vector2d> vertices;       ///< counter-clockwise, no repeats [m]
  Eigen::Matrix<double, Eigen::Dynamic, 2> A;  ///< one unit inward row per edge
  Eigen::VectorXd b;                           ///< A p + b >= 0 inside [m]
  Eigen::Vector2d centroid = Eigen::Vector2d::Zero();
  double height = 0.0;                                ///< z of the surface at the centroid [m]
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  ///< unit surface normal, z > 0

  /// Vertices in either orientation (stored counter-clockwise). Throws
  /// std::invalid_argument naming the parameter and value: fewer than 3 vertices (an
  /// empty polygon), non-finite or repeated vertices, zero area, a non-convex polygon, a
  /// non-finite height, a zero, non-finite or horizontal-or-downward (n_z <= 0) normal.
  static ConvexRegion fromPolygon(const std::vector<Eigen::Vector2d>& vertices, double height,
                                  const Eigen::Vector3d& normal = Eigen::Vector3d::UnitZ());

  /// min over edges of A p + b: >= 0 inside, the distance to the nearest edge line.
  double margin(const Eigen::Vector2d& p) const;
  bool contains(const Eigen::Vector2d& p, double tolerance = 1e-9) const {
    return margin(p) >= -tolerance;
  }
  /// The point of the polygon nearest to p (p itself inside).
  Eigen::Vector2d closestPoint(const Eigen::Vector2d& p) const;
  /// Euclidean distance from p to the polygon (0 inside).
  double distance(const Eigen::Vector2d& p) const;
  /// z of the region's plane above (x, y) = p.
  double heightAt(const Eigen::Vector2d& p) const;
  /// Area of the polygon seen from above [m^2].
  double area() const { return signedPolygonArea(vertices); }
  /// Shrinks [lo, hi] to the part of the line p + d e (e unit) inside the polygon; lo > hi
  /// after it when there is none. No allocation.
  void clipLine(const Eigen::Vector2d& p, const Eigen::Vector2d& e, double& lo, double& hi) const;
};

/// An axis-aligned box on the floor, seen from above: its footprint and top height [m].
struct TerrainBox {
  double x_min = 0.0, x_max = 0.0;
  double y_min = 0.0, y_max = 0.0;
  double top = 0.0;
};

class TerrainModel {
 public:
  TerrainModel() = default;
  explicit TerrainModel(std::vector<ConvexRegion> regions);

  int size() const { return static_cast<int>(regions_.size()); }
  /// The most edges of any region (0 for an empty model).
  int maxEdges() const;
  /// Exchanges the regions with `other` in O(1), without allocating: how a new terrain
  /// (e.g. from perception) replaces this one under the planners that point at it.
  void swap(TerrainModel& other) noexcept { regions_.swap(other.regions_); }
  const ConvexRegion& region(int i) const { return regions_[static_cast<std::size_t>(i)]; }
  const std::vector<ConvexRegion>& regions() const { return regions_; }

  /// The region a foot at (x, y) = p should use: among the regions containing p, the one
  /// whose surface is highest at p; if none contains p (a gap, a shrunk edge), the
  /// nearest. -1 for an empty model.
  int regionAt(const Eigen::Vector2d& p) const;
  /// Surface height at p from regionAt(p); `fallback` for an empty model.
  double heightAt(const Eigen::Vector2d& p, double fallback = 0.0) const;
  /// Up, down or level, from the surface heights at the lift-off and touch-down points.
  SwingDirection classifySwing(const Eigen::Vector2d& p_liftoff, const Eigen::Vector2d& p_touchdown,
                               double tolerance = 1e-3) const;
  /// The region that constrains a swing for collision avoidance: the lower one, i.e.
  /// the lift-off region when ascending (applied on the first half of the swing) and the
  /// touch-down region when descending (second half); -1 on the level.
  int swingRegion(const Eigen::Vector2d& p_liftoff, const Eigen::Vector2d& p_touchdown,
                  double tolerance = 1e-3) const;
  /// The region a foot at p moving along the unit direction e should use: regionAt(p) when
  /// a region contains p; in a gap, the region the ray p + d e (0 < d <= reach) enters
  /// first, if any (a foothold between two shrunk regions goes onto the next one along the
  /// travel instead of back onto the one it leaves); else the nearest. -1 for an empty model.
  int regionAhead(const Eigen::Vector2d& p, const Eigen::Vector2d& e, double reach) const;
  /// The terrain seen along a line, lowered beyond a distance: the largest of heightAt(p) and
  /// H(p + d e) - slope max(|d| - reach, 0) over every d, with H the highest region
  /// containing the point (points in no region, gaps between shrunk regions, count nothing).
  /// Exact (each region's plane clipped to the segment), no allocation. `e` is a unit
  /// direction; reach and slope are >= 0 (slope 0: only |d| <= reach counts). A step of
  /// height s within `reach` ahead or behind counts fully, one at reach + d raises the result
  /// to s - slope d: a body reference built from it is up before a step up and comes down
  /// only after a step down.
  double envelopeHeight(const Eigen::Vector2d& p, const Eigen::Vector2d& e, double reach,
                        double slope) const;

 private:
  std::vector<ConvexRegion> regions_;
};

/// A planar top face seen from above: its convex footprint and its plane.
struct TerrainSurface {
  std::vector<Eigen::Vector2d> footprint;             ///< convex, either orientation [m]
  Eigen::Vector3d point = Eigen::Vector3d::Zero();    ///< a point of the plane [m]
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  ///< the plane's normal, z > 0
};

/// Terrain from ground-truth geometry: a flat floor at `floor_height` over the rectangle
/// [x_min, x_max] x [y_min, y_max] of `floor`, under planar top faces (boxes, ramps; where
/// they overlap the highest wins, so stairs are boxes of growing height). What is seen from
/// above is cut into convex pieces along every footprint edge and every line where two
/// surfaces cross; each piece takes the highest surface over it, and pieces of one surface
/// merge while their union stays convex. The margin [m] keeps feet off steps: a band of
/// half-width `margin` around every step (a footprint edge where the seen height jumps by
/// more than 1 mm, the floor's border), square at its ends, is no foothold; nothing else
/// shrinks, so neighbouring pieces of one surface (the floor beside a block, a ramp meeting
/// the floor) still meet with no gap. Throws std::invalid_argument naming the bad field for
/// non-finite values, empty ranges, a non-convex footprint, a plane that is not upward, a
/// negative margin, or a margin that leaves a surface seen from above no foothold at all.
TerrainModel terrainFromSurfaces(const TerrainBox& floor, double floor_height,
                                 const std::vector<TerrainSurface>& surfaces, double margin = 0.0);

/// terrainFromSurfaces of axis-aligned boxes standing on the floor (a box's top is its
/// height); errors name the box ("boxes[1].x_max = ...").
TerrainModel terrainFromBoxes(const TerrainBox& floor, double floor_height,
                              const std::vector<TerrainBox>& boxes, double margin = 0.0);

/// Every region shrunk by `margin` [m] (each edge moved inwards, in the region's plane seen
/// from above; the height is the old plane's at the new centroid): the foothold regions of
/// a terrain whose surfaces are given unshrunk (e.g. a perceived terrain, whose unshrunk
/// regions are a collision model's solids). Regions that vanish are dropped.
///
/// Seams (seam_probe > 0): a surface covered by several convex pieces (a perceived floor
/// around holes) has edges between pieces where the surface goes on; moving those inwards
/// would open gaps of 2 margin in the middle of a floor. An edge is a seam, and stays, when
/// the points seam_probe beyond it (one every seam_probe along it, its ends included) all
/// lie in other regions whose surface there is within seam_height_tolerance of this one's.
/// Throws std::invalid_argument for a negative or non-finite margin, probe or tolerance.
TerrainModel shrinkTerrain(const TerrainModel& terrain, double margin, double seam_probe = 0.0,
                           double seam_height_tolerance = 0.02);

/// Nearly level surfaces made level (for measured terrains, whose planes carry the sensor's
/// noise): every region whose normal is within max_tilt [rad] of vertical gets the normal
/// +z, and such regions whose heights (at their centroids) lie within height_tolerance [m]
/// of the lowest of a group share one height, the area-weighted mean of the group's. Without
/// it, two pieces of one floor a millimetre apart make every swing between them a climb
/// (TerrainModel::classifySwing's tolerance is 1 mm) and tilt the friction cones. Other
/// regions are kept as they are. Throws std::invalid_argument for negative or non-finite
/// arguments.
TerrainModel levelTerrain(const TerrainModel& terrain, double max_tilt, double height_tolerance);

}  // namespace rollstep::planning
