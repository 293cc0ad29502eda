// Settings objects backed by the C++ YAML readers: the Python attributes are the YAML keys
// (the C++ member names), and every assignment goes through the same parser and checks as
// a configuration file (rollstep/_settings.py does the attribute access).
#include <string>

#include "bindings.hpp"
#include "rollstep/centroidal/ocp_settings.hpp"
#include "rollstep/common/yaml_tree.hpp"
#include "rollstep/control/control_settings.hpp"
#include "rollstep/solver/settings_yaml.hpp"

namespace rollstep::python {

namespace {

/// A YAML node as Python values: mappings as dicts, sequences of numbers as float64 arrays
/// (other sequences as lists), plain scalars as bool, int or float where they read as one.
/// Not a settings reader: it only turns the text the settings tables wrote (every value
/// already read and checked by them) into Python values for to_dict() and attribute access,
/// whatever the table; so it has no keys, ranges or messages of its own to keep.
py::object toPython(const yaml::Node& n) {
  switch (n.kind()) {
    case yaml::Kind::Null:
      return py::none();
    case yaml::Kind::Scalar: {
      bool b = false;
      int i = 0;
      double d = 0.0;
      if (n.toBool(b)) return py::bool_(b);
      if (n.toInt(i)) return py::int_(i);
      if (n.toDouble(d)) return py::float_(d);
      return py::str(n.scalar());
    }
    case yaml::Kind::Sequence: {
      bool numeric = n.size() > 0;
      Eigen::VectorXd values(static_cast<Eigen::Index>(n.size()));
      for (std::size_t k = 0; k < n.size(); ++k) {
        numeric = numeric && n.item(k).toDouble(values[static_cast<Eigen::Index>(k)]);
      }
      if (numeric) return py::cast(values);
      py::list list;
      for (std::size_t k = 0; k < n.size(); ++k) list.append(toPython(n.item(k)));
      return std::move(list);
    }
    case yaml::Kind::Mapping: {
      py::dict dict;
      for (std::size_t k = 0; k < n.size(); ++k)
        dict[py::str(n.key(k).scalar())] = toPython(n.value(k));
      return std::move(dict);
    }
  }
  return py::none();
}

py::object yamlToPython(const std::string& text) {
  const yaml::Document doc = yaml::Document::parse(text);
  return toPython(doc.root());
}

// Where assignments come from, in the messages of the checks.
constexpr const char* kOcpSource = "OcpSettings";
constexpr const char* kSolverSource = "SolverSettings";

}  // namespace

void bindSettings(py::module_& m) {
  m.def("_yaml_to_python", &yamlToPython, py::arg("text"),
        "YAML text as Python values (dicts, lists, float64 arrays, scalars).");

  py::class_<centroidal::OcpSettings>(m, "_OcpSettings",
                                      "C++ OcpSettings; use rollstep.OcpSettings.")
      .def(py::init<>())
      .def(py::init<const centroidal::OcpSettings&>())
      .def_static(
          "parse",
          [](const std::string& text, const std::string& source) {
            return centroidal::parseOcpSettings(text, source);
          },
          py::arg("text"), py::arg("source"))
      .def_static("load", &centroidal::loadOcpSettings, py::arg("path"))
      .def("to_yaml", [](const centroidal::OcpSettings& s) { return centroidal::toYaml(s); })
      .def("to_dict",
           [](const centroidal::OcpSettings& s) { return yamlToPython(centroidal::toYaml(s)); })
      .def("update", [](centroidal::OcpSettings& s, const std::string& text) {
        const yaml::Document doc =
            yaml::parseDocument(text, std::string("OCP settings ") + kOcpSource + ": YAML error: ");
        s = centroidal::parseOcpSettings(doc.root(), s, kOcpSource, "", "OCP settings");
      });

  py::class_<solver::SolverSettings>(m, "_SolverSettings",
                                     "C++ SolverSettings; use rollstep.SolverSettings.")
      .def(py::init<>())
      .def(py::init<const solver::SolverSettings&>())
      .def_static(
          "parse",
          [](const std::string& text, const std::string& source) {
            return solver::parseSolverSettings(text, source);
          },
          py::arg("text"), py::arg("source"))
      .def_static("load", &solver::loadSolverSettings, py::arg("path"))
      .def("to_yaml", [](const solver::SolverSettings& s) { return solver::toYaml(s); })
      .def("to_dict",
           [](const solver::SolverSettings& s) { return yamlToPython(solver::toYaml(s)); })
      .def("update", [](solver::SolverSettings& s, const std::string& text) {
        const std::string head = std::string("solver settings ") + kSolverSource + ": ";
        const yaml::Document doc = yaml::parseDocument(text, head + "YAML error: ");
        solver::SolverSettings updated = s;  // s unchanged when the text is refused
        settings::Reader reader(head);
        solver::readSolverSettings(doc.root(), updated, reader, "");
        s = updated;
      });

  py::class_<control::ControlSettings>(m, "_ControlSettings",
                                       "C++ ControlSettings; use rollstep.ControlSettings.")
      .def(py::init<>())
      .def(py::init<const control::ControlSettings&>())
      .def_static("parse", &control::parseControlSettings, py::arg("text"), py::arg("source"))
      .def_static(
          "load", [](const std::string& path) { return control::loadControlSettings(path); },
          py::arg("path"))
      .def("to_yaml", [](const control::ControlSettings& s) { return control::toYaml(s); })
      .def("to_dict",
           [](const control::ControlSettings& s) { return yamlToPython(control::toYaml(s)); });
}

}  // namespace rollstep::python
