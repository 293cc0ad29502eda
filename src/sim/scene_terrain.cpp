#include "rollstep/sim/scene_terrain.hpp"

#include <array>
#include <vector>

namespace rollstep::sim {

planning::TerrainModel terrainFromScene(const SceneGeometry& g, double margin) {
  std::vector<planning::TerrainSurface> tops;
  for (const SceneSolid& s : g.solids) {
    const std::array<Eigen::Vector2d, 4> f = s.topFootprint();
    tops.push_back({{f.begin(), f.end()}, s.topCenter(), s.topNormal()});
  }
  const double e = kSceneFloorHalfExtent;
  return planning::terrainFromSurfaces({-e, e, -e, e, 0.0}, 0.0, tops, margin);
}

planning::TerrainModel terrainFromScene(const SceneConfig& config, double margin) {
  return terrainFromScene(resolveScene(config), margin);
}

}  // namespace rollstep::sim
