// The real-time tick of the control pipeline (control/pipeline.hpp) on Tachyon 3, trotting
// forward at 0.15 m/s on flat ground with N = 100:
//   BM_RealTimeTick   contact planner + solution hand-over and time-lag refinement (when a
//                     new one arrives) + reference lookup + acceleration commands + CBF-QP
//                     + integrator + wheel commands. The MPC runs in its asynchronous mode on
//                     its own thread (the deployment layout: the tick on one core, the MPC
//                     on another), solving back to back on the states the tick posts.
// The "measured" state is the internal integrator's own state (perfect tracking), so the
// run follows the plan. Every tick is timed on its own (manual time); the counters give
// the distribution:
//   median_us, p99_us, max_us   wall time per tick
//   cpu_median_us, cpu_p99_us   thread CPU time per tick (the wall tail on a shared machine is
//                               other processes)
//   solutions                   MPC solutions received per second of ticks
//
//   BM_MpcUpdateFastTrot/0|1    the MPC update at the fastest gait the speed rule gives: a trot
//                     commanded at 0.5 m/s (the rule's shortest period) towards a 0.2 m step
//                     (slowed to the step speed limit there), with the library's default
//                     control settings; /0 deterministic timing (the update runs inside the
//                     tick at its solve time), /1 asynchronous (the MPC on its own thread).
//                     Counters from each adopted solution's solve time: update_median_ms,
//                     update_p99_ms, update_max_ms against period_ms (the MPC period), and
//                     p99_share = update_p99_ms / period_ms (< 1: real time holds).
#include <benchmark/benchmark.h>
#include <time.h>

#include <algorithm>
#include <chrono>
#include <vector>

#include "rollstep/control/pipeline.hpp"
#include "rollstep/control/speed_rule.hpp"
#include "rollstep/planning/terrain.hpp"

namespace {

using namespace rollstep;

double threadCpuSeconds() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const size_t i = std::min(v.size() - 1, static_cast<size_t>(p * static_cast<double>(v.size())));
  return v[i];
}

void BM_RealTimeTick(benchmark::State& state) {
  const centroidal::RobotOcpDescription robot = centroidal::loadRobotOcpDescription(
      std::string(ROLLSTEP_ROBOTS_DIR) + "/tachyon3/centroidal.yaml");
  control::ControlSettings settings;
  settings.mpc.timing = control::MpcTiming::Asynchronous;
  planning::TerrainBox floor{-50.0, 50.0, -50.0, 50.0, 0.0};
  const planning::TerrainModel terrain =
      planning::terrainFromBoxes(floor, 0.0, {}, robot.contact_offset + 0.01);
  control::ControlPipeline pipeline(robot, settings, terrain, planning::GaitKind::Trot);
  control::RobotState s = pipeline.makeState();
  s.base_position = Eigen::Vector3d(0.0, 0.0, pipeline.contactPlanner().stance().height);
  s.joint_position = pipeline.loadedRobot().description.nominal_joint_positions;
  pipeline.initialize(s, planning::BaseVelocityCommand{0.15, 0.0, 0.0});
  control::JointCommand command = pipeline.makeCommand();
  const double dt = settings.control_period;
  std::vector<double> us, cpu_us;
  us.reserve(1 << 20);
  cpu_us.reserve(1 << 20);
  long ticks = 0;
  for (auto _ : state) {
    control::fromModelState(s.time + dt, pipeline.integrator().q(), pipeline.integrator().v(), s);
    const double c0 = threadCpuSeconds();
    const auto w0 = std::chrono::steady_clock::now();
    pipeline.tick(s, command);
    const auto w1 = std::chrono::steady_clock::now();
    const double c1 = threadCpuSeconds();
    const double wall = std::chrono::duration<double>(w1 - w0).count();
    state.SetIterationTime(wall);
    if (us.size() < us.capacity()) {
      us.push_back(1e6 * wall);
      cpu_us.push_back(1e6 * (c1 - c0));
    }
    ++ticks;
    // Hold the 1 kHz rhythm loosely so the MPC thread solves at its natural rate relative
    // to the ticks (each tick is ~1 ms of robot time).
    const auto until = w0 + std::chrono::microseconds(1000);
    while (std::chrono::steady_clock::now() < until) {
    }
  }
  pipeline.stop();
  state.counters["median_us"] = percentile(us, 0.5);
  state.counters["p99_us"] = percentile(us, 0.99);
  state.counters["max_us"] = us.empty() ? 0.0 : *std::max_element(us.begin(), us.end());
  state.counters["cpu_median_us"] = percentile(cpu_us, 0.5);
  state.counters["cpu_p99_us"] = percentile(cpu_us, 0.99);
  state.counters["solutions_per_s"] =
      ticks > 0 ? static_cast<double>(pipeline.counters().solutions_received) / (ticks * dt) : 0.0;
  state.counters["qp_fallbacks"] = static_cast<double>(pipeline.counters().qp_fallbacks);
}
BENCHMARK(BM_RealTimeTick)->UseManualTime()->Iterations(5000)->Unit(benchmark::kMicrosecond);

void BM_MpcUpdateFastTrot(benchmark::State& state) {
  const centroidal::RobotOcpDescription robot = centroidal::loadRobotOcpDescription(
      std::string(ROLLSTEP_ROBOTS_DIR) + "/tachyon3/centroidal.yaml");
  control::ControlSettings settings;
  settings.mpc.timing =
      state.range(0) == 0 ? control::MpcTiming::Deterministic : control::MpcTiming::Asynchronous;
  const std::vector<planning::TimedBaseCommand> schedule{{0.0, {0.5, 0.0, 0.0}}};
  // The trot timed for the command, as rollstep sim times it.
  control::timeTrotForSchedule(settings.ocp, robot, planning::GaitKind::Trot, schedule);
  const planning::TerrainBox floor{-50.0, 50.0, -50.0, 50.0, 0.0};
  const planning::TerrainBox step{1.5, 2.5, -1.0, 1.0, 0.2};
  const planning::TerrainModel terrain =
      planning::terrainFromBoxes(floor, 0.0, {step}, robot.contact_offset + 0.01);
  control::ControlPipeline pipeline(robot, settings, terrain, planning::GaitKind::Trot);
  control::RobotState s = pipeline.makeState();
  s.base_position = Eigen::Vector3d(0.0, 0.0, pipeline.contactPlanner().stance().height);
  s.joint_position = pipeline.loadedRobot().description.nominal_joint_positions;
  pipeline.initializeSchedule(s, schedule);
  control::JointCommand command = pipeline.makeCommand();
  const double dt = settings.control_period;
  std::vector<double> update_ms;
  update_ms.reserve(1 << 16);
  std::vector<int> iterations;
  iterations.reserve(1 << 16);
  std::uint64_t last_sequence = pipeline.lastSolution().sequence;
  for (auto _ : state) {
    control::fromModelState(s.time + dt, pipeline.integrator().q(), pipeline.integrator().v(), s);
    const auto w0 = std::chrono::steady_clock::now();
    pipeline.tick(s, command);
    state.SetIterationTime(
        std::chrono::duration<double>(std::chrono::steady_clock::now() - w0).count());
    const control::MpcSolution& solution = pipeline.lastSolution();
    if (solution.sequence != last_sequence) {
      last_sequence = solution.sequence;
      if (update_ms.size() < update_ms.capacity()) {
        update_ms.push_back(solution.solve_time_ms);
        iterations.push_back(solution.iterations);
      }
    }
    if (settings.mpc.timing == control::MpcTiming::Asynchronous) {
      // The loop's 1 kHz rhythm, so the MPC thread sees robot time pass at its real rate.
      const auto until = w0 + std::chrono::microseconds(1000);
      while (std::chrono::steady_clock::now() < until) {
      }
    }
  }
  pipeline.stop();
  const double period_ms = 1e3 * settings.mpc.period;
  state.counters["updates"] = static_cast<double>(update_ms.size());
  state.counters["update_median_ms"] = percentile(update_ms, 0.5);
  state.counters["update_p99_ms"] = percentile(update_ms, 0.99);
  state.counters["update_max_ms"] =
      update_ms.empty() ? 0.0 : *std::max_element(update_ms.begin(), update_ms.end());
  state.counters["period_ms"] = period_ms;
  state.counters["p99_share"] = percentile(update_ms, 0.99) / period_ms;
  state.counters["iterations_max"] =
      iterations.empty() ? 0.0 : *std::max_element(iterations.begin(), iterations.end());
  state.counters["gait_period_s"] = settings.ocp.gait_period;
  state.counters["qp_fallbacks"] = static_cast<double>(pipeline.counters().qp_fallbacks);
}
// 6 s of robot time: the approach at full speed, the slowdown and the climb onto the step.
BENCHMARK(BM_MpcUpdateFastTrot)
    ->Arg(0)
    ->Arg(1)
    ->UseManualTime()
    ->Iterations(6000)
    ->Unit(benchmark::kMicrosecond);

}  // namespace
