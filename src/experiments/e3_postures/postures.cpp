#include "peha/experiments/e3_postures/postures.hpp"
#include "peha/experiments/common/mujoco_lock.hpp"
#include "peha/experiments/common/release_checks.hpp"
#include "peha/models/exoskeleton.hpp"

#include "peha/models/units.hpp"
#include "peha/safety/limited_backend.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <chrono>
#include <cmath>
#include <complex>
#include <limits>

namespace peha::experiments {
std::vector<std::size_t> gravity_joints(const ArmScenario& scenario) {
  std::vector<std::size_t> out;
  for (std::size_t i = 0; i < scenario.controller.joints.size(); ++i) {
    if (scenario.controller.joints[i].mode == control::ArmJointMode::kGravity) out.push_back(i);
  }
  return out;
}

std::string arm_log_prefix(const ArmScenario& scenario, std::size_t io_joint) {
  std::string name = scenario.plant.actuated[io_joint];
  bool two_sides = false;
  for (const std::string& n : scenario.plant.actuated) two_sides |= n[0] != scenario.plant.actuated[0][0];
  if (!two_sides) name = std::string(models::without_side(name));
  for (char& c : name) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return name;
}

std::vector<std::string> arm_log_columns(const ArmScenario& scenario) {
  std::vector<std::string> c = {"t_s", "operator_active"};
  for (std::size_t j = 0; j < scenario.plant.actuated.size(); ++j) {
    for (const char* f : {"angle_rad", "plant_angle_rad", "tau_gravity_Nm", "tau_desired_Nm", "tau_motor_cmd_Nm",
                          "operator_torque_Nm", "agonist_pressure_cmd_MPa", "antagonist_pressure_cmd_MPa", "agonist_loadcell_N",
                          "antagonist_loadcell_N", "plant_agonist_force_N", "plant_antagonist_force_N", "plant_gravity_Nm",
                          "plant_constraint_Nm", "plant_agonist_tension_N", "plant_antagonist_tension_N"}) {
      c.push_back(fmt::format("{}_{}", arm_log_prefix(scenario, j), f));
    }
  }
  c.push_back("limit_flags");
  c.push_back("fault_flags");
  return c;
}

hardware::HardwareRequest arm_hardware(const ArmScenario& scenario, const sim::ArmPlantParams& plant, bool one_board) {
  hardware::HardwareRequest r;
  r.period_s = scenario.period_s;
  r.joint_names = arm_joint_names(scenario);
  for (std::size_t j = 0; j < r.joint_names.size(); ++j) r.log_prefixes.push_back(arm_log_prefix(scenario, j) + "_");
  r.link = scenario.link ? &*scenario.link : nullptr;
  r.one_board = one_board;
  r.simulate = [plant]() -> std::unique_ptr<io::Backend> {
    const std::lock_guard lock(mujoco_load_mutex());  // MuJoCo's model loading is not thread-safe
    return std::make_unique<sim::ArmBackend>(plant);
  };
  return r;
}

sim::ArmPlantParams postures_plant_params(const ArmScenario& scenario) {
  // The operator's script: hold the arm where it starts while compensation comes on, then for each
  // posture carry the arm there, hold, let go, and watch.
  sim::ArmPlantParams p = scenario.plant;
  p.faults = scenario.faults;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  // Hold every gravity-compensated joint where it starts (a constant-pressure joint is left to its hold).
  std::vector<double> start(p.actuated.size(), nan);
  for (std::size_t i = 0; i < start.size(); ++i) {
    const control::ArmActuatedJoint& j = scenario.controller.joints[i];
    if (j.mode != control::ArmJointMode::kHoldPressure) start[i] = p.initial_q_rad[static_cast<std::size_t>(j.model_joint)];
  }
  p.operator_hands.moves.push_back({"start", 0.0, 2.0, 2.0, start});
  double t = 2.0 + scenario.observe_s * 0.2;
  for (const ArmPosture& a : scenario.postures) {
    p.operator_hands.moves.push_back({a.name, t, scenario.move_s + scenario.hold_s, scenario.move_s, a.target_rad});
    t += scenario.move_s + scenario.hold_s + scenario.observe_s;
  }
  return p;
}

std::vector<double> postures_release_times_s(const ArmScenario& scenario) {
  // The operator lets go at the end of each posture's move (the script's moves after "start").
  const sim::ArmPlantParams script = postures_plant_params(scenario);
  const std::vector<sim::OperatorMove>& moves = script.operator_hands.moves;
  std::vector<double> release_s;
  for (std::size_t i = 1; i < moves.size(); ++i) release_s.push_back(moves[i].start_s + moves[i].duration_s);
  return release_s;
}

double postures_duration_s(const ArmScenario& scenario) {
  const double whole_s = postures_release_times_s(scenario).back() + scenario.observe_s;
  return scenario.postures_stop_s > 0 ? std::min(whole_s, scenario.postures_stop_s) : whole_s;
}

PosturesResult run_postures(const ArmScenario& scenario, runtime::RowSink* log) {
  sim::ArmBackend plant(postures_plant_params(scenario));
  return run_postures_on(scenario, plant, &plant, log);
}

PosturesResult run_postures_on(const ArmScenario& scenario, io::Backend& backend, const sim::ArmBackend* sim, runtime::RowSink* log,
                               const runtime::CycleHooks& hooks) {
  const std::vector<double> release_s = postures_release_times_s(scenario);
  const double duration_s = postures_duration_s(scenario);
  const sim::ArmPlantParams script = postures_plant_params(scenario);  // where the operator's hands are, by the clock
  control::ArmController controller(scenario.controller);
  const safety::JointModels joints = arm_joint_models(controller.model());
  safety::LimitedBackend limited(backend, scenario.limits, joints);
  safety::Envelope envelope;
  const double nan = std::numeric_limits<double>::quiet_NaN();

  PosturesResult r;
  const auto steps = static_cast<std::size_t>(std::llround(duration_s / scenario.period_s));
  // Per judged joint and cycle: its angle, and from the plant's truth the constraint torque (friction,
  // stops), the gravity torque, and the controller's model of it.
  const std::vector<std::size_t> judged = gravity_joints(scenario);
  const std::size_t n_judged = judged.size();
  std::vector<std::vector<double>> angle(n_judged, std::vector<double>(steps + 1, 0.0));
  std::vector<std::vector<double>> held(n_judged, std::vector<double>(steps + 1, nan));
  std::vector<std::vector<double>> gravity(n_judged, std::vector<double>(steps + 1, nan));
  std::vector<std::vector<double>> model_gravity(n_judged, std::vector<double>(steps + 1, nan));
  io::SensorState state;
  io::Command command;
  std::vector<double> row(arm_log_columns(scenario).size());
  const auto wall_start = std::chrono::steady_clock::now();
  auto hold = [&](std::size_t k) {  // no new sample: the command is held
    for (std::vector<double>& a : angle) a[k] = k ? a[k - 1] : 0.0;
  };
  // An injected controller fault (sim/plant_faults.hpp: controller_nan) corrupts the command on its
  // joint here, before the supervisor: the test driver's part of the plant's fault injection (as E1).
  const sim::ControllerNanInjection controller_nan(scenario.faults);
  auto step = [&](std::size_t) {
    controller.update(state, command);
    controller_nan.apply(state.time_s, command);
  };
  auto observe = [&](std::size_t k, const io::Command& sent, std::uint32_t limit_flags) {
    const sim::ArmTruth* truth = sim ? &sim->sampled_truth() : nullptr;
    bool operator_active = false;
    if (truth) {
      operator_active = truth->operator_active;
    } else {
      for (const auto& m : script.operator_hands.moves) operator_active |= state.time_s >= m.start_s && state.time_s < m.start_s + m.duration_s;
    }
    for (std::size_t j = 0; j < n_judged; ++j) {
      const std::size_t a = judged[j];
      if (truth) {
        held[j][k] = truth->constraint_torque_Nm[a];
        gravity[j][k] = truth->bias_torque_Nm[a];
        model_gravity[j][k] = controller.diagnostics()[a].torque_gravity_Nm;
      }
      angle[j][k] = truth ? truth->actuated_q_rad[a] : state.joints[a].angle_rad;
    }
    for (std::size_t a = 0; a < static_cast<std::size_t>(state.joint_count); ++a) {
      safety::JointSample j = arm_joint_sample(state, sent, truth, a);
      // The start-up tare vents the muscles on purpose (the operator holds the arm): tension not judged.
      if (controller.wires_slack_on_purpose(state.time_s)) j.min_tension_N = std::numeric_limits<double>::infinity();
      envelope.observe(a, j);
      if (truth) r.peak_operator_torque_Nm = std::max(r.peak_operator_torque_Nm, std::abs(truth->operator_torque_Nm[a]));
    }
    if (log) {
      std::size_t col = 0;
      row[col++] = state.time_s;
      row[col++] = operator_active ? 1.0 : 0.0;
      const auto& diag = controller.diagnostics();
      for (std::size_t a = 0; a < scenario.controller.joints.size(); ++a) {
        const sim::PehaJointTruth* j = truth ? &truth->actuators[a] : nullptr;
        const double values[] = {state.joints[a].angle_rad, truth ? truth->actuated_q_rad[a] : nan, diag[a].torque_gravity_Nm, diag[a].tau_desired_Nm,
                                 sent.joints[a].motor_torque_Nm, truth ? truth->operator_torque_Nm[a] : nan,
                                 sent.joints[a].agonist_pressure_Pa * 1e-6, sent.joints[a].antagonist_pressure_Pa * 1e-6,
                                 state.joints[a].agonist_loadcell_N, state.joints[a].antagonist_loadcell_N, j ? j->muscle_force_N[0] : nan,
                                 j ? j->muscle_force_N[1] : nan, truth ? truth->bias_torque_Nm[a] : nan,
                                 truth ? truth->constraint_torque_Nm[a] : nan, j ? j->pulley_tension_min_N[0] : nan,
                                 j ? j->pulley_tension_min_N[1] : nan};
        for (double v : values) row[col++] = v;
      }
      row[col++] = static_cast<double>(limit_flags);
      row[col++] = static_cast<double>(limited.monitor().flags());
      log->push_row(row);
    }
  };
  const std::size_t done = runtime::run_cycles(limited, runtime::with_lifecycle(hooks, scenario.lifecycle), steps, state, command, step, hold, observe);
  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  r.realtime_factor = duration_s / std::max(wall_s, 1e-9);
  r.peak_muscle_force_N = envelope.peak_muscle_force_N();
  r.min_wire_tension_N = envelope.min_tension_N();
  add_arm_envelope_checks(scenario, joints, envelope, r.verdict);

  const auto window = static_cast<std::size_t>(std::llround(scenario.observe_s / scenario.period_s));
  for (std::size_t i = 0; i < scenario.postures.size(); ++i) {
    PostureResult p;
    p.name = scenario.postures[i].name;
    const auto k0 = static_cast<std::size_t>(std::llround(release_s[i] / scenario.period_s));
    if (k0 > done) continue;  // a run ended early analyses what it has
    const std::size_t k1 = std::min(k0 + window, done);
    for (std::size_t j = 0; j < n_judged; ++j) {
      const std::size_t io_joint = judged[j];
      PostureJointResult f;
      f.joint = arm_joint_names(scenario)[io_joint];
      f.target_deg = models::rad_to_deg(scenario.postures[i].target_rad[io_joint]);
      const std::vector<double>& a = angle[j];
      f.released_deg = models::rad_to_deg(a[k0]);
      f.drift_deg = models::rad_to_deg(a[k1] - a[k0]);
      const safety::JointLimits& range = scenario.limits.joints[io_joint];
      for (std::size_t k = k0; k <= k1; ++k) f.max_excursion_deg = std::max(f.max_excursion_deg, models::rad_to_deg(std::abs(a[k] - a[k0])));
      const StopDistance stop = stop_distance(a, k0, k1, range.min_angle_rad, range.max_angle_rad);
      f.stop_distance_deg = stop.closest_deg;
      add_release_checks(p.name + " " + f.joint, f.drift_deg, f.max_excursion_deg, stop, scenario.verdict, r.verdict);
      // Static torque error at rest (truth): what the friction and stops hold over the window's last
      // second; the controller's torque error is its negative (M qdd = tau + constraint - bias).
      const auto span = std::min(k1 - k0, static_cast<std::size_t>(std::llround(1.0 / scenario.period_s)));
      double held_sum = 0, gravity_sum = 0, model_sum = 0;
      for (std::size_t k = k1 - span; k <= k1; ++k) {
        held_sum += held[j][k];
        gravity_sum += gravity[j][k];
        model_sum += model_gravity[j][k];
      }
      const double n = static_cast<double>(span + 1);
      f.gravity_torque_Nm = gravity_sum / n;
      f.static_torque_error_pct = 100.0 * (-held_sum / n) / std::abs(f.gravity_torque_Nm);
      f.model_gravity_error_pct = 100.0 * (model_sum - gravity_sum) / n / std::abs(f.gravity_torque_Nm);
      if (sim && std::abs(f.gravity_torque_Nm) >= scenario.verdict.min_gravity_torque_Nm) {
        r.verdict.at_most(p.name + " " + f.joint + " |static torque error|", "% of gravity", std::abs(f.static_torque_error_pct),
                          scenario.verdict.max_static_torque_error_pct);
      }
      p.joints.push_back(f);
    }
    r.postures.push_back(p);
  }
  r.fault_flags = limited.monitor().flags();
  r.faults = limited.monitor().count();
  r.fault_reason = limited.monitor().run_reason();
  safety::add_supervisor_check(limited.monitor(), r.verdict);
  r.within_limits = r.verdict.passed();
  return r;
}

}  // namespace peha::experiments
