#pragma once
// The stages of PlaneSegmenter::segment (plane_segmentation.hpp lists the algorithm), each a
// free function over the map, the settings, the segmenter's workspace and the result, in
// the order segment() calls them. Apart so that each stage reads as one step and can be
// tested on its own (a test may also set the labels by hand and run one stage). Once the
// workspace is sized for the map, none allocates except where noted (the per-region
// buffers when there are more regions than before, the result's polygons).
#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <vector>

#include "rollstep/perception/elevation_map.hpp"
#include "rollstep/perception/plane_segmentation.hpp"

namespace rollstep::perception::segmentation {

/// Channels of the least-squares sums of a plane fit (x = column, y = row, z = height).
enum Channel { kN, kX, kY, kZ, kXX, kXY, kYY, kXZ, kYZ, kZZ, kChannels };
using PlaneSums = Eigen::Matrix<double, kChannels, 1>;

/// Every buffer of the stages, sized once per map size (resize) and kept between calls.
struct Workspace {
  int n = 0;                          ///< cells per side the buffers are sized for
  double zref = 0.0;                  ///< heights are fitted relative to it [m] (referenceHeight)
  std::vector<double> sat;            ///< (n + 1)^2 x kChannels summed-area tables, interleaved
  std::vector<float> fitted;          ///< local plane height at the cell [m] (NaN: no fit)
  std::vector<float> gx, gy;          ///< local gradient [m/m]
  std::vector<unsigned char> planar;  ///< 1: the local fit accepts the cell
  std::vector<int> queue, depth;      ///< breadth-first searches
  cv::Mat hmax, hmin, step;           ///< CV_32F, CV_32F, CV_8U (1: step edge)
  cv::Mat region_mask;                ///< CV_8U, (n + 2)^2: one region's mask with a border
  cv::Mat hole_fill;                  ///< CV_8U, one hole of a region's mask
  std::vector<int> rmin, rmax, cmin, cmax;  ///< bounding box of each region's cells
  std::vector<int> remap;                   ///< old region index -> new (-1: dropped)
  std::vector<int> parent;                  ///< union-find over regions (joining strips)
  std::vector<int> pair_cells;              ///< regions x regions: shared border cell pairs
  std::vector<int> on_plane;                ///< (l, m): cells of l within step_height of m's plane
  std::vector<int> region_cells;            ///< cells per region
  std::vector<PlaneSums> acc;               ///< per region: least-squares sums of its cells
  std::vector<std::vector<cv::Point>> contours;
  std::vector<cv::Vec4i> hierarchy;

  void resize(int size);
  bool stepEdge(int r, int c) const { return step.at<unsigned char>(r, c) != 0; }
};

/// Sizes the workspace for `map` and empties `out` (labels all -1) on the map's grid.
void beginSegmentation(const ElevationMap& map, Workspace& w, Segmentation& out);

// 1. Local plane fits.
/// w.zref: the first measured height (keeps the summed squares small), 0 for an empty map.
void referenceHeight(const ElevationMap& map, Workspace& w);
/// w.sat: summed-area tables of the measured cells' least-squares sums (O(1) window sums).
void sumMeasuredCells(const ElevationMap& map, Workspace& w);
/// w.step: measured cells whose 3 x 3 neighbourhood spans more than step_height.
void markStepEdges(const ElevationMap& map, const SegmentationSettings& settings, Workspace& w);
/// w.fitted, w.gx, w.gy, w.planar: a plane fitted in the window around every cell (needs
/// w.sat and w.step); planar when enough of the window is measured, the RMS residual is small,
/// the slope walkable and the cell no step edge.
void fitLocalPlanes(const ElevationMap& map, const SegmentationSettings& settings, Workspace& w);

// 2. Region growing.
/// out.labels: planar cells grown into regions (4-connected) while the fitted heights of
/// neighbours are within max_height_step and the normals within max_normal_angle_deg of the
/// region's mean normal (a slope and the floor it starts from become two regions); regions
/// smaller than min_region_area are dropped. out.regions gets one (unfitted) entry per region.
void growRegions(const ElevationMap& map, const SegmentationSettings& settings, Workspace& w,
                 Segmentation& out);

// 3. One plane per region.
/// out.regions: each region's plane, least squares over its cells (measured height, else the
/// fitted one); w.acc keeps the sums (joinRegionsOnPlanes refits from them).
void fitRegionPlanes(const ElevationMap& map, Workspace& w, Segmentation& out);
/// out.labels: each region grows back, breadth first and 8-connected, up to window_half + 1
/// cells over the unlabelled measured cells within grow_tolerance of its plane (a step blurs the
/// window fit a window's half-width in from the true edge).
void growBack(const ElevationMap& map, const SegmentationSettings& settings, Workspace& w,
              Segmentation& out);
/// A region whose cells (95 %) lie within step_height of a touching, larger region's plane
/// joins it (a strip at a riser's foot the window fit cut off the floor); merged planes are
/// refitted from w.acc, labels renumbered with the roots in their order.
void joinRegionsOnPlanes(const ElevationMap& map, const SegmentationSettings& settings,
                         Workspace& w, Segmentation& out);

// 4. Holes and polygons.
/// w.rmin, w.rmax, w.cmin, w.cmax: each region's bounding box (rmax -1: no cells).
void regionBoundingBoxes(Workspace& w, const Segmentation& out);
/// Fills the holes of each region that are small (max_hole_area) or level (max_level_hole_area:
/// every cell measured, within step_height of the region's plane, no step edge; cells of
/// other regions inside join the region). Needs the bounding boxes; returns whether a cell of
/// another region was taken (then dropEmptyRegions), else the boxes stand.
bool fillHoles(const ElevationMap& map, const SegmentationSettings& settings, Workspace& w,
               Segmentation& out);
/// Drops the regions left without cells, renumbering the labels; recomputes the boxes.
void dropEmptyRegions(Workspace& w, Segmentation& out);
/// Each region's boundary as polygons with holes on its cells' outer edges (needs the
/// boxes), its cell count and area.
void traceRegionPolygons(Workspace& w, Segmentation& out);

// 5. Step edges.
/// out.step_edges: the step-edge cells (w.step) as obstacle polygons.
void traceStepEdges(Workspace& w, Segmentation& out);

}  // namespace rollstep::perception::segmentation
