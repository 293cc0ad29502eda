#pragma once
// A single-producer single-consumer mailbox of the newest value: a lock-free triple
// buffer. Three slots allocated once; the producer fills the slot it owns (in place, or by
// copying a value in) and publishes it with one atomic index exchange; the consumer takes
// the newest published slot the same way and owns it until its next take. Neither side
// ever waits, locks or allocates in the exchange; a value published before the consumer
// took the previous one supersedes it (only the newest counts). Each publication gets a
// version 1, 2, ... (0: none yet), carried with its slot.
//
// Used for every hand-over between the threads of the stack: states to the MPC thread,
// MPC solutions to the real-time loop, terrains to the MPC and the loop, scans to the
// perception worker.
#include <array>
#include <atomic>
#include <cstdint>
#include <utility>

namespace rollstep {

template <typename T>
class LatestValueMailbox {
 public:
  LatestValueMailbox() = default;
  /// Every slot a copy of `prototype` (e.g. buffers sized once for a problem).
  explicit LatestValueMailbox(const T& prototype) {
    for (Slot& slot : slots_) slot.value = prototype;
  }
  LatestValueMailbox(const LatestValueMailbox&) = delete;
  LatestValueMailbox& operator=(const LatestValueMailbox&) = delete;

  // --- producer (one thread) --------------------------------------------------------------
  /// The slot the producer owns: fill it, then publish().
  T& writable() noexcept { return slots_[static_cast<std::size_t>(write_)].value; }
  /// Publishes the slot just filled and takes another one to fill next; returns its version.
  std::uint64_t publish() noexcept {
    const std::uint64_t version = ++published_;
    slots_[static_cast<std::size_t>(write_)].version = version;
    write_ = middle_.exchange(write_ | kDirty, std::memory_order_acq_rel) & kIndexMask;
    return version;
  }
  /// Copies `value` into the producer's slot (copy assignment: allocates only if T does)
  /// and publishes it; returns its version.
  std::uint64_t publish(const T& value) {
    writable() = value;
    return publish();
  }
  /// Versions published so far (the last one's).
  std::uint64_t published() const noexcept { return published_; }

  // --- consumer (one thread) --------------------------------------------------------------
  /// Takes the newest slot published since the last take (then true; current() is it);
  /// false when nothing newer was published (current() unchanged).
  bool take() noexcept {
    if ((middle_.load(std::memory_order_acquire) & kDirty) == 0) return false;
    read_ = middle_.exchange(read_, std::memory_order_acq_rel) & kIndexMask;
    return true;
  }
  /// Same, swapping the value taken into `target` (O(1) for a T with a member
  /// `void swap(T&) noexcept`): the old content of `target` goes into the slot, readable
  /// through current() until the next take, then overwritten by the producer.
  bool take(T& target, std::uint64_t& version) noexcept {
    if (!take()) return false;
    Slot& slot = slots_[static_cast<std::size_t>(read_)];
    target.swap(slot.value);
    version = slot.version;
    return true;
  }
  /// The slot the consumer owns (the last one taken; before any take, a slot never
  /// published).
  T& current() noexcept { return slots_[static_cast<std::size_t>(read_)].value; }
  const T& current() const noexcept { return slots_[static_cast<std::size_t>(read_)].value; }
  /// Version of current() (0 before any take).
  std::uint64_t currentVersion() const noexcept {
    return slots_[static_cast<std::size_t>(read_)].version;
  }
  /// After take(target, version): the value `target` held before it.
  const T& previous() const noexcept { return current(); }
  /// Whether a value is waiting (take() would return true).
  bool pending() const noexcept { return (middle_.load(std::memory_order_acquire) & kDirty) != 0; }

  // --- neither side running ---------------------------------------------------------------
  /// Back to the start (no value published, versions from 1 again); the slots' values stay.
  void reset() noexcept {
    write_ = 0;
    middle_.store(1, std::memory_order_relaxed);
    read_ = 2;
    published_ = 0;
    for (Slot& slot : slots_) slot.version = 0;
  }
  /// Calls f(value) on each of the three slots (to size or reset them).
  template <typename F>
  void forEachSlot(F&& f) {
    for (Slot& slot : slots_) f(slot.value);
  }

 private:
  static constexpr int kIndexMask = 3;
  static constexpr int kDirty = 4;
  struct Slot {
    T value{};
    std::uint64_t version = 0;
  };
  std::array<Slot, 3> slots_;
  int write_ = 0;                // producer's
  std::atomic<int> middle_{1};   // shared
  int read_ = 2;                 // consumer's
  std::uint64_t published_ = 0;  // producer's
};

}  // namespace rollstep
