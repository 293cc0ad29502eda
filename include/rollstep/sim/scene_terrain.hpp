#pragma once
// The planning layer's terrain model from a scene's ground truth: the scene's blocks
// (terrainBoxes) on the floor plane, as convex foothold regions. Perception will build
// the same planning::TerrainModel from LiDAR points later.
#include "rollstep/planning/terrain.hpp"
#include "rollstep/sim/scene.hpp"

namespace rollstep::sim {

/// Half extent [m] of the floor plane of every scene (terrainMjcf's floor geom).
inline constexpr double kSceneFloorHalfExtent = 50.0;

/// Convex regions of `config`'s terrain: the floor (height 0) cut around the blocks and
/// each block top, each region shrunk by `margin` [m] (see planning::terrainFromBoxes).
/// Validates the config first (std::invalid_argument naming the bad parameter).
planning::TerrainModel terrainFromScene(const SceneConfig& config, double margin = 0.0);

}  // namespace rollstep::sim
