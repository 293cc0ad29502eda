// The MuJoCo simulation of `rollstep sim` (apps/sim_command.cpp): a scene, the robot's
// plant and one of the existing controllers, stepped at the control rate with the state
// readable between steps, and its log kept in memory at full precision (the columns and
// units of sim::csvHeader() and the controller's own columns).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <limits>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "bindings.hpp"
#include "rollstep/centroidal/centroidal_ocp.hpp"
#include "rollstep/control/control_settings.hpp"
#include "rollstep/sim/cbfqp_controller.hpp"
#include "rollstep/sim/nmpc_controller.hpp"
#include "rollstep/sim/plant.hpp"
#include "rollstep/sim/scenario.hpp"
#include "rollstep/sim/scene.hpp"
#include "rollstep/sim/scene_terrain.hpp"
#include "rollstep/sim/simple_controllers.hpp"

namespace rollstep::python {

namespace {

namespace fs = std::filesystem;

std::vector<std::string> splitColumns(const std::string& text) {
  std::vector<std::string> out;
  std::size_t start = 0;
  while (start <= text.size()) {
    const std::size_t comma = text.find(',', start);
    const std::string item =
        text.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
    if (!item.empty()) out.push_back(item);
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  return out;
}

/// A robot folder's centroidal.yaml, or the file itself.
std::string descriptionFile(const std::string& robot) {
  return fs::is_directory(robot) ? (fs::path(robot) / "centroidal.yaml").string() : robot;
}

struct Simulation {
  Simulation(const sim::SceneConfig& scene, const std::string& controller_name,
             const std::string& robot_file, const std::string& robot_description,
             const control::ControlSettings& settings, const std::string& gait, double vx,
             double vy, double yaw_rate, double speed, double turn_speed, int log_every_)
      : plant(scene,
              [&] {
                sim::PlantOptions o;
                o.robot_file = robot_file;
                const centroidal::RobotOcpDescription d =
                    centroidal::loadRobotOcpDescription(descriptionFile(robot_description));
                o.contact_frames = d.contact_frames;
                o.drive_wheels = d.drive_wheels;
                return o;
              }()),
        log_every(log_every_) {
    if (log_every < 1) {
      throw std::invalid_argument("log_every = " + std::to_string(log_every) + ": must be >= 1");
    }
    checkFinite(Eigen::Vector3d(vx, vy, yaw_rate), "command");
    const std::string description = descriptionFile(robot_description);
    if (controller_name == "stand") {
      controller = std::make_unique<sim::StandController>(plant.nominalCommand());
    } else if (controller_name == "drive") {
      double radius = std::numeric_limits<double>::infinity();
      for (const int leg : plant.layout().drive_wheel_legs) {
        radius = std::min(radius, plant.wheelRadius(leg));
      }
      const double limit =
          plant.layout().numDriveWheels() > 0 ? plant.wheelSpeedLimit() * radius : 0.0;
      if (!std::isfinite(speed) || !std::isfinite(turn_speed) ||
          std::abs(speed) + std::abs(turn_speed) > limit) {
        throw std::invalid_argument(
            "speed " + std::to_string(speed) + " with turn_speed " + std::to_string(turn_speed) +
            ": valid range |speed| + |turn_speed| <= " + std::to_string(limit) +
            " m/s (the drive wheels' limit)");
      }
      sim::DriveController::Params p;
      p.speed = speed;
      p.turn_speed = turn_speed;
      controller = std::make_unique<sim::DriveController>(plant, p);
    } else if (controller_name == "nmpc") {
      const centroidal::RobotOcpDescription robot =
          centroidal::loadRobotOcpDescription(description);
      const double margin = centroidal::footholdRegionMargin(robot, settings.ocp);
      controller = std::make_unique<sim::NmpcController>(
          plant, robot, settings, sim::terrainFromScene(scene, margin),
          centroidal::gaitKindFromString(gait), planning::BaseVelocityCommand{vx, vy, yaw_rate});
    } else if (controller_name == "cbfqp") {
      const centroidal::RobotOcpDescription robot =
          centroidal::loadRobotOcpDescription(description);
      controller = std::make_unique<sim::CbfQpController>(
          plant, robot, settings, sim::terrainFromScene(scene, settings.baseline.foothold_margin),
          sim::terrainFromScene(scene, 0.0), centroidal::gaitKindFromString(gait),
          planning::BaseVelocityCommand{vx, vy, yaw_rate});
    } else {
      throw std::invalid_argument("controller '" + controller_name +
                                  "': valid: stand, drive, nmpc, cbfqp");
    }
    names = splitColumns(sim::csvHeader(plant.layout()) + controller->logColumns());
    columns.resize(names.size());
    command = plant.command();
    record();
  }

  /// One log row: the ground truth at full precision, then the controller's columns.
  void record() {
    const sim::GroundTruth& t = plant.groundTruth();
    std::size_t c = 0;
    const auto put = [&](double v) { columns[c++].push_back(v); };
    put(t.time);
    for (int i = 0; i < 3; ++i) put(t.base_position[i]);
    put(t.base_orientation.w());
    put(t.base_orientation.x());
    put(t.base_orientation.y());
    put(t.base_orientation.z());
    for (int i = 0; i < 3; ++i) put(t.base_linear_velocity[i]);
    for (int i = 0; i < 3; ++i) put(t.base_angular_velocity[i]);
    for (Eigen::Index j = 0; j < t.joint_position.size(); ++j) put(t.joint_position[j]);
    for (Eigen::Index j = 0; j < command.joint_position.size(); ++j) put(command.joint_position[j]);
    for (Eigen::Index w = 0; w < t.wheel_velocity.size(); ++w) put(t.wheel_velocity[w]);
    for (Eigen::Index w = 0; w < command.wheel_velocity.size(); ++w) put(command.wheel_velocity[w]);
    for (bool contact : t.foot_contact) put(contact ? 1.0 : 0.0);
    for (const Eigen::Vector3d& f : t.foot_force) put(f.z());
    for (const Eigen::Vector3d& w : t.wheel_center) put(w.z());
    for (int axis = 0; axis < 2; ++axis) {
      for (const Eigen::Vector3d& f : t.foot_force) put(f[axis]);
    }
    for (int axis = 0; axis < 3; ++axis) {
      for (const Eigen::Vector3d& p : t.contact_point) put(p[axis]);
    }
    put(static_cast<double>(t.body_contact_periods));
    controller->logValues(extra);
    for (const std::string& v : splitColumns(extra)) {
      if (c == columns.size()) break;
      char* end = nullptr;
      const double d = std::strtod(v.c_str(), &end);
      put(end != v.c_str() && *end == '\0' ? d : std::nan(""));
    }
    while (c < columns.size()) put(std::nan(""));
  }

  /// `steps` control periods, as sim::runScenario runs them.
  void advance(long steps) {
    const bool paced = controller->paceToWallClock();
    const auto wall0 = std::chrono::steady_clock::now();
    const auto period = std::chrono::duration<double>(plant.controlPeriod());
    for (long k = 1; k <= steps; ++k) {
      if (paced) {
        std::this_thread::sleep_until(
            wall0 + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                        static_cast<double>(k - 1) * period));
      }
      controller->compute(plant.time(), plant.sensors(), command);
      plant.setCommand(command);
      plant.step();
      if (++periods % log_every == 0) record();
    }
  }

  sim::Plant plant;
  std::unique_ptr<sim::Controller> controller;
  sim::PlantCommand command;
  int log_every;
  long periods = 0;
  std::vector<std::string> names;
  std::vector<std::vector<double>> columns;
  std::string extra;
  std::mutex mutex;
};

template <class V>
Eigen::VectorXd vec(const V& v) {
  return Eigen::VectorXd(v);
}

}  // namespace

void bindSimulation(py::module_& m) {
  py::class_<Simulation>(m, "_Simulation", "C++ side of rollstep.Simulation.")
      .def(py::init<const sim::SceneConfig&, const std::string&, const std::string&,
                    const std::string&, const control::ControlSettings&, const std::string&, double,
                    double, double, double, double, int>(),
           py::call_guard<py::gil_scoped_release>())
      .def("step",
           [](Simulation& s, long steps) {
             if (steps < 0 || steps > 1000000000L) {
               throw std::invalid_argument("steps = " + std::to_string(steps) +
                                           ": must be in [0, 1e9]");
             }
             py::gil_scoped_release release;
             const std::lock_guard<std::mutex> lock(s.mutex);
             s.advance(steps);
           })
      .def_property_readonly("control_period",
                             [](Simulation& s) { return s.plant.controlPeriod(); })
      .def_property_readonly("time", [](Simulation& s) { return s.plant.time(); })
      .def_property_readonly("controller_name",
                             [](Simulation& s) { return std::string(s.controller->name()); })
      .def("state",
           [](Simulation& s) {
             const std::lock_guard<std::mutex> lock(s.mutex);
             const sim::GroundTruth& t = s.plant.groundTruth();
             py::dict d;
             d["time"] = t.time;
             d["base_position"] = vec(t.base_position);
             d["base_orientation"] =
                 vec(Eigen::Vector4d(t.base_orientation.w(), t.base_orientation.x(),
                                     t.base_orientation.y(), t.base_orientation.z()));
             d["base_linear_velocity"] = vec(t.base_linear_velocity);
             d["base_angular_velocity"] = vec(t.base_angular_velocity);
             d["joint_position"] = vec(t.joint_position);
             d["joint_velocity"] = vec(t.joint_velocity);
             d["wheel_position"] = vec(t.wheel_position);
             d["wheel_velocity"] = vec(t.wheel_velocity);
             const int legs = s.plant.layout().numLegs();
             Eigen::MatrixXd centers(legs, 3), forces(legs, 3);
             Eigen::VectorXd contact(legs);
             for (int i = 0; i < legs; ++i) {
               const auto u = static_cast<std::size_t>(i);
               centers.row(i) = t.wheel_center[u].transpose();
               forces.row(i) = t.foot_force[u].transpose();
               contact[i] = t.foot_contact[u] ? 1.0 : 0.0;
             }
             d["wheel_center"] = centers;
             d["foot_force"] = forces;
             d["foot_contact"] = contact;
             d["body_contact"] = t.body_contact;
             d["command_joint_position"] = vec(s.command.joint_position);
             d["command_wheel_velocity"] = vec(s.command.wheel_velocity);
             return d;
           })
      .def("log_columns", [](Simulation& s) { return s.names; })
      .def("log_values", [](Simulation& s) {
        const std::lock_guard<std::mutex> lock(s.mutex);
        py::list out;
        for (const std::vector<double>& c : s.columns) {
          out.append(py::array_t<double>(static_cast<py::ssize_t>(c.size()), c.data()));
        }
        return out;
      });
}

}  // namespace rollstep::python
