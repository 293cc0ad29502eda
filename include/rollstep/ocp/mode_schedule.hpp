#pragma once
// A sequence of modes and the times at which they switch (paper Sec. 2.1):
// mode m_0 before t_0, m_1 in [t_0, t_1), ..., m_M after t_{M-1}.
#include <vector>

namespace rollstep::ocp {

class ModeSchedule {
 public:
  /// @param capacity the largest number of switches ever set (memory is reserved once).
  explicit ModeSchedule(int capacity = 64, int initial_mode = 0);
  /// Copies keep the capacity reserved (a copy's split() must not allocate either).
  ModeSchedule(const ModeSchedule& other);
  ModeSchedule& operator=(const ModeSchedule& other);
  ModeSchedule(ModeSchedule&&) noexcept = default;
  ModeSchedule& operator=(ModeSchedule&&) noexcept = default;
  ~ModeSchedule() = default;
  /// Replaces the schedule: modes.size() == switching_times.size() + 1, times sorted.
  /// Throws std::invalid_argument on bad sizes, unsorted times or capacity overflow.
  /// Does not allocate within capacity.
  void set(const std::vector<double>& switching_times, const std::vector<int>& modes);
  /// A single mode for all times.
  void setConstant(int mode);
  int modeAt(double t) const;
  /// Index of the phase containing t (0..switches()).
  int phaseAt(double t) const;
  int switches() const { return static_cast<int>(times_.size()); }
  const std::vector<double>& switchingTimes() const { return times_; }
  const std::vector<int>& modes() const { return modes_; }
  /// Inserts a switching time at t with the same mode on both sides (so nothing changes
  /// until a phase's mode is set), unless t is one already (within 1e-9 s). Returns false,
  /// changing nothing, for a non-finite t or a full capacity. Never allocates.
  bool split(double t) noexcept;
  /// Sets the mode of phase `phase` (0..switches()); out of range: nothing. Never allocates.
  void setMode(int phase, int mode) noexcept;

 private:
  int capacity_;
  std::vector<double> times_;
  std::vector<int> modes_;
};

}  // namespace rollstep::ocp
