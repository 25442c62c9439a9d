// The `peha._core` extension module: peha's C++ API for Python (docs/python.md).
#include "bindings.hpp"

#include "peha/config/reader.hpp"

namespace py = pybind11;

PYBIND11_MODULE(_core, m) {
  m.doc() = "peha's C++ models, calibration and simulator (SI units inside; see docs/python.md)";
  // Set-up errors name file:line:column; in Python they are ValueErrors.
  py::register_exception<peha::config::Error>(m, "ConfigError", PyExc_ValueError);
  peha::python::bind_models(m);
  peha::python::bind_calibration(m);
  peha::python::bind_sim(m);
  peha::python::bind_api(m);
}
