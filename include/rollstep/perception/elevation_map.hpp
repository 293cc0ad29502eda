#pragma once
// Robot-centric elevation map (Fankhauser et al. 2014/2018, simplified): a square grid of
// cells around the robot, each with a height estimate and its variance, fused from point
// clouds over time. Robot-agnostic: it sees points and the sensor pose, nothing else.
//
// Cells: column c along world x, row r along world y; cell (r, c) covers
// [origin_x + c res, origin_x + (c + 1) res) x [origin_y + r res, ...). The map moves with
// the robot in whole cells (moveTo): cells that leave it are forgotten, cells that enter it
// are empty. Empty cells hold NaN height. Fusion per point (1-D Kalman filter on the
// height): a point within `gate` standard deviations of the estimate is fused; a point
// clearly above it replaces it (a surface seen for the first time, e.g. the top of a step
// whose face was hit before); a point clearly below it only inflates the variance (it may
// be noise or a ray grazing an edge; repeated ones then fuse). Visibility clean-up: a ray
// that passes below a cell's height on its way to its hit proves that the cell's surface
// is not there (it moved, or was an outlier): the cell is cleared.
//
// Everything is allocated in the constructor: moveTo, update and predict never allocate.
#include <Eigen/Geometry>
#include <vector>

namespace rollstep::perception {

struct ElevationMapSettings {
  double length = 4.0;       ///< side of the square map [m] (rounded to whole cells)
  double resolution = 0.02;  ///< cell side [m]
  /// Standard deviation of a point's height [m] = sensor_noise + range_noise_slope * range.
  double sensor_noise = 0.005;
  double range_noise_slope = 0.002;
  double gate = 3.0;             ///< Mahalanobis gate [standard deviations]
  double process_noise = 1e-4;   ///< variance growth per second of a cell [m^2/s]
  double max_variance = 0.0025;  ///< a cell less certain than this is cleared [m^2]
  double min_variance = 1e-6;    ///< variance floor [m^2]
  bool visibility_cleanup = true;
  /// Clean-up along every n-th ray only (elevation_mapping runs it at a lower rate too).
  int visibility_stride = 4;
  /// Clear a cell only if the ray passed this far below its height [m].
  double visibility_margin = 0.03;
  /// Points further than this from the sensor, or nearer than min_range, are ignored [m].
  double max_range = 10.0;
  double min_range = 0.1;

  /// Throws std::invalid_argument naming the first bad parameter and its value.
  void validate() const;
};

/// What one update did with its points.
struct MapUpdateStats {
  int points = 0;      ///< points given
  int non_finite = 0;  ///< NaN / infinite points or sensor pose (ignored)
  int out_of_map = 0;  ///< outside the map or outside [min_range, max_range]
  int fused = 0;       ///< fused into or replaced a cell
  int cleared = 0;     ///< cells cleared by visibility clean-up
};

class ElevationMap {
 public:
  explicit ElevationMap(const ElevationMapSettings& settings = {});

  const ElevationMapSettings& settings() const { return settings_; }
  int size() const { return n_; }  ///< cells per side
  double resolution() const { return res_; }
  /// World (x, y) [m] of the map's lower corner (cell (0, 0)'s corner).
  Eigen::Vector2d origin() const { return {gx0_ * res_, gy0_ * res_}; }
  /// Centre of cell (r, c) in the world [m].
  Eigen::Vector2d cellCenter(int r, int c) const {
    return {(gx0_ + c + 0.5) * res_, (gy0_ + r + 0.5) * res_};
  }
  /// Cell containing world (x, y); false if outside the map.
  bool cellOf(const Eigen::Vector2d& p, int& r, int& c) const;

  /// Recentres the map on world (x, y) [m] (whole cells). Non-finite: ignored, false.
  bool moveTo(const Eigen::Vector2d& center);
  /// Grows every cell's variance by process_noise * dt and clears cells above
  /// max_variance (time passing, base pose drift).
  void predict(double dt);
  /// Fuses points given in the sensor frame, with the sensor's pose in the world.
  /// Non-finite points are counted and skipped; a non-finite pose fuses nothing.
  MapUpdateStats update(const Eigen::Vector3d* points, int count,
                        const Eigen::Isometry3d& sensor_pose);
  MapUpdateStats update(const std::vector<Eigen::Vector3d>& points,
                        const Eigen::Isometry3d& sensor_pose) {
    return update(points.data(), static_cast<int>(points.size()), sensor_pose);
  }
  /// Fills the empty cells under the robot, which the sensor cannot see, from its contact
  /// points (world; e.g. the wheels' ground contacts from the leg kinematics): the plane
  /// through them (least squares; their mean height with fewer than 3) over their
  /// bounding box grown by `margin` [m], with variance `variance` [m^2]. Measured cells are
  /// kept. Returns the cells filled (0 for no or non-finite contacts).
  int fillFootprint(const Eigen::Vector3d* contacts, int count, double margin, double variance);
  /// Azimuth sectors of fillBlindZone (half a degree each), and the sectors on either side
  /// that bound each one together with it (2 degrees: a cell at 0.6 m).
  static constexpr int kBlindZoneSectors = 720;
  static constexpr int kBlindZoneWindow = 4;
  /// Fills the empty cells of a sensor's blind zone: the ground near a LiDAR that its lowest
  /// beam passes over (a disc, off-centre when the sensor is tilted), which no scan taken
  /// from the start pose can see and a robot walking on never will. In each azimuth sector
  /// around the sensor's ground point `sensor_xy`, the nearest measured cell (within
  /// `max_radius` [m]) of the sector and its neighbours within 2 degrees bounds the zone; the empty
  /// cells nearer than it are filled from the contact plane (as fillFootprint) with variance
  /// `variance` [m^2], but only when that nearest cells lie within `max_step` [m] of the plane: the
  /// ground seen just beyond the zone continues the ground the robot stands on. A sector whose
  /// nearest surface is higher or lower (a step, an obstacle or a pit that begins inside the zone)
  /// or that has no measured cell within max_radius stays empty. Call it on measured cells only
  /// (before fillFootprint or gap filling). Returns the cells filled (0 for bad arguments). Never
  /// allocates.
  int fillBlindZone(const Eigen::Vector2d& sensor_xy, const Eigen::Vector3d* contacts, int count,
                    double max_radius, double max_step, double variance);
  /// Empties every cell.
  void clear();
  /// This map becomes a copy of `other` (cells and placement); `other` must have the same
  /// size (e.g. the same settings), else nothing is copied and false is returned. Never
  /// allocates.
  bool copyFrom(const ElevationMap& other);
  /// Fills the empty cells that lie in a small gap between measured cells: the unseen strips
  /// between the rings a multi-beam LiDAR draws on the ground, and the shadow behind a step
  /// down. An empty cell whose nearest measured cells on both sides along a row, a column or
  /// a diagonal have at most max_gap_cells empty cells between them (the shortest such gap
  /// wins) gets the linear interpolation between them when they differ by at most max_step
  /// [m] in height (one surface), else the lower one's height (a shadow behind an edge is the
  /// lower surface going on under it: anything higher would have been seen), and the larger
  /// of their variances. Never extrapolates: a cell with one side unseen stays empty.
  /// `max_shadow_cells` (< 0: max_gap_cells) is the same limit for a gap whose sides differ
  /// by more than max_step (a shadow: the lower side's height); the shortest gap still wins.
  /// Returns the cells filled. Never allocates.
  int fillGaps(int max_gap_cells, double max_step, int max_shadow_cells = -1);

  /// Row-major cells (index r * size() + c): height [m] (NaN: empty) and variance [m^2].
  const std::vector<float>& heights() const { return height_; }
  const std::vector<float>& variances() const { return variance_; }
  float height(int r, int c) const { return height_[static_cast<std::size_t>(r * n_ + c)]; }
  float variance(int r, int c) const { return variance_[static_cast<std::size_t>(r * n_ + c)]; }
  int validCells() const;

  /// Direct access for tests and offline tools: sets one cell (NaN empties it).
  void setCell(int r, int c, float height, float variance);

 private:
  void fuse(std::size_t i, double z, double var);
  int clearAlongRay(const Eigen::Vector3d& from, const Eigen::Vector3d& to, double top);

  ElevationMapSettings settings_;
  double res_;
  int n_;
  long gx0_ = 0, gy0_ = 0;  // global index of cell (0, 0)
  std::vector<float> height_, variance_, scratch_h_, scratch_v_;
};

}  // namespace rollstep::perception
