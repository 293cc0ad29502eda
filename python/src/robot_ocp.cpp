// The robot's full-centroidal OCP (centroidal::CentroidalOcp) with its solver, built as
// `rollstep plan` builds it (apps/plan_command.cpp), and the scene description its terrain
// comes from. Solves release the GIL: two OCPs solve in parallel from two Python threads.
#include <algorithm>
#include <chrono>
#include <filesystem>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "bindings.hpp"
#include "rollstep/centroidal/centroidal_ocp.hpp"
#include "rollstep/common/number_text.hpp"
#include "rollstep/sim/scene.hpp"
#include "rollstep/sim/scene_terrain.hpp"
#include "rollstep/solver/solver.hpp"

namespace rollstep::python {

namespace {

namespace fs = std::filesystem;
using Eigen::MatrixXd;
using Eigen::VectorXd;

/// A robot folder (its centroidal.yaml) or the description file itself.
std::string descriptionFile(const std::string& robot) {
  const fs::path p(robot);
  return fs::is_directory(p) ? (p / "centroidal.yaml").string() : robot;
}

lie::SE3 planarPose(double x, double y, double yaw) {
  lie::SE3 pose = lie::SE3::Identity();
  pose.translation = Eigen::Vector3d(x, y, 0.0);
  pose.rotation = Eigen::Quaterniond(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()));
  return pose;
}

/// One OCP and its solver; every method locks `mutex` (a solve runs without the GIL).
struct RobotOcp {
  RobotOcp(const std::string& robot, const centroidal::OcpSettings& settings,
           const sim::SceneConfig& scene, const std::string& gait, double vx, double vy,
           double yaw_rate, double x, double y, double yaw)
      : description_file(descriptionFile(robot)),
        description(centroidal::loadRobotOcpDescription(description_file)),
        ocp(std::make_unique<centroidal::CentroidalOcp>(
            description, settings,
            sim::terrainFromScene(scene, centroidal::footholdRegionMargin(description, settings)),
            centroidal::gaitKindFromString(gait))) {
    checkFinite(Eigen::Vector3d(vx, vy, yaw_rate), "command");
    checkFinite(Eigen::Vector3d(x, y, yaw), "start");
    ocp->reset(0.0, planarPose(x, y, yaw), planning::BaseVelocityCommand{vx, vy, yaw_rate});
    solver = std::make_unique<solver::Solver>(ocp->problem(), settings.solver);
    start = Eigen::Vector3d(x, y, yaw);
    coldStart();
  }

  void coldStart() {
    std::vector<VectorXd> xs, us;
    ocp->initialGuess(xs, us);
    solver->setInitialGuess(xs, us);
  }

  VectorXd checkedState(const std::optional<VectorXd>& x) const {
    if (!x) return ocp->standingState(start[0], start[1], start[2]);
    checkSize(x->size(), ocp->robot().nx(), "x0");
    return *x;
  }

  std::string description_file;
  centroidal::RobotOcpDescription description;
  std::unique_ptr<centroidal::CentroidalOcp> ocp;
  std::unique_ptr<solver::Solver> solver;
  Eigen::Vector3d start = Eigen::Vector3d::Zero();  // x [m], y [m], yaw [rad] of the reset
  double solve_time = 0.0;                          // [s] wall time of the last solve/update
  mutable std::mutex mutex;
};

using Lock = std::lock_guard<std::mutex>;

MatrixXd stackRows(const std::vector<VectorXd>& v) {
  MatrixXd out(static_cast<Eigen::Index>(v.size()), v.empty() ? 0 : v.front().size());
  for (std::size_t k = 0; k < v.size(); ++k) out.row(static_cast<Eigen::Index>(k)) = v[k];
  return out;
}

std::vector<VectorXd> splitRows(const MatrixXd& m, Eigen::Index rows, Eigen::Index cols,
                                const char* what) {
  if (m.rows() != rows || m.cols() != cols) {
    throw std::invalid_argument(std::string(what) + " has shape (" + std::to_string(m.rows()) +
                                ", " + std::to_string(m.cols()) + "); expected (" +
                                std::to_string(rows) + ", " + std::to_string(cols) + ")");
  }
  checkFinite(m, what);
  std::vector<VectorXd> out;
  for (Eigen::Index k = 0; k < rows; ++k) out.emplace_back(m.row(k).transpose());
  return out;
}

/// (n, nc, 3) array from a function giving a 3 x nc matrix per node.
template <class F>
py::array_t<double> perFoot(int n, int nc, F&& of_node) {
  py::array_t<double> a(
      {static_cast<py::ssize_t>(n), static_cast<py::ssize_t>(nc), py::ssize_t{3}});
  auto r = a.mutable_unchecked<3>();
  for (int k = 0; k < n; ++k) {
    const Eigen::Matrix3Xd m = of_node(k);
    for (int i = 0; i < nc; ++i) {
      for (int c = 0; c < 3; ++c) r(k, i, c) = m(c, i);
    }
  }
  return a;
}

py::dict statsDict(const std::vector<solver::IterationStats>& stats) {
  const auto column = [&](auto member) {
    VectorXd v(static_cast<Eigen::Index>(stats.size()));
    for (std::size_t k = 0; k < stats.size(); ++k) {
      v[static_cast<Eigen::Index>(k)] = static_cast<double>(stats[k].*member);
    }
    return v;
  };
  py::dict d;
  d["iteration"] = column(&solver::IterationStats::iteration);
  d["cost"] = column(&solver::IterationStats::cost);
  d["primal_residual"] = column(&solver::IterationStats::primal_residual);
  d["dual_residual"] = column(&solver::IterationStats::dual_residual);
  d["complementarity"] = column(&solver::IterationStats::complementarity);
  d["kkt_error"] = column(&solver::IterationStats::kkt_error);
  d["inertia_shift"] = column(&solver::IterationStats::inertia_shift);
  d["barrier"] = column(&solver::IterationStats::barrier);
  d["primal_step"] = column(&solver::IterationStats::primal_step);
  d["dual_step"] = column(&solver::IterationStats::dual_step);
  d["restoration"] = column(&solver::IterationStats::restoration);
  d["filter_reset"] = column(&solver::IterationStats::filter_reset);
  d["second_order_corrections"] = column(&solver::IterationStats::second_order_corrections);
  d["time_linearize_ms"] = column(&solver::IterationStats::time_linearize_ms);
  d["time_riccati_ms"] = column(&solver::IterationStats::time_riccati_ms);
  d["time_update_ms"] = column(&solver::IterationStats::time_update_ms);
  return d;
}

constexpr const char* kStatsDoc =
    "Iteration statistics of the last solve or real-time iteration, a dict of arrays (one "
    "entry per iteration): iteration, cost, primal_residual (inf-norm of defects and "
    "constraint violations), dual_residual, complementarity, kkt_error, inertia_shift, "
    "barrier, primal_step, dual_step, restoration (0/1), filter_reset (0/1), "
    "second_order_corrections, time_linearize_ms, time_riccati_ms, time_update_ms [ms]. "
    "Residuals are those of the point each iteration linearised at.";

}  // namespace

void bindRobotOcp(py::module_& m) {
  py::class_<sim::SceneConfig> scene_class(
      m, "SceneConfig",
      "A scene (docs/USER_GUIDE.md \"Scenes\"): friction, boxes and ramps, and the named "
      "parameters their numbers are computed from. Read and assign a parameter or friction as "
      "an attribute (scene.step1_height = 0.1), any number by its key path with get/set "
      "(scene.set('boxes[0].yaw_deg', 30)). Assignments are checked as the file loader checks "
      "the file (ValueError naming the key and the problem; the scene is left as it was).");
  // Sets one number, checked; the scene is unchanged when the result is invalid.
  const auto set_number = [](sim::SceneConfig& s, const std::string& path, double value) {
    sim::SceneConfig trial = s;
    sim::setSceneNumber(trial, path, value);
    try {
      trial.validate();
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(path + " = " + shortestNumberText(value) + ": " + e.what());
    }
    s = std::move(trial);
  };
  scene_class
      .def(py::init([](const std::string& name) { return sim::loadScene(name); }),
           py::arg("name") = "flat", "The scene of that name (config/scenes/NAME.yaml) or file.")
      .def_static(
          "load", [](const py::object& path) { return sim::loadSceneConfig(pathString(path)); },
          py::arg("path"), "Reads a scene file.")
      .def_static("parse", &sim::parseSceneConfig, py::arg("text"), py::arg("source") = "<text>",
                  "Reads scene YAML text.")
      .def(
          "to_yaml", [](const sim::SceneConfig& s) { return sim::toYaml(s); },
          "The scene as a complete scene file that parse reads back exactly.")
      .def_property_readonly(
          "name", [](const sim::SceneConfig& s) { return s.name; }, "The scene's name.")
      .def_property_readonly(
          "parameters",
          [](const sim::SceneConfig& s) {
            py::dict d;
            for (const sim::SceneParameter& p : s.parameters) d[py::str(p.name)] = p.value;
            return d;
          },
          "The named parameters and their values (a copy).")
      .def(
          "get",
          [](const sim::SceneConfig& s, const std::string& path) {
            return sim::sceneNumber(s, path);
          },
          py::arg("key"), "A number by key path: a parameter, 'friction', 'boxes[0].size[2]', ...")
      .def("set", set_number, py::arg("key"), py::arg("value"),
           "Sets a number by key path (checked).")
      .def("__getattr__",
           [](const sim::SceneConfig& s, const std::string& name) {
             if (name != "friction" &&
                 std::none_of(s.parameters.begin(), s.parameters.end(),
                              [&](const sim::SceneParameter& p) { return p.name == name; })) {
               throw py::attribute_error("scene " + s.name + " has no parameter '" + name + "'");
             }
             return sim::sceneNumber(s, name);
           })
      .def("__setattr__", [set_number](sim::SceneConfig& s, const std::string& name, double value) {
        set_number(s, name, value);
      });
  scene_class.def("__repr__", [](const sim::SceneConfig& s) {
    return "<rollstep.SceneConfig " + s.name + ">";
  });

  py::class_<RobotOcp>(m, "_RobotOcp",
                       "C++ side of rollstep.CentroidalOcp (see its documentation).")
      .def(py::init<const std::string&, const centroidal::OcpSettings&, const sim::SceneConfig&,
                    const std::string&, double, double, double, double, double, double>(),
           py::arg("robot"), py::arg("settings"), py::arg("scene"), py::arg("gait"), py::arg("vx"),
           py::arg("vy"), py::arg("yaw_rate"), py::arg("x"), py::arg("y"), py::arg("yaw"),
           py::call_guard<py::gil_scoped_release>())
      .def_property_readonly("description_file",
                             [](const RobotOcp& o) { return o.description_file; })
      .def_property_readonly(
          "model",
          [](const RobotOcp& o) {
            return std::const_pointer_cast<model::Model>(o.ocp->robot().modelPtr());
          })
      .def_property_readonly("settings", [](const RobotOcp& o) { return o.ocp->settings(); })
      .def_property_readonly("nx", [](const RobotOcp& o) { return o.ocp->robot().nx(); })
      .def_property_readonly("ndx", [](const RobotOcp& o) { return o.ocp->robot().ndx(); })
      .def_property_readonly("nu", [](const RobotOcp& o) { return o.ocp->robot().nu(); })
      .def_property_readonly("nc", [](const RobotOcp& o) { return o.ocp->robot().nc(); })
      .def_property_readonly("nj", [](const RobotOcp& o) { return o.ocp->robot().nj(); })
      .def_property_readonly("horizon",
                             [](const RobotOcp& o) { return o.ocp->problem()->horizon(); })
      .def_property_readonly("dt", [](const RobotOcp& o) { return o.ocp->problem()->dt(); })
      .def_property_readonly("contact_names",
                             [](const RobotOcp& o) { return o.ocp->contactNames(); })
      .def_property_readonly("joint_names",
                             [](const RobotOcp& o) { return o.ocp->robot().model().jointNames; })
      .def_property_readonly("tangent_names",
                             [](const RobotOcp& o) { return o.ocp->robot().tangentNames(); })
      .def_property_readonly("input_names",
                             [](const RobotOcp& o) { return o.ocp->robot().inputNames(); })
      .def("standing_state",
           [](const RobotOcp& o, double x, double y, double yaw) {
             const Lock lock(o.mutex);
             return o.ocp->standingState(x, y, yaw);
           })
      .def("reset",
           [](RobotOcp& o, double t0, double x, double y, double yaw, double vx, double vy,
              double yaw_rate) {
             checkFinite(Eigen::Vector3d(vx, vy, yaw_rate), "command");
             checkFinite(Eigen::Vector4d(t0, x, y, yaw), "start");
             const Lock lock(o.mutex);
             o.ocp->reset(t0, planarPose(x, y, yaw),
                          planning::BaseVelocityCommand{vx, vy, yaw_rate});
             o.start = Eigen::Vector3d(x, y, yaw);
           })
      .def("reset_schedule",
           [](RobotOcp& o, double t0, double x, double y, double yaw, const MatrixXd& schedule) {
             if (schedule.cols() != 4 || schedule.rows() < 1) {
               throw std::invalid_argument(
                   "command schedule: expected rows (time [s], vx [m/s], vy [m/s], yaw_rate "
                   "[rad/s]), at least one");
             }
             checkFinite(schedule, "command schedule");
             std::vector<planning::TimedBaseCommand> s;
             for (Eigen::Index r = 0; r < schedule.rows(); ++r) {
               s.push_back({schedule(r, 0), {schedule(r, 1), schedule(r, 2), schedule(r, 3)}});
             }
             const Lock lock(o.mutex);
             o.ocp->resetSchedule(t0, planarPose(x, y, yaw), s);
             o.start = Eigen::Vector3d(x, y, yaw);
           })
      .def("set_terrain",
           [](RobotOcp& o, const sim::SceneConfig& scene) {
             planning::TerrainModel terrain = sim::terrainFromScene(
                 scene, centroidal::footholdRegionMargin(o.description, o.ocp->settings()));
             const Lock lock(o.mutex);
             if (!o.ocp->swapTerrain(terrain)) {
               throw std::invalid_argument(
                   "set_terrain: the OCP cannot take this terrain (its foothold regions "
                   "exist only when the first terrain had regions, and a region may have at "
                   "most " +
                   std::to_string(o.ocp->regionEdgeCapacity()) + " edges)");
             }
           })
      .def("cold_start",
           [](RobotOcp& o) {
             const Lock lock(o.mutex);
             o.coldStart();
           })
      .def("initial_guess",
           [](const RobotOcp& o) {
             std::vector<VectorXd> xs, us;
             const Lock lock(o.mutex);
             o.ocp->initialGuess(xs, us);
             return py::make_tuple(stackRows(xs), stackRows(us));
           })
      .def("set_initial_guess",
           [](RobotOcp& o, const MatrixXd& xs, const MatrixXd& us) {
             const Lock lock(o.mutex);
             const int N = o.ocp->problem()->horizon();
             o.solver->setInitialGuess(splitRows(xs, N + 1, o.ocp->robot().nx(), "xs"),
                                       splitRows(us, N, o.ocp->robot().nu(), "us"));
           })
      .def("solve",
           [](RobotOcp& o, const std::optional<VectorXd>& x0) {
             solver::SolverStatus status{};
             {
               py::gil_scoped_release release;
               const Lock lock(o.mutex);
               const VectorXd x = o.checkedState(x0);
               const auto t0 = std::chrono::steady_clock::now();
               status = o.solver->solve(x);
               o.solve_time =
                   std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
             }
             return std::string(solver::toString(status));
           })
      .def("realtime_iteration",
           [](RobotOcp& o, double t, const VectorXd& x) {
             checkFinite(Eigen::Matrix<double, 1, 1>(t), "t");
             solver::SolverStatus status{};
             {
               py::gil_scoped_release release;
               const Lock lock(o.mutex);
               checkSize(x.size(), o.ocp->robot().nx(), "x");
               const auto t0 = std::chrono::steady_clock::now();
               o.ocp->advance(t);
               o.ocp->anchorStanceFeet(o.ocp->problem()->modeSchedule(), t, x);
               o.ocp->landLateFeet(o.ocp->problem()->modeSchedule(), t, x);
               status = o.solver->update(t, x);
               o.solve_time =
                   std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
             }
             return std::string(solver::toString(status));
           })
      .def_property_readonly("states",
                             [](const RobotOcp& o) {
                               const Lock lock(o.mutex);
                               return stackRows(o.solver->states());
                             })
      .def_property_readonly("inputs",
                             [](const RobotOcp& o) {
                               const Lock lock(o.mutex);
                               return stackRows(o.solver->inputs());
                             })
      .def_property_readonly("times",
                             [](const RobotOcp& o) {
                               const Lock lock(o.mutex);
                               const int N = o.ocp->problem()->horizon();
                               VectorXd t(N + 1);
                               for (int k = 0; k <= N; ++k)
                                 t[k] = o.ocp->problem()->context(k).time;
                               return t;
                             })
      .def_property_readonly("modes",
                             [](const RobotOcp& o) {
                               const Lock lock(o.mutex);
                               const int N = o.ocp->problem()->horizon();
                               Eigen::VectorXi modes(N + 1);
                               for (int k = 0; k <= N; ++k)
                                 modes[k] = o.ocp->problem()->context(k).mode;
                               return modes;
                             })
      .def_property_readonly(
          "contact_forces",
          [](const RobotOcp& o) {
            const Lock lock(o.mutex);
            const centroidal::CentroidalRobot& r = o.ocp->robot();
            const std::vector<VectorXd>& us = o.solver->inputs();
            return perFoot(static_cast<int>(us.size()), r.nc(), [&](int k) {
              return Eigen::Matrix3Xd(Eigen::Map<const Eigen::Matrix3Xd>(
                  us[static_cast<std::size_t>(k)].data() + r.inputForceIndex(0), 3, r.nc()));
            });
          })
      .def_property_readonly("foot_positions",
                             [](const RobotOcp& o) {
                               const Lock lock(o.mutex);
                               const std::vector<VectorXd>& xs = o.solver->states();
                               return perFoot(
                                   static_cast<int>(xs.size()), o.ocp->robot().nc(), [&](int k) {
                                     return o.ocp->footPositions(xs[static_cast<std::size_t>(k)]);
                                   });
                             })
      .def_property_readonly("base_twists",
                             [](const RobotOcp& o) {
                               const Lock lock(o.mutex);
                               const std::vector<VectorXd>& xs = o.solver->states();
                               const std::vector<VectorXd>& us = o.solver->inputs();
                               const std::size_t N = us.size();
                               MatrixXd out(static_cast<Eigen::Index>(xs.size()), 6);
                               for (std::size_t k = 0; k < xs.size(); ++k) {
                                 out.row(static_cast<Eigen::Index>(k)) =
                                     o.ocp->baseTwist(xs[k], us[std::min(k, N - 1)]).transpose();
                               }
                               return out;
                             })
      .def_property_readonly(
          "joint_torques",
          [](const RobotOcp& o) {
            const Lock lock(o.mutex);
            const std::vector<VectorXd>& xs = o.solver->states();
            const std::vector<VectorXd>& us = o.solver->inputs();
            MatrixXd out(static_cast<Eigen::Index>(us.size()), o.ocp->robot().nj());
            for (std::size_t k = 0; k < us.size(); ++k) {
              out.row(static_cast<Eigen::Index>(k)) = o.ocp->jointTorques(xs[k], us[k]).transpose();
            }
            return out;
          })
      .def_property_readonly("status",
                             [](const RobotOcp& o) {
                               const Lock lock(o.mutex);
                               return std::string(solver::toString(o.solver->status()));
                             })
      .def_property_readonly("message",
                             [](const RobotOcp& o) {
                               const Lock lock(o.mutex);
                               return std::string(o.solver->message());
                             })
      .def_property_readonly("iterations",
                             [](const RobotOcp& o) {
                               const Lock lock(o.mutex);
                               return o.solver->iterations();
                             })
      .def_property_readonly("cost",
                             [](const RobotOcp& o) {
                               const Lock lock(o.mutex);
                               return o.solver->cost();
                             })
      .def("feedback_gain",
           [](const RobotOcp& o, int k) {
             const Lock lock(o.mutex);
             const int N = o.ocp->problem()->horizon();
             if (k < 0 || k >= N) {
               throw std::out_of_range("node " + std::to_string(k) + " out of range [0, " +
                                       std::to_string(N) + ")");
             }
             return MatrixXd(o.solver->feedbackGain(k));
           })
      .def_property_readonly("solve_time", [](const RobotOcp& o) { return o.solve_time; })
      .def_property_readonly(
          "stats",
          [](const RobotOcp& o) {
            const Lock lock(o.mutex);
            return statsDict(o.solver->stats());
          },
          kStatsDoc)
      .def("constraint_violations", [](const RobotOcp& o) {
        const Lock lock(o.mutex);
        py::list out;
        for (const centroidal::ConstraintViolation& v : centroidal::constraintViolations(
                 *o.ocp->problem(), o.solver->states(), o.solver->inputs())) {
          py::dict d;
          d["group"] = v.group;
          d["value"] = v.value;
          d["node"] = v.node;
          d["row"] = v.row;
          out.append(d);
        }
        return out;
      });
  m.attr("_STATS_DOC") = kStatsDoc;
}

}  // namespace rollstep::python
