#include "rollstep/perception/plane_segmentation.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <string>

#include "rollstep/common/number_text.hpp"
#include "rollstep/perception/polygon.hpp"
#include "segmentation_stages.hpp"

namespace rollstep::perception {

namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
constexpr double kPi = 3.14159265358979323846;

void require(bool ok, const char* name, double value, const char* what) {
  if (!ok) {
    throw std::invalid_argument(std::string("plane segmentation: ") + name + " = " +
                                shortestNumberText(value) + ": " + what);
  }
}

}  // namespace

void SegmentationSettings::validate() const {
  require(window_half >= 1 && window_half <= 10, "window_half", window_half, "must be 1 to 10");
  require(min_window_fill > 0 && min_window_fill <= 1, "min_window_fill", min_window_fill,
          "must be in (0, 1]");
  require(std::isfinite(max_residual) && max_residual > 0, "max_residual", max_residual,
          "must be > 0");
  require(max_slope_deg > 0 && max_slope_deg < 90, "max_slope_deg", max_slope_deg,
          "must be in (0, 90)");
  require(max_normal_angle_deg > 0 && max_normal_angle_deg < 90, "max_normal_angle_deg",
          max_normal_angle_deg, "must be in (0, 90)");
  require(std::isfinite(max_height_step) && max_height_step > 0, "max_height_step", max_height_step,
          "must be > 0");
  require(std::isfinite(step_height) && step_height > 0, "step_height", step_height, "must be > 0");
  require(std::isfinite(grow_tolerance) && grow_tolerance >= 0, "grow_tolerance", grow_tolerance,
          "must be >= 0");
  require(std::isfinite(min_region_area) && min_region_area >= 0, "min_region_area",
          min_region_area, "must be >= 0");
  require(std::isfinite(fill_gap) && fill_gap >= 0 && fill_gap <= 1, "fill_gap", fill_gap,
          "must be in [0, 1] m");
  require(std::isfinite(max_hole_area) && max_hole_area >= 0, "max_hole_area", max_hole_area,
          "must be >= 0");
  require(std::isfinite(fill_shadow) && fill_shadow >= 0 && fill_shadow <= 1, "fill_shadow",
          fill_shadow, "must be in [0, 1] m");
  require(std::isfinite(max_level_hole_area) && max_level_hole_area >= 0, "max_level_hole_area",
          max_level_hole_area, "must be >= 0");
}

int Segmentation::regionAt(const Eigen::Vector2d& p) const {
  if (size <= 0 || !p.allFinite()) return -1;
  const Eigen::Vector2d q = (p - origin) / resolution;
  if (q.x() < 0 || q.y() < 0 || q.x() >= size || q.y() >= size) return -1;
  return label(static_cast<int>(q.y()), static_cast<int>(q.x()));
}

PlaneSegmenter::PlaneSegmenter(const SegmentationSettings& settings)
    : settings_(settings), ws_(std::make_unique<segmentation::Workspace>()) {
  settings_.validate();
}
PlaneSegmenter::~PlaneSegmenter() = default;
PlaneSegmenter::PlaneSegmenter(PlaneSegmenter&&) noexcept = default;
PlaneSegmenter& PlaneSegmenter::operator=(PlaneSegmenter&&) noexcept = default;

void PlaneSegmenter::segment(const ElevationMap& map, Segmentation& out) {
  using namespace segmentation;
  Workspace& w = *ws_;
  beginSegmentation(map, w, out);
  // 1. Local plane fits and step edges.
  referenceHeight(map, w);
  sumMeasuredCells(map, w);
  markStepEdges(map, settings_, w);
  fitLocalPlanes(map, settings_, w);
  // 2. Regions of planar cells.
  growRegions(map, settings_, w, out);
  if (out.regions.empty()) return;
  // 3. One plane per region, grown back over its blurred border; strips join their floor.
  fitRegionPlanes(map, w, out);
  growBack(map, settings_, w, out);
  joinRegionsOnPlanes(map, settings_, w, out);
  // 4. Holes filled, polygons traced.
  regionBoundingBoxes(w, out);
  if (fillHoles(map, settings_, w, out)) dropEmptyRegions(w, out);
  traceRegionPolygons(w, out);
  // 5. Step edges as obstacles.
  traceStepEdges(w, out);
}

namespace segmentation {

namespace {

/// Traces the boundary of mask (CV_8U, 1 = inside; a one-cell zero border around the
/// map) as polygons on the cells' outer edges, in world coordinates.
std::vector<PolygonWithHoles> tracePolygons(const cv::Mat& mask, const Eigen::Vector2d& origin,
                                            double res,
                                            std::vector<std::vector<cv::Point>>& contours,
                                            std::vector<cv::Vec4i>& hierarchy) {
  contours.clear();
  hierarchy.clear();
  cv::findContours(mask, contours, hierarchy, cv::RETR_CCOMP, cv::CHAIN_APPROX_SIMPLE);
  std::vector<PolygonWithHoles> centres;
  std::vector<cv::Point> simple;
  auto toRing = [&](const std::vector<cv::Point>& c) {
    cv::approxPolyDP(c, simple, 0.5, true);
    Ring ring;
    // Mask pixel (u, v) is map cell (v - 1, u - 1) (the border).
    for (const cv::Point& p : simple)
      ring.push_back(origin + res * Eigen::Vector2d(p.x - 0.5, p.y - 0.5));
    return ring;
  };
  for (std::size_t i = 0; i < contours.size(); ++i) {
    if (hierarchy[i][3] >= 0) continue;  // a hole, taken with its parent
    PolygonWithHoles poly;
    poly.outer = toRing(contours[i]);
    for (int h = hierarchy[i][2]; h >= 0; h = hierarchy[static_cast<std::size_t>(h)][0]) {
      Ring hole = toRing(contours[static_cast<std::size_t>(h)]);
      if (hole.size() >= 3) poly.holes.push_back(std::move(hole));
    }
    if (poly.outer.size() >= 3) centres.push_back(std::move(poly));
  }
  // The contours run through the boundary cells' centres: grow by half a cell so that
  // the polygons lie on the cells' outer edges (the area they cover).
  std::vector<PolygonWithHoles> out;
  for (PolygonWithHoles& p : centres) {
    std::vector<PolygonWithHoles> one{std::move(p)};
    for (PolygonWithHoles& q : offset(one, 0.5 * res)) out.push_back(std::move(q));
  }
  // Single cells and one-cell-wide lines have no area: they give no polygon.
  return out;
}

/// The height a region's plane is fitted to: measured, else the local fit's (a filled hole).
inline double cellHeight(const std::vector<float>& H, const Workspace& w, std::size_t i) {
  return static_cast<double>(std::isnan(H[i]) ? w.fitted[i] : H[i]);
}

/// The plane of least-squares sums `a` (cells' x, y relative to origin, z to zref).
void fitPlane(const PlaneSums& a, const Eigen::Vector2d& origin, double zref, PlanarRegion& reg) {
  const double cnt = a[kN];
  const double mx = a[kX] / cnt, my = a[kY] / cnt, mz = a[kZ] / cnt;
  const double cxx = a[kXX] / cnt - mx * mx, cxy = a[kXY] / cnt - mx * my;
  const double cyy = a[kYY] / cnt - my * my, cxz = a[kXZ] / cnt - mx * mz;
  const double cyz = a[kYZ] / cnt - my * mz, czz = a[kZZ] / cnt - mz * mz;
  Eigen::Matrix2d C;
  C << cxx, cxy, cxy, cyy;
  Eigen::Vector2d g = Eigen::Vector2d::Zero();
  if (C.determinant() > 1e-12) g = C.ldlt().solve(Eigen::Vector2d(cxz, cyz));
  reg.anchor = origin + Eigen::Vector2d(mx, my);
  reg.height = mz + zref;
  reg.gradient = g;
  reg.normal = Eigen::Vector3d(-g.x(), -g.y(), 1.0).normalized();
  reg.rms = std::sqrt(std::max(0.0, czz - g.dot(Eigen::Vector2d(cxz, cyz))));
}

/// Region k's mask in its box with a one-pixel zero border: pixel (u, v) = cell
/// (rmin + v - 1, cmin + u - 1). Empty (0 x 0) for a region without cells.
cv::Mat regionMask(Workspace& w, const Segmentation& out, int k) {
  const int n = out.size;
  const std::vector<int>& labels = out.labels;
  const auto kk = static_cast<std::size_t>(k);
  if (w.rmax[kk] < 0) return cv::Mat();
  const int rows = w.rmax[kk] - w.rmin[kk] + 1, cols = w.cmax[kk] - w.cmin[kk] + 1;
  cv::Mat mask = w.region_mask(cv::Rect(0, 0, cols + 2, rows + 2));
  mask.setTo(0);
  for (int r = 0; r < rows; ++r) {
    unsigned char* row = mask.ptr<unsigned char>(r + 1);
    for (int c = 0; c < cols; ++c) {
      row[c + 1] =
          labels[static_cast<std::size_t>((w.rmin[kk] + r) * n + w.cmin[kk] + c)] == k ? 1 : 0;
    }
  }
  return mask;
}

}  // namespace

void Workspace::resize(int size) {
  if (n == size) return;
  n = size;
  const auto cells = static_cast<std::size_t>(n) * static_cast<std::size_t>(n);
  sat.assign(static_cast<std::size_t>(n + 1) * static_cast<std::size_t>(n + 1) * kChannels, 0.0);
  fitted.assign(cells, kNaN);
  gx.assign(cells, 0.f);
  gy.assign(cells, 0.f);
  planar.assign(cells, 0);
  queue.reserve(cells);
  depth.assign(cells, 0);
  hmax.create(n, n, CV_32F);
  hmin.create(n, n, CV_32F);
  step.create(n, n, CV_8U);
  region_mask.create(n + 2, n + 2, CV_8U);
}

void beginSegmentation(const ElevationMap& map, Workspace& w, Segmentation& out) {
  const int n = map.size();
  w.resize(n);
  const auto cells = static_cast<std::size_t>(n) * static_cast<std::size_t>(n);
  out.size = n;
  out.resolution = map.resolution();
  out.origin = map.origin();
  out.regions.clear();
  out.step_edges.clear();
  out.labels.assign(cells, -1);
}

void referenceHeight(const ElevationMap& map, Workspace& w) {
  w.zref = 0.0;
  for (float h : map.heights()) {
    if (!std::isnan(h)) {
      w.zref = static_cast<double>(h);
      break;
    }
  }
}

void sumMeasuredCells(const ElevationMap& map, Workspace& w) {
  const int n = map.size();
  const std::vector<float>& H = map.heights();
  const double zref = w.zref;
  const int m = n + 1;
  double* S = w.sat.data();
  std::fill(w.sat.begin(), w.sat.end(), 0.0);
  for (int r = 0; r < n; ++r) {
    double row[kChannels] = {};
    for (int c = 0; c < n; ++c) {
      const float h = H[static_cast<std::size_t>(r * n + c)];
      if (!std::isnan(h)) {
        const double x = c, y = r, z = static_cast<double>(h) - zref;
        row[kN] += 1;
        row[kX] += x;
        row[kY] += y;
        row[kZ] += z;
        row[kXX] += x * x;
        row[kXY] += x * y;
        row[kYY] += y * y;
        row[kXZ] += x * z;
        row[kYZ] += y * z;
        row[kZZ] += z * z;
      }
      double* dst = S + (static_cast<std::size_t>((r + 1) * m + c + 1)) * kChannels;
      const double* above = S + (static_cast<std::size_t>(r * m + c + 1)) * kChannels;
      for (int k = 0; k < kChannels; ++k) dst[k] = above[k] + row[k];
    }
  }
}

void markStepEdges(const ElevationMap& map, const SegmentationSettings& settings, Workspace& w) {
  const int n = map.size();
  const std::vector<float>& H = map.heights();
  cv::Mat h(n, n, CV_32F, const_cast<float*>(H.data()));
  h.copyTo(w.hmax);
  h.copyTo(w.hmin);
  cv::patchNaNs(w.hmax, -1e6);
  cv::patchNaNs(w.hmin, 1e6);
  cv::dilate(w.hmax, w.hmax, cv::Mat());
  cv::erode(w.hmin, w.hmin, cv::Mat());
  for (int r = 0; r < n; ++r) {
    const float* hi = w.hmax.ptr<float>(r);
    const float* lo = w.hmin.ptr<float>(r);
    unsigned char* st = w.step.ptr<unsigned char>(r);
    for (int c = 0; c < n; ++c) {
      const double span = static_cast<double>(hi[c]) - static_cast<double>(lo[c]);
      st[c] = (span > settings.step_height && span < 1e5 &&
               !std::isnan(H[static_cast<std::size_t>(r * n + c)]))
                  ? 1
                  : 0;
    }
  }
}

void fitLocalPlanes(const ElevationMap& map, const SegmentationSettings& settings, Workspace& w) {
  const int n = map.size();
  const double res = map.resolution();
  const double zref = w.zref;
  const int m = n + 1;
  const double* S = w.sat.data();
  const int hw = settings.window_half;
  const double min_count = settings.min_window_fill * (2 * hw + 1) * (2 * hw + 1);
  const double max_sse_per_point = settings.max_residual * settings.max_residual;
  const double max_grad = std::tan(settings.max_slope_deg * kPi / 180.0);
  const double max_grad2 = max_grad * max_grad;
  for (int r = 0; r < n; ++r) {
    const int r0 = std::max(0, r - hw), r1 = std::min(n, r + hw + 1);
    for (int c = 0; c < n; ++c) {
      const auto i = static_cast<std::size_t>(r * n + c);
      w.planar[i] = 0;
      w.fitted[i] = kNaN;
      const int c0 = std::max(0, c - hw), c1 = std::min(n, c + hw + 1);
      const double* a = S + static_cast<std::size_t>(r0 * m + c0) * kChannels;
      const double* b = S + static_cast<std::size_t>(r0 * m + c1) * kChannels;
      const double* d = S + static_cast<std::size_t>(r1 * m + c0) * kChannels;
      const double* e = S + static_cast<std::size_t>(r1 * m + c1) * kChannels;
      double s[kChannels];
      for (int k = 0; k < kChannels; ++k) s[k] = e[k] - b[k] - d[k] + a[k];
      const double cnt = s[kN];
      if (cnt < min_count || cnt < 4) continue;
      // Coordinates relative to this cell.
      const double x0 = c, y0 = r;
      const double su = s[kX] - cnt * x0, sv = s[kY] - cnt * y0;
      const double suu = s[kXX] - 2 * x0 * s[kX] + cnt * x0 * x0;
      const double svv = s[kYY] - 2 * y0 * s[kY] + cnt * y0 * y0;
      const double suv = s[kXY] - x0 * s[kY] - y0 * s[kX] + cnt * x0 * y0;
      const double suz = s[kXZ] - x0 * s[kZ], svz = s[kYZ] - y0 * s[kZ];
      Eigen::Matrix3d M;
      M << suu, suv, su, suv, svv, sv, su, sv, cnt;
      const Eigen::Vector3d rhs(suz, svz, s[kZ]);
      const double det = M.determinant();
      if (!(std::abs(det) > 1e-9)) continue;
      const Eigen::Vector3d theta = M.inverse() * rhs;
      const double sse = std::max(0.0, s[kZZ] - theta.dot(rhs));
      const double gxv = theta.x() / res, gyv = theta.y() / res;
      w.fitted[i] = static_cast<float>(theta.z() + zref);
      w.gx[i] = static_cast<float>(gxv);
      w.gy[i] = static_cast<float>(gyv);
      w.planar[i] = (sse <= max_sse_per_point * cnt && gxv * gxv + gyv * gyv <= max_grad2 &&
                     !w.step.at<unsigned char>(r, c))
                        ? 1
                        : 0;
    }
  }
}

void growRegions(const ElevationMap& map, const SegmentationSettings& settings, Workspace& w,
                 Segmentation& out) {
  const int n = map.size();
  const double res = map.resolution();
  const auto cells = static_cast<std::size_t>(n) * static_cast<std::size_t>(n);
  const double cos_max = std::cos(settings.max_normal_angle_deg * kPi / 180.0);
  const int min_cells =
      std::max(1, static_cast<int>(std::ceil(settings.min_region_area / (res * res))));
  std::vector<int>& labels = out.labels;
  auto normalOf = [&](std::size_t i) {
    return Eigen::Vector3d(-static_cast<double>(w.gx[i]), -static_cast<double>(w.gy[i]), 1.0)
        .normalized();
  };
  constexpr int kRejected = -2;
  int next = 0;
  for (std::size_t seed = 0; seed < cells; ++seed) {
    if (!w.planar[seed] || labels[seed] != -1) continue;
    w.queue.clear();
    w.queue.push_back(static_cast<int>(seed));
    labels[seed] = next;
    Eigen::Vector3d nsum = normalOf(seed);
    for (std::size_t head = 0; head < w.queue.size(); ++head) {
      const int i = w.queue[head];
      const int r = i / n, c = i % n;
      const Eigen::Vector3d nmean = nsum.normalized();
      const int nb[4][2] = {{r - 1, c}, {r + 1, c}, {r, c - 1}, {r, c + 1}};
      for (const auto& q : nb) {
        if (q[0] < 0 || q[1] < 0 || q[0] >= n || q[1] >= n) continue;
        const auto j = static_cast<std::size_t>(q[0] * n + q[1]);
        if (!w.planar[j] || labels[j] != -1) continue;
        if (std::abs(static_cast<double>(w.fitted[j] - w.fitted[static_cast<std::size_t>(i)])) >
            settings.max_height_step)
          continue;
        const Eigen::Vector3d nj = normalOf(j);
        if (nj.dot(nmean) < cos_max) continue;
        labels[j] = next;
        nsum += nj;
        w.queue.push_back(static_cast<int>(j));
      }
    }
    if (static_cast<int>(w.queue.size()) < min_cells) {
      for (int i : w.queue) labels[static_cast<std::size_t>(i)] = kRejected;
    } else {
      ++next;
    }
  }
  for (int& l : labels) {
    if (l == kRejected) l = -1;
  }
  out.regions.resize(static_cast<std::size_t>(next));
}

void fitRegionPlanes(const ElevationMap& map, Workspace& w, Segmentation& out) {
  const int n = map.size();
  const double res = map.resolution();
  const std::vector<float>& H = map.heights();
  const std::vector<int>& labels = out.labels;
  const double zref = w.zref;
  const int nreg = static_cast<int>(out.regions.size());
  std::vector<PlaneSums>& acc = w.acc;
  acc.assign(static_cast<std::size_t>(nreg), PlaneSums::Zero());
  for (int r = 0; r < n; ++r) {
    for (int c = 0; c < n; ++c) {
      const auto i = static_cast<std::size_t>(r * n + c);
      if (labels[i] < 0) continue;
      const double x = (c + 0.5) * res, y = (r + 0.5) * res, z = cellHeight(H, w, i) - zref;
      PlaneSums& a = acc[static_cast<std::size_t>(labels[i])];
      a[kN] += 1;
      a[kX] += x;
      a[kY] += y;
      a[kZ] += z;
      a[kXX] += x * x;
      a[kXY] += x * y;
      a[kYY] += y * y;
      a[kXZ] += x * z;
      a[kYZ] += y * z;
      a[kZZ] += z * z;
    }
  }
  for (int k = 0; k < nreg; ++k) {
    fitPlane(acc[static_cast<std::size_t>(k)], out.origin, zref,
             out.regions[static_cast<std::size_t>(k)]);
  }
}

void growBack(const ElevationMap& map, const SegmentationSettings& settings, Workspace& w,
              Segmentation& out) {
  const int n = map.size();
  const std::vector<float>& H = map.heights();
  const auto cells = static_cast<std::size_t>(n) * static_cast<std::size_t>(n);
  std::vector<int>& labels = out.labels;
  const int hw = settings.window_half;
  w.queue.clear();
  for (std::size_t i = 0; i < cells; ++i) {
    w.depth[i] = 0;
    if (labels[i] >= 0) w.queue.push_back(static_cast<int>(i));
  }
  for (std::size_t head = 0; head < w.queue.size(); ++head) {
    const int i = w.queue[head];
    const int d = w.depth[static_cast<std::size_t>(i)];
    if (d > hw) continue;
    const int r = i / n, c = i % n;
    const int L = labels[static_cast<std::size_t>(i)];
    const PlanarRegion& reg = out.regions[static_cast<std::size_t>(L)];
    // 8-connected: the window fit rejects a square band, corners included.
    const int nb[8][2] = {{r - 1, c},     {r + 1, c},     {r, c - 1},     {r, c + 1},
                          {r - 1, c - 1}, {r - 1, c + 1}, {r + 1, c - 1}, {r + 1, c + 1}};
    for (const auto& q : nb) {
      if (q[0] < 0 || q[1] < 0 || q[0] >= n || q[1] >= n) continue;
      const auto j = static_cast<std::size_t>(q[0] * n + q[1]);
      if (labels[j] != -1 || std::isnan(H[j])) continue;
      const Eigen::Vector2d p = out.cellCenter(q[0], q[1]);
      if (std::abs(static_cast<double>(H[j]) - reg.heightAt(p)) > settings.grow_tolerance) continue;
      labels[j] = L;
      w.depth[j] = d + 1;
      w.queue.push_back(static_cast<int>(j));
    }
  }
}

// The band of cells the window fit rejects at the foot of a riser (mixed cells a centimetre
// or two high) can cut a strip of the floor off the rest and fit it as a slope (16 deg over
// 83 cells); grown back, the two touch across the band. Left apart, the strip is an obstacle
// to the floor's convex pieces, which then began 10-25 cm past a block's far edge (step20 on
// perception). Joined when 95 % of the smaller region's cells lie within step_height of the
// larger one's plane, as a level hole is (a tread or a ramp beside a floor does not).
void joinRegionsOnPlanes(const ElevationMap& map, const SegmentationSettings& settings,
                         Workspace& w, Segmentation& out) {
  const int n = map.size();
  const std::vector<float>& H = map.heights();
  const auto cells = static_cast<std::size_t>(n) * static_cast<std::size_t>(n);
  std::vector<int>& labels = out.labels;
  const auto R = out.regions.size();
  w.pair_cells.assign(R * R, 0);
  for (int r = 0; r < n; ++r) {
    for (int c = 0; c < n; ++c) {
      const int L = labels[static_cast<std::size_t>(r * n + c)];
      if (L < 0) continue;
      const int nb[2][2] = {{r, c + 1}, {r + 1, c}};
      for (const auto& q : nb) {
        if (q[0] >= n || q[1] >= n) continue;
        const int M = labels[static_cast<std::size_t>(q[0] * n + q[1])];
        if (M < 0 || M == L) continue;
        ++w.pair_cells[static_cast<std::size_t>(std::min(L, M)) * R +
                       static_cast<std::size_t>(std::max(L, M))];
      }
    }
  }
  // Regions touching along at least two cell pairs (a corner is not a border).
  auto touching = [&](std::size_t a, std::size_t b) {
    return w.pair_cells[std::min(a, b) * R + std::max(a, b)] >= 2;
  };
  // Per region: its cells, and how many lie within step_height of each touching region's
  // plane.
  w.on_plane.assign(R * R, 0);
  w.region_cells.assign(R, 0);
  for (std::size_t i = 0; i < cells; ++i) {
    const int L = labels[i];
    if (L < 0) continue;
    const auto l = static_cast<std::size_t>(L);
    ++w.region_cells[l];
    const Eigen::Vector2d p = out.cellCenter(static_cast<int>(i) / n, static_cast<int>(i) % n);
    for (std::size_t o = 0; o < R; ++o) {
      if (o == l || !touching(l, o)) continue;
      if (std::abs(cellHeight(H, w, i) - out.regions[o].heightAt(p)) <= settings.step_height)
        ++w.on_plane[l * R + o];
    }
  }
  w.parent.resize(R);
  for (std::size_t k = 0; k < R; ++k) w.parent[k] = static_cast<int>(k);
  auto root = [&](int k) {
    while (w.parent[static_cast<std::size_t>(k)] != k) k = w.parent[static_cast<std::size_t>(k)];
    return k;
  };
  bool merged = false;
  for (std::size_t a = 0; a < R; ++a) {
    for (std::size_t b = a + 1; b < R; ++b) {
      if (!touching(a, b)) continue;
      // The smaller region (fewer cells) on the larger one's plane.
      const bool a_small = w.region_cells[a] <= w.region_cells[b];
      const std::size_t sm = a_small ? a : b, lg = a_small ? b : a;
      if (w.on_plane[sm * R + lg] < 0.95 * w.region_cells[sm]) continue;
      const int ra = root(static_cast<int>(a)), rb = root(static_cast<int>(b));
      if (ra == rb) continue;
      w.parent[static_cast<std::size_t>(std::max(ra, rb))] = std::min(ra, rb);
      merged = true;
    }
  }
  if (!merged) return;
  // Roots keep their order; each merged region's plane is fitted to all its parts' cells.
  w.remap.assign(R, -1);
  int kept = 0;
  for (std::size_t k = 0; k < R; ++k) {
    if (root(static_cast<int>(k)) == static_cast<int>(k)) w.remap[k] = kept++;
  }
  for (std::size_t k = 0; k < R; ++k) {
    const int rk = root(static_cast<int>(k));
    if (rk != static_cast<int>(k)) w.acc[static_cast<std::size_t>(rk)] += w.acc[k];
  }
  for (std::size_t k = 0; k < R; ++k) {
    if (w.remap[k] < 0) continue;
    fitPlane(w.acc[k], out.origin, w.zref, out.regions[static_cast<std::size_t>(w.remap[k])]);
  }
  out.regions.resize(static_cast<std::size_t>(kept));
  for (int& l : labels) {
    if (l >= 0) l = w.remap[static_cast<std::size_t>(root(l))];
  }
}

void regionBoundingBoxes(Workspace& w, const Segmentation& out) {
  const int n = out.size;
  const auto nreg = out.regions.size();
  w.rmin.assign(nreg, n);
  w.rmax.assign(nreg, -1);
  w.cmin.assign(nreg, n);
  w.cmax.assign(nreg, -1);
  for (int r = 0; r < n; ++r) {
    for (int c = 0; c < n; ++c) {
      const int L = out.labels[static_cast<std::size_t>(r * n + c)];
      if (L < 0) continue;
      const auto k = static_cast<std::size_t>(L);
      w.rmin[k] = std::min(w.rmin[k], r);
      w.rmax[k] = std::max(w.rmax[k], r);
      w.cmin[k] = std::min(w.cmin[k], c);
      w.cmax[k] = std::max(w.cmax[k], c);
    }
  }
}

// A level hole is the surface itself: noisy cells the window fit rejected (the few, steep
// rays at the rim of the sensor's blind spot), a patch that grew into a region of its own;
// an obstacle or a pit in it has a step edge or cells off the plane, and an unseen patch
// stays a hole (never a foothold).
bool fillHoles(const ElevationMap& map, const SegmentationSettings& settings, Workspace& w,
               Segmentation& out) {
  const int n = map.size();
  const double res = map.resolution();
  const std::vector<float>& H = map.heights();
  std::vector<int>& labels = out.labels;
  const int nreg = static_cast<int>(out.regions.size());
  const double max_hole_cells = settings.max_hole_area / (res * res);
  const double max_level_cells = settings.max_level_hole_area / (res * res);
  bool absorbed = false;
  for (int k = 0; k < nreg; ++k) {
    const auto kk = static_cast<std::size_t>(k);
    cv::Mat mask = regionMask(w, out, k);
    if (mask.empty()) continue;
    const PlanarRegion& reg = out.regions[kk];
    w.contours.clear();
    w.hierarchy.clear();
    cv::findContours(mask, w.contours, w.hierarchy, cv::RETR_CCOMP, cv::CHAIN_APPROX_NONE);
    for (std::size_t h = 0; h < w.contours.size(); ++h) {
      if (w.hierarchy[h][3] < 0) continue;
      const cv::Rect box = cv::boundingRect(w.contours[h]);
      const bool small = box.area() <= max_hole_cells + 2 * (box.width + box.height) + 4;
      if (!small && box.area() > max_level_cells + 2 * (box.width + box.height) + 4) continue;
      w.hole_fill.create(mask.size(), CV_8U);
      w.hole_fill.setTo(0);
      cv::drawContours(w.hole_fill, w.contours, static_cast<int>(h), 1, cv::FILLED);
      auto cellOf = [&](int u, int v) {
        return static_cast<std::size_t>((w.rmin[kk] + v - 1) * n + w.cmin[kk] + u - 1);
      };
      bool level = !small;
      for (int v = box.y; level && v < box.y + box.height; ++v) {
        for (int u = box.x; u < box.x + box.width; ++u) {
          if (!w.hole_fill.at<unsigned char>(v, u)) continue;
          const std::size_t i = cellOf(u, v);
          if (labels[i] == k) continue;
          const int r = static_cast<int>(i) / n, c = static_cast<int>(i) % n;
          if (std::isnan(H[i]) || w.step.at<unsigned char>(r, c) ||
              std::abs(static_cast<double>(H[i]) - reg.heightAt(out.cellCenter(r, c))) >
                  settings.step_height) {
            level = false;
            break;
          }
        }
      }
      if (!small && !level) continue;
      for (int v = box.y; v < box.y + box.height; ++v) {
        for (int u = box.x; u < box.x + box.width; ++u) {
          if (!w.hole_fill.at<unsigned char>(v, u)) continue;
          int& l = labels[cellOf(u, v)];
          if (l == -1 || (level && l != k)) {
            absorbed = absorbed || l != -1;
            l = k;
          }
        }
      }
    }
  }
  return absorbed;
}

void dropEmptyRegions(Workspace& w, Segmentation& out) {
  const int nreg = static_cast<int>(out.regions.size());
  regionBoundingBoxes(w, out);
  w.remap.assign(static_cast<std::size_t>(nreg), -1);
  int kept = 0;
  for (int k = 0; k < nreg; ++k) {
    const auto kk = static_cast<std::size_t>(k);
    if (w.rmax[kk] < 0) continue;
    w.remap[kk] = kept;
    if (kept != k) out.regions[static_cast<std::size_t>(kept)] = std::move(out.regions[kk]);
    ++kept;
  }
  out.regions.resize(static_cast<std::size_t>(kept));
  for (int& l : out.labels) {
    if (l >= 0) l = w.remap[static_cast<std::size_t>(l)];
  }
  regionBoundingBoxes(w, out);
}

void traceRegionPolygons(Workspace& w, Segmentation& out) {
  const double res = out.resolution;
  const int kept = static_cast<int>(out.regions.size());
  for (int k = 0; k < kept; ++k) {
    const auto kk = static_cast<std::size_t>(k);
    cv::Mat mask = regionMask(w, out, k);
    PlanarRegion& reg = out.regions[kk];
    const Eigen::Vector2d roi_origin = out.origin + res * Eigen::Vector2d(w.cmin[kk], w.rmin[kk]);
    reg.polygons = tracePolygons(mask, roi_origin, res, w.contours, w.hierarchy);
  }
  for (std::size_t i = 0; i < out.labels.size(); ++i) {
    if (out.labels[i] >= 0) ++out.regions[static_cast<std::size_t>(out.labels[i])].cells;
  }
  for (PlanarRegion& reg : out.regions) reg.area = reg.cells * res * res;
}

void traceStepEdges(Workspace& w, Segmentation& out) {
  const int n = out.size;
  cv::Mat mask = w.region_mask(cv::Rect(0, 0, n + 2, n + 2));
  mask.setTo(0);
  w.step.copyTo(mask(cv::Rect(1, 1, n, n)));
  out.step_edges = tracePolygons(mask, out.origin, out.resolution, w.contours, w.hierarchy);
}

}  // namespace segmentation

}  // namespace rollstep::perception
