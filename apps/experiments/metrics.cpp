#include "metrics.hpp"

#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>

#include "rollstep/common/number_text.hpp"

namespace rollstep::experiments {

namespace {

bool on(double contact) { return contact > 0.5; }

}  // namespace

TraverseLegs traverseLegs(const std::vector<std::string>& names, const std::vector<double>& hip_x,
                          const std::vector<double>& hip_y) {
  if (names.empty() || hip_x.size() != names.size() || hip_y.size() != names.size()) {
    throw std::invalid_argument("traverseLegs: no legs, or names and hip positions differ in size");
  }
  constexpr double kTie = 1e-3;  // [m] hips this close along x are side by side
  // Whether leg i is ahead of leg k in the direction `sign` (+1 front, -1 hind).
  const auto better = [&](std::size_t i, std::size_t k, double sign) {
    const double dx = sign * (hip_x[i] - hip_x[k]);
    if (std::abs(dx) > kTie) return dx > 0.0;
    return std::abs(hip_y[i]) < std::abs(hip_y[k]) - kTie;
  };
  std::size_t climb = 0, descent = 0;
  for (std::size_t i = 1; i < names.size(); ++i) {
    if (better(i, climb, 1.0)) climb = i;
    if (better(i, descent, -1.0)) descent = i;
  }
  return {names[climb], names[descent]};
}

TraverseWindow findTraverseWindow(const std::vector<double>& t, const std::vector<double>& climb_z,
                                  const std::vector<double>& climb_contact,
                                  const std::vector<double>& descent_z,
                                  const std::vector<double>& descent_contact,
                                  const TraverseLegs& legs, double up_height) {
  const std::size_t n = t.size();
  if (climb_z.size() != n || climb_contact.size() != n || descent_z.size() != n ||
      descent_contact.size() != n) {
    throw std::invalid_argument("findTraverseWindow: the series differ in length");
  }
  TraverseWindow w;
  // The climb: the climbing leg lands on the step, having lifted off for it.
  std::size_t landed = n;
  for (std::size_t i = 0; i < n; ++i) {
    if (on(climb_contact[i]) && climb_z[i] > up_height) {
      landed = i;
      break;
    }
  }
  if (landed == n) {
    w.reason = "the " + legs.climb + " wheel never landed on the step";
    return w;
  }
  std::size_t lift = n;
  for (std::size_t i = landed; i-- > 1;) {
    if (on(climb_contact[i - 1]) && !on(climb_contact[i])) {
      lift = i;
      break;
    }
  }
  if (lift == n) {
    w.reason = "no " + legs.climb + " lift-off before it reached the step";
    return w;
  }
  // The descent: the touch-down that brings the descending leg back to the floor after its
  // last stance up.
  std::size_t last_up = n;
  for (std::size_t i = n; i-- > 0;) {
    if (on(descent_contact[i]) && descent_z[i] > up_height) {
      last_up = i;
      break;
    }
  }
  if (last_up == n || last_up < landed) {
    w.reason = "the " + legs.descent + " wheel never stood on the step";
    return w;
  }
  std::size_t down = n;
  for (std::size_t i = last_up + 1; i < n; ++i) {
    if (on(descent_contact[i]) && !on(descent_contact[i - 1]) && descent_z[i] <= up_height) {
      down = i;
      break;
    }
  }
  if (down == n) {
    w.reason =
        "the " + legs.descent +
        formatText(" wheel did not come down from the step (last on it at t = %.2f s)", t[last_up]);
    return w;
  }
  w.found = true;
  w.start = t[lift];
  w.end = t[down];
  return w;
}

TraverseWindow findTraverseWindow(const LogTable& log, const TraverseLegs& legs, double up_height) {
  return findTraverseWindow(log.column("time[s]"), log.column("foot_z_" + legs.climb + "[m]"),
                            log.column("contact_" + legs.climb + "[0/1]"),
                            log.column("foot_z_" + legs.descent + "[m]"),
                            log.column("contact_" + legs.descent + "[0/1]"), legs, up_height);
}

std::vector<double> localVz(const LogTable& log) {
  const auto& qw = log.column("base_qw[-]");
  const auto& qx = log.column("base_qx[-]");
  const auto& qy = log.column("base_qy[-]");
  const auto& qz = log.column("base_qz[-]");
  const auto& vx = log.column("base_vx[m/s]");
  const auto& vy = log.column("base_vy[m/s]");
  const auto& vz = log.column("base_vz[m/s]");
  std::vector<double> out(log.rows());
  for (std::size_t i = 0; i < out.size(); ++i) {
    // The third row of R(q) (R maps base to world), i.e. the base z axis in world: R^T v.z.
    const double w = qw[i], x = qx[i], y = qy[i], z = qz[i];
    const double n2 = w * w + x * x + y * y + z * z;
    const double s = n2 > 0.0 ? 2.0 / n2 : 0.0;
    const double zx = s * (x * z + w * y), zy = s * (y * z - w * x), zz = 1.0 - s * (x * x + y * y);
    out[i] = zx * vx[i] + zy * vy[i] + zz * vz[i];
  }
  return out;
}

Table1Metrics table1Metrics(const LogTable& log, const TraverseWindow& window) {
  if (!window.found) throw std::invalid_argument("table1Metrics: no traverse window");
  const auto& t = log.column("time[s]");
  const auto& wy = log.column("base_wy[rad/s]");
  const std::vector<double> vz = localVz(log);
  Table1Metrics m;
  m.traverse_time = window.end - window.start;
  const auto& x = log.column("base_x[m]");
  const auto& y = log.column("base_y[m]");
  double vz_sum = 0.0, wy_sum = 0.0;
  std::size_t first = t.size(), last = 0;
  for (std::size_t i = 0; i < t.size(); ++i) {
    if (t[i] < window.start - 1e-9 || t[i] > window.end + 1e-9) continue;
    vz_sum += std::abs(vz[i]);
    wy_sum += std::abs(wy[i]);
    ++m.samples;
    first = std::min(first, i);
    last = i;
  }
  if (m.samples > 0) {
    m.distance = std::hypot(x[last] - x[first], y[last] - y[first]);
    m.mean_abs_vz = vz_sum / m.samples;
    m.mean_abs_wy = wy_sum / m.samples;
  }
  return m;
}

RunAssessment assessRun(const LogTable& log, const std::vector<JointLimit>& limits,
                        const RunCriteria& criteria, bool traverse_required,
                        const TraverseLegs& legs, double up_height) {
  RunAssessment a;
  const auto& t = log.column("time[s]");
  if (t.empty()) {
    a.failures.push_back("the log has no rows");
    return a;
  }
  a.duration = t.back() - t.front();
  // Tilt: angle between the base z axis and the world z axis.
  const auto& qw = log.column("base_qw[-]");
  const auto& qx = log.column("base_qx[-]");
  const auto& qy = log.column("base_qy[-]");
  const auto& qz = log.column("base_qz[-]");
  double tilt_time = 0.0;
  for (std::size_t i = 0; i < t.size(); ++i) {
    const double n2 = qw[i] * qw[i] + qx[i] * qx[i] + qy[i] * qy[i] + qz[i] * qz[i];
    const double zz = 1.0 - 2.0 * (qx[i] * qx[i] + qy[i] * qy[i]) / n2;
    double tilt = std::acos(std::max(-1.0, std::min(1.0, zz)));
    if (!std::isfinite(tilt)) tilt = M_PI;  // a broken orientation counts as a fall
    if (tilt > a.max_tilt) {
      a.max_tilt = tilt;
      tilt_time = t[i];
    }
  }
  if (a.max_tilt > criteria.max_tilt) {
    a.failures.push_back(
        formatText("fell: the base tilted %.0f deg (at t = %.2f s; limit %.0f deg)",
                   a.max_tilt * 180.0 / M_PI, tilt_time, criteria.max_tilt * 180.0 / M_PI));
  }
  if (log.has("body_contact_periods[-]")) {
    const auto& b = log.column("body_contact_periods[-]");
    a.body_contact_periods = static_cast<long>(b.back());
    for (std::size_t i = 0; i < b.size(); ++i) {
      if (b[i] > 0.5) {
        a.failures.push_back(
            formatText("the body touched the terrain (first logged at t = %.2f s, %.0f "
                       "control periods of contact in all)",
                       t[i], static_cast<double>(b.back())));
        break;
      }
    }
  } else {
    a.failures.push_back("body contact not checked: the log has no body_contact_periods[-]");
  }
  for (const JointLimit& limit : limits) {
    std::string column;
    for (const std::string& name : log.names()) {
      if (name.rfind("q_" + limit.name + "[", 0) == 0) column = name;
    }
    if (column.empty()) {
      a.failures.push_back("joint " + limit.name + " not checked: the log has no q_" + limit.name);
      continue;
    }
    const auto& q = log.column(column);
    double worst = 0.0, worst_value = 0.0, worst_time = 0.0;
    for (std::size_t i = 0; i < q.size(); ++i) {
      const double over = std::max(limit.lower - q[i], q[i] - limit.upper);
      if (over > worst || !std::isfinite(q[i])) {
        worst = std::isfinite(q[i]) ? over : std::numeric_limits<double>::infinity();
        worst_value = q[i];
        worst_time = t[i];
      }
    }
    if (worst > criteria.joint_limit_tolerance) {
      a.failures.push_back(limit.name +
                           formatText(" left its limits: %.4f at t = %.2f s (range [%.4f, %.4f])",
                                      worst_value, worst_time, limit.lower, limit.upper));
    }
  }
  a.window = findTraverseWindow(log, legs, up_height);
  if (a.window.found) {
    a.metrics = table1Metrics(log, a.window);
  } else if (traverse_required) {
    a.failures.push_back("did not traverse the step: " + a.window.reason);
  }
  return a;
}

double relativeChange(double candidate, double baseline) {
  if (baseline == 0.0) return std::numeric_limits<double>::quiet_NaN();
  return (candidate - baseline) / baseline;
}

}  // namespace rollstep::experiments
