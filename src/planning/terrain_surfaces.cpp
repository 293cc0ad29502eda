// Foothold regions from planar top faces (terrainFromSurfaces, terrainFromBoxes): one path
// for every scene of boxes and ramps, yawed, sloped or axis-aligned.
#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "check.hpp"
#include "rollstep/planning/terrain.hpp"

namespace rollstep::planning {

namespace {

using Polygon = std::vector<Eigen::Vector2d>;

// Pieces thinner than this are rounding, not terrain [m, m^2]: two boxes meant to share an
// edge may have been built with different rounding (a + (b + c) against (a + b) + c).
constexpr double kLineTolerance = 1e-9;
constexpr double kAreaTolerance = 1e-9;
constexpr double kSnap = 1e-10;
// How far beside an edge its two sides are looked at [m], and the height difference across
// it that makes it a step [m] (less is a crease: a ramp meeting the floor, two surfaces
// crossing).
constexpr double kSideProbe = 1e-6;
constexpr double kStepHeight = 1e-3;
// Surfaces closer than this [m] meet: a scene file's numbers are written with a few digits
// (a ramp's end from its slope), so a ramp meant to end on a block's edge ends a few um
// short of it or past it. Such a hairline gap is no step (it is rechecked this far beside
// the edge), and a piece of terrain narrower than it is no foothold (dropped).
constexpr double kGapBridge = 2e-4;

/// A surface seen from above: its footprint (convex, counter-clockwise) and its plane
/// z = z0 + g . (p - p0).
struct Surface {
  Polygon footprint;
  Eigen::Vector2d p0 = Eigen::Vector2d::Zero();
  double z0 = 0.0;
  Eigen::Vector2d gradient = Eigen::Vector2d::Zero();
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();

  double heightAt(const Eigen::Vector2d& p) const { return z0 + gradient.dot(p - p0); }
  bool covers(const Eigen::Vector2d& p) const {
    const std::size_t n = footprint.size();
    for (std::size_t i = 0; i < n; ++i) {
      const Eigen::Vector2d e = footprint[(i + 1) % n] - footprint[i];
      const Eigen::Vector2d d = p - footprint[i];
      if (e.x() * d.y() - e.y() * d.x() < -kLineTolerance * e.norm()) return false;
    }
    return true;
  }
};

/// A line a . p + c = 0 with |a| = 1.
struct Line {
  Eigen::Vector2d a;
  double c;
  /// Where the cut matters: only cells overlapping all of these polygons are cut (a top
  /// face's edge matters on that face only, two surfaces' crossing where both are, the
  /// border of an edge's margin band within the band).
  std::vector<const Polygon*> scope;
};

double area(const Polygon& p) { return signedPolygonArea(p); }

/// The line through a and b, a . p + c >= 0 on its left.
Line lineThrough(const Eigen::Vector2d& a, const Eigen::Vector2d& b,
                 std::vector<const Polygon*> scope) {
  const Eigen::Vector2d d = (b - a).normalized();
  const Eigen::Vector2d n(-d.y(), d.x());
  return {n, -n.dot(a), std::move(scope)};
}

/// The part of convex `poly` where a . p + c >= 0 (sign +1) or <= 0 (sign -1).
Polygon clip(const Polygon& poly, const Line& line, double sign) {
  Polygon out;
  const std::size_t n = poly.size();
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector2d& p = poly[i];
    const Eigen::Vector2d& q = poly[(i + 1) % n];
    const double dp = sign * (line.a.dot(p) + line.c), dq = sign * (line.a.dot(q) + line.c);
    if (dp >= 0.0) out.push_back(p);
    if ((dp > 0.0 && dq < 0.0) || (dp < 0.0 && dq > 0.0)) {
      out.push_back(p + (q - p) * (dp / (dp - dq)));
    }
  }
  return out;
}

Eigen::Vector2d centroid(const Polygon& poly) {
  const double a = area(poly);
  Eigen::Vector2d c = Eigen::Vector2d::Zero();
  const std::size_t n = poly.size();
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector2d& p = poly[i];
    const Eigen::Vector2d& q = poly[(i + 1) % n];
    const double cross = p.x() * q.y() - q.x() * p.y();
    c += (p + q) * cross;
  }
  return c / (6.0 * a);
}

/// Convex hull, counter-clockwise, without collinear or repeated points. The points are
/// first put on a grid of kSnap: pieces cut along two lines that are one line but for
/// rounding (a band's side and another band's end) then share their corners exactly, and a
/// corner a rounding error left of its neighbour above it is not taken for a turn back.
Polygon hull(Polygon points) {
  for (Eigen::Vector2d& p : points) p = (p / kSnap).array().round() * kSnap;
  std::sort(points.begin(), points.end(), [](const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
    return a.x() < b.x() || (a.x() == b.x() && a.y() < b.y());
  });
  const auto cross = [](const Eigen::Vector2d& o, const Eigen::Vector2d& a,
                        const Eigen::Vector2d& b) {
    return (a - o).x() * (b - o).y() - (a - o).y() * (b - o).x();
  };
  Polygon h(2 * points.size());
  std::size_t k = 0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    while (k >= 2 && cross(h[k - 2], h[k - 1], points[i]) <= kLineTolerance) --k;
    h[k++] = points[i];
  }
  for (std::size_t i = points.size() - 1, t = k + 1; i-- > 0;) {
    while (k >= t && cross(h[k - 2], h[k - 1], points[i]) <= kLineTolerance) --k;
    h[k++] = points[i];
  }
  h.resize(k > 1 ? k - 1 : k);
  return h;
}

/// Whether two convex counter-clockwise polygons share some area.
bool overlaps(const Polygon& a, const Polygon& b) {
  Polygon piece = a;
  for (std::size_t k = 0; k < b.size() && piece.size() >= 3; ++k) {
    piece = clip(piece, lineThrough(b[k], b[(k + 1) % b.size()], {}), 1.0);
  }
  return piece.size() >= 3 && area(piece) > kAreaTolerance;
}

/// Whether the bounding boxes of two polygons meet (a cheap test before a hull).
bool boundsMeet(const Polygon& a, const Polygon& b) {
  const auto bounds = [](const Polygon& p) {
    Eigen::Vector2d lo = p.front(), hi = p.front();
    for (const Eigen::Vector2d& v : p) {
      lo = lo.cwiseMin(v);
      hi = hi.cwiseMax(v);
    }
    return std::pair{lo, hi};
  };
  const auto [alo, ahi] = bounds(a);
  const auto [blo, bhi] = bounds(b);
  const double t = 1e-7;
  return alo.x() <= bhi.x() + t && blo.x() <= ahi.x() + t && alo.y() <= bhi.y() + t &&
         blo.y() <= ahi.y() + t;
}

/// The smallest distance between two parallel lines enclosing a convex polygon, and their
/// normal.
std::pair<double, Eigen::Vector2d> width(const Polygon& p) {
  double smallest = std::numeric_limits<double>::infinity();
  Eigen::Vector2d across = Eigen::Vector2d::UnitX();
  for (std::size_t i = 0; i < p.size(); ++i) {
    const Eigen::Vector2d e = p[(i + 1) % p.size()] - p[i];
    const double length = e.norm();
    if (length < 1e-15) continue;
    double farthest = 0.0;
    for (const Eigen::Vector2d& v : p) {
      const Eigen::Vector2d d = v - p[i];
      farthest = std::max(farthest, std::abs(e.x() * d.y() - e.y() * d.x()) / length);
    }
    if (farthest < smallest) {
      smallest = farthest;
      across = Eigen::Vector2d(-e.y(), e.x()) / length;
    }
  }
  return {smallest, across};
}

/// Height of the highest surface covering p; -inf where none does (beyond the floor).
double visibleHeight(const std::vector<Surface>& surfaces, const Eigen::Vector2d& p) {
  double h = -std::numeric_limits<double>::infinity();
  for (const Surface& s : surfaces) {
    if (s.covers(p)) h = std::max(h, s.heightAt(p));
  }
  return h;
}

/// The parts of footprint edge a-b where the visible height jumps across it (a step), as
/// segments; `lines` split the edge where what lies beside it may change.
std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>> stepParts(
    const std::vector<Surface>& surfaces, const std::vector<Line>& lines, const Eigen::Vector2d& a,
    const Eigen::Vector2d& b) {
  const Eigen::Vector2d d = b - a;
  const double length = d.norm();
  const Eigen::Vector2d outward = Eigen::Vector2d(d.y(), -d.x()) / length;
  std::vector<double> ts{0.0, 1.0};
  for (const Line& l : lines) {
    const double fa = l.a.dot(a) + l.c, fb = l.a.dot(b) + l.c;
    if ((fa > 0.0) == (fb > 0.0) || std::abs(fa - fb) < 1e-15) continue;
    const double t = fa / (fa - fb);
    if (t * length > kLineTolerance && (1.0 - t) * length > kLineTolerance) ts.push_back(t);
  }
  std::sort(ts.begin(), ts.end());
  std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>> parts;
  bool open = false;
  for (std::size_t k = 0; k + 1 < ts.size(); ++k) {
    if ((ts[k + 1] - ts[k]) * length <= kLineTolerance) continue;
    const Eigen::Vector2d mid = a + 0.5 * (ts[k] + ts[k + 1]) * d;
    const double inside = visibleHeight(surfaces, mid - kSideProbe * outward);
    const auto jumps = [&](double probe) {
      const double beside = visibleHeight(surfaces, mid + probe * outward);
      return std::isinf(inside) != std::isinf(beside) ||
             (!std::isinf(inside) && std::abs(inside - beside) > kStepHeight);
    };
    const bool step = jumps(kSideProbe) && jumps(kGapBridge);
    if (step && open) {
      parts.back().second = a + ts[k + 1] * d;  // continues the previous part
    } else if (step) {
      parts.emplace_back(a + ts[k] * d, a + ts[k + 1] * d);
    }
    open = step;
  }
  return parts;
}

std::string describe(const Polygon& p) {
  Eigen::Vector2d lo = p.front(), hi = p.front();
  for (const Eigen::Vector2d& v : p) {
    lo = lo.cwiseMin(v);
    hi = hi.cwiseMax(v);
  }
  std::ostringstream os;
  os << "x [" << lo.x() << ", " << hi.x() << "], y [" << lo.y() << ", " << hi.y() << "] m";
  return os.str();
}

void checkBox(const char* where, const std::string& name, const TerrainBox& b) {
  const std::pair<const char*, double> fields[] = {{".x_min", b.x_min},
                                                   {".x_max", b.x_max},
                                                   {".y_min", b.y_min},
                                                   {".y_max", b.y_max},
                                                   {".top", b.top}};
  for (const auto& f : fields) detail::checkFinite(where, (name + f.first).c_str(), f.second);
  if (!(b.x_max > b.x_min))
    detail::fail(where, (name + ".x_max").c_str(), b.x_max, "must be > x_min");
  if (!(b.y_max > b.y_min))
    detail::fail(where, (name + ".y_max").c_str(), b.y_max, "must be > y_min");
}

TerrainModel regionsOf(const char* where, const TerrainBox& floor_box, double floor_height,
                       const std::vector<TerrainSurface>& tops, double margin) {
  std::vector<Surface> surfaces;
  Surface floor;
  floor.footprint = {{floor_box.x_min, floor_box.y_min},
                     {floor_box.x_max, floor_box.y_min},
                     {floor_box.x_max, floor_box.y_max},
                     {floor_box.x_min, floor_box.y_max}};
  floor.z0 = floor_height;
  surfaces.push_back(floor);
  for (const TerrainSurface& top : tops) {
    Surface t;
    t.footprint = top.footprint;
    if (area(t.footprint) < 0.0) std::reverse(t.footprint.begin(), t.footprint.end());
    t.p0 = top.point.head<2>();
    t.z0 = top.point.z();
    t.normal = top.normal.normalized();
    t.gradient = -t.normal.head<2>() / t.normal.z();
    surfaces.push_back(std::move(t));
  }
  // Cut lines: every footprint edge, and where two overlapping surfaces cross.
  std::vector<Line> lines;
  for (std::size_t i = 1; i < surfaces.size(); ++i) {
    const Polygon& f = surfaces[i].footprint;
    for (std::size_t k = 0; k < f.size(); ++k)
      lines.push_back(lineThrough(f[k], f[(k + 1) % f.size()], {&f}));
  }
  for (std::size_t i = 0; i < surfaces.size(); ++i) {
    for (std::size_t j = i + 1; j < surfaces.size(); ++j) {
      const Surface& s = surfaces[i];
      const Surface& t = surfaces[j];
      // s - t = (z0s - gs.p0s) - (z0t - gt.p0t) + (gs - gt) . p
      const Eigen::Vector2d a = s.gradient - t.gradient;
      const double norm = a.norm();
      if (norm < 1e-12) continue;
      const double c = (s.z0 - s.gradient.dot(s.p0)) - (t.z0 - t.gradient.dot(t.p0));
      if (!overlaps(s.footprint, t.footprint)) continue;
      lines.push_back({a / norm, c / norm, {&s.footprint, &t.footprint}});
    }
  }
  // The margin: a band of half-width `margin` around every step (a footprint edge where
  // the visible height jumps, the floor's border), its ends squared off, is no foothold.
  // Its borders are cut lines too, so every cell lies inside a band or outside all of
  // them; cells inside are dropped. Nothing else moves: pieces of one surface that meet
  // (a floor cut along a block's side line) keep meeting, with no gap between them.
  std::vector<Polygon> bands;
  if (margin > 0.0) {
    std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>> steps;
    for (const Surface& s : surfaces) {
      const Polygon& f = s.footprint;
      for (std::size_t k = 0; k < f.size(); ++k) {
        const auto parts = stepParts(surfaces, lines, f[k], f[(k + 1) % f.size()]);
        steps.insert(steps.end(), parts.begin(), parts.end());
      }
    }
    bands.reserve(steps.size());  // the lines below point into it
    for (const auto& [a, b] : steps) {
      const Eigen::Vector2d d = (b - a).normalized() * margin;
      const Eigen::Vector2d n(-d.y(), d.x());
      bands.push_back({a - d - n, b + d - n, b + d + n, a - d + n});
    }
    for (const Polygon& band : bands) {
      for (std::size_t k = 0; k < 4; ++k)
        lines.push_back(lineThrough(band[k], band[(k + 1) % 4], {&band}));
    }
  }
  std::vector<Polygon> cells{floor.footprint};
  for (const Line& line : lines) {
    std::vector<Polygon> next;
    for (Polygon& cell : cells) {
      bool inside_scope = true;
      for (const Polygon* f : line.scope) inside_scope = inside_scope && overlaps(cell, *f);
      bool above = false, below = false;
      for (const Eigen::Vector2d& p : cell) {
        const double d = line.a.dot(p) + line.c;
        above = above || d > kLineTolerance;
        below = below || d < -kLineTolerance;
      }
      if (!inside_scope || !(above && below)) {
        next.push_back(std::move(cell));
        continue;
      }
      for (double sign : {1.0, -1.0}) {
        Polygon piece = clip(cell, line, sign);
        if (piece.size() >= 3 && area(piece) > kAreaTolerance) next.push_back(std::move(piece));
      }
    }
    cells = std::move(next);
  }
  // Each cell's surface: the highest covering its centroid (surfaces cross only on cuts);
  // cells in a band are dropped, but a surface that is seen and loses every cell so is an
  // error (a ledge narrower than twice the margin: no foot could stand there).
  std::vector<std::size_t> owner;
  std::vector<Polygon> kept;
  std::vector<Polygon> seen(surfaces.size());
  std::vector<bool> has_region(surfaces.size(), false);
  for (Polygon& cell : cells) {
    cell = hull(cell);
    if (cell.size() < 3) continue;
    const Eigen::Vector2d m = centroid(cell);
    std::size_t best = 0;
    for (std::size_t k = 1; k < surfaces.size(); ++k) {
      if (surfaces[k].covers(m) && surfaces[k].heightAt(m) > surfaces[best].heightAt(m)) best = k;
    }
    // A hairline crevice between two higher surfaces that meet (see kGapBridge): no foothold.
    const auto [narrow, across] = width(cell);
    if (narrow < kGapBridge) {
      const double floor_of_gap = surfaces[best].heightAt(m) + kStepHeight;
      if (visibleHeight(surfaces, m + kGapBridge * across) > floor_of_gap &&
          visibleHeight(surfaces, m - kGapBridge * across) > floor_of_gap) {
        continue;
      }
    }
    seen[best].insert(seen[best].end(), cell.begin(), cell.end());
    const bool in_band = std::any_of(bands.begin(), bands.end(), [&](const Polygon& band) {
      for (std::size_t k = 0; k < 4; ++k) {
        const Eigen::Vector2d e = band[(k + 1) % 4] - band[k];
        const Eigen::Vector2d d = m - band[k];
        if (e.x() * d.y() - e.y() * d.x() <= kLineTolerance * e.norm()) return false;
      }
      return true;
    });
    if (in_band) continue;
    has_region[best] = true;
    owner.push_back(best);
    kept.push_back(std::move(cell));
  }
  for (std::size_t k = 0; k < surfaces.size(); ++k) {
    if (seen[k].empty() || has_region[k]) continue;
    std::ostringstream need;
    need << "empties a region of the terrain: the surface at height "
         << surfaces[k].heightAt(centroid(hull(seen[k]))) << " m over " << describe(seen[k])
         << " is not wider than twice the margin";
    detail::fail(where, "margin", margin, need.str().c_str());
  }
  // Merge pieces of one surface while their union is convex (its hull has their area).
  // Passes until none merges; a cell that grew is tried again against the rest at once.
  bool merged = true;
  while (merged) {
    merged = false;
    for (std::size_t i = 0; i < kept.size(); ++i) {
      for (std::size_t j = i + 1; j < kept.size();) {
        if (owner[i] == owner[j] && boundsMeet(kept[i], kept[j])) {
          Polygon both = kept[i];
          both.insert(both.end(), kept[j].begin(), kept[j].end());
          Polygon h = hull(both);
          const double sum = area(kept[i]) + area(kept[j]);
          if (std::abs(area(h) - sum) <= 1e-9 * std::max(1.0, sum)) {
            kept[i] = std::move(h);
            kept.erase(kept.begin() + static_cast<std::ptrdiff_t>(j));
            owner.erase(owner.begin() + static_cast<std::ptrdiff_t>(j));
            merged = true;
            j = i + 1;
            continue;
          }
        }
        ++j;
      }
    }
  }
  std::vector<ConvexRegion> regions;
  for (std::size_t i = 0; i < kept.size(); ++i) {
    const Surface& s = surfaces[owner[i]];
    regions.push_back(ConvexRegion::fromPolygon(kept[i], s.heightAt(centroid(kept[i])), s.normal));
  }
  return TerrainModel(std::move(regions));
}

}  // namespace

TerrainModel terrainFromSurfaces(const TerrainBox& floor, double floor_height,
                                 const std::vector<TerrainSurface>& surfaces, double margin) {
  const char* where = "terrainFromSurfaces";
  TerrainBox f = floor;
  f.top = floor_height;
  checkBox(where, "floor", f);
  detail::checkNonNegative(where, "margin", margin);
  for (std::size_t k = 0; k < surfaces.size(); ++k) {
    const std::string name = "surfaces[" + std::to_string(k) + "]";
    const TerrainSurface& s = surfaces[k];
    if (!s.point.allFinite()) {
      detail::fail(where, (name + ".point").c_str(), "(not finite)", "must be finite");
    }
    if (!s.normal.allFinite() || !(s.normal.z() > 1e-9 * s.normal.norm())) {
      detail::fail(where, (name + ".normal").c_str(), "(not upward)", "must be finite with z > 0");
    }
    try {
      (void)ConvexRegion::fromPolygon(s.footprint, s.point.z(), s.normal);
    } catch (const std::invalid_argument& e) {
      detail::fail(where, (name + ".footprint").c_str(), e.what(), "must be a convex polygon");
    }
  }
  return regionsOf(where, f, floor_height, surfaces, margin);
}

TerrainModel terrainFromBoxes(const TerrainBox& floor, double floor_height,
                              const std::vector<TerrainBox>& boxes, double margin) {
  const char* where = "terrainFromBoxes";
  TerrainBox f = floor;
  f.top = floor_height;
  checkBox(where, "floor", f);
  std::vector<TerrainSurface> tops;
  for (std::size_t k = 0; k < boxes.size(); ++k) {
    const TerrainBox& b = boxes[k];
    checkBox(where, "boxes[" + std::to_string(k) + "]", b);
    tops.push_back(
        {{{b.x_min, b.y_min}, {b.x_max, b.y_min}, {b.x_max, b.y_max}, {b.x_min, b.y_max}},
         Eigen::Vector3d(0.5 * (b.x_min + b.x_max), 0.5 * (b.y_min + b.y_max), b.top),
         Eigen::Vector3d::UnitZ()});
  }
  detail::checkNonNegative(where, "margin", margin);
  return regionsOf(where, f, floor_height, tops, margin);
}

}  // namespace rollstep::planning
