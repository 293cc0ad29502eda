#pragma once
// Convex foothold regions from a plane segmentation, in the planning layer's terrain form
// (planning::ConvexRegion: half-planes A p + b >= 0, height at the centroid, normal).
//
// Growing: a convex polygon is the intersection of K half-planes with fixed directions
// (K evenly spaced, turned to the region's main axis from OpenCV's minimum-area
// rectangle, or to the map grid's axes when that gives the larger polygon: a ragged
// border turns the rectangle by a fraction of a degree), around a seed inside the region. The cells
// bordering the region (outside it, holes and map border included) are obstacles. All half-planes
// are pushed outwards together, a little per round, each only as far as no obstacle cell centre
// enters the polygon (a point leaves the polygon's interior once it is on or beyond any one
// half-plane; counting, per obstacle, the half-planes it is beyond keeps a round linear
// in the obstacles). When all obstacles that would stop a half-plane in a round lie
// within a cell of another, already stopped half-plane, that one steps back onto them
// (once): a one-cell irregularity of the border (a cell straddling a step edge, whose
// label flips with last-bit rounding) moves an edge by a cell, not a far edge by the
// distance to it. A deeper notch (up to max_notch_depth) is looked at after the growth:
// where the obstacles that stopped one half-plane all lie within that depth beyond another
// one, that one steps back behind them, the others grow on, and the larger polygon is kept
// (the side edge of a floor's piece that met a notch at the riser's foot after the near
// edge had passed it ends the piece there; stepping the near edge back spans the floor).
// The result is then pulled in by half a cell (obstacle centres are
// half a cell beyond the region's edge) and by `margin`. An axis-aligned rectangle region
// is recovered exactly (to a cell); any region gives an inscribed convex polygon that
// grows from the seed in every direction until it touches the region's border.
#include <Eigen/Core>
#include <optional>
#include <utility>
#include <vector>

#include "rollstep/perception/plane_segmentation.hpp"
#include "rollstep/planning/terrain.hpp"

namespace rollstep::perception {

struct ConvexRegionSettings {
  int directions = 4;           ///< K half-plane directions (>= 4, even)
  double margin = 0.0;          ///< pulled in from the region's edge [m]
  double min_clearance = 0.03;  ///< a seed this close to the edge is moved inwards [m]
  double search_radius = 0.5;   ///< foothold selection: regions within this distance [m]
  double height_weight = 2.0;   ///< selection cost per metre of height difference
  /// Terrain cover: pieces per planar region, and the share of a region's cells the
  /// pieces must cover before the cover stops.
  int max_pieces_per_region = 8;
  double cover_fraction = 0.97;
  /// Terrain cover [m]: it also goes on while an uncovered part of a region is wider than
  /// this. The last few percent of a floor can be one long strip along its edge, where a
  /// wheel steps down (a piece that stepped back behind a notch leaves the strip in front).
  double cover_gap = 0.05;
  double min_piece_area = 0.01;  ///< smaller convex pieces are dropped [m^2]
  /// [m] A grown polygon's edge steps back up to this far behind a notch in the region's
  /// border when that lets the polygon grow larger (0: off). Uniform growth stops the
  /// edge that meets a notch first: a 10 cm notch of mixed cells at a riser's foot, met
  /// by the side edge of the floor's piece after its near edge had passed it, split the
  /// floor into two pieces with a 10 cm strip between them, under a stance wheel.
  double max_notch_depth = 0.2;

  void validate() const;  ///< std::invalid_argument naming the bad parameter
};

class ConvexRegionGrower {
 public:
  explicit ConvexRegionGrower(const ConvexRegionSettings& settings = {});
  const ConvexRegionSettings& settings() const { return settings_; }

  /// The region a foothold at nominal world position `foothold` (z: the expected height)
  /// should use: the one containing its (x, y) if any, else the nearest within
  /// search_radius, cost = distance + height_weight * |height difference|. -1 if none.
  int selectRegion(const Segmentation& seg, const Eigen::Vector3d& foothold) const;

  /// The largest convex polygon grown inside region `region` around `seed` (moved to the
  /// nearest cell at least min_clearance inside the region when it is not). nullopt when
  /// the region has no such cell or the polygon vanishes under the margin.
  std::optional<planning::ConvexRegion> grow(const Segmentation& seg, int region,
                                             const Eigen::Vector2d& seed);
  /// selectRegion then grow around the foothold.
  std::optional<planning::ConvexRegion> forFoothold(const Segmentation& seg,
                                                    const Eigen::Vector3d& foothold);

  /// The whole map as a planning terrain model: each planar region covered by up to
  /// max_pieces_per_region convex pieces, each grown from the region's cell furthest
  /// from its border and from the pieces before it, until cover_fraction of its cells is
  /// covered and no uncovered part is wider than cover_gap.
  planning::TerrainModel terrain(const Segmentation& seg);

 private:
  /// Fills obstacles_ and mask_ for `region`; returns false if the region is empty.
  bool prepare(const Segmentation& seg, int region);
  /// The larger of the polygons grown at the main axis and at the grid's axes.
  std::optional<planning::ConvexRegion> growPrepared(const Segmentation& seg, int region,
                                                     const Eigen::Vector2d& seed);
  /// Grown with direction 0 at `angle` [rad].
  std::optional<planning::ConvexRegion> growAt(const Segmentation& seg, int region,
                                               const Eigen::Vector2d& seed, double angle);
  /// The polygon of half-plane offsets `off` around s (each pulled in by `inset`).
  std::vector<Eigen::Vector2d> polygonAt(const std::vector<Eigen::Vector2d>& dirs,
                                         const Eigen::Vector2d& s, double cap,
                                         const std::vector<double>& off, double inset);
  /// Obstacle i lies within every half-plane of offsets `off` but k (so k alone keeps it out).
  bool insideAllBut(std::size_t i, std::size_t k, const std::vector<double>& off) const;
  /// How far half-plane k can go from off[k] before an obstacle inside all the others
  /// stops it (cap if none does).
  double reach(int k, const std::vector<double>& off, double cap) const;
  /// After the growth: where a half-plane stopped at a notch of the border (obstacles at
  /// most max_notch_depth beyond another half-plane), that one steps back behind the notch
  /// and the others grow on, when the polygon gets larger.
  void stepBackFromNotches(const std::vector<Eigen::Vector2d>& dirs, const Eigen::Vector2d& s,
                           double cap, double res, std::vector<double>& off);

  ConvexRegionSettings settings_;
  std::vector<Eigen::Vector2d> obstacles_;
  std::vector<double> proj_;                         // obstacles x directions
  std::vector<std::pair<std::size_t, int>> rescue_;  // (obstacle, half-plane stepping back)
  std::vector<int> beyond_;                          // per obstacle: half-planes it is on or beyond
  std::vector<unsigned char> mask_;                  // region cells (row-major, map size)
  std::vector<double> clearance_;  // distance to the nearest non-region cell [cells]
  std::vector<Eigen::Vector2d> clip_tmp_;
  double angle_ = 0.0;  // of direction 0 [rad]
};

}  // namespace rollstep::perception
