// The terrain hand-over (a LatestValueMailbox of terrains): the consumer gets the newest published
// value, swapped in without allocating; the old value comes back through previous();
// across threads every value taken is whole (its regions match its version) and versions
// only grow.
#include <gtest/gtest.h>

#include <atomic>
#include <thread>

#include "common/alloc_counter.hpp"
#include "rollstep/common/latest_value_mailbox.hpp"
#include "rollstep/planning/terrain.hpp"

namespace {

using rollstep::LatestValueMailbox;
using rollstep::planning::ConvexRegion;
using rollstep::planning::TerrainModel;

/// A terrain of `n` unit squares side by side at height h.
TerrainModel squares(int n, double h) {
  std::vector<ConvexRegion> regions;
  for (int i = 0; i < n; ++i) {
    regions.push_back(ConvexRegion::fromPolygon(
        {{i + 0.0, 0.0}, {i + 1.0, 0.0}, {i + 1.0, 1.0}, {i + 0.0, 1.0}}, h));
  }
  return TerrainModel(std::move(regions));
}

TEST(TerrainExchange, TakesTheNewestWithoutAllocating) {
  LatestValueMailbox<TerrainModel> exchange;
  TerrainModel in_use = squares(1, 0.0);
  std::uint64_t version = 0;
  EXPECT_FALSE(exchange.pending());
  EXPECT_FALSE(exchange.take(in_use, version));
  EXPECT_EQ(exchange.publish(squares(2, 0.1)), 1u);
  EXPECT_EQ(exchange.publish(squares(3, 0.2)), 2u);
  EXPECT_EQ(exchange.publish(squares(4, 0.3)), 3u);
  EXPECT_TRUE(exchange.pending());
  {
    rollstep::test::AllocationGuard guard;
    EXPECT_TRUE(exchange.take(in_use, version));
    EXPECT_FALSE(exchange.take(in_use, version));  // nothing newer
    EXPECT_EQ(guard.count(), 0u) << "the consumer's take allocated";
  }
  EXPECT_EQ(version, 3u);  // only the newest counts
  EXPECT_EQ(in_use.size(), 4);
  EXPECT_DOUBLE_EQ(in_use.region(0).height, 0.3);
  EXPECT_EQ(exchange.previous().size(), 1);  // what in_use held before
  // The slots are reused: more publications and takes keep giving the newest.
  for (int k = 0; k < 5; ++k) {
    exchange.publish(squares(1 + k % 3, 1.0 + k));
    ASSERT_TRUE(exchange.take(in_use, version));
    EXPECT_EQ(version, 4u + static_cast<std::uint64_t>(k));
    EXPECT_DOUBLE_EQ(in_use.region(0).height, 1.0 + k);
    EXPECT_EQ(in_use.size(), 1 + k % 3);
  }
}

TEST(TerrainExchange, ProducerAndConsumerThreadsSeeWholeValues) {
  LatestValueMailbox<TerrainModel> exchange;
  constexpr int kValues = 3000;
  std::atomic<bool> done{false};
  std::thread producer([&] {
    // Version v: (v % 5) + 1 squares at height v.
    for (int v = 1; v <= kValues; ++v) exchange.publish(squares(v % 5 + 1, v));
    done.store(true, std::memory_order_release);
  });
  TerrainModel in_use;
  std::uint64_t last = 0, taken = 0;
  bool consistent = true, increasing = true;
  for (;;) {
    const bool finished = done.load(std::memory_order_acquire);
    std::uint64_t version = 0;
    if (exchange.take(in_use, version)) {
      ++taken;
      increasing = increasing && version > last;
      last = version;
      const int n = static_cast<int>(version % 5 + 1);
      consistent = consistent && in_use.size() == n;
      for (int i = 0; i < in_use.size() && consistent; ++i) {
        consistent = in_use.region(i).height == static_cast<double>(version);
      }
    } else if (finished) {
      break;
    }
  }
  producer.join();
  EXPECT_TRUE(consistent) << "a terrain taken did not match its version";
  EXPECT_TRUE(increasing);
  EXPECT_EQ(last, static_cast<std::uint64_t>(kValues));  // the newest arrives in the end
  EXPECT_GE(taken, 1u);
}

}  // namespace
