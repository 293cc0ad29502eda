#pragma once
// The planning layer's terrain model from a scene's ground truth: the floor and the top
// faces of the scene's boxes and ramps, as convex foothold regions. Perception builds the
// same planning::TerrainModel from LiDAR points.
#include "rollstep/planning/terrain.hpp"
#include "rollstep/sim/scene.hpp"

namespace rollstep::sim {

/// Half extent [m] of the floor plane of every scene (terrainMjcf's floor geom).
inline constexpr double kSceneFloorHalfExtent = 50.0;

/// Convex regions of `config`'s terrain with a margin [m] around its steps: what is seen
/// from above, the floor (height 0) where nothing covers it and, elsewhere, the highest top
/// face (planning::terrainFromSurfaces, the same rule for every box and ramp). The strip of
/// a ramp's high end face seen from above is not a foothold region. Resolves the config
/// first (std::invalid_argument naming the bad number).
planning::TerrainModel terrainFromScene(const SceneConfig& config, double margin = 0.0);
planning::TerrainModel terrainFromScene(const SceneGeometry& geometry, double margin = 0.0);

}  // namespace rollstep::sim
