#include "rollstep/sim/scenario.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>
#include <string>
#include <thread>

#include "rollstep/common/interrupt.hpp"

namespace rollstep::sim {

std::string csvHeader(const PlantLayout& layout) {
  std::string h =
      "time[s],base_x[m],base_y[m],base_z[m],base_qw[-],base_qx[-],base_qy[-],base_qz[-],"
      "base_vx[m/s],base_vy[m/s],base_vz[m/s],base_wx[rad/s],base_wy[rad/s],base_wz[rad/s]";
  for (const char* prefix : {"q_", "cmd_"}) {
    for (int j = 0; j < layout.numJoints(); ++j) {
      h += std::string(",") + prefix + layout.joints[static_cast<std::size_t>(j)].name + "[" +
           layout.jointUnit(j) + "]";
    }
  }
  for (const char* prefix : {"wheel_vel_", "cmd_wheel_"}) {
    for (int leg : layout.drive_wheel_legs) {
      h += std::string(",") + prefix + layout.legs[static_cast<std::size_t>(leg)].name + "[rad/s]";
    }
  }
  for (const PlantLayout::Leg& leg : layout.legs) h += ",contact_" + leg.name + "[0/1]";
  for (const PlantLayout::Leg& leg : layout.legs) h += ",fz_" + leg.name + "[N]";
  for (const PlantLayout::Leg& leg : layout.legs) h += ",foot_z_" + leg.name + "[m]";
  for (const char* prefix : {"fx_", "fy_"}) {
    for (const PlantLayout::Leg& leg : layout.legs) h += "," + (prefix + leg.name) + "[N]";
  }
  for (const char* axis : {"x_", "y_", "z_"}) {
    for (const PlantLayout::Leg& leg : layout.legs) {
      h += ",contact_point_" + (axis + leg.name) + "[m]";
    }
  }
  h += ",body_contact_periods[-]";
  return h;
}

CsvLog::CsvLog(const std::string& path, const PlantLayout& layout, const std::string& extra_columns)
    : file_(path) {
  file_.write(csvHeader(layout));
  file_.write(extra_columns);
  file_.write("\n");
}

void CsvLog::write(const GroundTruth& t, const PlantCommand& c, const std::string& extra) {
  file_.printf("%.4f,%.6f,%.6f,%.6f,%.6f,%.6f,%.6f,%.6f,%.5f,%.5f,%.5f,%.5f,%.5f,%.5f", t.time,
               t.base_position.x(), t.base_position.y(), t.base_position.z(),
               t.base_orientation.w(), t.base_orientation.x(), t.base_orientation.y(),
               t.base_orientation.z(), t.base_linear_velocity.x(), t.base_linear_velocity.y(),
               t.base_linear_velocity.z(), t.base_angular_velocity.x(), t.base_angular_velocity.y(),
               t.base_angular_velocity.z());
  for (Eigen::Index j = 0; j < t.joint_position.size(); ++j) {
    file_.printf(",%.6f", t.joint_position[j]);
  }
  for (Eigen::Index j = 0; j < c.joint_position.size(); ++j) {
    file_.printf(",%.6f", c.joint_position[j]);
  }
  for (Eigen::Index w = 0; w < t.wheel_velocity.size(); ++w) {
    file_.printf(",%.4f", t.wheel_velocity[w]);
  }
  for (Eigen::Index w = 0; w < c.wheel_velocity.size(); ++w) {
    file_.printf(",%.4f", c.wheel_velocity[w]);
  }
  for (bool contact : t.foot_contact) file_.write(contact ? ",1" : ",0");
  for (const Eigen::Vector3d& f : t.foot_force) file_.printf(",%.3f", f.z());
  for (const Eigen::Vector3d& w : t.wheel_center) file_.printf(",%.5f", w.z());
  for (int axis = 0; axis < 2; ++axis) {
    for (const Eigen::Vector3d& f : t.foot_force) file_.printf(",%.3f", f[axis]);
  }
  for (int axis = 0; axis < 3; ++axis) {
    for (const Eigen::Vector3d& p : t.contact_point) file_.printf(",%.5f", p[axis]);
  }
  file_.printf(",%ld", t.body_contact_periods);
  file_.write(extra);
  file_.write("\n");
}

double yawOf(const Eigen::Quaterniond& q) {
  const Eigen::Vector3d x = q * Eigen::Vector3d::UnitX();
  return std::atan2(x.y(), x.x());
}

RunSummary runScenario(Plant& plant, Controller& controller, double duration, CsvLog* log,
                       int log_every, const ProgressCallback& progress) {
  if (!std::isfinite(duration) || duration < 0.0 || duration > 1e6) {
    throw std::invalid_argument("runScenario: duration = " + std::to_string(duration) +
                                " s: must be finite and in [0, 1e6] s");
  }
  if (log_every < 1) {
    throw std::invalid_argument("runScenario: log_every = " + std::to_string(log_every) +
                                ": must be >= 1");
  }
  RunSummary s;
  const long steps = std::lround(duration / plant.controlPeriod());
  const GroundTruth& truth = plant.groundTruth();
  s.start_position = truth.base_position;
  s.min_base_height = s.max_base_height = truth.base_position.z();
  double yaw = yawOf(truth.base_orientation);
  double yaw_change = 0.0;
  const int warnings0 = plant.warningCount();
  PlantCommand command = plant.command();
  double speed_sum = 0.0;
  long all_contact = 0;
  std::string extra;
  extra.reserve(2048);  // a controller's columns: no growth inside the loop
  if (log != nullptr) {
    controller.logValues(extra);
    log->write(truth, command, extra);
  }
  const auto wall0 = std::chrono::steady_clock::now();
  auto next_report = wall0 + std::chrono::seconds(1);
  const bool paced = controller.paceToWallClock();
  const auto period = std::chrono::duration<double>(plant.controlPeriod());
  for (long k = 1; k <= steps; ++k) {
    throwIfInterrupted();  // SIGINT/SIGTERM once the program has deferred them (interrupt.hpp)
    if (paced) {
      std::this_thread::sleep_until(wall0 +
                                    std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                        static_cast<double>(k - 1) * period));
    }
    controller.compute(plant.time(), plant.sensors(), command);
    plant.setCommand(command);
    plant.step();
    s.min_base_height = std::min(s.min_base_height, truth.base_position.z());
    s.max_base_height = std::max(s.max_base_height, truth.base_position.z());
    // Unwrapped: the yaw moves by far less than pi per control period.
    const double yaw_now = yawOf(truth.base_orientation);
    yaw_change += std::remainder(yaw_now - yaw, 2.0 * M_PI);
    yaw = yaw_now;
    speed_sum += (truth.base_orientation.conjugate() * truth.base_linear_velocity).x();
    all_contact +=
        std::all_of(truth.foot_contact.begin(), truth.foot_contact.end(), [](bool c) { return c; })
            ? 1
            : 0;
    if (log != nullptr && k % log_every == 0) {
      controller.logValues(extra);
      log->write(truth, command, extra);
    }
    if (progress && k % 100 == 0) {
      const auto now = std::chrono::steady_clock::now();
      if (now >= next_report) {
        next_report = now + std::chrono::seconds(1);
        progress(Progress{static_cast<double>(k) * plant.controlPeriod(), duration,
                          std::chrono::duration<double>(now - wall0).count()});
      }
    }
  }
  s.wall_time = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
  s.sim_time = static_cast<double>(steps) * plant.controlPeriod();
  s.real_time_factor = s.wall_time > 0.0 ? s.sim_time / s.wall_time : 0.0;
  s.end_position = truth.base_position;
  s.yaw_change = yaw_change;
  s.mean_forward_speed = steps > 0 ? speed_sum / static_cast<double>(steps) : 0.0;
  s.all_feet_contact_fraction =
      steps > 0 ? static_cast<double>(all_contact) / static_cast<double>(steps) : 0.0;
  s.warnings = plant.warningCount() - warnings0;
  return s;
}

}  // namespace rollstep::sim
