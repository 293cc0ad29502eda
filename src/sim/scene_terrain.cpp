#include "rollstep/sim/scene_terrain.hpp"

#include <vector>

namespace rollstep::sim {

planning::TerrainModel terrainFromScene(const SceneConfig& config, double margin) {
  config.validate();
  std::vector<planning::TerrainBox> boxes;
  for (const TerrainBox& b : terrainBoxes(config)) {
    boxes.push_back({b.center.x() - b.half_size.x(), b.center.x() + b.half_size.x(),
                     b.center.y() - b.half_size.y(), b.center.y() + b.half_size.y(),
                     b.center.z() + b.half_size.z()});
  }
  const double e = kSceneFloorHalfExtent;
  return planning::terrainFromBoxes({-e, e, -e, e, 0.0}, 0.0, boxes, margin);
}

}  // namespace rollstep::sim
