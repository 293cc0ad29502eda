#include "rollstep/sim/scenario.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>

namespace rollstep::sim {

CsvLog::CsvLog(const std::string& path) : path_(path), file_(std::fopen(path.c_str(), "w")) {
  if (file_ == nullptr) throw SimError("log " + path + ": cannot open for writing");
  std::fputs(
      "time,base_x,base_y,base_z,base_qw,base_qx,base_qy,base_qz,base_vx,base_vy,base_vz,"
      "base_wx,base_wy,base_wz",
      file_);
  for (const char* prefix : {"q_", "cmd_"}) {
    for (int leg = 0; leg < kNumLegs; ++leg) {
      std::fprintf(file_, ",%s%s_hip,%s%s_knee", prefix, kLegNames[static_cast<std::size_t>(leg)],
                   prefix, kLegNames[static_cast<std::size_t>(leg)]);
    }
  }
  for (const char* prefix : {"wheel_vel_", "cmd_wheel_"}) {
    for (int leg : kDriveWheelLegs) {
      std::fprintf(file_, ",%s%s", prefix, kLegNames[static_cast<std::size_t>(leg)]);
    }
  }
  for (const char* prefix : {"contact_", "fz_"}) {
    for (const char* leg : kLegNames) std::fprintf(file_, ",%s%s", prefix, leg);
  }
  std::fputc('\n', file_);
}

CsvLog::~CsvLog() {
  if (file_ != nullptr) std::fclose(file_);
}

void CsvLog::write(const GroundTruth& t, const PlantCommand& c) {
  std::fprintf(file_, "%.4f,%.6f,%.6f,%.6f,%.6f,%.6f,%.6f,%.6f,%.5f,%.5f,%.5f,%.5f,%.5f,%.5f",
               t.time, t.base_position.x(), t.base_position.y(), t.base_position.z(),
               t.base_orientation.w(), t.base_orientation.x(), t.base_orientation.y(),
               t.base_orientation.z(), t.base_linear_velocity.x(), t.base_linear_velocity.y(),
               t.base_linear_velocity.z(), t.base_angular_velocity.x(), t.base_angular_velocity.y(),
               t.base_angular_velocity.z());
  for (int j = 0; j < kNumJoints; ++j) std::fprintf(file_, ",%.6f", t.joint_position[j]);
  for (int j = 0; j < kNumJoints; ++j) std::fprintf(file_, ",%.6f", c.joint_position[j]);
  for (int w = 0; w < kNumDriveWheels; ++w) std::fprintf(file_, ",%.4f", t.wheel_velocity[w]);
  for (int w = 0; w < kNumDriveWheels; ++w) std::fprintf(file_, ",%.4f", c.wheel_velocity[w]);
  for (bool contact : t.foot_contact) std::fprintf(file_, ",%d", contact ? 1 : 0);
  for (const Eigen::Vector3d& f : t.foot_force) std::fprintf(file_, ",%.3f", f.z());
  std::fputc('\n', file_);
}

double yawOf(const Eigen::Quaterniond& q) {
  const Eigen::Vector3d x = q * Eigen::Vector3d::UnitX();
  return std::atan2(x.y(), x.x());
}

RunSummary runScenario(Plant& plant, Controller& controller, double duration, CsvLog* log,
                       int log_every) {
  RunSummary s;
  const int steps = static_cast<int>(std::lround(duration / plant.controlPeriod()));
  const GroundTruth& truth = plant.groundTruth();
  s.start_position = truth.base_position;
  s.min_base_height = s.max_base_height = truth.base_position.z();
  const double yaw0 = yawOf(truth.base_orientation);
  const int warnings0 = plant.warningCount();
  PlantCommand command = plant.command();
  double speed_sum = 0.0;
  int all_contact = 0;
  if (log != nullptr) log->write(truth, command);
  const auto wall0 = std::chrono::steady_clock::now();
  for (int k = 1; k <= steps; ++k) {
    controller.compute(plant.time(), plant.sensors(), command);
    plant.setCommand(command);
    plant.step();
    s.min_base_height = std::min(s.min_base_height, truth.base_position.z());
    s.max_base_height = std::max(s.max_base_height, truth.base_position.z());
    speed_sum += (truth.base_orientation.conjugate() * truth.base_linear_velocity).x();
    all_contact +=
        std::all_of(truth.foot_contact.begin(), truth.foot_contact.end(), [](bool c) { return c; })
            ? 1
            : 0;
    if (log != nullptr && log_every > 0 && k % log_every == 0) log->write(truth, command);
  }
  s.wall_time = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
  s.sim_time = steps * plant.controlPeriod();
  s.real_time_factor = s.wall_time > 0.0 ? s.sim_time / s.wall_time : 0.0;
  s.end_position = truth.base_position;
  double dyaw = yawOf(truth.base_orientation) - yaw0;
  while (dyaw > M_PI) dyaw -= 2.0 * M_PI;
  while (dyaw <= -M_PI) dyaw += 2.0 * M_PI;
  s.yaw_change = dyaw;
  s.mean_forward_speed = steps > 0 ? speed_sum / steps : 0.0;
  s.all_feet_contact_fraction = steps > 0 ? static_cast<double>(all_contact) / steps : 0.0;
  s.warnings = plant.warningCount() - warnings0;
  return s;
}

}  // namespace rollstep::sim
