#pragma once
// Plane segmentation of an elevation map (after Grandia et al. 2023, "Perceptive
// locomotion through nonlinear model predictive control", section on terrain
// segmentation, simplified):
//  1. a local plane is fitted by least squares in a window around every cell (summed-area
//     tables: O(1) per cell); a cell is planar when the window holds enough measured
//     cells, the RMS residual is small and the slope is walkable. A planar cell without a
//     measurement of its own gets the fitted height (small holes in the data are filled);
//  2. planar cells are grown into regions (4-connected) while their heights are
//     continuous and their normals stay close to the region's mean normal, so a slope
//     and the flat floor it starts from become two regions;
//  3. each region gets one plane (least squares over its cells) and is grown back over
//     the cells the window fit rejected near its border (steps blur the window fit a
//     window's half-width in from the true edge) whose measured height lies on its plane;
//     a region whose cells (95 %) lie within step_height of an adjacent, larger region's
//     plane then joins it (a strip at a riser's foot the window fit cut off the floor);
//  4. small holes of a region are filled, its boundary is traced (OpenCV contours) as
//     polygons with holes in world coordinates on the cells' outer edges;
//  5. step edges (cells whose neighbourhood spans more than step_height) are obstacles,
//     traced as polygons too.
// The map is read as an image with OpenCV (core, imgproc). Buffers are kept between
// calls; only the result's polygon lists allocate. Each step is a function of its own
// (src/perception/segmentation_stages.hpp), tested on its own.
#include <Eigen/Core>
#include <memory>
#include <vector>

#include "rollstep/perception/elevation_map.hpp"

namespace rollstep::perception {

namespace segmentation {
struct Workspace;  // the stages' buffers (src/perception/segmentation_stages.hpp)
}

struct SegmentationSettings {
  int window_half = 2;                ///< local fit window: (2 h + 1)^2 cells
  double min_window_fill = 0.5;       ///< fraction of the window that must be measured
  double max_residual = 0.012;        ///< RMS of the local fit [m]
  double max_slope_deg = 30.0;        ///< steeper is not walkable
  double max_normal_angle_deg = 6.0;  ///< region growing: to the region's mean normal
  double max_height_step = 0.025;     ///< region growing: between neighbours [m]
  double step_height = 0.04;          ///< a neighbourhood spanning more is a step edge [m]
  double grow_tolerance = 0.02;       ///< grow-back: distance to the region's plane [m]
  double min_region_area = 0.02;      ///< smaller regions are dropped [m^2]
  double max_hole_area = 0.01;        ///< smaller holes in a region are filled [m^2]
  /// [m^2] Larger holes up to this area are filled when they are level: every cell in them
  /// measured (or gap-filled), within step_height of the region's plane, no step edge (noise
  /// the local fit rejected; other regions inside join the region; unseen patches stay
  /// holes); 0: off.
  double max_level_hole_area = 0.25;
  /// [m] Before segmenting, unseen gaps on one surface (ends within step_height) at most
  /// this wide are filled, interpolated (ElevationMap::fillGaps); 0: off.
  double fill_gap = 0.2;
  /// [m] The same for an unseen gap between surfaces more than step_height apart, filled
  /// with the lower one (the shadow behind a step down: a LiDAR mounted at the front and
  /// looking back over a step down never sees the floor right behind it); 0: off.
  double fill_shadow = 0.4;

  void validate() const;  ///< std::invalid_argument naming the bad parameter
};

/// A closed polygon (world x, y [m], counter-clockwise outer / clockwise holes).
using Ring = std::vector<Eigen::Vector2d>;
struct PolygonWithHoles {
  Ring outer;
  std::vector<Ring> holes;
};

struct PlanarRegion {
  /// Plane z = c0 + g . (p - anchor) with anchor the region's cell centroid.
  Eigen::Vector2d anchor = Eigen::Vector2d::Zero();
  double height = 0.0;                                 ///< z at anchor [m]
  Eigen::Vector2d gradient = Eigen::Vector2d::Zero();  ///< dz/dx, dz/dy
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
  double rms = 0.0;  ///< of the cells' heights to the plane [m]
  int cells = 0;
  double area = 0.0;  ///< cells * resolution^2 [m^2]
  std::vector<PolygonWithHoles> polygons;

  double heightAt(const Eigen::Vector2d& p) const { return height + gradient.dot(p - anchor); }
};

struct Segmentation {
  std::vector<PlanarRegion> regions;
  std::vector<PolygonWithHoles> step_edges;  ///< obstacles
  /// Row-major per map cell: index of its region, -1 for none.
  std::vector<int> labels;
  int size = 0;                                      ///< cells per side
  double resolution = 0.0;                           ///< [m]
  Eigen::Vector2d origin = Eigen::Vector2d::Zero();  ///< world corner of cell (0, 0)

  int label(int r, int c) const { return labels[static_cast<std::size_t>(r * size + c)]; }
  Eigen::Vector2d cellCenter(int r, int c) const {
    return origin + resolution * Eigen::Vector2d(c + 0.5, r + 0.5);
  }
  /// Region index under world point p (-1: none or outside the map).
  int regionAt(const Eigen::Vector2d& p) const;
};

class PlaneSegmenter {
 public:
  explicit PlaneSegmenter(const SegmentationSettings& settings = {});
  ~PlaneSegmenter();
  PlaneSegmenter(PlaneSegmenter&&) noexcept;
  PlaneSegmenter& operator=(PlaneSegmenter&&) noexcept;

  const SegmentationSettings& settings() const { return settings_; }
  /// Segments `map` into `out` (its previous content is replaced).
  void segment(const ElevationMap& map, Segmentation& out);

 private:
  SegmentationSettings settings_;
  std::unique_ptr<segmentation::Workspace> ws_;
};

}  // namespace rollstep::perception
