#include "rollstep/planning/gait_clock.hpp"

#include <algorithm>
#include <cmath>

namespace rollstep::planning {

double GaitClock::gaitTime(double t) const noexcept {
  double tau = t - offset_;
  for (int i = 0; i < size_; ++i) {
    const Hold& h = holds_[static_cast<std::size_t>(i)];
    if (t <= h.start) break;
    tau -= std::min(t - h.start, h.duration);
  }
  return tau;
}

double GaitClock::loopTime(double tau) const noexcept {
  double t = tau + offset_;
  for (int i = 0; i < size_; ++i) {
    const Hold& h = holds_[static_cast<std::size_t>(i)];
    if (t <= h.start) break;
    t += h.duration;
  }
  return t;
}

bool GaitClock::addHold(double start, double duration) noexcept {
  if (!std::isfinite(start) || !std::isfinite(duration) || duration < 0.0) return false;
  if (duration == 0.0) return true;
  if (size_ > 0) {
    Hold& last = holds_[static_cast<std::size_t>(size_ - 1)];
    constexpr double kTouch = 1e-12;  // [s] a hold beginning where the last ends extends it
    if (start < last.end() - kTouch) return false;
    if (start <= last.end() + kTouch) {
      last.duration = start + duration - last.start;
      return true;
    }
  }
  if (size_ == kMaxHolds) return false;
  holds_[static_cast<std::size_t>(size_++)] = Hold{start, duration};
  return true;
}

void GaitClock::dropHoldsAfter(double t) noexcept {
  while (size_ > 0 && holds_[static_cast<std::size_t>(size_ - 1)].start > t) --size_;
}

void GaitClock::forgetBefore(double t) noexcept {
  int k = 0;
  while (k < size_ && holds_[static_cast<std::size_t>(k)].end() <= t) {
    offset_ += holds_[static_cast<std::size_t>(k)].duration;
    ++k;
  }
  if (k == 0) return;
  std::copy(holds_.begin() + k, holds_.begin() + size_, holds_.begin());
  size_ -= k;
}

void GaitClock::clear() noexcept {
  size_ = 0;
  offset_ = 0.0;
}

double GaitClock::totalHeld() const noexcept {
  double held = offset_;
  for (int i = 0; i < size_; ++i) held += holds_[static_cast<std::size_t>(i)].duration;
  return held;
}

}  // namespace rollstep::planning
