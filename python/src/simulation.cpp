// The MuJoCo simulation of `rollstep sim`: the run of a run spec built by sim::buildRun (as
// `rollstep sim` builds it: the plant, the controller, perception and the state estimator),
// stepped at the control rate with the state readable between steps, and its log kept in
// memory at full precision (the columns and units of sim::csvHeader() and the controller's
// own columns).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "bindings.hpp"
#include "rollstep/control/control_settings.hpp"
#include "rollstep/sim/run.hpp"
#include "rollstep/sim/scenario.hpp"

namespace rollstep::python {

namespace {

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

struct Simulation {
  /// The run of `spec` as buildRun builds it for `rollstep sim` (perception and the
  /// estimator included), with `control` and `scene` (then the spec's own, inline) instead
  /// of the spec's files when given.
  Simulation(const sim::RunSpec& spec, std::optional<control::ControlSettings> control_settings,
             std::optional<sim::SceneConfig> scene_config)
      : run(sim::buildRun(
            withScene(withControl(spec, std::move(control_settings)), std::move(scene_config)))),
        plant(*run.plant),
        log_every(spec.log_every) {
    if (sim::OnlinePerception* p = run.perception(); p != nullptr) p->openLog();
    names = splitColumns(sim::csvHeader(plant.layout()) + run.controller->logColumns());
    columns.resize(names.size());
    texts.resize(names.size());
    // A column without a unit holds words (the QP status), kept as text.
    for (const std::string& n : names) is_text.push_back(n.find('[') == std::string::npos);
    command = plant.command();
    record();
  }

  /// Settings given in code go into the spec inline (replacing its control_config), so that
  /// the spec written out runs the same again.
  static sim::RunSpec withControl(sim::RunSpec spec,
                                  std::optional<control::ControlSettings> settings) {
    if (settings) {
      spec.control = std::move(settings);
      spec.control_config.clear();
    }
    return spec;
  }

  /// A scene given in code goes into the spec inline (replacing its scene file), for the
  /// same reason; the spec's scene_parameters are set over it.
  static sim::RunSpec withScene(sim::RunSpec spec, std::optional<sim::SceneConfig> scene) {
    if (scene) {
      spec.scene = scene->name.empty() ? "inline" : scene->name;
      spec.scene_file.clear();
      spec.inline_scene = std::move(scene);
    }
    return spec;
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
    run.controller->logValues(extra);
    for (const std::string& v : splitColumns(extra)) {
      if (c == columns.size()) break;
      if (is_text[c]) {
        texts[c++].push_back(v);
        continue;
      }
      char* end = nullptr;
      const double d = std::strtod(v.c_str(), &end);
      put(end != v.c_str() && *end == '\0' ? d : std::nan(""));
    }
    while (c < columns.size()) {
      if (is_text[c]) {
        texts[c++].emplace_back();
      } else {
        put(std::nan(""));
      }
    }
  }

  /// `steps` control periods, as sim::runScenario runs them.
  void advance(long steps) {
    const bool paced = run.controller->paceToWallClock();
    const auto wall0 = std::chrono::steady_clock::now();
    const auto period = std::chrono::duration<double>(plant.controlPeriod());
    for (long k = 1; k <= steps; ++k) {
      if (paced) {
        std::this_thread::sleep_until(
            wall0 + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                        static_cast<double>(k - 1) * period));
      }
      run.controller->compute(plant.time(), plant.sensors(), command);
      plant.setCommand(command);
      plant.step();
      if (++periods % log_every == 0) record();
    }
  }

  sim::BuiltRun run;
  sim::Plant& plant;
  sim::PlantCommand command;
  int log_every;
  long periods = 0;
  std::vector<std::string> names;
  std::vector<std::vector<double>> columns;
  std::vector<std::vector<std::string>> texts;  ///< the text columns' values (is_text)
  std::vector<bool> is_text;
  std::string extra;
  std::mutex mutex;
};

template <class V>
Eigen::VectorXd vec(const V& v) {
  return Eigen::VectorXd(v);
}

}  // namespace

void bindSimulation(py::module_& m) {
  py::class_<sim::RunSpec>(m, "_RunSpec", "C++ RunSpec; use rollstep.RunSpec.")
      .def(py::init<>())
      .def(py::init<const sim::RunSpec&>())
      .def_static(
          "parse",
          [](const std::string& text, const std::string& source) {
            return sim::parseRunSpec(text, source);
          },
          py::arg("text"), py::arg("source"))
      .def_static("load", &sim::loadRunSpec, py::arg("path"))
      .def_static("defaults", &sim::runSpecDefaults)
      .def("to_yaml", [](const sim::RunSpec& s) { return sim::toYaml(s); })
      .def("check", [](const sim::RunSpec& s) { sim::checkRunSpec(s); })
      .def("update", [](sim::RunSpec& s, const std::string& text) {
        s = sim::parseRunSpec(text, "run spec RunSpec", "", s);  // s unchanged when refused
      });

  py::class_<Simulation>(m, "_Simulation", "C++ side of rollstep.Simulation.")
      .def(py::init<const sim::RunSpec&, std::optional<control::ControlSettings>,
                    std::optional<sim::SceneConfig>>(),
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
                             [](Simulation& s) { return std::string(s.run.controller->name()); })
      .def_property_readonly("controller_text", [](Simulation& s) { return s.run.controller_text; })
      .def_property_readonly("spec", [](Simulation& s) { return s.run.spec; })
      .def("spec_yaml",
           [](Simulation& s) { return sim::toYaml(sim::withAbsolutePaths(s.run.spec)); })
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
        const py::object array = py::module_::import("numpy").attr("array");
        for (std::size_t k = 0; k < s.columns.size(); ++k) {
          const std::vector<double>& c = s.columns[k];
          if (s.is_text[k]) {
            out.append(array(py::cast(s.texts[k]), py::arg("dtype") = "str"));
          } else {
            out.append(py::array_t<double>(static_cast<py::ssize_t>(c.size()), c.data()));
          }
        }
        return out;
      });
}

}  // namespace rollstep::python
