#pragma once
// The surface a foot stands on, extended as a plane: what the step rules (speed limit near
// steps, trot edge timing, sideways hold) measure heights against, so that a ramp, along
// which a wheel rolls, is no step, while a riser on it or its crest still is.
#include <Eigen/Core>

#include "rollstep/planning/terrain.hpp"

namespace rollstep::planning::detail {

class SurfacePlane {
 public:
  /// The plane of the surface at p (terrain.regionAt(p)).
  SurfacePlane(const TerrainModel& terrain, const Eigen::Vector2d& p)
      : terrain_(&terrain), height_(terrain.heightAt(p)), region_(terrain.regionAt(p)) {
    if (region_ >= 0) {
      const Eigen::Vector3d& n = terrain.region(region_).normal;
      sloped_ = n.x() != 0.0 || n.y() != 0.0;
    }
  }
  /// The surface's height at p.
  double height() const { return height_; }
  /// The plane's height at q: the surface's height at p on level ground (exactly).
  double at(const Eigen::Vector2d& q) const {
    return sloped_ ? terrain_->region(region_).heightAt(q) : height_;
  }
  /// The plane's rise from p to q: 0 on level ground.
  double riseTo(const Eigen::Vector2d& q) const { return sloped_ ? at(q) - height_ : 0.0; }

 private:
  const TerrainModel* terrain_;
  double height_;
  int region_;
  bool sloped_ = false;
};

}  // namespace rollstep::planning::detail
