// peha_py_reference: the C++ results the Python bindings are checked against (python/tests/).
// Prints one JSON object: inputs and outputs of every bound function, computed here through the
// C++ API directly, at full precision (%.17g).
//
//   peha_py_reference <e1 scenario> <right-arm scenario> [<calibration yaml>]
#include "peha/calibration/calibration_file.hpp"
#include "peha/config/reader.hpp"
#include "peha/control/allocation.hpp"
#include "peha/control/one_dof_gravity.hpp"
#include "peha/experiments/e1_gravity/e1_gravity.hpp"
#include "peha/experiments/arm/arm_scenario.hpp"
#include "peha/models/arm.hpp"
#include "peha/models/bowden.hpp"
#include "peha/models/joint.hpp"
#include "peha/models/tendon_spring.hpp"
#include "peha/sim/one_dof_rig.hpp"
#include "peha/sim/arm_plant.hpp"

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

namespace {

using namespace peha;

bool first_key = true;

std::string num(double v) {
  if (std::isnan(v)) return "NaN";
  if (std::isinf(v)) return v > 0 ? "Infinity" : "-Infinity";
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

void key(const std::string& k) {
  std::printf("%s\n\"%s\": ", first_key ? "" : ",", k.c_str());
  first_key = false;
}

void array(const std::string& k, const std::vector<double>& v) {
  key(k);
  std::printf("[");
  for (std::size_t i = 0; i < v.size(); ++i) std::printf("%s%s", i ? "," : "", num(v[i]).c_str());
  std::printf("]");
}

std::vector<double> linspace(double a, double b, int n) {
  std::vector<double> v(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) v[static_cast<std::size_t>(i)] = a + (b - a) * i / (n - 1);
  return v;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: %s <e1 scenario> <right-arm scenario> [<calibration yaml>]\n", argv[0]);
    return 2;
  }
  const experiments::E1Scenario e1 = experiments::read_e1(config::Document::load_file(argv[1]));
  const experiments::ArmScenario arm = experiments::read_arm_scenario(config::Document::load_file(argv[2]));
  const models::JointModel& joint = e1.controller.joint;
  const models::TendonSpringParams& pam = joint.agonist.pam;
  const models::BowdenParams& bowden = joint.agonist.bowden;
  std::printf("{");

  // Tendon-spring: a grid of (pressure or force, eps), edges included (negative, zero, past the supply).
  std::vector<double> x, eps;
  for (double a : linspace(-0.1, 1.2, 27))
    for (double e : linspace(-0.05, 0.3, 15)) { x.push_back(a); eps.push_back(e); }
  std::vector<double> P(x.size()), F(x.size()), forward(x.size()), inverse(x.size()), status(x.size()), gain(x.size());
  for (std::size_t i = 0; i < x.size(); ++i) {
    P[i] = x[i] * 1e6;
    F[i] = x[i] * 1500.0;
    forward[i] = models::forward_force_N(pam, P[i], eps[i]);
    const models::InverseResult r = models::inverse_pressure(pam, F[i], eps[i], joint.supply_pressure_Pa);
    inverse[i] = r.pressure_Pa;
    status[i] = static_cast<double>(r.status);
    gain[i] = models::gain_N_per_Pa(pam, eps[i]);
  }
  array("pressure_Pa", P), array("force_N", F), array("eps", eps);
  array("forward_force", forward), array("inverse_pressure", inverse), array("inverse_status", status);
  array("gain", gain);
  key("supply_pressure_Pa"), std::printf("%s", num(joint.supply_pressure_Pa).c_str());

  // Bowden and the joint.
  const std::vector<double> v = linspace(-0.2, 0.2, 41), angle = linspace(-0.8, 0.8, 41);
  std::vector<double> ratio, for_joint, from_loadcell, muscle_p, contraction1, contraction2, wire2, torque;
  for (std::size_t i = 0; i < v.size(); ++i) {
    const double f = 50.0 + 20.0 * static_cast<double>(i);
    ratio.push_back(models::muscle_to_joint_ratio(bowden, v[i]));
    for_joint.push_back(models::muscle_force_for_joint_N(bowden, f, v[i]));
    from_loadcell.push_back(models::joint_force_from_loadcell_N(bowden, f, v[i]));
    muscle_p.push_back(models::muscle_pressure(joint.agonist, f, 0.02 + 0.002 * static_cast<double>(i), joint.supply_pressure_Pa).pressure_Pa);
    contraction1.push_back(models::rigid_contraction(joint.agonist, joint.pulley_radius_m, +1, angle[i]));
    contraction2.push_back(models::rigid_contraction(joint.antagonist, joint.pulley_radius_m, -1, angle[i]));
    wire2.push_back(models::wire_velocity_mps(joint.pulley_radius_m, -1, v[i] * 10));
    torque.push_back(models::joint_torque_Nm(joint.pulley_radius_m, f, 0.5 * f, v[i] * 10));
  }
  array("wire_velocity_mps", v), array("angle_rad", angle);
  array("muscle_to_joint_ratio", ratio), array("muscle_force_for_joint", for_joint);
  array("joint_force_from_loadcell", from_loadcell), array("muscle_pressure", muscle_p);
  array("rigid_contraction_agonist", contraction1), array("rigid_contraction_antagonist", contraction2);
  array("wire_velocity_antagonist", wire2), array("joint_torque", torque);
  key("force_ceiling_antagonist"), std::printf("%s", num(models::force_ceiling_N(joint.antagonist)).c_str());
  std::vector<double> rig_gravity;
  control::OneDofGravityModel g = e1.controller.gravity;
  g.payload_mass_kg = e1.cases.back().payload_kg;
  for (double a : angle) rig_gravity.push_back(control::gravity_torque_Nm(g, a));
  array("rig_gravity_torque", rig_gravity);

  // The arm: gravity torque and inverse dynamics at a few postures (row-major samples x dof).
  const models::ArmModel& am = arm.controller.arm;
  models::ArmData data(am);
  std::vector<double> q_all, qd_all, qdd_all, grav_all, id_all;
  for (int s = 0; s < 7; ++s) {
    Eigen::VectorXd q(am.dof()), qd(am.dof()), qdd(am.dof());
    for (int j = 0; j < am.dof(); ++j) {
      q[j] = std::sin(0.7 * s + j) * 1.2;
      qd[j] = std::cos(1.3 * s - j) * 2.0;
      qdd[j] = std::sin(2.1 * s + 0.5 * j) * 5.0;
    }
    const Eigen::VectorXd tg = models::gravity_torque(am, data, q);
    for (int j = 0; j < am.dof(); ++j) grav_all.push_back(tg[j]);
    const Eigen::VectorXd ti = models::inverse_dynamics(am, data, q, qd, qdd);
    for (int j = 0; j < am.dof(); ++j) {
      id_all.push_back(ti[j]);
      q_all.push_back(q[j]), qd_all.push_back(qd[j]), qdd_all.push_back(qdd[j]);
    }
  }
  key("arm_dof"), std::printf("%d", am.dof());
  array("arm_q", q_all), array("arm_qd", qd_all), array("arm_qdd", qdd_all);
  array("arm_gravity_torque", grav_all), array("arm_inverse_dynamics", id_all);

  // The rig under the C++ E1 controller (straight to the backend: no limits stage, no supervisor),
  // 3 s of the last case: angle and commands per cycle.
  {
    const experiments::E1Case& c = e1.cases.back();
    sim::OneDofRigBackend rig(experiments::e1_plant_params(e1, c));
    rig.configure();
    rig.activate();
    control::OneDofControllerModel model = experiments::e1_controller_model(e1, c);
    model.allocation.loadcell_check.tare_s = 0.0;  // the Python example has no start-up tare (docs/python.md)
    control::OneDofGravityController controller(model);
    io::SensorState s;
    io::Command cmd;
    std::vector<double> t, a, p1, p2, mt, truth_angle;
    for (int k = 0; k <= 3000; ++k) {
      rig.read(s);
      controller.update(s, cmd);
      rig.write(cmd);
      t.push_back(s.time_s), a.push_back(s.joints[0].angle_rad), truth_angle.push_back(rig.truth().angle_rad);
      p1.push_back(cmd.joints[0].agonist_pressure_Pa), p2.push_back(cmd.joints[0].antagonist_pressure_Pa);
      mt.push_back(cmd.joints[0].motor_torque_Nm);
    }
    key("rig_case"), std::printf("\"%s\"", c.name.c_str());
    array("rig_time_s", t), array("rig_angle_rad", a), array("rig_truth_angle_rad", truth_angle);
    array("rig_agonist_pressure_cmd_Pa", p1), array("rig_antagonist_pressure_cmd_Pa", p2), array("rig_motor_cmd_Nm", mt);
  }

  // The right arm under a constant command for 0.5 s: the actuated joints' encoder angles.
  {
    sim::ArmBackend plant(arm.plant);
    plant.configure();
    plant.activate();
    io::SensorState s;
    io::Command cmd;
    cmd.joint_count = static_cast<int>(plant.info().joint_names.size());
    for (int j = 0; j < cmd.joint_count; ++j) cmd.joints[static_cast<std::size_t>(j)] = {0.3e6, 0.2e6, 0.5};
    std::vector<double> q;
    for (int k = 0; k < 500; ++k) {
      plant.read(s);
      for (int j = 0; j < s.joint_count; ++j) q.push_back(s.joints[static_cast<std::size_t>(j)].angle_rad);
      plant.write(cmd);
    }
    array("arm_sim_angle_rad", q);
  }

  // A calibration file: its pressure model's mean (as models::muscle_pressure) and std.
  if (argc > 3) {
    const calibration::MuscleCalibration c = calibration::read_calibration(argv[3]);
    const models::MuscleModel m = calibration::calibrated_muscle(c, true, models::MuscleModel{});
    std::vector<double> ce, cf, mean, sd;
    for (double e : linspace(0.0, 0.25, 9))
      for (double f : linspace(0.0, 900.0, 9)) {
        ce.push_back(e), cf.push_back(f);
        mean.push_back(models::muscle_pressure(m, f, e, 0.8e6).pressure_Pa);
        const double xx[2] = {e, f};
        sd.push_back(c.spgp ? std::sqrt(std::max(c.spgp->predict_variance(xx), 0.0)) : 0.0);
      }
    array("cal_eps", ce), array("cal_force_N", cf), array("cal_mean_Pa", mean), array("cal_std_Pa", sd);
    const models::TendonSpringParams& p = c.params;
    array("cal_params", {p.a_N_per_Pa, p.b_N_per_Pa, p.c_N_per_Pa, p.k_N, p.eps0});
  }
  std::printf("\n}\n");
  return 0;
}
