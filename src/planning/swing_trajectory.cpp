#include "rollstep/planning/swing_trajectory.hpp"

#include <algorithm>
#include <cmath>

#include "check.hpp"

namespace rollstep::planning {

SwingDirection classifySwing(double z_liftoff, double z_touchdown, double tolerance) {
  if (z_touchdown > z_liftoff + tolerance) return SwingDirection::Ascending;
  if (z_touchdown < z_liftoff - tolerance) return SwingDirection::Descending;
  return SwingDirection::Level;
}

bool swingRegionActive(SwingDirection direction, double phase, double apex_phase) {
  switch (direction) {
    case SwingDirection::Ascending:
      return phase <= apex_phase;
    case SwingDirection::Descending:
      return phase >= apex_phase;
    case SwingDirection::Level:
      break;
  }
  return false;
}

SwingHeightSpline::SwingHeightSpline(double t_liftoff, double t_touchdown, double z_liftoff,
                                     double z_touchdown, double clearance, double apex_margin)
    : t0_(t_liftoff), t1_(t_touchdown), z0_(z_liftoff), z1_(z_touchdown) {
  const char* where = "SwingHeightSpline";
  detail::checkFinite(where, "t_liftoff", t_liftoff);
  detail::checkFinite(where, "t_touchdown", t_touchdown);
  if (!(t_touchdown > t_liftoff)) {
    detail::fail(where, "t_touchdown", t_touchdown, "must be after t_liftoff");
  }
  detail::checkFinite(where, "z_liftoff", z_liftoff);
  detail::checkFinite(where, "z_touchdown", z_touchdown);
  detail::checkNonNegative(where, "clearance", clearance);
  if (!(apex_margin > 0.0 && apex_margin <= 0.5)) {
    detail::fail(where, "apex_margin", apex_margin, "must be in (0, 0.5]");
  }
  za_ = std::max(z_liftoff, z_touchdown) + clearance;
  const double rise = za_ - z0_, fall = za_ - z1_;
  const double phase = rise + fall > 0.0 ? rise / (rise + fall) : 0.5;
  tm_ = t0_ + std::clamp(phase, apex_margin, 1.0 - apex_margin) * (t1_ - t0_);
}

void SwingHeightSpline::evaluate(double t, double& z, double& z_dot) const {
  const double tm = apexTime();
  if (t <= t0_) {
    z = z0_;
    z_dot = 0.0;
    return;
  }
  if (t >= t1_) {
    z = z1_;
    z_dot = 0.0;
    return;
  }
  // Cubic Hermite with zero end slopes from (ta, za) to (tb, zb): z = za + (zb - za) h(s),
  // h(s) = 3 s^2 - 2 s^3, h'(s) = 6 s (1 - s).
  const bool up = t < tm;
  const double ta = up ? t0_ : tm, tb = up ? tm : t1_;
  const double za = up ? z0_ : za_, zb = up ? za_ : z1_;
  const double dur = tb - ta;
  const double s = (t - ta) / dur;
  z = za + (zb - za) * s * s * (3.0 - 2.0 * s);
  z_dot = (zb - za) * 6.0 * s * (1.0 - s) / dur;
}

double SwingHeightSpline::position(double t) const {
  double z, zd;
  evaluate(t, z, zd);
  return z;
}

double SwingHeightSpline::velocity(double t) const {
  double z, zd;
  evaluate(t, z, zd);
  return zd;
}

}  // namespace rollstep::planning
