#include "rollstep/ocp/mode_schedule.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace rollstep::ocp {

ModeSchedule::ModeSchedule(int capacity, int initial_mode) : capacity_(capacity) {
  if (capacity < 0) throw std::invalid_argument("ModeSchedule: negative capacity");
  times_.reserve(static_cast<std::size_t>(capacity));
  modes_.reserve(static_cast<std::size_t>(capacity) + 1);
  modes_.push_back(initial_mode);
}

ModeSchedule::ModeSchedule(const ModeSchedule& other) { *this = other; }

ModeSchedule& ModeSchedule::operator=(const ModeSchedule& other) {
  if (this == &other) return *this;
  capacity_ = other.capacity_;
  times_.reserve(static_cast<std::size_t>(capacity_));
  modes_.reserve(static_cast<std::size_t>(capacity_) + 1);
  times_ = other.times_;
  modes_ = other.modes_;
  return *this;
}

void ModeSchedule::set(const std::vector<double>& switching_times, const std::vector<int>& modes) {
  if (modes.size() != switching_times.size() + 1) {
    throw std::invalid_argument(
        "ModeSchedule::set: need modes.size() == switching_times.size() + 1 (got " +
        std::to_string(modes.size()) + " modes, " + std::to_string(switching_times.size()) +
        " times)");
  }
  if (static_cast<int>(switching_times.size()) > capacity_) {
    throw std::invalid_argument("ModeSchedule::set: " + std::to_string(switching_times.size()) +
                                " switches exceed the capacity " + std::to_string(capacity_));
  }
  for (std::size_t i = 0; i < switching_times.size(); ++i) {
    if (!std::isfinite(switching_times[i]) ||
        (i > 0 && switching_times[i] < switching_times[i - 1])) {
      throw std::invalid_argument("ModeSchedule::set: switching times must be finite and sorted");
    }
  }
  times_.assign(switching_times.begin(), switching_times.end());
  modes_.assign(modes.begin(), modes.end());
}

void ModeSchedule::setConstant(int mode) {
  times_.clear();
  modes_.clear();
  modes_.push_back(mode);
}

int ModeSchedule::phaseAt(double t) const {
  // Number of switching times <= t: mode m_i holds on [t_{i-1}, t_i).
  return static_cast<int>(std::upper_bound(times_.begin(), times_.end(), t) - times_.begin());
}

int ModeSchedule::modeAt(double t) const { return modes_[static_cast<std::size_t>(phaseAt(t))]; }

bool ModeSchedule::split(double t) noexcept {
  if (!std::isfinite(t)) return false;
  const auto at = std::lower_bound(times_.begin(), times_.end(), t - 1e-9);
  if (at != times_.end() && *at <= t + 1e-9) return true;  // a switch already
  if (static_cast<int>(times_.size()) >= capacity_) return false;
  const std::ptrdiff_t phase = at - times_.begin();
  // Within the reserved capacity: insert does not allocate.
  times_.insert(at, t);
  modes_.insert(modes_.begin() + phase, modes_[static_cast<std::size_t>(phase)]);
  return true;
}

void ModeSchedule::setMode(int phase, int mode) noexcept {
  if (phase < 0 || phase >= static_cast<int>(modes_.size())) return;
  modes_[static_cast<std::size_t>(phase)] = mode;
}

}  // namespace rollstep::ocp
