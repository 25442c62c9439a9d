#pragma once
// Shared helpers of the `peha` Python module (python/src/*.cpp): numpy in, numpy out.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

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

void bind_models(py::module_& m);
void bind_calibration(py::module_& m);
void bind_sim(py::module_& m);
void bind_api(py::module_& m);

}  // namespace peha::python
