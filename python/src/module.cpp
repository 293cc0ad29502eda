// The _rollstep extension module: every C++ exception reaches Python with its message
// (std::invalid_argument as ValueError, std::out_of_range as IndexError, the library's
// own errors as the classes registered below, any other std::exception as RuntimeError).
#include "bindings.hpp"
#include "rollstep/common/text_file.hpp"
#include "rollstep/common/yaml_tree.hpp"
#include "rollstep/model/model.hpp"
#include "rollstep/sim/plant.hpp"

PYBIND11_MODULE(_rollstep, m) {
  m.doc() =
      "rollstep: full-centroidal NMPC for telescopic-wheeled-legged robots (compiled part; "
      "import the `rollstep` package).";
  py::register_exception<rollstep::model::ModelError>(m, "ModelError", PyExc_RuntimeError).doc() =
      "A URDF that cannot be loaded (the message names the file, element and value).";
  py::register_exception<rollstep::yaml::YamlError>(m, "YamlError", PyExc_RuntimeError).doc() =
      "YAML text that cannot be parsed (the message names the source, line and column).";
  py::register_exception<rollstep::InputError>(m, "InputError", PyExc_RuntimeError).doc() =
      "An input file that cannot be used (missing, not a regular file, too large).";
  py::register_exception<rollstep::OutputError>(m, "OutputError", PyExc_RuntimeError).doc() =
      "An output file that could not be written completely.";
  py::register_exception<rollstep::sim::SimError>(m, "SimError", PyExc_RuntimeError).doc() =
      "The simulation failed (diverged, a scene or robot file that does not fit).";
  rollstep::python::bindModel(m);
  rollstep::python::bindSettings(m);
  rollstep::python::bindRobotOcp(m);
  rollstep::python::bindLqProblem(m);
  rollstep::python::bindSimulation(m);
}
