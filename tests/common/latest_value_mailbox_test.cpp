// The latest-value mailbox (lock-free triple buffer): the consumer gets the newest value
// published since its last take, whole and with its version, never an older one; taking,
// publishing in place and swapping out never allocate; across threads every value taken is
// consistent and versions only grow (also run under ThreadSanitizer: label `threads`).
#include "rollstep/common/latest_value_mailbox.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <cstdint>
#include <thread>
#include <vector>

#include "common/alloc_counter.hpp"

namespace {

using rollstep::LatestValueMailbox;

/// A value whose consistency can be checked: `size` entries, all equal to `stamp`.
struct Stamped {
  std::vector<std::uint64_t> entries;
  void fill(std::uint64_t stamp, std::size_t size) {
    entries.resize(size);
    for (std::uint64_t& e : entries) e = stamp;
  }
  bool consistent(std::uint64_t stamp, std::size_t size) const {
    if (entries.size() != size) return false;
    for (std::uint64_t e : entries) {
      if (e != stamp) return false;
    }
    return true;
  }
  void swap(Stamped& other) noexcept { entries.swap(other.entries); }
};

TEST(LatestValueMailbox, TheConsumerGetsOnlyTheNewestValueWithItsVersion) {
  LatestValueMailbox<int> box;
  EXPECT_FALSE(box.pending());
  EXPECT_FALSE(box.take());
  EXPECT_EQ(box.currentVersion(), 0u);
  box.writable() = 10;
  EXPECT_EQ(box.publish(), 1u);
  box.writable() = 20;
  EXPECT_EQ(box.publish(), 2u);
  EXPECT_EQ(box.publish(30), 3u);
  EXPECT_EQ(box.published(), 3u);
  EXPECT_TRUE(box.pending());
  ASSERT_TRUE(box.take());
  EXPECT_EQ(box.current(), 30);  // 10 and 20 superseded
  EXPECT_EQ(box.currentVersion(), 3u);
  EXPECT_FALSE(box.pending());
  EXPECT_FALSE(box.take());  // nothing newer: current() stays
  EXPECT_EQ(box.current(), 30);
  // Alternating publications and takes cycle through the three slots without losing one.
  for (int k = 4; k < 20; ++k) {
    EXPECT_EQ(box.publish(k * 10), static_cast<std::uint64_t>(k));
    ASSERT_TRUE(box.take());
    EXPECT_EQ(box.current(), k * 10);
    EXPECT_EQ(box.currentVersion(), static_cast<std::uint64_t>(k));
  }
  // The producer never writes the slot the consumer holds.
  box.publish(1000);
  ASSERT_TRUE(box.take());
  for (int k = 0; k < 5; ++k) box.publish(2000 + k);
  EXPECT_EQ(box.current(), 1000);
  box.reset();
  EXPECT_FALSE(box.pending());
  EXPECT_EQ(box.published(), 0u);
  EXPECT_EQ(box.publish(5), 1u);
}

TEST(LatestValueMailbox, SlotsSizedOnceExchangeWithoutAllocating) {
  Stamped prototype;
  prototype.fill(0, 64);
  LatestValueMailbox<Stamped> box(prototype);
  box.forEachSlot([](Stamped& s) { EXPECT_EQ(s.entries.size(), 64u); });
  Stamped mine;
  mine.fill(0, 64);
  {
    rollstep::test::AllocationGuard guard;
    for (std::uint64_t v = 1; v <= 10; ++v) {
      box.writable().fill(v, 64);  // in place, within the slot's size
      box.publish();
      std::uint64_t version = 0;
      ASSERT_TRUE(box.take(mine, version));  // swapped in: O(1)
      EXPECT_EQ(version, v);
      EXPECT_TRUE(mine.consistent(v, 64));
      // What `mine` held before is in the consumer's slot until the next take.
      EXPECT_TRUE(box.previous().consistent(v - 1, 64));
    }
    EXPECT_EQ(guard.count(), 0u) << "publishing in place, taking or swapping allocated";
  }
}

TEST(LatestValueMailbox, ProducerAndConsumerThreadsSeeWholeValuesInOrder) {
  // Sizes vary with the version, so a torn value (a slot written while read) shows as a
  // size or an entry that does not match its version.
  LatestValueMailbox<Stamped> box;
  constexpr std::uint64_t kValues = 20000;
  std::atomic<bool> done{false};
  std::thread producer([&] {
    for (std::uint64_t v = 1; v <= kValues; ++v) {
      box.writable().fill(v, v % 7 + 1);
      EXPECT_EQ(box.publish(), v);
    }
    done.store(true, std::memory_order_release);
  });
  std::uint64_t last = 0, taken = 0;
  bool consistent = true, increasing = true;
  for (;;) {
    const bool finished = done.load(std::memory_order_acquire);
    if (box.take()) {
      ++taken;
      const std::uint64_t v = box.currentVersion();
      increasing = increasing && v > last;
      last = v;
      consistent = consistent && box.current().consistent(v, v % 7 + 1);
    } else if (finished) {
      break;
    }
  }
  producer.join();
  EXPECT_TRUE(consistent) << "a value taken did not match its version";
  EXPECT_TRUE(increasing) << "a value older than one already taken came back";
  EXPECT_EQ(last, kValues) << "the newest value never arrived";
  EXPECT_GE(taken, 1u);
}

}  // namespace
