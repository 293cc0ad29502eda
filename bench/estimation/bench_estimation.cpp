// One step of the state estimator (estimation/invariant_ekf.hpp) on Tachyon 3 with its six
// wheels in stance (four drive wheels: 3 rows each, two omni wheels: 1 row each, and a
// ground-height row for each: 20 rows), as in the closed loop:
// IMU propagation, leg kinematics of the six contacts, chi-square gates and the batch
// update. Generated samples of a robot rolling at 0.5 m/s with a little noise. Every tick
// is timed on its own (manual time); the counters give the distribution: median_us,
// p99_us, max_us.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <random>
#include <string>
#include <vector>

#include "rollstep/estimation/invariant_ekf.hpp"
#include "rollstep/model/model.hpp"

namespace {

using namespace rollstep;

void BM_EstimatorTick(benchmark::State& state) {
  const model::Model m =
      model::buildModelFromUrdfFile(std::string(ROLLSTEP_ROBOTS_DIR) + "/tachyon3/tachyon3.urdf");
  std::vector<estimation::ContactSpec> contacts;
  for (const char* leg : {"LF", "MF", "RF", "LR", "MR", "RR"}) {
    const bool omni = leg[0] == 'M';
    contacts.push_back(
        {std::string(leg) + "_wheel",
         omni ? estimation::ContactKind::OmniWheel : estimation::ContactKind::DriveWheel, 0.075});
  }
  estimation::InvariantEkf filter(m, contacts, {});
  filter.reset(0.0, Eigen::Quaterniond::Identity(), Eigen::Vector3d(0, 0, 0.4),
               Eigen::Vector3d(0.5, 0, 0));
  estimation::EstimatorInput in = filter.makeInput();
  std::mt19937_64 rng(1);
  std::normal_distribution<double> n(0.0, 1.0);
  in.joint_position.setConstant(0.1);
  std::vector<double> times;
  times.reserve(static_cast<size_t>(state.max_iterations));
  long k = 0;
  for (auto _ : state) {
    in.time = 1e-3 * static_cast<double>(++k);
    in.gyro = Eigen::Vector3d(n(rng), n(rng), n(rng)) * 0.01;
    in.accel = Eigen::Vector3d(0, 0, 9.81) + Eigen::Vector3d(n(rng), n(rng), n(rng)) * 0.06;
    for (int j = 0; j < in.joint_velocity.size(); ++j) in.joint_velocity[j] = 0.01 * n(rng);
    for (size_t i = 0; i < contacts.size(); ++i) {
      in.contact[i] = true;
      in.ground_height[i] = -0.05 + 0.001 * n(rng);
      in.wheel_velocity[i] = 0.5 / 0.075 + 0.02 * n(rng);
    }
    const auto t0 = std::chrono::steady_clock::now();
    filter.tick(in);
    const double dt = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    benchmark::DoNotOptimize(filter.position().data());
    state.SetIterationTime(dt);
    times.push_back(dt * 1e6);
  }
  std::sort(times.begin(), times.end());
  if (!times.empty()) {
    state.counters["median_us"] = times[times.size() / 2];
    state.counters["p99_us"] = times[std::min(times.size() - 1, times.size() * 99 / 100)];
    state.counters["max_us"] = times.back();
  }
  state.counters["contacts_used_per_tick"] = static_cast<double>(filter.counters().contacts_used) /
                                             static_cast<double>(std::max<long>(1, k));
}
BENCHMARK(BM_EstimatorTick)->UseManualTime()->Iterations(20000)->Unit(benchmark::kMicrosecond);

}  // namespace
