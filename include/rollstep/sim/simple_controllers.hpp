#pragma once
// Joint-hold and driving controllers for the plant demo, the plant tests and the CLI.
// They use no model and no estimator: the joints hold a posture, the drive wheels get
// velocity targets. Real controllers (MPC, CBF-QP) live in the control layer.
#include <algorithm>
#include <string>
#include <string_view>
#include <vector>

#include "rollstep/sim/plant.hpp"

namespace rollstep::sim {

/// A controller of the plant, called once per control period.
class Controller {
 public:
  virtual ~Controller() = default;
  /// Writes the command for time t [s] from the sensor readings.
  virtual void compute(double t, const SensorReadings& sensors, PlantCommand& command) = 0;
  virtual std::string_view name() const = 0;
  /// True if the simulation must run in step with the wall clock (a controller with a
  /// thread of its own, such as the asynchronous MPC): runScenario then waits until the wall
  /// clock reaches the simulated time before each period.
  virtual bool paceToWallClock() const { return false; }
  /// Extra CSV log columns of this controller, each as ",name[unit]" (none by default).
  virtual std::string logColumns() const { return {}; }
  /// The values of those columns after the last compute(), each as ",value" (the string
  /// keeps its capacity from call to call).
  virtual void logValues(std::string& out) const { out.clear(); }
};

/// Holds a joint posture (default: the plant's nominal posture), wheels at rest.
class StandController final : public Controller {
 public:
  explicit StandController(const PlantCommand& posture) : posture_(posture) {
    posture_.wheel_velocity.setZero();
  }
  void compute(double, const SensorReadings&, PlantCommand& command) override {
    command = posture_;
  }
  std::string_view name() const override { return "stand"; }

 private:
  PlantCommand posture_;
};

/// Holds the plant's nominal posture and rolls on the drive wheels: left wheels (first joint
/// at base y > 0) at surface speed v - turn_speed, right wheels (y < 0) at v + turn_speed,
/// wheels on the centre line at v [m/s], where v ramps from 0 to `speed` at `acceleration`
/// from `start_time`.
class DriveController final : public Controller {
 public:
  struct Params {
    double speed = 0.5;         ///< [m/s] forward surface speed of the wheels
    double turn_speed = 0.0;    ///< [m/s] right minus left surface speed, halved
    double acceleration = 1.0;  ///< [m/s^2] ramp of both speeds
    double start_time = 0.0;    ///< [s] wheels at rest before this time
  };
  DriveController(const Plant& plant, const Params& params)
      : posture_(plant.nominalCommand()), params_(params) {
    for (const int leg : plant.layout().drive_wheel_legs) {
      radius_.push_back(plant.wheelRadius(leg));
      const double y = plant.hipPosition(leg).y();
      side_.push_back(y > 0.0 ? -1.0 : (y < 0.0 ? 1.0 : 0.0));
    }
  }

  void compute(double t, const SensorReadings&, PlantCommand& command) override {
    command = posture_;
    const double elapsed = t - params_.start_time;
    if (elapsed <= 0.0) {
      command.wheel_velocity.setZero();
      return;
    }
    const auto ramp = [&](double target) {
      const double reach = params_.acceleration * elapsed;
      return target >= 0.0 ? std::min(target, reach) : std::max(target, -reach);
    };
    const double v = ramp(params_.speed);
    const double turn = ramp(params_.turn_speed);
    for (std::size_t w = 0; w < radius_.size(); ++w) {
      const double surface = side_[w] < 0.0 ? v - turn : (side_[w] > 0.0 ? v + turn : v);
      command.wheel_velocity[static_cast<Eigen::Index>(w)] = surface / radius_[w];
    }
  }
  std::string_view name() const override { return "drive"; }

 private:
  PlantCommand posture_;
  std::vector<double> radius_;  // per drive wheel [m]
  std::vector<double> side_;    // per drive wheel: -1 left, +1 right, 0 centre
  Params params_;
};

}  // namespace rollstep::sim
