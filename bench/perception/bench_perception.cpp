// One LiDAR scan through the perception pipeline on the 4 m x 4 m, 2 cm map (200 x 200
// cells): map update (with visibility clean-up), plane segmentation, convex terrain cover.
// The scan: the synthetic stairs (three 30 cm treads and a landing, blocks terrain's
// noise and dropouts) sampled every 2 cm, about 36 000 points, as seen from 0.6 m up.
#include <benchmark/benchmark.h>

#include "perception/synthetic_terrain.hpp"
#include "rollstep/perception/terrain_perception.hpp"

namespace {

using namespace rollstep::perception;

const Eigen::Vector3d kSensor(0.0, 0.0, 0.6);

Eigen::Isometry3d pose() {
  Eigen::Isometry3d p = Eigen::Isometry3d::Identity();
  p.translation() = kSensor;
  return p;
}

void BM_MapUpdate(benchmark::State& state) {
  const std::vector<Eigen::Vector3d> scan =
      test::stairsTerrain().cloud(0.02, 0.005, 0.1, kSensor, 1);
  ElevationMap map;
  for (auto _ : state) map.update(scan, pose());
  state.counters["points"] = static_cast<double>(scan.size());
}
BENCHMARK(BM_MapUpdate)->Unit(benchmark::kMillisecond);

void BM_Segmentation(benchmark::State& state) {
  ElevationMap map;
  map.update(test::stairsTerrain().cloud(0.02, 0.005, 0.1, kSensor, 1), pose());
  PlaneSegmenter segmenter;
  Segmentation seg;
  for (auto _ : state) segmenter.segment(map, seg);
  state.counters["regions"] = static_cast<double>(seg.regions.size());
}
BENCHMARK(BM_Segmentation)->Unit(benchmark::kMillisecond);

void BM_TerrainCover(benchmark::State& state) {
  ElevationMap map;
  map.update(test::stairsTerrain().cloud(0.02, 0.005, 0.1, kSensor, 1), pose());
  PlaneSegmenter segmenter;
  Segmentation seg;
  segmenter.segment(map, seg);
  ConvexRegionGrower grower;
  int pieces = 0;
  for (auto _ : state) pieces = grower.terrain(seg).size();
  state.counters["pieces"] = pieces;
}
BENCHMARK(BM_TerrainCover)->Unit(benchmark::kMillisecond);

void BM_FootholdRegion(benchmark::State& state) {
  ElevationMap map;
  map.update(test::stairsTerrain().cloud(0.02, 0.005, 0.1, kSensor, 1), pose());
  PlaneSegmenter segmenter;
  Segmentation seg;
  segmenter.segment(map, seg);
  ConvexRegionGrower grower;
  for (auto _ : state) benchmark::DoNotOptimize(grower.forFoothold(seg, {0.76, 0.1, 0.3}));
}
BENCHMARK(BM_FootholdRegion)->Unit(benchmark::kMillisecond);

// The whole pipeline per scan: the figure.
void BM_PerceptionScan(benchmark::State& state) {
  const std::vector<Eigen::Vector3d> scan =
      test::stairsTerrain().cloud(0.02, 0.005, 0.1, kSensor, 1);
  TerrainPerception perception;
  double t = 0;
  for (auto _ : state) {
    t += 0.1;
    benchmark::DoNotOptimize(perception.update(scan, pose(), t));
  }
  state.counters["pieces"] = perception.terrain().size();
}
BENCHMARK(BM_PerceptionScan)->Unit(benchmark::kMillisecond);

}  // namespace
