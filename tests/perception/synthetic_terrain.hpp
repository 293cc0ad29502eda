#pragma once
// Synthetic terrains with known planes, and point clouds sampled from them (noise,
// dropouts, patches without data), for the perception tests and benchmark.
#include <Eigen/Geometry>
#include <cmath>
#include <random>
#include <vector>

#include "rollstep/perception/polygon.hpp"

namespace rollstep::perception::test {

/// A ground-truth planar surface: its footprint and z = height + gradient . (p - anchor).
struct TruthPlane {
  std::vector<PolygonWithHoles> footprint;
  double height = 0.0;
  Eigen::Vector2d anchor = Eigen::Vector2d::Zero();
  Eigen::Vector2d gradient = Eigen::Vector2d::Zero();
  /// Footprint sides that are step edges (segments), where the surface's boundary must be.
  std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>> edges;
  double at(const Eigen::Vector2d& p) const { return height + gradient.dot(p - anchor); }
};

struct Box {
  double x0, x1, y0, y1, top;
};

/// A terrain of boxes on a floor (z = 0) or a tilted plane (slope), over a square of side
/// `extent` centred on the origin; the highest box wins.
struct SyntheticTerrain {
  double extent = 4.0;
  Eigen::Vector2d floor_gradient = Eigen::Vector2d::Zero();
  std::vector<Box> boxes;
  std::vector<PolygonWithHoles> no_data;  ///< patches without points

  double height(const Eigen::Vector2d& p) const {
    double z = floor_gradient.dot(p);
    bool on_box = false;
    double top = 0.0;
    for (const Box& b : boxes) {
      if (p.x() >= b.x0 && p.x() < b.x1 && p.y() >= b.y0 && p.y() < b.y1) {
        top = on_box ? std::max(top, b.top) : b.top;
        on_box = true;
      }
    }
    return on_box ? top : z;
  }

  /// Boxes must not overlap (stairs are side by side): each top is a plane, the floor is
  /// the square minus the boxes.
  std::vector<TruthPlane> planes() const {
    const double e = 0.5 * extent;
    std::vector<TruthPlane> out;
    TruthPlane floor;
    PolygonWithHoles sq = rectangle(-e, e, -e, e);
    for (const Box& b : boxes) {
      sq.holes.push_back(rectangle(b.x0, b.x1, b.y0, b.y1).outer);
    }
    floor.footprint = {sq};
    floor.gradient = floor_gradient;
    out.push_back(floor);
    for (const Box& b : boxes) {
      TruthPlane t;
      t.footprint = {rectangle(b.x0, b.x1, b.y0, b.y1)};
      t.height = b.top;
      t.anchor = {0.5 * (b.x0 + b.x1), 0.5 * (b.y0 + b.y1)};
      out.push_back(t);
    }
    // Step edges: box sides not shared with a box of the same height.
    for (std::size_t k = 0; k < boxes.size(); ++k) {
      const Box& b = boxes[k];
      const Eigen::Vector2d c[4] = {{b.x0, b.y0}, {b.x1, b.y0}, {b.x1, b.y1}, {b.x0, b.y1}};
      for (int s = 0; s < 4; ++s) {
        const Eigen::Vector2d a = c[s], d = c[(s + 1) % 4];
        const Eigen::Vector2d mid = 0.5 * (a + d), out_n = (mid - out[k + 1].anchor).normalized();
        // Probe just outside the side: a different height makes it a step edge.
        const Eigen::Vector2d probe =
            mid + 0.01 * Eigen::Vector2d(std::round(out_n.x()), std::round(out_n.y()));
        if (std::abs(height(probe) - b.top) < 0.02) continue;
        out[k + 1].edges.emplace_back(a, d);
        if (std::abs(height(probe) - floor_gradient.dot(probe)) < 1e-9)
          out[0].edges.emplace_back(a, d);
      }
    }
    return out;
  }

  /// Points on a jittered grid of `spacing` [m] over the square, with Gaussian height
  /// noise, a share `dropout` of them missing and none inside no_data; in the frame of a
  /// sensor at `sensor` (world), i.e. p - sensor.
  std::vector<Eigen::Vector3d> cloud(double spacing, double noise, double dropout,
                                     const Eigen::Vector3d& sensor, unsigned seed) const {
    std::mt19937 rng(seed);
    std::normal_distribution<double> gauss(0.0, noise);
    std::uniform_real_distribution<double> uni(0.0, 1.0);
    std::vector<Eigen::Vector3d> pts;
    const double e = 0.5 * extent;
    for (double y = -e + 0.5 * spacing; y < e; y += spacing) {
      for (double x = -e + 0.5 * spacing; x < e; x += spacing) {
        const Eigen::Vector2d p(x + (uni(rng) - 0.5) * spacing, y + (uni(rng) - 0.5) * spacing);
        const double drop = uni(rng), dz = gauss(rng);
        if (drop < dropout) continue;
        bool hidden = false;
        for (const PolygonWithHoles& h : no_data) {
          const Eigen::Vector2d lo = h.outer[0], hi = h.outer[2];
          hidden =
              hidden || (p.x() >= lo.x() && p.x() <= hi.x() && p.y() >= lo.y() && p.y() <= hi.y());
        }
        if (hidden) continue;
        pts.push_back(Eigen::Vector3d(p.x(), p.y(), height(p) + dz) - sensor);
      }
    }
    return pts;
  }
};

inline SyntheticTerrain blocksTerrain() {
  SyntheticTerrain t;
  t.boxes = {{0.313, 1.127, -0.61, 0.547, 0.20}, {-1.21, -0.453, 0.297, 1.103, 0.12}};
  t.no_data = {rectangle(-1.0, -0.9, -1.0, -0.9)};
  return t;
}

inline SyntheticTerrain stairsTerrain() {
  SyntheticTerrain t;
  t.boxes = {{0.307, 0.613, -0.81, 0.79, 0.15},
             {0.613, 0.919, -0.81, 0.79, 0.30},
             {0.919, 1.6, -0.81, 0.79, 0.45}};
  t.no_data = {rectangle(1.2, 1.3, 0.1, 0.2)};
  return t;
}

}  // namespace rollstep::perception::test
