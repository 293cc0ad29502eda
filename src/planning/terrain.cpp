#include "rollstep/planning/terrain.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>

#include "check.hpp"

namespace rollstep::planning {

namespace {

double cross(const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  return a.x() * b.y() - a.y() * b.x();
}

Eigen::Vector2d segmentClosestPoint(const Eigen::Vector2d& p, const Eigen::Vector2d& a,
                                    const Eigen::Vector2d& b) {
  const Eigen::Vector2d e = b - a;
  const double s = std::clamp((p - a).dot(e) / e.squaredNorm(), 0.0, 1.0);
  return a + s * e;
}

std::string str(const Eigen::Vector2d& v) {
  std::ostringstream os;
  os << "(" << v.x() << ", " << v.y() << ")";
  return os.str();
}

}  // namespace

double signedPolygonArea(const std::vector<Eigen::Vector2d>& vertices) {
  const std::size_t n = vertices.size();
  double twice = 0.0;
  for (std::size_t k = 0; k < n; ++k) twice += cross(vertices[k], vertices[(k + 1) % n]);
  return 0.5 * twice;
}

ConvexRegion ConvexRegion::fromPolygon(const std::vector<Eigen::Vector2d>& vertices, double height,
                                       const Eigen::Vector3d& normal) {
  const char* where = "ConvexRegion::fromPolygon";
  const std::size_t n = vertices.size();
  if (n < 3) {
    detail::fail(where, "vertices.size()", n, "a polygon needs at least 3 vertices");
  }
  for (std::size_t k = 0; k < n; ++k) {
    if (!vertices[k].allFinite()) {
      detail::fail(where, ("vertices[" + std::to_string(k) + "]").c_str(), str(vertices[k]),
                   "must be finite");
    }
    if ((vertices[(k + 1) % n] - vertices[k]).norm() < 1e-12) {
      detail::fail(where, ("vertices[" + std::to_string((k + 1) % n) + "]").c_str(),
                   str(vertices[(k + 1) % n]), "repeats the previous vertex");
    }
  }
  detail::checkFinite(where, "height", height);
  if (!normal.allFinite() || normal.norm() < 1e-12 || normal.z() <= 1e-9 * normal.norm()) {
    std::ostringstream os;
    os << "(" << normal.x() << ", " << normal.y() << ", " << normal.z() << ")";
    detail::fail(where, "normal", os.str(), "must be finite, non-zero, with z > 0");
  }
  const double area = signedPolygonArea(vertices);
  if (std::abs(area) < 0.5e-12)
    detail::fail(where, "vertices", "(zero area)", "degenerate polygon");
  ConvexRegion r;
  r.vertices = vertices;
  if (area < 0.0) std::reverse(r.vertices.begin(), r.vertices.end());
  const auto& v = r.vertices;
  for (std::size_t k = 0; k < n; ++k) {
    const Eigen::Vector2d e0 = v[(k + 1) % n] - v[k];
    const Eigen::Vector2d e1 = v[(k + 2) % n] - v[(k + 1) % n];
    if (cross(e0, e1) < -1e-12 * e0.norm() * e1.norm()) {
      detail::fail(where, ("vertices[" + std::to_string((k + 1) % n) + "]").c_str(),
                   str(v[(k + 1) % n]), "the polygon is not convex there");
    }
  }
  // Convex with consistent turns can still wind twice (a star): the turning angles must
  // sum to 2 pi.
  double turn = 0.0;
  for (std::size_t k = 0; k < n; ++k) {
    const Eigen::Vector2d e0 = v[(k + 1) % n] - v[k];
    const Eigen::Vector2d e1 = v[(k + 2) % n] - v[(k + 1) % n];
    turn += std::atan2(cross(e0, e1), e0.dot(e1));
  }
  if (std::abs(turn - 2.0 * M_PI) > 1e-6) {
    detail::fail(where, "vertices", "(self-intersecting)", "the polygon is not convex");
  }
  r.A.resize(static_cast<Eigen::Index>(n), 2);
  r.b.resize(static_cast<Eigen::Index>(n));
  Eigen::Vector2d c = Eigen::Vector2d::Zero();
  double a6 = 0.0;
  for (std::size_t k = 0; k < n; ++k) {
    const Eigen::Vector2d e = v[(k + 1) % n] - v[k];
    const Eigen::Vector2d in = Eigen::Vector2d(-e.y(), e.x()).normalized();
    r.A.row(static_cast<Eigen::Index>(k)) = in.transpose();
    r.b(static_cast<Eigen::Index>(k)) = -in.dot(v[k]);
    const double w = cross(v[k], v[(k + 1) % n]);
    c += w * (v[k] + v[(k + 1) % n]);
    a6 += 3.0 * w;
  }
  r.centroid = c / a6;
  r.height = height;
  r.normal = normal.normalized();
  return r;
}

double ConvexRegion::margin(const Eigen::Vector2d& p) const {
  // Row by row: A * p + b as an expression would evaluate the product into a heap
  // temporary.
  double m = std::numeric_limits<double>::infinity();
  for (Eigen::Index k = 0; k < A.rows(); ++k) {
    m = std::min(m, A(k, 0) * p.x() + A(k, 1) * p.y() + b(k));
  }
  return m;
}

void ConvexRegion::clipLine(const Eigen::Vector2d& p, const Eigen::Vector2d& e, double& lo,
                            double& hi) const {
  for (Eigen::Index k = 0; k < A.rows() && lo <= hi; ++k) {
    const double s = A(k, 0) * p.x() + A(k, 1) * p.y() + b(k);  // distance at d = 0
    const double rate = A(k, 0) * e.x() + A(k, 1) * e.y();
    if (std::abs(rate) < 1e-12) {
      if (s < 0.0) hi = lo - 1.0;  // parallel and outside
    } else if (rate > 0.0) {
      lo = std::max(lo, -s / rate);
    } else {
      hi = std::min(hi, -s / rate);
    }
  }
}

Eigen::Vector2d ConvexRegion::closestPoint(const Eigen::Vector2d& p) const {
  if (margin(p) >= 0.0) return p;
  double best = std::numeric_limits<double>::infinity();
  Eigen::Vector2d q = p;
  const std::size_t n = vertices.size();
  for (std::size_t k = 0; k < n; ++k) {
    const Eigen::Vector2d c = segmentClosestPoint(p, vertices[k], vertices[(k + 1) % n]);
    const double d = (p - c).norm();
    if (d < best) {
      best = d;
      q = c;
    }
  }
  return q;
}

double ConvexRegion::distance(const Eigen::Vector2d& p) const {
  return (p - closestPoint(p)).norm();
}

double ConvexRegion::heightAt(const Eigen::Vector2d& p) const {
  const Eigen::Vector2d d = p - centroid;
  return height - (normal.x() * d.x() + normal.y() * d.y()) / normal.z();
}

TerrainModel::TerrainModel(std::vector<ConvexRegion> regions) : regions_(std::move(regions)) {}

int TerrainModel::maxEdges() const {
  int edges = 0;
  for (const ConvexRegion& r : regions_) edges = std::max(edges, static_cast<int>(r.A.rows()));
  return edges;
}

int TerrainModel::regionAt(const Eigen::Vector2d& p) const {
  int best = -1;
  double best_height = -std::numeric_limits<double>::infinity();
  for (int i = 0; i < size(); ++i) {
    const ConvexRegion& r = region(i);
    if (!r.contains(p)) continue;
    const double h = r.heightAt(p);
    if (best < 0 || h > best_height) {
      best = i;
      best_height = h;
    }
  }
  if (best >= 0) return best;
  double best_distance = std::numeric_limits<double>::infinity();
  for (int i = 0; i < size(); ++i) {
    const double d = region(i).distance(p);
    if (d < best_distance) {
      best = i;
      best_distance = d;
    }
  }
  return best;
}

double TerrainModel::heightAt(const Eigen::Vector2d& p, double fallback) const {
  const int i = regionAt(p);
  return i < 0 ? fallback : region(i).heightAt(p);
}

SwingDirection TerrainModel::classifySwing(const Eigen::Vector2d& p_liftoff,
                                           const Eigen::Vector2d& p_touchdown,
                                           double tolerance) const {
  return planning::classifySwing(heightAt(p_liftoff), heightAt(p_touchdown), tolerance);
}

int TerrainModel::swingRegion(const Eigen::Vector2d& p_liftoff, const Eigen::Vector2d& p_touchdown,
                              double tolerance) const {
  switch (classifySwing(p_liftoff, p_touchdown, tolerance)) {
    case SwingDirection::Ascending:
      return regionAt(p_liftoff);
    case SwingDirection::Descending:
      return regionAt(p_touchdown);
    case SwingDirection::Level:
      break;
  }
  return -1;
}

int TerrainModel::regionAhead(const Eigen::Vector2d& p, const Eigen::Vector2d& e,
                              double reach) const {
  const int here = regionAt(p);
  if (here < 0 || reach <= 0.0 || region(here).contains(p)) return here;
  int best = here;
  double best_entry = std::numeric_limits<double>::infinity();
  for (int i = 0; i < size(); ++i) {
    const ConvexRegion& r = region(i);
    double lo = 0.0, hi = reach;  // the part of the ray inside the polygon
    r.clipLine(p, e, lo, hi);
    if (lo <= hi && lo < best_entry) {
      best = i;
      best_entry = lo;
    }
  }
  return best;
}

double TerrainModel::envelopeHeight(const Eigen::Vector2d& p, const Eigen::Vector2d& e,
                                    double reach, double slope) const {
  double best = heightAt(p);
  // Beyond reach + (highest - lowest region) / slope nothing can raise the result.
  double span = 0.0;
  if (slope > 0.0 && !regions_.empty()) {
    double lowest = regions_.front().height, highest = lowest;
    for (const ConvexRegion& r : regions_) {
      lowest = std::min(lowest, r.heightAt(p));
      highest = std::max(highest, r.heightAt(p));
    }
    span = (highest - lowest) / slope;
  }
  const double extent = reach + span;
  for (const ConvexRegion& r : regions_) {
    // The part [lo, hi] of the segment p + d e, |d| <= extent, inside the polygon.
    double lo = -extent, hi = extent;
    r.clipLine(p, e, lo, hi);
    if (lo > hi) continue;
    // The plane along the segment is linear in d; minus slope max(|d| - reach, 0), concave
    // and piecewise linear, it peaks at an end, at 0 or at +-reach.
    const double h0 = r.heightAt(p);
    const double grade = -(r.normal.x() * e.x() + r.normal.y() * e.y()) / r.normal.z();
    const auto value = [&](double d) {
      return h0 + grade * d - slope * std::max(std::abs(d) - reach, 0.0);
    };
    best = std::max({best, value(lo), value(hi)});
    for (const double d : {0.0, -reach, reach}) {
      if (lo < d && d < hi) best = std::max(best, value(d));
    }
  }
  return best;
}

namespace {

/// Whether edge e of region `index` is a seam (shrinkTerrain): the surface goes on beyond it
/// in other regions at about the same height.
bool isSeam(const TerrainModel& terrain, int index, Eigen::Index e, double probe,
            double tolerance) {
  const ConvexRegion& r = terrain.region(index);
  const std::size_t n = r.vertices.size();
  // Edge e runs from vertex e to vertex e + 1 (fromPolygon's row order).
  const Eigen::Vector2d a = r.vertices[static_cast<std::size_t>(e)];
  const Eigen::Vector2d b = r.vertices[(static_cast<std::size_t>(e) + 1) % n];
  const Eigen::Vector2d outward = -r.A.row(e).transpose();
  const double length = (b - a).norm();
  const int samples = std::max(1, static_cast<int>(std::ceil(length / probe)));
  for (int k = 0; k <= samples; ++k) {
    const Eigen::Vector2d on = a + (b - a) * (static_cast<double>(k) / samples);
    const Eigen::Vector2d p = on + probe * outward;
    const double h = r.heightAt(on);
    bool covered = false;
    for (int j = 0; j < terrain.size() && !covered; ++j) {
      if (j == index) continue;
      const ConvexRegion& other = terrain.region(j);
      covered = other.contains(p) && std::abs(other.heightAt(p) - h) <= tolerance;
    }
    if (!covered) return false;
  }
  return true;
}

}  // namespace

TerrainModel shrinkTerrain(const TerrainModel& terrain, double margin, double seam_probe,
                           double seam_height_tolerance) {
  if (!std::isfinite(margin) || margin < 0.0) {
    detail::fail("shrinkTerrain", "margin", margin, "must be finite and >= 0");
  }
  if (!std::isfinite(seam_probe) || seam_probe < 0.0) {
    detail::fail("shrinkTerrain", "seam_probe", seam_probe, "must be finite and >= 0");
  }
  if (!std::isfinite(seam_height_tolerance) || seam_height_tolerance < 0.0) {
    detail::fail("shrinkTerrain", "seam_height_tolerance", seam_height_tolerance,
                 "must be finite and >= 0");
  }
  std::vector<ConvexRegion> out;
  std::vector<Eigen::Vector2d> polygon, clipped;
  for (int index = 0; index < terrain.size(); ++index) {
    const ConvexRegion& r = terrain.region(index);
    // Clip the polygon by each edge's half-plane moved inwards (Sutherland-Hodgman: a
    // convex polygon stays convex; edges that vanish simply produce no vertex).
    polygon = r.vertices;
    for (Eigen::Index e = 0; e < r.A.rows() && polygon.size() >= 3; ++e) {
      const Eigen::Vector2d a = r.A.row(e).transpose();
      const bool seam =
          seam_probe > 0.0 && isSeam(terrain, index, e, seam_probe, seam_height_tolerance);
      const double b = r.b[e] - (seam ? 0.0 : margin);
      clipped.clear();
      for (std::size_t k = 0; k < polygon.size(); ++k) {
        const Eigen::Vector2d& p = polygon[k];
        const Eigen::Vector2d& q = polygon[(k + 1) % polygon.size()];
        const double dp = a.dot(p) + b, dq = a.dot(q) + b;
        if (dp >= 0.0) clipped.push_back(p);
        if ((dp >= 0.0) != (dq >= 0.0)) clipped.push_back(p + dp / (dp - dq) * (q - p));
      }
      polygon.swap(clipped);
    }
    // Drop near-duplicate vertices (an edge clipped to a point) and vertices on a straight
    // line through their neighbours: a shrunk region never has more edges than the region.
    clipped.clear();
    for (const Eigen::Vector2d& p : polygon) {
      if (clipped.empty() || (p - clipped.back()).norm() > 1e-7) clipped.push_back(p);
    }
    while (clipped.size() > 1 && (clipped.front() - clipped.back()).norm() <= 1e-7) {
      clipped.pop_back();
    }
    for (std::size_t k = 0; clipped.size() >= 3 && k < clipped.size();) {
      const std::size_t n = clipped.size();
      const Eigen::Vector2d& a = clipped[(k + n - 1) % n];
      const Eigen::Vector2d& c = clipped[(k + 1) % n];
      const Eigen::Vector2d u = clipped[k] - a, v = c - clipped[k];
      if (std::abs(u.x() * v.y() - u.y() * v.x()) <= 1e-9 * u.norm() * v.norm()) {
        clipped.erase(clipped.begin() + static_cast<std::ptrdiff_t>(k));
      } else {
        ++k;
      }
    }
    if (clipped.size() < 3) continue;
    if (std::abs(signedPolygonArea(clipped)) < 0.5e-10) continue;
    try {
      ConvexRegion shrunk = ConvexRegion::fromPolygon(clipped, r.height, r.normal);
      shrunk.height = r.heightAt(shrunk.centroid);
      out.push_back(std::move(shrunk));
    } catch (const std::invalid_argument&) {
      // A sliver that rounding made non-convex: too thin to stand on, dropped.
    }
  }
  return TerrainModel(std::move(out));
}

TerrainModel levelTerrain(const TerrainModel& terrain, double max_tilt, double height_tolerance) {
  if (!std::isfinite(max_tilt) || max_tilt < 0.0) {
    detail::fail("levelTerrain", "max_tilt", max_tilt, "must be finite and >= 0");
  }
  if (!std::isfinite(height_tolerance) || height_tolerance < 0.0) {
    detail::fail("levelTerrain", "height_tolerance", height_tolerance, "must be finite and >= 0");
  }
  const double min_nz = std::cos(max_tilt);
  // The nearly level regions by height; groups of heights within the tolerance of their
  // lowest.
  std::vector<int> level;
  for (int i = 0; i < terrain.size(); ++i) {
    if (terrain.region(i).normal.z() >= min_nz) level.push_back(i);
  }
  std::sort(level.begin(), level.end(),
            [&](int a, int b) { return terrain.region(a).height < terrain.region(b).height; });
  std::vector<double> height(static_cast<std::size_t>(terrain.size()), 0.0);
  for (std::size_t first = 0; first < level.size();) {
    const double lowest = terrain.region(level[first]).height;
    std::size_t last = first;
    double area_sum = 0.0, weighted = 0.0;
    while (last < level.size() && terrain.region(level[last]).height <= lowest + height_tolerance) {
      const ConvexRegion& r = terrain.region(level[last]);
      const double area = std::abs(r.area());
      area_sum += area;
      weighted += area * r.height;
      ++last;
    }
    const double h = area_sum > 0.0 ? weighted / area_sum : lowest;
    for (std::size_t k = first; k < last; ++k) height[static_cast<std::size_t>(level[k])] = h;
    first = last;
  }
  std::vector<ConvexRegion> out;
  out.reserve(static_cast<std::size_t>(terrain.size()));
  for (int i = 0; i < terrain.size(); ++i) {
    const ConvexRegion& r = terrain.region(i);
    if (r.normal.z() >= min_nz) {
      ConvexRegion flat = r;
      flat.height = height[static_cast<std::size_t>(i)];
      flat.normal = Eigen::Vector3d::UnitZ();
      out.push_back(std::move(flat));
    } else {
      out.push_back(r);
    }
  }
  return TerrainModel(std::move(out));
}

}  // namespace rollstep::planning
