#include "rollstep/sim/scene_terrain.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

namespace rollstep::sim {

namespace {

using Polygon = std::vector<Eigen::Vector2d>;

// Pieces thinner than this are rounding, not terrain [m, m^2].
constexpr double kLineTolerance = 1e-9;
constexpr double kAreaTolerance = 1e-9;

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
      if (e.x() * d.y() - e.y() * d.x() < -kLineTolerance) return false;
    }
    return true;
  }
};

/// A line a . p + c = 0 with |a| = 1.
struct Line {
  Eigen::Vector2d a;
  double c;
  /// Where the cut matters: only cells overlapping all of these footprints are cut (a
  /// top face's edge matters on that face only, two surfaces' crossing where both are).
  std::vector<const Polygon*> scope;
};

double area(const Polygon& p) { return planning::signedPolygonArea(p); }

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

/// Convex hull, counter-clockwise, without collinear or repeated points.
Polygon hull(Polygon points) {
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
    const Eigen::Vector2d d = (b[(k + 1) % b.size()] - b[k]).normalized();
    const Eigen::Vector2d n(-d.y(), d.x());  // inwards for counter-clockwise
    piece = clip(piece, Line{n, -n.dot(b[k]), {}}, 1.0);
  }
  return piece.size() >= 3 && area(piece) > kAreaTolerance;
}

planning::TerrainModel axisAlignedTerrain(const SceneGeometry& g, double margin) {
  std::vector<planning::TerrainBox> boxes;
  for (const SceneSolid& s : g.solids) {
    boxes.push_back({s.center.x() - s.half_size.x(), s.center.x() + s.half_size.x(),
                     s.center.y() - s.half_size.y(), s.center.y() + s.half_size.y(),
                     s.center.z() + s.half_size.z()});
  }
  const double e = kSceneFloorHalfExtent;
  return planning::terrainFromBoxes({-e, e, -e, e, 0.0}, 0.0, boxes, margin);
}

}  // namespace

planning::TerrainModel terrainFromScene(const SceneGeometry& g, double margin) {
  const bool axis_aligned = std::all_of(g.solids.begin(), g.solids.end(), [](const SceneSolid& s) {
    return !s.ramp && s.yaw == 0.0 && s.slope == 0.0;
  });
  if (axis_aligned) return axisAlignedTerrain(g, margin);
  if (!std::isfinite(margin) || margin < 0.0) {
    throw std::invalid_argument("terrainFromScene: margin = " + std::to_string(margin) +
                                " m: must be finite and >= 0");
  }

  const double e = kSceneFloorHalfExtent;
  std::vector<Surface> surfaces;
  Surface floor;
  floor.footprint = {{-e, -e}, {e, -e}, {e, e}, {-e, e}};
  surfaces.push_back(floor);
  for (const SceneSolid& s : g.solids) {
    Surface t;
    const std::array<Eigen::Vector2d, 4> f = s.topFootprint();
    t.footprint.assign(f.begin(), f.end());
    const Eigen::Vector3d c = s.topCenter();
    t.p0 = c.head<2>();
    t.z0 = c.z();
    t.normal = s.topNormal();
    t.gradient = -t.normal.head<2>() / t.normal.z();
    surfaces.push_back(t);
  }
  // Cut lines: every footprint edge, and where two overlapping surfaces cross.
  std::vector<Line> lines;
  for (std::size_t i = 1; i < surfaces.size(); ++i) {
    const Polygon& f = surfaces[i].footprint;
    for (std::size_t k = 0; k < f.size(); ++k) {
      const Eigen::Vector2d d = (f[(k + 1) % f.size()] - f[k]).normalized();
      const Eigen::Vector2d a(-d.y(), d.x());
      lines.push_back({a, -a.dot(f[k]), {&f}});
    }
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
  std::vector<Polygon> cells{floor.footprint};
  for (const Line& line : lines) {
    std::vector<Polygon> next;
    for (const Polygon& cell : cells) {
      bool inside_scope = true;
      for (const Polygon* f : line.scope) inside_scope = inside_scope && overlaps(cell, *f);
      if (!inside_scope) {
        next.push_back(cell);
        continue;
      }
      bool above = false, below = false;
      for (const Eigen::Vector2d& p : cell) {
        const double d = line.a.dot(p) + line.c;
        above = above || d > kLineTolerance;
        below = below || d < -kLineTolerance;
      }
      if (!(above && below)) {
        next.push_back(cell);
        continue;
      }
      for (double sign : {1.0, -1.0}) {
        Polygon piece = clip(cell, line, sign);
        if (piece.size() >= 3 && area(piece) > kAreaTolerance) next.push_back(std::move(piece));
      }
    }
    cells = std::move(next);
  }
  // Each cell's surface: the highest covering its centroid (surfaces cross only on cuts).
  std::vector<std::size_t> owner;
  for (Polygon& cell : cells) {
    cell = hull(cell);
    const Eigen::Vector2d m = centroid(cell);
    std::size_t best = 0;
    for (std::size_t k = 1; k < surfaces.size(); ++k) {
      if (surfaces[k].covers(m) && surfaces[k].heightAt(m) > surfaces[best].heightAt(m)) best = k;
    }
    owner.push_back(best);
  }
  // Merge pieces of one surface while their union is convex (its hull has their area).
  // Passes until none merges; a cell that grew is tried again against the rest at once.
  bool merged = true;
  while (merged) {
    merged = false;
    for (std::size_t i = 0; i < cells.size(); ++i) {
      for (std::size_t j = i + 1; j < cells.size();) {
        if (owner[i] == owner[j]) {
          Polygon both = cells[i];
          both.insert(both.end(), cells[j].begin(), cells[j].end());
          Polygon h = hull(both);
          const double sum = area(cells[i]) + area(cells[j]);
          if (std::abs(area(h) - sum) <= 1e-9 * std::max(1.0, sum)) {
            cells[i] = std::move(h);
            cells.erase(cells.begin() + static_cast<std::ptrdiff_t>(j));
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
  std::vector<planning::ConvexRegion> regions;
  for (std::size_t i = 0; i < cells.size(); ++i) {
    const Surface& s = surfaces[owner[i]];
    regions.push_back(
        planning::ConvexRegion::fromPolygon(cells[i], s.heightAt(centroid(cells[i])), s.normal));
  }
  planning::TerrainModel model(std::move(regions));
  if (margin == 0.0) return model;
  // Edges between pieces of one surface (or where a ramp meets the floor) are seams.
  return planning::shrinkTerrain(model, margin, 0.01, 1e-3);
}

planning::TerrainModel terrainFromScene(const SceneConfig& config, double margin) {
  return terrainFromScene(resolveScene(config), margin);
}

}  // namespace rollstep::sim
