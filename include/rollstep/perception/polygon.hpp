#pragma once
// Polygon-with-holes geometry on Boost.Geometry (kept to one translation unit for build
// time): areas, overlap, offsets and distances of the segmentation's polygons.
#include <Eigen/Core>
#include <vector>

#include "rollstep/perception/plane_segmentation.hpp"

namespace rollstep::perception {

/// Area [m^2] (outer minus holes); orientation and closure of the rings do not matter.
double area(const PolygonWithHoles& p);
/// Area of the intersection of two sets of polygons (each set a union) [m^2].
double intersectionArea(const std::vector<PolygonWithHoles>& a,
                        const std::vector<PolygonWithHoles>& b);
/// Area of the union of two sets of polygons [m^2].
double unionArea(const std::vector<PolygonWithHoles>& a, const std::vector<PolygonWithHoles>& b);
/// Intersection over union of two sets of polygons (0 when both are empty).
double iou(const std::vector<PolygonWithHoles>& a, const std::vector<PolygonWithHoles>& b);
/// Distance [m] from p to the nearest boundary (outer ring or hole) of the polygons.
double boundaryDistance(const std::vector<PolygonWithHoles>& polygons, const Eigen::Vector2d& p);
/// The polygons grown by `distance` [m] (< 0: shrunk) with mitred corners; pieces that
/// vanish are dropped.
std::vector<PolygonWithHoles> offset(const std::vector<PolygonWithHoles>& polygons,
                                     double distance);
/// An axis-aligned rectangle as a polygon (for ground truth and tests).
PolygonWithHoles rectangle(double x_min, double x_max, double y_min, double y_max);

}  // namespace rollstep::perception
