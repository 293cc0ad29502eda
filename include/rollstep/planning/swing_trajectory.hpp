#pragma once
// Swing foot height reference z_ref(t), z_dot_ref(t) (paper eq. swingFootTrajectory).
//
// Two cubic Hermite pieces with zero end slopes: from the lift-off height z_lo at
// t_lo up to the apex z_apex = max(z_lo, z_td) + clearance at the apex time t_m, then down
// to the touch-down height z_td at t_td. Each piece is monotone (3 s^2 - 2 s^3 is), so z
// rises before the apex and falls after it: the property the swing collision-avoidance
// region rule relies on (ascending swings are constrained over their first half, descending
// ones over their second: FootReferencePlanner calls swingRegionActive with apex_phase 1/2,
// the paper's halves, also when the apex margin moves the apex later; measured with
// a window up to a later apex, or up to where the reference clears the upper surface, and
// the climbs fell with both). The apex is at mid-swing by default. With an apex margin
// m < 1/2 it moves towards the end that needs the longer way, to the phase
// rise / (rise + fall) clamped to [m, 1 - m], which equalises the two pieces' peak
// speeds (1.5 rise / t_up and 1.5 fall / t_down): a 0.22 m climb with 0.02 m clearance in
// a 0.56 s swing needs a 1.18 m/s foot speed with the apex at the middle, 0.71 m/s with
// it at 0.8 of the swing (a telescopic knee's limit is about 0.8 m/s). C1 everywhere
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
/// in [0, 1] of a swing whose apex is at `apex_phase`: up to the apex
/// (phase <= apex_phase) of an ascending swing, from it (phase >= apex_phase) of a
/// descending one, never on the level.
bool swingRegionActive(SwingDirection direction, double phase, double apex_phase = 0.5);

class SwingHeightSpline {
 public:
  /// A level swing at height 0 on [0, 1] with no clearance.
  SwingHeightSpline() = default;
  /// Times [s] with t_touchdown > t_liftoff, heights [m], clearance >= 0 [m] and the apex
  /// margin in (0, 1/2] (1/2: apex at mid-swing); throws std::invalid_argument naming the
  /// parameter and its value otherwise (NaN included).
  SwingHeightSpline(double t_liftoff, double t_touchdown, double z_liftoff, double z_touchdown,
                    double clearance, double apex_margin = 0.5);

  double liftoffTime() const { return t0_; }
  double touchdownTime() const { return t1_; }
  double apexTime() const { return tm_; }
  /// Share of the swing before the apex, in [apex_margin, 1 - apex_margin].
  double apexPhase() const { return (tm_ - t0_) / (t1_ - t0_); }
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
  double t0_ = 0.0, t1_ = 1.0, tm_ = 0.5;
  double z0_ = 0.0, z1_ = 0.0, za_ = 0.0;
};

}  // namespace rollstep::planning
