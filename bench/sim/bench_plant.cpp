// Real-time factor of the plant: simulated seconds per wall-clock second, one thread.
//
//   build/bench/sim/bench_plant
//
// The counter `rtf` is the real-time factor (Google Benchmark rate counter of simulated
// seconds). Each iteration simulates 1 s (1000 control periods of 1 ms) with the stand
// or the drive controller, including the sensor/ground-truth update of every period.
#include <benchmark/benchmark.h>

#include "rollstep/sim/plant.hpp"
#include "rollstep/sim/scene.hpp"
#include "rollstep/sim/simple_controllers.hpp"

namespace {

using rollstep::sim::Controller;
using rollstep::sim::DriveController;
using rollstep::sim::loadScene;
using rollstep::sim::Plant;
using rollstep::sim::PlantCommand;
using rollstep::sim::SceneConfig;
using rollstep::sim::StandController;

void runOneSecond(benchmark::State& state, Plant& plant, Controller& controller) {
  PlantCommand command = plant.nominalCommand();  // sized: no allocation in the loop
  const int steps = static_cast<int>(1.0 / plant.controlPeriod());
  for (auto _ : state) {
    for (int k = 0; k < steps; ++k) {
      controller.compute(plant.time(), plant.sensors(), command);
      plant.setCommand(command);
      plant.step();
    }
    benchmark::DoNotOptimize(plant.groundTruth().base_position.data());
    if (plant.time() > 20.0) {
      state.PauseTiming();
      plant.reset();
      state.ResumeTiming();
    }
  }
  state.counters["rtf"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
  state.counters["warnings"] = plant.warningCount();
}

void BM_PlantStandFlat(benchmark::State& state) {
  Plant plant(SceneConfig{});
  StandController stand(plant.nominalCommand());
  runOneSecond(state, plant, stand);
}

void BM_PlantDriveFlat(benchmark::State& state) {
  Plant plant(SceneConfig{});
  DriveController drive(plant, DriveController::Params{});
  runOneSecond(state, plant, drive);
}

void BM_PlantDriveStep20(benchmark::State& state) {
  const SceneConfig scene = loadScene("step20");
  Plant plant(scene);
  DriveController drive(plant, DriveController::Params{});
  runOneSecond(state, plant, drive);
}

void BM_PlantRaycast(benchmark::State& state) {
  const SceneConfig scene = loadScene("stairs2");
  Plant plant(scene);
  double sum = 0.0;
  for (auto _ : state) {
    sum += plant.raycast(Eigen::Vector3d(1.5, 0.0, 1.0), Eigen::Vector3d(0.6, 0.0, -0.8), 10.0);
  }
  benchmark::DoNotOptimize(sum);
}

}  // namespace

BENCHMARK(BM_PlantStandFlat)->Unit(benchmark::kMillisecond)->MinTime(2.0);
BENCHMARK(BM_PlantDriveFlat)->Unit(benchmark::kMillisecond)->MinTime(2.0);
BENCHMARK(BM_PlantDriveStep20)->Unit(benchmark::kMillisecond)->MinTime(2.0);
BENCHMARK(BM_PlantRaycast);

// main: bench/common/bench_main.cpp
