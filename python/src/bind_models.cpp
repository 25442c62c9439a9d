// peha.models for Python: Tendon-spring forward and inverse, Bowden compensation, the joint, the arm.
// Element-wise functions broadcast their array arguments like numpy (py::vectorize) and return a
// float for scalar inputs.
#include "bindings.hpp"

#include "peha/config/reader.hpp"
#include "peha/experiments/arm/arm_scenario.hpp"
#include "peha/models/arm.hpp"
#include "peha/models/bowden.hpp"
#include "peha/models/joint.hpp"
#include "peha/models/tendon_spring.hpp"

#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include <limits>

namespace peha::python {
namespace {

using models::ArmModel;
using models::BowdenParams;
using models::MuscleModel;
using models::TendonSpringParams;

/// Joint torques for each row of q (and qd, qdd): 1-D in, 1-D out; 2-D (samples x dof) in, 2-D out.
template <class F>
Eigen::MatrixXd per_row(const ArmModel& model, const Eigen::MatrixXd& q, F f) {
  const int dof = model.dof();
  const bool row = q.rows() == 1 || q.cols() == 1;
  const Eigen::MatrixXd Q = (row && q.rows() != 1) ? Eigen::MatrixXd(q.transpose()) : q;
  if (Q.cols() != dof) throw py::value_error("q must have " + std::to_string(dof) + " columns (one per joint)");
  models::ArmData data(model);
  Eigen::MatrixXd out(Q.rows(), dof);
  for (Eigen::Index i = 0; i < Q.rows(); ++i) out.row(i) = f(data, i, Eigen::VectorXd(Q.row(i).transpose())).transpose();
  return out;
}

py::object arm_result(const Eigen::MatrixXd& out, bool one) {
  if (one) return py::cast(Eigen::VectorXd(out.row(0).transpose()));
  return py::cast(out);
}

Eigen::MatrixXd as_rows(const Array& a) {
  if (a.ndim() == 1) return Eigen::Map<const Eigen::RowVectorXd>(a.data(), a.size());
  if (a.ndim() != 2) throw py::value_error("expected a 1-D (dof) or 2-D (samples x dof) array");
  Eigen::MatrixXd m(a.shape(0), a.shape(1));
  for (py::ssize_t i = 0; i < a.shape(0); ++i)
    for (py::ssize_t j = 0; j < a.shape(1); ++j) m(i, j) = a.at(i, j);
  return m;
}

}  // namespace

void bind_models(py::module_& m) {
  // --- Tendon-spring PAM model ---
  py::class_<TendonSpringParams>(m, "TendonSpringParams",
                                 "The five Tendon-spring parameters: g(u) = a u^2 + b u + c in N/Pa, "
                                 "u = eps + eps0 + F/k (docs/models.md).")
      .def(py::init<>())
      .def(py::init([](double a, double b, double c, double k, double eps0, double min_gain) {
             return TendonSpringParams{a, b, c, k, eps0, min_gain};
           }),
           py::arg("a_N_per_Pa"), py::arg("b_N_per_Pa"), py::arg("c_N_per_Pa"), py::arg("k_N"), py::arg("eps0"),
           py::arg("min_gain_N_per_Pa") = 1e-6)
      .def_readwrite("a_N_per_Pa", &TendonSpringParams::a_N_per_Pa, "quadratic coefficient of g(u), N/Pa")
      .def_readwrite("b_N_per_Pa", &TendonSpringParams::b_N_per_Pa, "linear coefficient of g(u), N/Pa")
      .def_readwrite("c_N_per_Pa", &TendonSpringParams::c_N_per_Pa, "g(0), N/Pa")
      .def_readwrite("k_N", &TendonSpringParams::k_N, "wire stiffness, N per unit contraction (> 0)")
      .def_readwrite("eps0", &TendonSpringParams::eps0, "initial wire slack as a contraction ratio")
      .def_readwrite("min_gain_N_per_Pa", &TendonSpringParams::min_gain_N_per_Pa,
                     "g(u) below this counts as 'cannot pull', N/Pa")
      .def("__repr__", [](const TendonSpringParams& p) {
        return py::str("TendonSpringParams(a_N_per_Pa={!r}, b_N_per_Pa={!r}, c_N_per_Pa={!r}, k_N={!r}, eps0={!r})")
            .format(p.a_N_per_Pa, p.b_N_per_Pa, p.c_N_per_Pa, p.k_N, p.eps0);
      });

  py::enum_<models::InverseStatus>(m, "InverseStatus", "Why the inverse model returned what it returned")
      .value("OK", models::InverseStatus::kOk)
      .value("NO_FORCE", models::InverseStatus::kNoForce)
      .value("SATURATED", models::InverseStatus::kSaturated)
      .value("UNREACHABLE", models::InverseStatus::kUnreachable)
      .value("INVALID_INPUT", models::InverseStatus::kInvalidInput);

  m.def("gain", [](const TendonSpringParams& p, Array u) {
    return py::vectorize([&p](double x) { return models::gain_N_per_Pa(p, x); })(u);
  }, py::arg("params"), py::arg("muscle_contraction"), "g(u) in N/Pa at muscle contraction u (-), element-wise.");

  const char* forward_doc =
      "Forward Tendon-spring model: muscle force in N for gauge pressure `pressure_Pa` (Pa) at rigid-wire "
      "contraction `eps` (-). Arrays broadcast; a float for floats. A pressure outside 0 or 100 Pa .. 1.2 MPa "
      "raises ValueError (0.3 is 0.3 MPa given as Pa).";
  m.def("forward_force", [](const TendonSpringParams& p, double P, double eps) {
    check_pressure_Pa(P, "pressure_Pa");
    return models::forward_force_N(p, P, eps);
  },
        py::arg("params"), py::arg("pressure_Pa"), py::arg("eps"), forward_doc);
  m.def("forward_force", [](const TendonSpringParams& p, Array P, Array eps) {
    check_pressures_Pa(P, "pressure_Pa");
    return py::vectorize([&p](double x, double e) { return models::forward_force_N(p, x, e); })(P, eps);
  }, py::arg("params"), py::arg("pressure_Pa"), py::arg("eps"), forward_doc);

  const char* inverse_doc =
      "Closed-form inverse Tendon-spring model: pressure in Pa (gauge) that makes `force_N` (N) at rigid-wire "
      "contraction `eps` (-), within [0, max_pressure_Pa]. Arrays broadcast; a float for floats. "
      "inverse_status() says why (InverseStatus values).";
  const double inf = std::numeric_limits<double>::infinity();
  m.def("inverse_pressure", [](const TendonSpringParams& p, double F, double eps, double max_P) {
    return models::inverse_pressure(p, F, eps, max_P).pressure_Pa;
  }, py::arg("params"), py::arg("force_N"), py::arg("eps"), py::arg("max_pressure_Pa") = inf, inverse_doc);
  m.def("inverse_pressure", [](const TendonSpringParams& p, Array F, Array eps, double max_P) {
    return py::vectorize([&p, max_P](double f, double e) { return models::inverse_pressure(p, f, e, max_P).pressure_Pa; })(F, eps);
  }, py::arg("params"), py::arg("force_N"), py::arg("eps"), py::arg("max_pressure_Pa") = inf, inverse_doc);
  m.def("inverse_status", [](const TendonSpringParams& p, Array F, Array eps, double max_P) {
    return py::vectorize([&p, max_P](double f, double e) {
      return static_cast<int>(models::inverse_pressure(p, f, e, max_P).status);
    })(F, eps);
  }, py::arg("params"), py::arg("force_N"), py::arg("eps"), py::arg("max_pressure_Pa") = inf,
        "The InverseStatus (as int) of inverse_pressure for each element.");

  // --- Bowden cable ---
  py::class_<BowdenParams>(m, "BowdenParams", "Bowden cable friction: F_pam = F_joint exp(mu psi tanh(alpha v / 2)).")
      .def(py::init<>())
      .def(py::init([](double mu, double psi, double alpha) { return BowdenParams{mu, psi, alpha}; }),
           py::arg("friction_coefficient"), py::arg("wrap_angle_rad"), py::arg("sigmoid_gain_s_per_m") = 100.0)
      .def_readwrite("friction_coefficient", &BowdenParams::friction_coefficient, "mu, dimensionless")
      .def_readwrite("wrap_angle_rad", &BowdenParams::wrap_angle_rad, "psi, total bend angle of the housing, rad")
      .def_readwrite("sigmoid_gain_s_per_m", &BowdenParams::sigmoid_gain_s_per_m, "alpha, s/m");
  m.def("muscle_to_joint_ratio", [](const BowdenParams& p, Array v) {
    return py::vectorize([&p](double x) { return models::muscle_to_joint_ratio(p, x); })(v);
  }, py::arg("params"), py::arg("wire_velocity_mps"), "F_pam / F_joint at wire velocity (m/s, > 0 toward the muscle).");
  m.def("muscle_force_for_joint", [](const BowdenParams& p, Array F, Array v) {
    return py::vectorize([&p](double f, double x) { return models::muscle_force_for_joint_N(p, f, x); })(F, v);
  }, py::arg("params"), py::arg("joint_force_N"), py::arg("wire_velocity_mps"),
        "Muscle force (N) that delivers `joint_force_N` (N) at the pulley at wire velocity (m/s).");
  m.def("joint_force_from_loadcell", [](const BowdenParams& p, Array F, Array v) {
    return py::vectorize([&p](double f, double x) { return models::joint_force_from_loadcell_N(p, f, x); })(F, v);
  }, py::arg("params"), py::arg("loadcell_N"), py::arg("wire_velocity_mps"),
        "Force (N) reaching the pulley when the muscle-side load cell reads `loadcell_N` (N).");

  // --- The joint ---
  py::class_<MuscleModel>(m, "MuscleModel", "One muscle of a joint with its cable (the controller's model).")
      .def(py::init<>())
      .def_readwrite("name", &MuscleModel::name)
      .def_readwrite("pam", &MuscleModel::pam, "Tendon-spring parameters (pressures in Pa)")
      .def_readwrite("bowden", &MuscleModel::bowden, "cable friction")
      .def_readwrite("rest_length_m", &MuscleModel::rest_length_m, "nominal length L0, m")
      .def_readwrite("contraction_at_zero_angle", &MuscleModel::contraction_at_zero_angle, "rigid-wire eps at angle 0, -")
      .def_readwrite("max_force_N", &MuscleModel::max_force_N, "this muscle's force ceiling, N")
      .def_property_readonly("has_residual", [](const MuscleModel& mm) { return mm.residual != nullptr; },
                             "a learned pressure residual (SPGP) is attached");
  py::class_<models::JointModel>(m, "JointModel", "One PEHA joint: pulley, muscle pair, motor, supply, pretension.")
      .def(py::init<>())
      .def_readwrite("name", &models::JointModel::name)
      .def_readwrite("pulley_radius_m", &models::JointModel::pulley_radius_m, "r0, m")
      .def_readwrite("supply_pressure_Pa", &models::JointModel::supply_pressure_Pa, "valve supply, Pa gauge")
      .def_readwrite("pretension_N", &models::JointModel::pretension_N, "least muscle force, N")
      .def_readwrite("agonist", &models::JointModel::agonist)
      .def_readwrite("antagonist", &models::JointModel::antagonist)
      .def_readwrite("has_motor", &models::JointModel::has_motor)
      .def_readwrite("motor_max_torque_Nm", &models::JointModel::motor_max_torque_Nm, "motor rating at the joint, Nm");
  m.def("force_ceiling", &models::force_ceiling_N, py::arg("muscle"), "The muscle's force ceiling, N.");
  m.def("muscle_pressure", [](const MuscleModel& mm, Array F, Array eps, double supply) {
    check_pressure_Pa(supply, "supply_pressure_Pa");
    return py::vectorize([&mm, supply](double f, double e) { return models::muscle_pressure(mm, f, e, supply).pressure_Pa; })(F, eps);
  }, py::arg("muscle"), py::arg("force_N"), py::arg("eps"), py::arg("supply_pressure_Pa"),
        "The controller's pressure model (Pa): inverse Tendon-spring + learned residual, within [0, supply].");
  m.def("rigid_contraction", [](const MuscleModel& mm, double r0, int side, Array angle) {
    return py::vectorize([&mm, r0, side](double a) { return models::rigid_contraction(mm, r0, side, a); })(angle);
  }, py::arg("muscle"), py::arg("pulley_radius_m"), py::arg("side"), py::arg("angle_rad"),
        "Rigid-wire contraction (-) of the agonist (side +1) or antagonist (-1) at the joint angle (rad).");
  m.def("wire_velocity", [](double r0, int side, Array qd) {
    return py::vectorize([r0, side](double v) { return models::wire_velocity_mps(r0, side, v); })(qd);
  }, py::arg("pulley_radius_m"), py::arg("side"), py::arg("joint_velocity_radps"),
        "Wire velocity (m/s, > 0 toward the muscle) of the agonist (+1) or antagonist (-1).");
  m.def("joint_torque", [](double r0, Array f1, Array f2, Array tm) {
    return py::vectorize([r0](double a, double b, double c) { return models::joint_torque_Nm(r0, a, b, c); })(f1, f2, tm);
  }, py::arg("pulley_radius_m"), py::arg("agonist_force_N"), py::arg("antagonist_force_N"), py::arg("motor_torque_Nm"),
        "Paper eq. (1): (f1 - f2) r0 + tau_motor in Nm, pulley forces in N.");

  // --- The arm ---
  py::class_<models::ArmJoint>(m, "ArmJoint",
                               "A revolute joint of the arm's kinematic tree (parent -2: the joint listed before, -1: the world).")
      .def(py::init([](std::string name, const Eigen::Vector3d& offset, const Eigen::Vector3d& axis, bool active, int parent) {
             models::ArmJoint j;
             j.name = std::move(name);
             j.offset_m = offset;
             j.axis = axis;
             j.active = active;
             j.parent = parent;
             return j;
           }),
           py::arg("name"), py::arg("offset_m"), py::arg("axis"), py::arg("active") = true,
           py::arg("parent") = models::kPreviousJoint)
      .def_readwrite("name", &models::ArmJoint::name)
      .def_readwrite("offset_m", &models::ArmJoint::offset_m, "origin in the parent frame, m")
      .def_readwrite("axis", &models::ArmJoint::axis, "unit rotation axis in the joint frame")
      .def_readwrite("active", &models::ArmJoint::active)
      .def_readwrite("parent", &models::ArmJoint::parent, "index of the parent joint, -1 the world, -2 the joint listed before");
  py::class_<models::ArmBody>(m, "ArmBody", "A rigid body attached to a joint frame.")
      .def(py::init([](std::string name, int joint, double mass, const Eigen::Vector3d& com, const Eigen::Matrix3d& inertia) {
             models::ArmBody b;
             b.name = std::move(name);
             b.joint = joint;
             b.mass_kg = mass;
             b.com_m = com;
             b.inertia_kgm2 = inertia;
             return b;
           }),
           py::arg("name"), py::arg("joint"), py::arg("mass_kg"), py::arg("com_m"),
           py::arg("inertia_kgm2") = Eigen::Matrix3d::Zero().eval())
      .def_readwrite("name", &models::ArmBody::name)
      .def_readwrite("joint", &models::ArmBody::joint)
      .def_readwrite("mass_kg", &models::ArmBody::mass_kg)
      .def_readwrite("com_m", &models::ArmBody::com_m, "centre of mass in the joint frame, m")
      .def_readwrite("inertia_kgm2", &models::ArmBody::inertia_kgm2, "about the COM, kg m^2");
  py::class_<ArmModel>(m, "ArmModel", "The controller's rigid-body model of the right arm (docs/right-arm.md).")
      .def(py::init<>())
      .def_static("from_scenario", [](const std::string& path) {
        return experiments::read_arm_scenario(config::Document::load_file(path)).controller.arm;
      }, py::arg("scenario"), "The nominal arm model of a right-arm scenario YAML (configs/right_arm.yaml).")
      .def_readwrite("joints", &ArmModel::joints)
      .def_readwrite("bodies", &ArmModel::bodies)
      .def_readwrite("gravity_mps2", &ArmModel::gravity_mps2)
      .def_property_readonly("dof", &ArmModel::dof)
      .def_property_readonly("joint_names", [](const ArmModel& a) {
        std::vector<std::string> n;
        for (const auto& j : a.joints) n.push_back(j.name);
        return n;
      });
  m.def("gravity_torque", [](const ArmModel& model, Array q) {
    const Eigen::MatrixXd Q = as_rows(q);
    return arm_result(per_row(model, Q, [&](models::ArmData& d, Eigen::Index, const Eigen::VectorXd& qi) {
      return Eigen::VectorXd(models::gravity_torque(model, d, qi));
    }), q.ndim() == 1);
  }, py::arg("model"), py::arg("q_rad"),
        "Joint torques (Nm) that hold the arm still at angles q (rad): shape (dof,) or (samples, dof).");
  m.def("inverse_dynamics", [](const ArmModel& model, Array q, Array qd, Array qdd) {
    const Eigen::MatrixXd Q = as_rows(q), QD = as_rows(qd), QDD = as_rows(qdd);
    if (QD.rows() != Q.rows() || QDD.rows() != Q.rows() || QD.cols() != Q.cols() || QDD.cols() != Q.cols())
      throw py::value_error("q, qd and qdd must have the same shape");
    return arm_result(per_row(model, Q, [&](models::ArmData& d, Eigen::Index i, const Eigen::VectorXd& qi) {
      return Eigen::VectorXd(models::inverse_dynamics(model, d, qi, QD.row(i).transpose(), QDD.row(i).transpose()));
    }), q.ndim() == 1);
  }, py::arg("model"), py::arg("q_rad"), py::arg("qd_radps"), py::arg("qdd_radps2"),
        "Recursive Newton-Euler: joint torques (Nm) for angles (rad), velocities (rad/s), accelerations (rad/s^2), "
        "gravity included. Shapes (dof,) or (samples, dof).");
}

}  // namespace peha::python
