// Smoothed prism distance and support polygon (barriers.hpp).
#include "rollstep/control/barriers.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace rollstep::control {

namespace {

/// The most faces a prism has: the top and one side per edge (regions of terrainFromBoxes
/// have 4; perception's may have more).
constexpr int kMaxFaces = 65;

/// Face f of the prism: outward unit normal n and signed distance s = n . p - o.
template <typename F>
void forEachFace(const planning::ConvexRegion& region, const Eigen::Vector3d& p, F&& f) {
  // Top: the surface plane through (centroid, height) with its unit normal.
  const Eigen::Vector3d on_top(region.centroid.x(), region.centroid.y(), region.height);
  f(region.normal, region.normal.dot(p - on_top));
  for (Eigen::Index e = 0; e < region.A.rows(); ++e) {
    const Eigen::Vector3d n(-region.A(e, 0), -region.A(e, 1), 0.0);
    f(n, -(region.A(e, 0) * p.x() + region.A(e, 1) * p.y() + region.b[e]));
  }
}

}  // namespace

double prismFaceDistance(const planning::ConvexRegion& region, const Eigen::Vector3d& p) {
  double m = -std::numeric_limits<double>::infinity();
  forEachFace(region, p, [&](const Eigen::Vector3d&, double s) { m = std::max(m, s); });
  return m;
}

SmoothDistance smoothPrismDistance(const planning::ConvexRegion& region, const Eigen::Vector3d& p,
                                   double k) {
  const double m = prismFaceDistance(region, p);
  // Stable log-sum-exp: weights w_f = exp(k (s_f - m)) / sum.
  double sum = 0.0;
  Eigen::Vector3d g = Eigen::Vector3d::Zero();
  Eigen::Matrix3d nn = Eigen::Matrix3d::Zero();
  int faces = 0;
  forEachFace(region, p, [&](const Eigen::Vector3d& n, double s) {
    if (faces++ >= kMaxFaces) return;
    const double w = std::exp(k * (s - m));
    sum += w;
    g += w * n;
    nn += w * (n * n.transpose());
  });
  SmoothDistance d;
  d.value = m + std::log(sum) / k;
  d.gradient = g / sum;
  // Hessian of (1/k) log sum exp(k s_f): k (sum w_f n_f n_f^T - g g^T) with normalised w.
  d.hessian = k * (nn / sum - d.gradient * d.gradient.transpose());
  return d;
}

double prismDistance(const planning::ConvexRegion& region, const Eigen::Vector3d& p) {
  const double horizontal = region.distance(p.head<2>());
  const double above = std::max(0.0, p.z() - region.heightAt(p.head<2>()));
  return std::hypot(horizontal, above);
}

int convexHull(const Eigen::Vector2d* points, int n, int* hull) {
  // Andrew's monotone chain over indices sorted by (x, y); n is small (a robot's feet).
  constexpr int kMaxPoints = 64;
  if (n < 3 || n > kMaxPoints) return 0;
  int order[kMaxPoints];
  for (int i = 0; i < n; ++i) order[i] = i;
  std::sort(order, order + n, [&](int a, int b) {
    return points[a].x() < points[b].x() ||
           (points[a].x() == points[b].x() && points[a].y() < points[b].y());
  });
  const auto cross = [&](int o, int a, int b) {
    return (points[a].x() - points[o].x()) * (points[b].y() - points[o].y()) -
           (points[a].y() - points[o].y()) * (points[b].x() - points[o].x());
  };
  // Turns below this area [m^2] count as collinear (feet 1e-6 m off a line).
  constexpr double kTolerance = 1e-12;
  int count = 0;
  for (int s = 0; s < n; ++s) {  // lower chain
    while (count >= 2 && cross(hull[count - 2], hull[count - 1], order[s]) <= kTolerance) --count;
    hull[count++] = order[s];
  }
  const int lower = count + 1;
  for (int s = n - 2; s >= 0; --s) {  // upper chain
    while (count >= lower && cross(hull[count - 2], hull[count - 1], order[s]) <= kTolerance) {
      --count;
    }
    hull[count++] = order[s];
  }
  --count;  // the chain ends where it started
  return count >= 3 ? count : 0;
}

}  // namespace rollstep::control
