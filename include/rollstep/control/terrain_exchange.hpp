#pragma once
// The hand-over of new terrains (from perception, at its own rate) to a consumer that must
// not allocate, lock or wait: the MPC at the start of a solve, the real-time loop.
//
// A single-producer single-consumer mailbox of the newest value: three slots, the producer
// writes one (copy-assigning: it may allocate, it is not real-time), publishes it through
// an atomic index exchange, and the consumer takes the newest published slot and swaps its
// content into its own object (O(1), no allocation: the old value goes into the slot the
// producer will overwrite later). Neither side ever waits for the other; a value published
// before the consumer took the previous one supersedes it (only the newest counts).
//
// T needs copy assignment and a member `void swap(T&) noexcept` (planning::TerrainModel,
// or a pair of terrains). Each published value gets a version 1, 2, ... (0: none yet).
#include <array>
#include <atomic>
#include <cstdint>

namespace rollstep::control {

template <typename T>
class LatestValueExchange {
 public:
  /// Producer (one thread): publishes a copy of `value`; returns its version.
  std::uint64_t publish(const T& value) {
    Slot& slot = slots_[static_cast<std::size_t>(write_)];
    slot.value = value;
    slot.version = ++published_;
    write_ = middle_.exchange(write_ | kDirty, std::memory_order_acq_rel) & kIndexMask;
    return slot.version;
  }

  /// Consumer (one thread): if a value newer than the last one taken was published, swaps
  /// it into `target` (which gives its old content to the exchange), stores its version in
  /// `version` and returns true. Never allocates, locks or throws.
  bool take(T& target, std::uint64_t& version) noexcept {
    if ((middle_.load(std::memory_order_acquire) & kDirty) == 0) return false;
    read_ = middle_.exchange(read_, std::memory_order_acq_rel) & kIndexMask;
    Slot& slot = slots_[static_cast<std::size_t>(read_)];
    target.swap(slot.value);
    version = slot.version;
    return true;
  }
  /// Consumer: the value `target` held before the last successful take() (until the next
  /// take()).
  const T& previous() const noexcept { return slots_[static_cast<std::size_t>(read_)].value; }
  /// Consumer: whether a value is waiting (take() would return true).
  bool pending() const noexcept { return (middle_.load(std::memory_order_acquire) & kDirty) != 0; }

 private:
  static constexpr int kIndexMask = 3;
  static constexpr int kDirty = 4;
  struct Slot {
    T value;
    std::uint64_t version = 0;
  };
  std::array<Slot, 3> slots_;
  int write_ = 0;                // producer's
  std::atomic<int> middle_{1};   // shared
  int read_ = 2;                 // consumer's
  std::uint64_t published_ = 0;  // producer's
};

}  // namespace rollstep::control
