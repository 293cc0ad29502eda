#include "rollstep/perception/polygon.hpp"

#include <boost/geometry.hpp>
#include <boost/geometry/geometries/linestring.hpp>
#include <boost/geometry/geometries/multi_polygon.hpp>
#include <boost/geometry/geometries/point_xy.hpp>
#include <boost/geometry/geometries/polygon.hpp>
#include <limits>

namespace rollstep::perception {

namespace bg = boost::geometry;
using BPoint = bg::model::d2::point_xy<double>;
using BPolygon = bg::model::polygon<BPoint>;  // clockwise outer, closed
using BMulti = bg::model::multi_polygon<BPolygon>;

namespace {

void fillRing(const Ring& in, BPolygon::ring_type& out) {
  out.clear();
  for (const Eigen::Vector2d& v : in) out.emplace_back(v.x(), v.y());
}

BPolygon toBoost(const PolygonWithHoles& p) {
  BPolygon b;
  fillRing(p.outer, b.outer());
  for (const Ring& h : p.holes) {
    b.inners().emplace_back();
    fillRing(h, b.inners().back());
  }
  bg::correct(b);  // orientation and closure
  return b;
}

BMulti toBoost(const std::vector<PolygonWithHoles>& ps) {
  BMulti out;
  for (const PolygonWithHoles& p : ps) {
    const BPolygon b = toBoost(p);
    if (bg::area(b) <= 0) continue;
    BMulti merged;
    bg::union_(out, b, merged);
    out.swap(merged);
  }
  return out;
}

Ring fromRing(const BPolygon::ring_type& r) {
  Ring out;
  for (std::size_t i = 0; i + 1 < r.size(); ++i) out.emplace_back(r[i].x(), r[i].y());  // open
  return out;
}

}  // namespace

double area(const PolygonWithHoles& p) { return bg::area(toBoost(p)); }

double intersectionArea(const std::vector<PolygonWithHoles>& a,
                        const std::vector<PolygonWithHoles>& b) {
  BMulti out;
  bg::intersection(toBoost(a), toBoost(b), out);
  return bg::area(out);
}

double unionArea(const std::vector<PolygonWithHoles>& a, const std::vector<PolygonWithHoles>& b) {
  BMulti out;
  bg::union_(toBoost(a), toBoost(b), out);
  return bg::area(out);
}

double iou(const std::vector<PolygonWithHoles>& a, const std::vector<PolygonWithHoles>& b) {
  const double u = unionArea(a, b);
  return u > 0 ? intersectionArea(a, b) / u : 0.0;
}

double boundaryDistance(const std::vector<PolygonWithHoles>& polygons, const Eigen::Vector2d& p) {
  const BPoint q(p.x(), p.y());
  double best = std::numeric_limits<double>::infinity();
  for (const PolygonWithHoles& poly : polygons) {
    const BPolygon b = toBoost(poly);
    // As lines: the distance of a point to an areal ring is 0 inside it.
    const auto line = [](const BPolygon::ring_type& r) {
      return bg::model::linestring<BPoint>(r.begin(), r.end());
    };
    best = std::min(best, static_cast<double>(bg::distance(q, line(b.outer()))));
    for (const auto& h : b.inners())
      best = std::min(best, static_cast<double>(bg::distance(q, line(h))));
  }
  return best;
}

std::vector<PolygonWithHoles> offset(const std::vector<PolygonWithHoles>& polygons,
                                     double distance) {
  const BMulti in = toBoost(polygons);
  BMulti out;
  bg::strategy::buffer::distance_symmetric<double> dist(distance);
  bg::strategy::buffer::side_straight side;
  bg::strategy::buffer::join_miter join(2.0);
  bg::strategy::buffer::end_flat end;
  bg::strategy::buffer::point_square point;
  bg::buffer(in, out, dist, side, join, end, point);
  std::vector<PolygonWithHoles> result;
  for (const BPolygon& b : out) {
    if (bg::area(b) <= 0) continue;
    PolygonWithHoles p;
    p.outer = fromRing(b.outer());
    for (const auto& h : b.inners()) p.holes.push_back(fromRing(h));
    result.push_back(std::move(p));
  }
  return result;
}

PolygonWithHoles rectangle(double x_min, double x_max, double y_min, double y_max) {
  PolygonWithHoles p;
  p.outer = {{x_min, y_min}, {x_max, y_min}, {x_max, y_max}, {x_min, y_max}};
  return p;
}

}  // namespace rollstep::perception
