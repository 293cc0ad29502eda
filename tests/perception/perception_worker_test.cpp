// Perception on its own thread (PerceptionWorker, asynchronous runs): the same scans give
// the same terrains as the synchronous pipeline, posting never allocates or waits and the
// newest scan always wins, failures reach the owner. Run in the ThreadSanitizer tree too
// (label `threads`).
#include "rollstep/perception/perception_worker.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <stdexcept>
#include <thread>
#include <vector>

#include "common/alloc_counter.hpp"
#include "perception/synthetic_terrain.hpp"

namespace rollstep::perception {
namespace {

Eigen::Isometry3d poseAt(const Eigen::Vector3d& p) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translation() = p;
  return pose;
}

PerceptionSettings settings() {
  PerceptionSettings s;
  s.map.visibility_cleanup = false;  // points from straight above (synthetic clouds)
  s.map.length = 2.4;                // the floor and three treads; fast under TSan too
  return s;
}

/// Scans of the synthetic stairs from a sensor moving along x (different noise per scan).
struct Scans {
  std::vector<std::vector<Eigen::Vector3d>> points;
  std::vector<Eigen::Isometry3d> poses;
  int max_size = 0;
};
Scans stairScans(int n) {
  const test::SyntheticTerrain stairs = test::stairsTerrain();
  Scans s;
  for (int k = 0; k < n; ++k) {
    const Eigen::Vector3d sensor(0.05 * k, 0.0, 3.0);
    s.points.push_back(stairs.cloud(0.03, 0.004, 0.05, sensor, 10u + static_cast<unsigned>(k)));
    s.poses.push_back(poseAt(sensor));
    s.max_size = std::max(s.max_size, static_cast<int>(s.points.back().size()));
  }
  return s;
}

bool sameTerrain(const planning::TerrainModel& a, const planning::TerrainModel& b) {
  if (a.size() != b.size()) return false;
  for (int i = 0; i < a.size(); ++i) {
    const planning::ConvexRegion& ra = a.region(i);
    const planning::ConvexRegion& rb = b.region(i);
    if (ra.vertices != rb.vertices || ra.A != rb.A || ra.b != rb.b || ra.normal != rb.normal ||
        ra.height != rb.height || ra.centroid != rb.centroid) {
      return false;
    }
  }
  return true;
}

void waitIdle(const PerceptionWorker& w) {
  while (!w.idle()) std::this_thread::sleep_for(std::chrono::microseconds(100));
}

// Each scan posted once the previous one is done: the worker's terrains equal the
// synchronous pipeline's bit for bit (same code, same order), each seen by the sink on the
// worker thread.
TEST(PerceptionWorker, ScansInLockstepGiveTheSynchronousTerrainsBitForBit) {
  const Scans scans = stairScans(4);
  TerrainPerception sync(settings());
  std::vector<planning::TerrainModel> expected;
  std::vector<PerceptionStatus> expected_status;
  for (std::size_t k = 0; k < scans.points.size(); ++k) {
    expected_status.push_back(sync.update(scans.points[k], scans.poses[k], 0.1 * k));
    expected.push_back(sync.terrain());
  }
  ASSERT_EQ(expected_status.back(), PerceptionStatus::Ok);
  ASSERT_GE(expected.back().size(), 4);  // floor and three treads at least

  TerrainPerception async(settings());
  std::vector<planning::TerrainModel> got;
  std::vector<PerceptionStatus> got_status;
  std::vector<double> times;
  const std::thread::id poster = std::this_thread::get_id();
  bool on_other_thread = true;
  PerceptionWorker worker(
      async, scans.max_size, [&](const TerrainPerception& p, PerceptionStatus status, double t) {
        on_other_thread = on_other_thread && std::this_thread::get_id() != poster;
        got.push_back(p.terrain());
        got_status.push_back(status);
        times.push_back(t);
      });
  for (std::size_t k = 0; k < scans.points.size(); ++k) {
    ASSERT_TRUE(worker.post(scans.points[k], scans.poses[k], 0.1 * k));
    waitIdle(worker);
  }
  worker.stop();
  const PerceptionWorkerCounters c = worker.counters();
  EXPECT_EQ(c.posted, 4u);
  EXPECT_EQ(c.processed, 4u);
  EXPECT_EQ(c.superseded, 0u);
  EXPECT_GT(c.total_update_ms, 0.0);
  EXPECT_TRUE(on_other_thread);
  ASSERT_EQ(got.size(), expected.size());
  for (std::size_t k = 0; k < got.size(); ++k) {
    EXPECT_EQ(got_status[k], expected_status[k]) << k;
    EXPECT_TRUE(sameTerrain(got[k], expected[k])) << "scan " << k;
    EXPECT_EQ(times[k], 0.1 * k);
  }
  EXPECT_FALSE(worker.post(scans.points[0], scans.poses[0], 1.0)) << "posted after stop";
}

// Scans posted back to back, faster than the worker fuses them (the real-time side never
// waits): the posting thread allocates nothing, every scan is either processed or
// superseded by a newer one, and the last one posted is always processed (the map ends on
// the newest scan).
TEST(PerceptionWorker, PostingNeverAllocatesOrWaitsAndTheNewestScanWins) {
  const Scans scans = stairScans(3);
  TerrainPerception perception(settings());
  std::vector<double> times;
  times.reserve(64);
  PerceptionWorker worker(
      perception, scans.max_size,
      [&](const TerrainPerception&, PerceptionStatus, double t) { times.push_back(t); });
  constexpr int kPosts = 40;
  std::size_t allocations = 0;
  {
    rollstep::test::AllocationGuard guard;
    for (int k = 0; k < kPosts; ++k) {
      const std::size_t i = static_cast<std::size_t>(k) % scans.points.size();
      if (!worker.post(scans.points[i], scans.poses[i], 0.01 * k)) ADD_FAILURE() << "post " << k;
      std::this_thread::sleep_for(std::chrono::microseconds(500));
    }
    allocations = guard.count();
  }
  EXPECT_EQ(allocations, 0u);
  // More points than the frames hold: refused, nothing posted.
  const std::vector<Eigen::Vector3d> too_many(static_cast<std::size_t>(scans.max_size) + 1,
                                              Eigen::Vector3d(0, 0, -3));
  EXPECT_FALSE(worker.post(too_many, scans.poses[0], 1.0));
  worker.stop();
  const PerceptionWorkerCounters c = worker.counters();
  EXPECT_EQ(c.posted, static_cast<std::uint64_t>(kPosts));
  EXPECT_EQ(c.processed + c.superseded, c.posted);
  EXPECT_GE(c.processed, 1u);
  ASSERT_EQ(times.size(), c.processed);
  EXPECT_EQ(times.back(), 0.01 * (kPosts - 1)) << "the newest scan was not processed";
  for (std::size_t k = 1; k < times.size(); ++k) EXPECT_GT(times[k], times[k - 1]);
  EXPECT_EQ(perception.lastStatus(), PerceptionStatus::Ok);
}

// A failure on the worker thread (here the sink throws) stops the worker; posting is
// refused from then on and stop() rethrows it to the owner, once.
TEST(PerceptionWorker, AFailureOnTheWorkerReachesTheOwner) {
  const Scans scans = stairScans(1);
  TerrainPerception perception(settings());
  PerceptionWorker worker(perception, scans.max_size,
                          [](const TerrainPerception&, PerceptionStatus, double) {
                            throw std::runtime_error("sink failed");
                          });
  ASSERT_TRUE(worker.post(scans.points[0], scans.poses[0], 0.0));
  waitIdle(worker);
  EXPECT_TRUE(worker.failed());
  EXPECT_FALSE(worker.post(scans.points[0], scans.poses[0], 0.1));
  try {
    worker.stop();
    ADD_FAILURE() << "stop() did not rethrow";
  } catch (const std::runtime_error& e) {
    EXPECT_STREQ(e.what(), "sink failed");
  }
  EXPECT_NO_THROW(worker.stop());
  EXPECT_THROW(ScanMailbox(0), std::invalid_argument);
}

}  // namespace
}  // namespace rollstep::perception
