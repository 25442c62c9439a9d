// A user's own controller from Python (docs/user-controller.md): peha.Exoskeleton(config).control(fn,
// duration_s) calls `fn(state)` every control period of the simulated arm, inside peha's allocation,
// limits, plausibility monitor, log and verdict. `state` is a dict of numpy arrays per joint; `fn`
// returns one torque per joint (Nm), or None to end the run. The simulator only: a Python callback
// cannot keep a board's 1 ms deadline.
#include "bindings.hpp"

#include "peha/api/exoskeleton.hpp"
#include "peha/hardware/backend_uri.hpp"

#include <pybind11/functional.h>
#include <pybind11/stl.h>

#include <exception>
#include <memory>

namespace peha::python {
namespace {

py::dict state_dict(const api::ArmState& s) {
  py::dict d;
  d["time_s"] = s.time_s;
  d["starting"] = s.starting;
  const auto n = static_cast<py::ssize_t>(s.joint_count);
  const std::pair<const char*, double api::JointState::*> fields[] = {
      {"angle_rad", &api::JointState::angle_rad},
      {"velocity_radps", &api::JointState::velocity_radps},
      {"gravity_torque_Nm", &api::JointState::gravity_torque_Nm},
      {"agonist_loadcell_N", &api::JointState::agonist_loadcell_N},
      {"antagonist_loadcell_N", &api::JointState::antagonist_loadcell_N},
      {"agonist_pressure_Pa", &api::JointState::agonist_pressure_Pa},
      {"antagonist_pressure_Pa", &api::JointState::antagonist_pressure_Pa}};
  for (const auto& [name, field] : fields) {
    py::array_t<double> a(n);
    for (py::ssize_t i = 0; i < n; ++i) a.mutable_data()[i] = s.joints[static_cast<std::size_t>(i)].*field;
    d[name] = a;
  }
  return d;
}

}  // namespace

void bind_api(py::module_& m) {
  py::class_<api::ControlResult>(m, "ControlResult", "What Exoskeleton.control gives back")
      .def_readonly("passed", &api::ControlResult::passed, "the verdict (safety envelope and faults) passed")
      .def_readonly("cycles", &api::ControlResult::cycles)
      .def_readonly("faults", &api::ControlResult::faults)
      .def_readonly("fault_reason", &api::ControlResult::fault_reason)
      .def_readonly("realtime_factor", &api::ControlResult::realtime_factor)
      .def_property_readonly("verdict", [](const api::ControlResult& r) { return r.verdict.describe_all(); }, "one line per figure")
      .def_property_readonly("failures", [](const api::ControlResult& r) { return r.verdict.failures(); });
  py::class_<api::Exoskeleton>(m, "Exoskeleton",
                               "An arm scenario's simulated arm with your own controller inside peha's allocation, limits, monitor and "
                               "verdict (docs/user-controller.md)")
      .def(py::init([](const std::string& config, const std::string& backend) {
             if (hardware::BackendUri::parse(backend).kind != hardware::BackendKind::kSim) {
               throw py::value_error("peha.Exoskeleton runs on the simulator (sim:): a Python callback cannot keep a board's 1 ms deadline; "
                                     "use the C++ API (peha::api::Exoskeleton) on the board");
             }
             return std::make_unique<api::Exoskeleton>(config, backend);
           }),
           py::arg("config"), py::arg("backend") = "sim:")
      .def_property_readonly("joint_names", &api::Exoskeleton::joint_names)
      .def("torque_controlled", &api::Exoskeleton::torque_controlled, py::arg("joint"))
      .def(
          "control",
          [](api::Exoskeleton& exo, const py::function& fn, double duration_s, const std::string& log) {
            std::exception_ptr error;  // a Python exception ends the run and is raised after it
            const auto n = exo.joint_names().size();
            api::ControlResult result = exo.control(
                [&](const api::ArmState& s, double) {
                  api::JointTorques tau;
                  if (error) {
                    tau.finished = true;
                    return tau;
                  }
                  try {
                    const py::object out = fn(state_dict(s));
                    if (out.is_none()) {
                      tau.finished = true;
                      return tau;
                    }
                    const Array a = out.cast<Array>();
                    if (static_cast<std::size_t>(a.size()) != n) {
                      throw py::value_error("the controller returned " + std::to_string(a.size()) + " torques; the arm has " + std::to_string(n) + " joints");
                    }
                    for (std::size_t j = 0; j < n; ++j) tau.tau_Nm[j] = a.data()[j];
                  } catch (...) {
                    error = std::current_exception();
                    tau.finished = true;
                  }
                  return tau;
                },
                duration_s, log);
            if (error) std::rethrow_exception(error);
            return result;
          },
          py::arg("controller"), py::arg("duration_s"), py::arg("log") = "",
          "Calls controller(state) every control period for duration_s: state is a dict (time_s, starting, and per joint numpy "
          "arrays angle_rad, velocity_radps, gravity_torque_Nm, agonist/antagonist_loadcell_N, agonist/antagonist_pressure_Pa); it "
          "returns one torque per joint in Nm, or None to end the run. Returns a ControlResult.");
}

}  // namespace peha::python
