#pragma once
// Shared helpers of the `peha` Python module (python/src/*.cpp): numpy in, numpy out.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <cmath>
#include <string>
#include <vector>

namespace peha::python {

namespace py = pybind11;

/// A float64 C-contiguous array (anything array-like is converted).
using Array = py::array_t<double, py::array::c_style | py::array::forcecast>;

/// A copy of `v` as a new 1-D numpy array.
inline py::array_t<double> to_numpy(const std::vector<double>& v) {
  py::array_t<double> out(static_cast<py::ssize_t>(v.size()));
  std::copy(v.begin(), v.end(), out.mutable_data());
  return out;
}

/// The values of a 1-D array-like as a vector.
inline std::vector<double> to_vector(const Array& a) {
  if (a.ndim() > 1) throw py::value_error("expected a 1-D array");
  return {a.data(), a.data() + a.size()};
}

/// Gauge pressures a pneumatic muscle can see, in Pa: up to this (the readers' 1.2 MPa) ...
inline constexpr double kMaxGaugePressure_Pa = 1.2e6;
/// ... and a positive value below this is a pressure given in MPa (0.3 for 0.3 MPa = 300000 Pa):
/// no PAM makes a force below its threshold of some 10 kPa, so such a value is a unit mistake.
inline constexpr double kLeastMeaningfulPressure_Pa = 100.0;

/// Refuses (ValueError naming `what` and the units) a pressure outside what a muscle can see.
inline void check_pressure_Pa(double p, const char* what) {
  if (!std::isfinite(p) || p < -1e5 || p > kMaxGaugePressure_Pa * (1 + 1e-9) || (p > 0 && p < kLeastMeaningfulPressure_Pa)) {
    const bool mpa = p > 0 && p < kLeastMeaningfulPressure_Pa;
    throw py::value_error(std::string(what) + " = " + std::to_string(p) + " Pa is outside a muscle's gauge pressures (0 or 100 Pa .. 1.2 MPa)" +
                          (mpa ? ": MPa given as Pa? (0.3 MPa = 300000 Pa)" : p > kMaxGaugePressure_Pa * (1 + 1e-9) ? ": kPa or bar given as Pa?" : ""));
  }
}
inline void check_pressures_Pa(const Array& a, const char* what) {
  for (py::ssize_t i = 0; i < a.size(); ++i) check_pressure_Pa(a.data()[i], what);
}

void bind_models(py::module_& m);
void bind_calibration(py::module_& m);
void bind_sim(py::module_& m);
void bind_api(py::module_& m);

}  // namespace peha::python
