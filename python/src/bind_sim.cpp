// The simulated plants for Python: build the one-DOF rig or the right arm from a scenario YAML,
// reset, read the sensors, write a command (one control period), read the plant's truth. The plants
// are the same io::Backend objects `peha run` drives; the controller is the caller's (the limits
// stage and the supervisor of `peha run` are not in between). Also the torque allocation, so that a
// Python controller can use the same macro-mini split as the C++ ones.
#include "bindings.hpp"

#include "peha/config/reader.hpp"
#include "peha/control/allocation.hpp"
#include "peha/control/one_dof_gravity.hpp"
#include "peha/experiments/e1_gravity/e1_gravity.hpp"
#include "peha/experiments/arm/arm_scenario.hpp"
#include "peha/sim/one_dof_rig.hpp"
#include "peha/sim/arm_plant.hpp"

#include <pybind11/stl.h>

#include <memory>
#include <optional>

namespace peha::python {
namespace {

py::dict sensors_dict(const io::SensorState& s) {
  py::dict d;
  d["time_s"] = s.time_s;
  d["sequence"] = s.sequence;
  const auto n = static_cast<py::ssize_t>(s.joint_count);
  py::array_t<double> angle(n), lc1(n), lc2(n), p1(n), p2(n);
  for (py::ssize_t i = 0; i < n; ++i) {
    const io::JointSensors& j = s.joints[static_cast<std::size_t>(i)];
    angle.mutable_data()[i] = j.angle_rad;
    lc1.mutable_data()[i] = j.agonist_loadcell_N;
    lc2.mutable_data()[i] = j.antagonist_loadcell_N;
    p1.mutable_data()[i] = j.agonist_pressure_Pa;
    p2.mutable_data()[i] = j.antagonist_pressure_Pa;
  }
  d["angle_rad"] = angle;
  d["agonist_loadcell_N"] = lc1;
  d["antagonist_loadcell_N"] = lc2;
  d["agonist_pressure_Pa"] = p1;
  d["antagonist_pressure_Pa"] = p2;
  return d;
}

/// A command for `joints` joints from arrays (or scalars) of pressures (Pa) and motor torques (Nm).
io::Command make_command(int joints, const Array& p1, const Array& p2, const Array& motor) {
  io::Command c;
  c.joint_count = joints;
  auto value = [](const Array& a, int i, const char* what) {
    if (a.size() == 1) return a.data()[0];
    if (a.size() <= i) throw py::value_error(std::string(what) + ": one value per joint expected");
    return a.data()[i];
  };
  for (int i = 0; i < joints; ++i) {
    c.joints[static_cast<std::size_t>(i)] = {value(p1, i, "agonist_pressure_Pa"), value(p2, i, "antagonist_pressure_Pa"),
                                             value(motor, i, "motor_torque_Nm")};
  }
  return c;
}

py::dict joint_truth(const sim::PehaJointTruth& t, py::dict d) {
  d["agonist_force_N"] = t.muscle_force_N[0];
  d["antagonist_force_N"] = t.muscle_force_N[1];
  d["agonist_tension_min_N"] = t.pulley_tension_min_N[0];
  d["antagonist_tension_min_N"] = t.pulley_tension_min_N[1];
  d["agonist_pressure_Pa"] = t.pressure_Pa[0];
  d["antagonist_pressure_Pa"] = t.pressure_Pa[1];
  d["agonist_contraction"] = t.muscle_contraction[0];
  d["antagonist_contraction"] = t.muscle_contraction[1];
  d["motor_torque_Nm"] = t.motor_torque_Nm;
  d["cable_friction_Nm"] = t.cable_friction_Nm;
  return d;
}

py::dict rig_truth(const sim::OneDofRigTruth& t) {
  py::dict d = joint_truth(t, py::dict());
  d["time_s"] = t.time_s;
  d["angle_rad"] = t.angle_rad;
  d["velocity_radps"] = t.velocity_radps;
  d["finger_force_N"] = t.finger_force_N;
  d["finger_active"] = t.finger_active;
  d["constraint_torque_Nm"] = t.constraint_torque_Nm;
  return d;
}

/// The one-DOF rig of an E1 scenario, one case (payload).
class Rig {
 public:
  Rig(const std::string& scenario, const std::string& case_name, std::optional<std::uint64_t> seed)
      : scenario_(experiments::read_e1(config::Document::load_file(scenario))) {
    if (scenario_.cases.empty()) throw py::value_error(scenario + ": no cases");
    case_ = scenario_.cases.front();
    if (!case_name.empty()) {
      bool found = false;
      for (const auto& c : scenario_.cases) {
        if (c.name == case_name) { case_ = c; found = true; }
      }
      if (!found) throw py::value_error(scenario + ": no case named '" + case_name + "'");
    }
    if (seed) scenario_.plant.seed = *seed;
    reset();
  }
  /// A fresh plant at the scenario's initial state, outputs active.
  void reset() {
    plant_ = std::make_unique<sim::OneDofRigBackend>(experiments::e1_plant_params(scenario_, case_));
    plant_->configure();
    plant_->activate();
  }
  py::object read() {
    if (!plant_->read(state_)) return py::none();
    return sensors_dict(state_);
  }
  void write(double p1, double p2, double motor) {
    io::Command c;
    c.joint_count = 1;
    c.joints[0] = {p1, p2, motor};
    plant_->write(c);
  }
  sim::OneDofRigBackend& plant() { return *plant_; }
  const experiments::E1Scenario& scenario() const { return scenario_; }
  const experiments::E1Case& current_case() const { return case_; }

 private:
  experiments::E1Scenario scenario_;
  experiments::E1Case case_;
  std::unique_ptr<sim::OneDofRigBackend> plant_;
  io::SensorState state_;
};

/// The right arm of a right-arm scenario.
class Arm {
 public:
  Arm(const std::string& scenario, std::optional<std::uint64_t> seed)
      : scenario_(experiments::read_arm_scenario(config::Document::load_file(scenario))) {
    if (seed) scenario_.plant.seed = *seed;
    reset();
  }
  void reset() {
    plant_ = std::make_unique<sim::ArmBackend>(scenario_.plant);
    plant_->configure();
    plant_->activate();
  }
  py::object read() {
    if (!plant_->read(state_)) return py::none();
    return sensors_dict(state_);
  }
  void write(const Array& p1, const Array& p2, const Array& motor) {
    plant_->write(make_command(static_cast<int>(plant_->info().joint_names.size()), p1, p2, motor));
  }
  py::dict truth(bool sampled) const {
    const sim::ArmTruth& t = sampled ? plant_->sampled_truth() : plant_->truth();
    py::dict d;
    d["time_s"] = t.time_s;
    d["q_rad"] = to_numpy(t.q_rad);
    d["qd_radps"] = to_numpy(t.qd_radps);
    d["operator_torque_Nm"] = to_numpy(t.operator_torque_Nm);
    d["operator_active"] = t.operator_active;
    py::list actuators;
    for (const auto& a : t.actuators) actuators.append(joint_truth(a, py::dict()));
    d["actuators"] = actuators;
    return d;
  }
  const experiments::ArmScenario& scenario() const { return scenario_; }
  const sim::ArmBackend& plant() const { return *plant_; }

 private:
  experiments::ArmScenario scenario_;
  std::unique_ptr<sim::ArmBackend> plant_;
  io::SensorState state_;
};

/// control::allocate with its state, for a controller written in Python.
class Allocator {
 public:
  Allocator(models::JointModel joint, control::AllocationParams params) : joint_(std::move(joint)), params_(params) {}
  py::dict step(double tau, double angle, double velocity, double lc1, double lc2, double p1, double p2, double dt) {
    const control::AllocationInput in{tau, angle, velocity, lc1, lc2, p1, p2, dt};
    control::allocate(joint_, params_, data_, in, out_);
    py::dict d;
    d["tau_pam_cmd_Nm"] = out_.tau_pam_cmd_Nm;
    d["tau_pam_measured_Nm"] = out_.tau_pam_measured_Nm;
    d["tau_motor_cmd_Nm"] = out_.tau_motor_cmd_Nm;
    d["agonist_force_cmd_N"] = out_.agonist_force_cmd_N;
    d["antagonist_force_cmd_N"] = out_.antagonist_force_cmd_N;
    d["agonist_pressure_Pa"] = out_.agonist_pressure_Pa;
    d["antagonist_pressure_Pa"] = out_.antagonist_pressure_Pa;
    d["agonist_contraction"] = out_.agonist_contraction;
    d["antagonist_contraction"] = out_.antagonist_contraction;
    d["agonist_trim_N"] = out_.agonist_trim_N;
    d["antagonist_trim_N"] = out_.antagonist_trim_N;
    d["flags"] = out_.flags;
    return d;
  }
  void reset() { data_ = {}; }
  const models::JointModel& joint() const { return joint_; }
  const control::AllocationParams& params() const { return params_; }

 private:
  models::JointModel joint_;
  control::AllocationParams params_;
  control::AllocationData data_;
  control::AllocationOutput out_;
};

}  // namespace

void bind_sim(py::module_& m) {
  py::class_<control::AllocationParams>(m, "AllocationParams", "Macro-mini torque allocation settings (docs/models.md).")
      .def(py::init<>())
      .def_readwrite("pam_cutoff_Hz", &control::AllocationParams::pam_cutoff_Hz, "PAM share low-pass cut-off, Hz")
      .def_readwrite("use_motor", &control::AllocationParams::use_motor)
      .def_readwrite("force_trim_rate_1ps", &control::AllocationParams::force_trim_rate_1ps, "force trim gain, 1/s (0 = off)")
      .def_readwrite("force_trim_max_N", &control::AllocationParams::force_trim_max_N, "force trim bound, N")
      .def_readwrite("period_s", &control::AllocationParams::period_s, "control period, s");
  py::class_<control::OneDofGravityModel>(m, "OneDofGravityModel", "The controller's nominal gravity model of the rig.")
      .def(py::init<>())
      .def_readwrite("link_mass_kg", &control::OneDofGravityModel::link_mass_kg)
      .def_readwrite("link_com_m", &control::OneDofGravityModel::link_com_m)
      .def_readwrite("payload_mass_kg", &control::OneDofGravityModel::payload_mass_kg)
      .def_readwrite("payload_lever_m", &control::OneDofGravityModel::payload_lever_m)
      .def_readwrite("gravity_mps2", &control::OneDofGravityModel::gravity_mps2);
  m.def("rig_gravity_torque", [](const control::OneDofGravityModel& g, Array angle) {
    return py::vectorize([&g](double a) { return control::gravity_torque_Nm(g, a); })(angle);
  }, py::arg("model"), py::arg("angle_rad"), "Torque (Nm) that holds the rig's link still at the angle (rad).");

  py::class_<Allocator>(m, "Allocator",
                        "control::allocate with its filter state: desired torque -> two pressures and a motor torque.")
      .def(py::init<models::JointModel, control::AllocationParams>(), py::arg("joint"), py::arg("params"))
      .def("step", &Allocator::step, py::arg("tau_desired_Nm"), py::arg("angle_rad"), py::arg("velocity_radps"),
           py::arg("agonist_loadcell_N"), py::arg("antagonist_loadcell_N"), py::arg("agonist_pressure_Pa"),
           py::arg("antagonist_pressure_Pa"), py::arg("dt_s"),
           "One allocation step; returns the AllocationOutput as a dict (N, Nm, Pa, flags).")
      .def("reset", &Allocator::reset, "Clears the filter state (the next step is a bumpless start).")
      .def_property_readonly("joint", &Allocator::joint)
      .def_property_readonly("params", &Allocator::params);

  py::class_<Rig>(m, "Rig",
                  "The simulated one-DOF rig of an E1 scenario (configs/e1_one_dof.yaml), one case (payload). "
                  "read() -> sensors (SI), write(p_agonist_Pa, p_antagonist_Pa, motor_Nm) steps one control period.")
      .def(py::init<const std::string&, const std::string&, std::optional<std::uint64_t>>(), py::arg("scenario"),
           py::arg("case") = "", py::arg("seed") = py::none())
      .def("reset", &Rig::reset, "A fresh plant in the scenario's initial state, outputs active.")
      .def("read", &Rig::read,
           "The latest sample: dict with time_s and per-joint arrays angle_rad, agonist/antagonist_loadcell_N, "
           "agonist/antagonist_pressure_Pa (gauge); None when there is none.")
      .def("write", &Rig::write, py::arg("agonist_pressure_Pa"), py::arg("antagonist_pressure_Pa"),
           py::arg("motor_torque_Nm"), "Commands the valves (Pa gauge) and the motor (Nm at the joint); steps one period.")
      .def("truth", [](Rig& r) { return rig_truth(r.plant().truth()); }, "The plant's truth after the latest write.")
      .def("sampled_truth", [](Rig& r) { return rig_truth(r.plant().sampled_truth()); },
           "The plant's truth at the instant of the latest read's sample.")
      .def_property_readonly("case", [](const Rig& r) { return r.current_case().name; })
      .def_property_readonly("payload_kg", [](const Rig& r) { return r.current_case().payload_kg; })
      .def_property_readonly("cases", [](const Rig& r) {
        std::vector<std::string> n;
        for (const auto& c : r.scenario().cases) n.push_back(c.name);
        return n;
      })
      .def_property_readonly("period_s", [](const Rig& r) { return r.scenario().period_s; }, "control period, s")
      .def_property_readonly("duration_s", [](const Rig& r) { return r.scenario().duration_s; })
      .def_property_readonly("drift_window_s", [](const Rig& r) { return r.scenario().drift_window_s; })
      .def_property_readonly("joint", [](const Rig& r) { return r.scenario().controller.joint; },
                             "the controller's JointModel from the scenario")
      .def_property_readonly("allocation", [](const Rig& r) { return r.scenario().controller.allocation; })
      .def_property_readonly("gravity", [](const Rig& r) {
        return experiments::e1_controller_model(r.scenario(), r.current_case()).gravity;
      }, "the controller's nominal gravity model, with this case's payload")
      .def_property_readonly("velocity_cutoff_Hz", [](const Rig& r) { return r.scenario().controller.velocity_cutoff_Hz; })
      .def_property_readonly("pushes", [](const Rig& r) {
        py::list l;
        for (const auto& p : r.scenario().plant.finger.pushes) {
          py::dict d;
          d["name"] = p.name;
          d["start_s"] = p.start_s;
          d["duration_s"] = p.duration_s;
          d["move_s"] = p.move_s;
          d["target_angle_rad"] = p.target_angle_rad;
          d["hold"] = p.hold;
          l.append(d);
        }
        return l;
      }, "the operator's finger script");

  py::class_<Arm>(m, "Arm",
                  "The simulated arm of an arm scenario (configs/right_arm.yaml, configs/upper_body.yaml: both arms). read() -> sensors, "
                  "write(agonist_Pa[], antagonist_Pa[], motor_Nm[]) steps one control period (one value per actuated joint).")
      .def(py::init<const std::string&, std::optional<std::uint64_t>>(), py::arg("scenario"), py::arg("seed") = py::none())
      .def("reset", &Arm::reset)
      .def("read", &Arm::read)
      .def("write", &Arm::write, py::arg("agonist_pressure_Pa"), py::arg("antagonist_pressure_Pa"), py::arg("motor_torque_Nm"))
      .def("truth", [](const Arm& a) { return a.truth(false); })
      .def("sampled_truth", [](const Arm& a) { return a.truth(true); })
      .def_property_readonly("joint_names", [](const Arm& a) { return a.plant().info().joint_names; })
      .def_property_readonly("period_s", [](const Arm& a) { return a.scenario().period_s; })
      .def_property_readonly("arm_model", [](const Arm& a) { return a.scenario().controller.arm; },
                             "the controller's nominal ArmModel")
      .def_property_readonly("joints", [](const Arm& a) {
        std::vector<models::JointModel> j;
        for (const auto& x : a.scenario().controller.joints) j.push_back(x.actuator);
        return j;
      }, "the controller's JointModel per actuated joint")
      .def_property_readonly("model_joint_index", [](const Arm& a) {
        std::vector<int> j;
        for (const auto& x : a.scenario().controller.joints) j.push_back(x.model_joint);
        return j;
      }, "index into arm_model.joints of each actuated joint")
      .def_property_readonly("allocation", [](const Arm& a) { return a.scenario().controller.allocation; });
}

}  // namespace peha::python
