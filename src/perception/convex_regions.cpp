#include "rollstep/perception/convex_regions.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <string>

#include "rollstep/common/number_text.hpp"

namespace rollstep::perception {

namespace {

constexpr double kPi = 3.14159265358979323846;
// Obstacles on a half-plane's line count as beyond it: cells in a row project to the same
// offset up to rounding, which must not let one of them in.
constexpr double kTie = 1e-9;

void require(bool ok, const char* name, double value, const char* what) {
  if (!ok) {
    throw std::invalid_argument(std::string("convex regions: ") + name + " = " +
                                shortestNumberText(value) + ": " + what);
  }
}

/// Clips a convex polygon by the half-plane n . (p - s) <= o (Sutherland-Hodgman).
void clip(std::vector<Eigen::Vector2d>& poly, std::vector<Eigen::Vector2d>& tmp,
          const Eigen::Vector2d& n, const Eigen::Vector2d& s, double o) {
  tmp.clear();
  const std::size_t m = poly.size();
  for (std::size_t i = 0; i < m; ++i) {
    const Eigen::Vector2d& a = poly[i];
    const Eigen::Vector2d& b = poly[(i + 1) % m];
    const double fa = n.dot(a - s) - o, fb = n.dot(b - s) - o;
    if (fa <= 0) tmp.push_back(a);
    if ((fa < 0 && fb > 0) || (fa > 0 && fb < 0)) tmp.push_back(a + (fa / (fa - fb)) * (b - a));
  }
  poly.swap(tmp);
}

double polygonArea(const std::vector<Eigen::Vector2d>& v) {
  return std::abs(planning::signedPolygonArea(v));
}

}  // namespace

void ConvexRegionSettings::validate() const {
  require(directions >= 4 && directions <= 64 && directions % 2 == 0, "directions", directions,
          "must be even, 4 to 64");
  require(std::isfinite(margin) && margin >= 0, "margin", margin, "must be >= 0");
  require(std::isfinite(min_clearance) && min_clearance >= 0, "min_clearance", min_clearance,
          "must be >= 0");
  require(std::isfinite(search_radius) && search_radius >= 0, "search_radius", search_radius,
          "must be >= 0");
  require(std::isfinite(height_weight) && height_weight >= 0, "height_weight", height_weight,
          "must be >= 0");
  require(max_pieces_per_region >= 1 && max_pieces_per_region <= 100, "max_pieces_per_region",
          max_pieces_per_region, "must be 1 to 100");
  require(cover_fraction > 0 && cover_fraction <= 1, "cover_fraction", cover_fraction,
          "must be in (0, 1]");
  require(std::isfinite(max_notch_depth) && max_notch_depth >= 0, "max_notch_depth",
          max_notch_depth, "must be >= 0");
  require(std::isfinite(cover_gap) && cover_gap >= 0, "cover_gap", cover_gap, "must be >= 0");
  require(std::isfinite(min_piece_area) && min_piece_area >= 0, "min_piece_area", min_piece_area,
          "must be >= 0");
}

ConvexRegionGrower::ConvexRegionGrower(const ConvexRegionSettings& settings) : settings_(settings) {
  settings_.validate();
}

int ConvexRegionGrower::selectRegion(const Segmentation& seg,
                                     const Eigen::Vector3d& foothold) const {
  if (!foothold.allFinite() || seg.size <= 0) return -1;
  const Eigen::Vector2d p = foothold.head<2>();
  const int inside = seg.regionAt(p);
  if (inside >= 0) return inside;
  const double res = seg.resolution;
  const Eigen::Vector2d q = (p - seg.origin) / res;
  const int reach = static_cast<int>(std::ceil(settings_.search_radius / res));
  const int c0 = std::max(0, static_cast<int>(q.x()) - reach);
  const int c1 = std::min(seg.size - 1, static_cast<int>(q.x()) + reach);
  const int r0 = std::max(0, static_cast<int>(q.y()) - reach);
  const int r1 = std::min(seg.size - 1, static_cast<int>(q.y()) + reach);
  int best = -1;
  double best_cost = std::numeric_limits<double>::infinity();
  for (int r = r0; r <= r1; ++r) {
    for (int c = c0; c <= c1; ++c) {
      const int L = seg.label(r, c);
      if (L < 0) continue;
      const double d = (seg.cellCenter(r, c) - p).norm();
      if (d > settings_.search_radius) continue;
      const PlanarRegion& reg = seg.regions[static_cast<std::size_t>(L)];
      const double cost = d + settings_.height_weight * std::abs(reg.heightAt(p) - foothold.z());
      if (cost < best_cost) {
        best_cost = cost;
        best = L;
      }
    }
  }
  return best;
}

bool ConvexRegionGrower::prepare(const Segmentation& seg, int region) {
  const int n = seg.size;
  const auto cells = static_cast<std::size_t>(n) * static_cast<std::size_t>(n);
  mask_.assign(cells, 0);
  obstacles_.clear();
  bool any = false;
  for (std::size_t i = 0; i < cells; ++i) {
    if (seg.labels[i] == region) {
      mask_[i] = 1;
      any = true;
    }
  }
  if (!any) return false;
  // Close one-cell notches of the border (noise at step edges): a half-plane stops at
  // the innermost obstacle, so one stray cell would cost a whole row.
  {
    cv::Mat m(n, n, CV_8U, mask_.data());
    cv::Mat closed;
    cv::morphologyEx(m, closed, cv::MORPH_CLOSE, cv::Mat::ones(3, 3, CV_8U), cv::Point(-1, -1), 1,
                     cv::BORDER_CONSTANT, cv::Scalar(0));
    for (int r = 0; r < n; ++r) {
      for (int c = 0; c < n; ++c) {
        const auto i = static_cast<std::size_t>(r * n + c);
        if (closed.at<unsigned char>(r, c) && seg.labels[i] < 0) mask_[i] = 1;
      }
    }
  }
  // Obstacles: the 8-neighbours of the region outside it (the map border included).
  std::vector<unsigned char> seen(cells, 0);
  for (int r = 0; r < n; ++r) {
    for (int c = 0; c < n; ++c) {
      if (!mask_[static_cast<std::size_t>(r * n + c)]) continue;
      for (int dr = -1; dr <= 1; ++dr) {
        for (int dc = -1; dc <= 1; ++dc) {
          const int rr = r + dr, cc = c + dc;
          const bool outside = rr < 0 || cc < 0 || rr >= n || cc >= n;
          if (!outside) {
            const auto j = static_cast<std::size_t>(rr * n + cc);
            if (mask_[j] || seen[j]) continue;
            seen[j] = 1;
          }
          obstacles_.push_back(seg.cellCenter(rr, cc));
        }
      }
    }
  }
  // Distance of every cell to the nearest obstacle cell [cells] (map border = obstacle).
  cv::Mat padded = cv::Mat::zeros(n + 2, n + 2, CV_8U);
  for (int r = 0; r < n; ++r) {
    for (int c = 0; c < n; ++c)
      padded.at<unsigned char>(r + 1, c + 1) = mask_[static_cast<std::size_t>(r * n + c)];
  }
  cv::Mat dist;
  cv::distanceTransform(padded, dist, cv::DIST_L2, cv::DIST_MASK_PRECISE);
  clearance_.resize(cells);
  for (int r = 0; r < n; ++r) {
    for (int c = 0; c < n; ++c)
      clearance_[static_cast<std::size_t>(r * n + c)] =
          static_cast<double>(dist.at<float>(r + 1, c + 1));
  }
  // Direction 0 along the region's main axis.
  std::vector<cv::Point2f> pts;
  pts.reserve(obstacles_.size());
  for (const Eigen::Vector2d& o : obstacles_)
    pts.emplace_back(static_cast<float>(o.x()), static_cast<float>(o.y()));
  const cv::RotatedRect rect = cv::minAreaRect(pts);
  angle_ = static_cast<double>(rect.angle) * kPi / 180.0;
  return true;
}

std::optional<planning::ConvexRegion> ConvexRegionGrower::growPrepared(
    const Segmentation& seg, int region, const Eigen::Vector2d& seed) {
  std::optional<planning::ConvexRegion> best = growAt(seg, region, seed, angle_);
  // The minimum-area rectangle of a rasterised border is turned by a fraction of a degree
  // when the border is ragged by a cell (a stair tread 3 m long: 0.4 deg); half-planes at
  // that angle meet the long edges before they span the region. The grid's own directions
  // are tried too, and the larger polygon wins (a turned region keeps its angle).
  const double step = 2.0 * kPi / settings_.directions;
  const double turn = std::remainder(angle_, step);
  if (std::abs(turn) > 1e-9) {
    std::optional<planning::ConvexRegion> grid = growAt(seg, region, seed, angle_ - turn);
    if (grid && (!best || polygonArea(grid->vertices) > polygonArea(best->vertices)))
      best = std::move(grid);
  }
  return best;
}

std::optional<planning::ConvexRegion> ConvexRegionGrower::growAt(const Segmentation& seg,
                                                                 int region,
                                                                 const Eigen::Vector2d& seed_in,
                                                                 double angle) {
  const int n = seg.size;
  const double res = seg.resolution;
  const double need = std::max(1.0, settings_.min_clearance / res);
  // Seed cell: the given one if clear enough, else the nearest clear cell.
  int seed_cell = -1;
  {
    int r = 0, c = 0;
    const Eigen::Vector2d q = (seed_in - seg.origin) / res;
    if (seed_in.allFinite() && q.x() >= 0 && q.y() >= 0 && q.x() < n && q.y() < n) {
      r = static_cast<int>(q.y());
      c = static_cast<int>(q.x());
      if (clearance_[static_cast<std::size_t>(r * n + c)] >= need) seed_cell = r * n + c;
    }
    if (seed_cell < 0) {
      double best = std::numeric_limits<double>::infinity();
      const Eigen::Vector2d target = seed_in.allFinite() ? seed_in : seg.origin;
      for (int i = 0; i < n * n; ++i) {
        if (clearance_[static_cast<std::size_t>(i)] < need) continue;
        const double d = (seg.cellCenter(i / n, i % n) - target).squaredNorm();
        if (d < best) {
          best = d;
          seed_cell = i;
        }
      }
    }
  }
  if (seed_cell < 0) return std::nullopt;
  const Eigen::Vector2d s = seg.cellCenter(seed_cell / n, seed_cell % n);
  const int K = settings_.directions;
  std::vector<Eigen::Vector2d> dirs(static_cast<std::size_t>(K));
  for (int k = 0; k < K; ++k) {
    const double a = angle + 2.0 * kPi * k / K;
    dirs[static_cast<std::size_t>(k)] = {std::cos(a), std::sin(a)};
  }
  const double d0 = clearance_[static_cast<std::size_t>(seed_cell)] * res;
  std::vector<double> off(static_cast<std::size_t>(K), 0.9 * d0 * std::cos(kPi / K));
  const double cap = 2.0 * n * res;
  const std::size_t P = obstacles_.size();
  proj_.resize(P * static_cast<std::size_t>(K));
  beyond_.assign(P, 0);
  for (std::size_t i = 0; i < P; ++i) {
    for (int k = 0; k < K; ++k) {
      const double v = dirs[static_cast<std::size_t>(k)].dot(obstacles_[i] - s);
      proj_[i * static_cast<std::size_t>(K) + static_cast<std::size_t>(k)] = v;
      if (v >= off[static_cast<std::size_t>(k)] - kTie) ++beyond_[i];
    }
  }
  // Uniform growth: every half-plane not yet blocked sits at the common offset t, which
  // grows by a cell (or 3 % of t, when larger) per round; a half-plane stops at the first obstacle
  // only it keeps out. Moving together, the half-plane facing an obstacle most squarely is the one
  // that stops at it (larger or one-at-a-time steps let an oblique one cut corners).
  std::vector<unsigned char> blocked(static_cast<std::size_t>(K), 0);
  std::vector<unsigned char> stepped(static_cast<std::size_t>(K), 0);
  for (double t = off[0] + res; t < cap + res; t += std::max(res, 0.03 * t)) {
    bool any = false;
    for (int k = 0; k < K; ++k) {
      const auto kk = static_cast<std::size_t>(k);
      if (blocked[kk]) continue;
      any = true;
      const double o = off[kk];
      double limit = std::min(t, cap);
      // One-cell irregularities of the border (a cell straddling a step edge joins one
      // region or the other with last-bit rounding: GCC and clang builds differ) must
      // not stop this half-plane rows early. When every obstacle that would stop it this
      // round lies within a cell of another, already stopped half-plane, that one steps
      // back onto them instead (at most a cell, once): the border moves by a cell, not
      // by the distance to the irregularity.
      rescue_.clear();
      bool rescuable = true;
      for (std::size_t i = 0; i < P && rescuable; ++i) {
        const double v = proj_[i * static_cast<std::size_t>(K) + kk];
        if (beyond_[i] != 1 || v < o - kTie || v >= limit) continue;
        int best = -1;
        double best_gap = res + kTie;
        for (int j = 0; j < K; ++j) {
          if (j == k || !blocked[static_cast<std::size_t>(j)] ||
              stepped[static_cast<std::size_t>(j)])
            continue;
          const double gap = off[static_cast<std::size_t>(j)] -
                             proj_[i * static_cast<std::size_t>(K) + static_cast<std::size_t>(j)];
          if (gap <= best_gap) {
            best_gap = gap;
            best = j;
          }
        }
        if (best < 0)
          rescuable = false;
        else
          rescue_.push_back({i, best});
      }
      if (rescuable) {
        for (const auto& [i, j] : rescue_) {
          const auto jj = static_cast<std::size_t>(j);
          const double p = proj_[i * static_cast<std::size_t>(K) + jj];
          if (p >= off[jj] - kTie) continue;  // already stepped back past it
          for (std::size_t m = 0; m < P; ++m) {
            const double pm = proj_[m * static_cast<std::size_t>(K) + jj];
            if (pm >= p - kTie && pm < off[jj] - kTie) ++beyond_[m];
          }
          off[jj] = p;
          blocked[jj] = 1;
          stepped[jj] = 1;
        }
      }
      for (std::size_t i = 0; i < P; ++i) {
        const double v = proj_[i * static_cast<std::size_t>(K) + kk];
        if (beyond_[i] == 1 && v >= o - kTie) limit = std::min(limit, v);
      }
      if (limit < t || limit >= cap) blocked[kk] = 1;
      if (limit <= o) continue;
      for (std::size_t i = 0; i < P; ++i) {
        const double v = proj_[i * static_cast<std::size_t>(K) + kk];
        if (v >= o - kTie && v < limit - kTie) --beyond_[i];
      }
      off[kk] = limit;
    }
    if (!any) break;
  }
  stepBackFromNotches(dirs, s, cap, res, off);
  // Obstacle centres lie half a cell beyond the region's edge.
  std::vector<Eigen::Vector2d> poly = polygonAt(dirs, s, cap, off, 0.5 * res + settings_.margin);
  if (poly.size() < 3) return std::nullopt;
  // Drop repeated and collinear vertices.
  std::vector<Eigen::Vector2d> clean;
  for (std::size_t i = 0; i < poly.size(); ++i) {
    const Eigen::Vector2d& prev = clean.empty() ? poly.back() : clean.back();
    if ((poly[i] - prev).norm() > 1e-6) clean.push_back(poly[i]);
  }
  for (bool again = true; again && clean.size() > 3;) {
    again = false;
    for (std::size_t i = 0; i < clean.size(); ++i) {
      const Eigen::Vector2d& a = clean[(i + clean.size() - 1) % clean.size()];
      const Eigen::Vector2d& b = clean[i];
      const Eigen::Vector2d& c = clean[(i + 1) % clean.size()];
      const Eigen::Vector2d u = b - a, v = c - b;
      if (std::abs(u.x() * v.y() - u.y() * v.x()) < 1e-9 * (u.norm() + v.norm())) {
        clean.erase(clean.begin() + static_cast<std::ptrdiff_t>(i));
        again = true;
        break;
      }
    }
  }
  if (clean.size() < 3) return std::nullopt;
  const PlanarRegion& reg = seg.regions[static_cast<std::size_t>(region)];
  try {
    planning::ConvexRegion out = planning::ConvexRegion::fromPolygon(clean, 0.0, reg.normal);
    out.height = reg.heightAt(out.centroid);
    return out;
  } catch (const std::invalid_argument&) {
    return std::nullopt;  // vanished under the margin
  }
}

std::vector<Eigen::Vector2d> ConvexRegionGrower::polygonAt(const std::vector<Eigen::Vector2d>& dirs,
                                                           const Eigen::Vector2d& s, double cap,
                                                           const std::vector<double>& off,
                                                           double inset) {
  std::vector<Eigen::Vector2d> poly{s + Eigen::Vector2d(-cap, -cap), s + Eigen::Vector2d(cap, -cap),
                                    s + Eigen::Vector2d(cap, cap), s + Eigen::Vector2d(-cap, cap)};
  for (std::size_t k = 0; k < dirs.size() && poly.size() >= 3; ++k)
    clip(poly, clip_tmp_, dirs[k], s, off[k] - inset);
  return poly;
}

bool ConvexRegionGrower::insideAllBut(std::size_t i, std::size_t k,
                                      const std::vector<double>& off) const {
  const std::size_t K = off.size();
  for (std::size_t j = 0; j < K; ++j) {
    if (j != k && proj_[i * K + j] >= off[j] - kTie) return false;
  }
  return true;
}

double ConvexRegionGrower::reach(int k, const std::vector<double>& off, double cap) const {
  const auto K = off.size();
  const auto kk = static_cast<std::size_t>(k);
  double limit = cap;
  for (std::size_t i = 0; i < obstacles_.size(); ++i) {
    const double v = proj_[i * K + kk];
    if (v < off[kk] - kTie || v >= limit) continue;
    if (insideAllBut(i, kk, off)) limit = v;  // within every other half-plane: it stops k
  }
  return limit;
}

void ConvexRegionGrower::stepBackFromNotches(const std::vector<Eigen::Vector2d>& dirs,
                                             const Eigen::Vector2d& s, double cap, double res,
                                             std::vector<double>& off) {
  const double depth = settings_.max_notch_depth;
  if (!(depth > 0.0)) return;
  const std::size_t K = dirs.size(), P = obstacles_.size();
  double area = polygonArea(polygonAt(dirs, s, cap, off, 0.0));
  std::vector<double> trial(K), best_off(K), back(K);
  // Each accepted move grows the area; K rounds bound the search (a notch per edge).
  for (std::size_t round = 0; round < K; ++round) {
    double best_area = area;
    for (std::size_t k = 0; k < K; ++k) {
      if (off[k] >= cap) continue;  // not stopped by an obstacle
      // The obstacles that stop half-plane k: on its line, inside every other one. Half-plane
      // j stepping back to back[j] puts all of them behind it, and k can go on.
      std::fill(back.begin(), back.end(), std::numeric_limits<double>::infinity());
      bool any = false;
      for (std::size_t i = 0; i < P; ++i) {
        const double v = proj_[i * K + k];
        if (v < off[k] - kTie || v > off[k] + kTie + 0.5 * res) continue;
        if (!insideAllBut(i, k, off)) continue;
        any = true;
        for (std::size_t j = 0; j < K; ++j) back[j] = std::min(back[j], proj_[i * K + j]);
      }
      if (!any) continue;
      for (std::size_t j = 0; j < K; ++j) {
        // Not a notch (deeper than max_notch_depth), or the seed would leave the polygon.
        if (j == k || back[j] < off[j] - depth - kTie || back[j] <= 0.5 * res) continue;
        trial = off;
        trial[j] = back[j];
        trial[k] = reach(static_cast<int>(k), trial, cap);
        for (std::size_t m = 0; m < K; ++m) {
          if (m != j && m != k) trial[m] = reach(static_cast<int>(m), trial, cap);
        }
        const double a = polygonArea(polygonAt(dirs, s, cap, trial, 0.0));
        if (a > best_area * (1.0 + 1e-9)) {
          best_area = a;
          best_off = trial;
        }
      }
    }
    if (!(best_area > area)) break;
    area = best_area;
    off = best_off;
  }
}

std::optional<planning::ConvexRegion> ConvexRegionGrower::grow(const Segmentation& seg, int region,
                                                               const Eigen::Vector2d& seed) {
  if (region < 0 || region >= static_cast<int>(seg.regions.size())) return std::nullopt;
  if (!prepare(seg, region)) return std::nullopt;
  return growPrepared(seg, region, seed);
}

std::optional<planning::ConvexRegion> ConvexRegionGrower::forFoothold(
    const Segmentation& seg, const Eigen::Vector3d& foothold) {
  const int region = selectRegion(seg, foothold);
  if (region < 0) return std::nullopt;
  return grow(seg, region, foothold.head<2>());
}

planning::TerrainModel ConvexRegionGrower::terrain(const Segmentation& seg) {
  std::vector<planning::ConvexRegion> pieces;
  const int n = seg.size;
  const double res = seg.resolution;
  for (int k = 0; k < static_cast<int>(seg.regions.size()); ++k) {
    if (seg.regions[static_cast<std::size_t>(k)].area < settings_.min_piece_area) continue;
    if (!prepare(seg, k)) continue;
    const std::vector<unsigned char> region_mask = mask_;
    const auto total = static_cast<double>(std::count(region_mask.begin(), region_mask.end(), 1));
    std::vector<unsigned char> covered(region_mask.size(), 0);
    double covered_cells = 0;
    // The region's bounding box: the seed search and the coverage stay inside it.
    int r0 = n, r1 = -1, c0 = n, c1 = -1;
    for (int r = 0; r < n; ++r) {
      for (int c = 0; c < n; ++c) {
        if (!region_mask[static_cast<std::size_t>(r * n + c)]) continue;
        r0 = std::min(r0, r);
        r1 = std::max(r1, r);
        c0 = std::min(c0, c);
        c1 = std::max(c1, c);
      }
    }
    const int rows = r1 - r0 + 1, cols = c1 - c0 + 1;
    cv::Mat padded(rows + 2, cols + 2, CV_8U), dist;
    for (int piece = 0; piece < settings_.max_pieces_per_region; ++piece) {
      // Seed: the uncovered region cell furthest from the border and the pieces so far.
      padded.setTo(0);
      for (int r = r0; r <= r1; ++r) {
        for (int c = c0; c <= c1; ++c) {
          const auto i = static_cast<std::size_t>(r * n + c);
          padded.at<unsigned char>(r - r0 + 1, c - c0 + 1) =
              (region_mask[i] && !covered[i]) ? 1 : 0;
        }
      }
      cv::distanceTransform(padded, dist, cv::DIST_L2, cv::DIST_MASK_PRECISE);
      double best = 0;
      cv::Point at;
      cv::minMaxLoc(dist, nullptr, &best, nullptr, &at);
      if (best < 1.5) break;
      // Enough: the share is covered and no uncovered part is wider than cover_gap (the
      // distance transform's largest value spans about 2 best - 1 cells).
      if (covered_cells >= settings_.cover_fraction * total &&
          (2.0 * best - 1.0) * res <= settings_.cover_gap)
        break;
      const Eigen::Vector2d seed = seg.cellCenter(r0 + at.y - 1, c0 + at.x - 1);
      std::optional<planning::ConvexRegion> r = growPrepared(seg, k, seed);
      if (!r) break;
      // Cells the piece covers (its edges sit on the region's cell edges, minus margin).
      for (int rr = r0; rr <= r1; ++rr) {
        for (int cc = c0; cc <= c1; ++cc) {
          const auto i = static_cast<std::size_t>(rr * n + cc);
          if (!region_mask[i] || covered[i]) continue;
          if (r->margin(seg.cellCenter(rr, cc)) >= -settings_.margin - 0.5 * res) {
            covered[i] = 1;
            ++covered_cells;
          }
        }
      }
      if (polygonArea(r->vertices) >= settings_.min_piece_area) pieces.push_back(std::move(*r));
    }
  }
  return planning::TerrainModel(std::move(pieces));
}

}  // namespace rollstep::perception
