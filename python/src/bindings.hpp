#pragma once
// Shared helpers of the Python bindings (the _rollstep extension module).
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <Eigen/Core>
#include <stdexcept>
#include <string>

namespace py = pybind11;

namespace rollstep::python {

void bindModel(py::module_& m);
void bindSettings(py::module_& m);
void bindRobotOcp(py::module_& m);
void bindLqProblem(py::module_& m);
void bindSimulation(py::module_& m);

/// A file name given as str or os.PathLike (pathlib.Path).
inline std::string pathString(const py::object& path) {
  return py::str(py::module_::import("os").attr("fspath")(path)).cast<std::string>();
}

/// Throws std::invalid_argument "<what> has size <got>; expected <want>" (ValueError).
inline void checkSize(Eigen::Index got, Eigen::Index want, const char* what) {
  if (got != want) {
    throw std::invalid_argument(std::string(what) + " has size " + std::to_string(got) +
                                "; expected " + std::to_string(want));
  }
}

/// Throws std::invalid_argument unless every entry of v is finite.
template <class Derived>
void checkFinite(const Eigen::DenseBase<Derived>& v, const char* what) {
  if (!v.allFinite()) throw std::invalid_argument(std::string(what) + " is not finite");
}

}  // namespace rollstep::python
