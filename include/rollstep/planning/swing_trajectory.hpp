#pragma once
// Swing foot height reference z_ref(t), z_dot_ref(t) (paper eq. swingFootTrajectory).
//
// Two cubic Hermite pieces with zero end slopes: from the lift-off height z_lo at
// t_lo up to the apex z_apex = max(z_lo, z_td) + clearance at the mid time
// t_m = (t_lo + t_td) / 2, then down to the touch-down height z_td at t_td. Each piece is
// monotone (3 s^2 - 2 s^3 is), so z rises on the first half and falls on the second:
// the property the swing collision-avoidance region rule relies on (ascending swings
// are constrained on the first half, descending on the second). C1 everywhere
// (z_dot = 0 at lift-off, apex and touch-down). Before t_lo the value is z_lo, after
// t_td it is z_td, with zero velocity.
//
// A plain value: constructing and evaluating allocate nothing.
namespace rollstep::planning {

/// Swing up a step, down a step, or on the level (|z_td - z_lo| <= tolerance).
enum class SwingDirection { Level, Ascending, Descending };

/// Classifies a swing by its end heights [m].
SwingDirection classifySwing(double z_liftoff, double z_touchdown, double tolerance = 1e-3);

/// Whether the swing collision-avoidance region constraint applies at swing `phase`
/// in [0, 1]: the first half (phase <= 1/2) of an ascending swing, the second half
/// (phase >= 1/2) of a descending one, never on the level.
bool swingRegionActive(SwingDirection direction, double phase);

class SwingHeightSpline {
 public:
  /// A level swing at height 0 on [0, 1] with no clearance.
  SwingHeightSpline() = default;
  /// Times [s] with t_touchdown > t_liftoff, heights [m] and clearance >= 0 [m]; throws
  /// std::invalid_argument naming the parameter and its value otherwise (NaN included).
  SwingHeightSpline(double t_liftoff, double t_touchdown, double z_liftoff, double z_touchdown,
                    double clearance);

  double liftoffTime() const { return t0_; }
  double touchdownTime() const { return t1_; }
  double apexTime() const { return 0.5 * (t0_ + t1_); }
  double apexHeight() const { return za_; }
  SwingDirection direction(double tolerance = 1e-3) const {
    return classifySwing(z0_, z1_, tolerance);
  }

  /// z_ref(t) [m].
  double position(double t) const;
  /// z_dot_ref(t) [m/s].
  double velocity(double t) const;
  /// Both at once.
  void evaluate(double t, double& z, double& z_dot) const;

 private:
  double t0_ = 0.0, t1_ = 1.0;
  double z0_ = 0.0, z1_ = 0.0, za_ = 0.0;
};

}  // namespace rollstep::planning
