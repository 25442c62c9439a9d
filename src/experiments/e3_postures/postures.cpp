#include "peha/experiments/e3_postures/postures.hpp"
#include "peha/experiments/common/log_row.hpp"
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
                          "plant_constraint_Nm", "plant_agonist_tension_N", "plant_antagonist_tension_N", "plant_agonist_contraction",
                          "plant_antagonist_contraction", "agonist_pressure_MPa",
                          "antagonist_pressure_MPa", "supply_pressure_MPa", "redundant_angle_rad", "motor_torque_monitor_Nm"}) {
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

hardware::HardwareRequest postures_hardware(const ArmScenario& scenario) { return arm_hardware(scenario, postures_plant_params(scenario)); }

PosturesResult run_postures(const ArmScenario& scenario, runtime::RowSink* log) {
  const hardware::Hardware arm = hardware::open_backend(hardware::BackendUri{}, postures_hardware(scenario));
  return run_postures_on(scenario, *arm.backend, dynamic_cast<sim::ArmBackend*>(arm.backend.get()), log);
}

namespace {

/// A joint's block of arm_log_columns (the same names, in order). The sensors the controller read
/// that a replay needs besides the angle and load cells come last (added after the others).
struct ArmJointColumns {
  double angle_rad, plant_angle_rad, tau_gravity_Nm, tau_desired_Nm, tau_motor_cmd_Nm, operator_torque_Nm, agonist_pressure_cmd_MPa,
      antagonist_pressure_cmd_MPa, agonist_loadcell_N, antagonist_loadcell_N, plant_agonist_force_N, plant_antagonist_force_N,
      plant_gravity_Nm, plant_constraint_Nm, plant_agonist_tension_N, plant_antagonist_tension_N, plant_agonist_contraction,
      plant_antagonist_contraction, agonist_pressure_MPa,
      antagonist_pressure_MPa, supply_pressure_MPa, redundant_angle_rad, motor_torque_monitor_Nm;
};

/// One E3 run: the controller, its per-cycle step and observation (the judged joints' angles and
/// torques, the envelope, the log row), and the buffers analyse_postures reads. Every buffer is sized
/// here, before the loop: step, hold and observe allocate nothing.
struct PosturesRun {
  PosturesRun(const ArmScenario& scenario, sim::ArmBackend* sim, std::size_t steps)
      : scenario(scenario),
        sim(sim),
        script(postures_plant_params(scenario)),
        controller(scenario.controller),
        joints(arm_joint_models(controller.model())),
        controller_nan(scenario.faults),
        judged(gravity_joints(scenario)),
        angle(judged.size(), std::vector<double>(steps + 1, 0.0)),
        held(judged.size(), std::vector<double>(steps + 1, kNaN)),
        gravity(judged.size(), std::vector<double>(steps + 1, kNaN)),
        model_gravity(judged.size(), std::vector<double>(steps + 1, kNaN)),
        row(arm_log_columns(scenario).size()) {}

  void step(const io::SensorState& state, io::Command& command) {
    controller.update(state, command);
    controller_nan.apply(state.time_s, command);
  }

  void hold(std::size_t k) {  // no new sample: the command is held
    for (std::vector<double>& a : angle) a[k] = k ? a[k - 1] : 0.0;
  }

  void observe(std::size_t k, const io::SensorState& state, const io::Command& sent, std::uint32_t limit_flags, std::uint32_t fault_flags,
               runtime::RowSink* log) {
    const sim::ArmTruth* truth = sim ? &sim->sampled_truth() : nullptr;
    for (std::size_t j = 0; j < judged.size(); ++j) {
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
      if (truth) peak_operator_torque_Nm = std::max(peak_operator_torque_Nm, std::abs(truth->operator_torque_Nm[a]));
    }
    if (log) {
      write_row(state, sent, truth, limit_flags, fault_flags);
      log->push_row(row);
    }
  }

  const ArmScenario& scenario;
  sim::ArmBackend* sim;
  const sim::ArmPlantParams script;  ///< where the operator's hands are, by the clock
  control::ArmController controller;
  const safety::JointModels joints;
  /// An injected controller fault (sim/plant_faults.hpp: controller_nan) corrupts the command on its
  /// joint here, before the supervisor: the test driver's part of the plant's fault injection (as E1).
  const sim::ControllerNanInjection controller_nan;
  /// Per judged joint and cycle: its angle (rad), and from the plant's truth the constraint torque
  /// (friction, stops), the gravity torque, and the controller's model of it (Nm).
  const std::vector<std::size_t> judged;
  std::vector<std::vector<double>> angle, held, gravity, model_gravity;
  safety::Envelope envelope;
  double peak_operator_torque_Nm = 0;
  std::vector<double> row;  ///< the log row, in arm_log_columns' order

 private:
  static constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

  /// The log row, in arm_log_columns' order.
  void write_row(const io::SensorState& state, const io::Command& sent, const sim::ArmTruth* truth, std::uint32_t limit_flags,
                 std::uint32_t fault_flags) {
    bool operator_active = false;
    if (truth) {
      operator_active = truth->operator_active;
    } else {
      for (const auto& m : script.operator_hands.moves) operator_active |= state.time_s >= m.start_s && state.time_s < m.start_s + m.duration_s;
    }
    std::size_t col = 0;
    row[col++] = state.time_s;
    row[col++] = operator_active ? 1.0 : 0.0;
    const auto& diag = controller.diagnostics();
    for (std::size_t a = 0; a < scenario.controller.joints.size(); ++a) {
      const sim::PehaJointTruth* j = truth ? &truth->actuators[a] : nullptr;
      const io::JointSensors& s = state.joints[a];
      const io::JointCommand& cmd = sent.joints[a];
      put_columns(row, col, ArmJointColumns{
          .angle_rad = s.angle_rad, .plant_angle_rad = truth ? truth->actuated_q_rad[a] : kNaN, .tau_gravity_Nm = diag[a].torque_gravity_Nm,
          .tau_desired_Nm = diag[a].tau_desired_Nm, .tau_motor_cmd_Nm = cmd.motor_torque_Nm,
          .operator_torque_Nm = truth ? truth->operator_torque_Nm[a] : kNaN, .agonist_pressure_cmd_MPa = cmd.agonist_pressure_Pa * 1e-6,
          .antagonist_pressure_cmd_MPa = cmd.antagonist_pressure_Pa * 1e-6, .agonist_loadcell_N = s.agonist_loadcell_N,
          .antagonist_loadcell_N = s.antagonist_loadcell_N, .plant_agonist_force_N = j ? j->muscle_force_N[0] : kNaN,
          .plant_antagonist_force_N = j ? j->muscle_force_N[1] : kNaN, .plant_gravity_Nm = truth ? truth->bias_torque_Nm[a] : kNaN,
          .plant_constraint_Nm = truth ? truth->constraint_torque_Nm[a] : kNaN,
          .plant_agonist_tension_N = j ? j->pulley_tension_min_N[0] : kNaN, .plant_antagonist_tension_N = j ? j->pulley_tension_min_N[1] : kNaN,
          .plant_agonist_contraction = j ? j->muscle_contraction[0] : kNaN,
          .plant_antagonist_contraction = j ? j->muscle_contraction[1] : kNaN,
          .agonist_pressure_MPa = s.agonist_pressure_Pa * 1e-6, .antagonist_pressure_MPa = s.antagonist_pressure_Pa * 1e-6,
          .supply_pressure_MPa = s.supply_pressure_Pa * 1e-6, .redundant_angle_rad = s.redundant_angle_rad,
          .motor_torque_monitor_Nm = s.motor_torque_Nm});
    }
    row[col++] = static_cast<double>(limit_flags);
    row[col++] = static_cast<double>(fault_flags);
  }
};

/// One judged joint (index j of run.judged) after the release of posture i, over cycles k0..k1: its
/// drift, excursion and distance to its stops, and its static torque error; the checks into `verdict`.
PostureJointResult analyse_posture_joint(const PosturesRun& run, std::size_t i, std::size_t j, std::size_t k0, std::size_t k1,
                                         safety::Verdict& verdict) {
  const ArmScenario& scenario = run.scenario;
  const std::string& posture = scenario.postures[i].name;
  const std::size_t io_joint = run.judged[j];
  PostureJointResult f;
  f.joint = arm_joint_names(scenario)[io_joint];
  f.target_deg = models::rad_to_deg(scenario.postures[i].target_rad[io_joint]);
  const std::vector<double>& a = run.angle[j];
  f.released_deg = models::rad_to_deg(a[k0]);
  f.drift_deg = models::rad_to_deg(a[k1] - a[k0]);
  const safety::JointLimits& range = scenario.limits.joints[io_joint];
  for (std::size_t k = k0; k <= k1; ++k) f.max_excursion_deg = std::max(f.max_excursion_deg, models::rad_to_deg(std::abs(a[k] - a[k0])));
  const StopDistance stop = stop_distance(a, k0, k1, range.min_angle_rad, range.max_angle_rad);
  f.stop_distance_deg = stop.closest_deg;
  add_release_checks(posture + " " + f.joint, f.drift_deg, f.max_excursion_deg, stop, scenario.verdict, verdict);
  // Static torque error at rest (truth): what the friction and stops hold over the window's last
  // second; the controller's torque error is its negative (M qdd = tau + constraint - bias).
  const auto span = std::min(k1 - k0, static_cast<std::size_t>(std::llround(1.0 / scenario.period_s)));
  double held_sum = 0, gravity_sum = 0, model_sum = 0;
  for (std::size_t k = k1 - span; k <= k1; ++k) {
    held_sum += run.held[j][k];
    gravity_sum += run.gravity[j][k];
    model_sum += run.model_gravity[j][k];
  }
  const double n = static_cast<double>(span + 1);
  f.gravity_torque_Nm = gravity_sum / n;
  f.static_torque_error_pct = 100.0 * (-held_sum / n) / std::abs(f.gravity_torque_Nm);
  f.model_gravity_error_pct = 100.0 * (model_sum - gravity_sum) / n / std::abs(f.gravity_torque_Nm);
  if (run.sim && std::abs(f.gravity_torque_Nm) >= scenario.verdict.min_gravity_torque_Nm) {
    verdict.at_most(posture + " " + f.joint + " |static torque error|", "% of gravity", std::abs(f.static_torque_error_pct),
                    scenario.verdict.max_static_torque_error_pct);
  }
  return f;
}

/// E3's figures and verdict from a run's buffers, `done` its last cycle: each posture over the
/// observe_s window after its release.
PosturesResult analyse_postures(const PosturesRun& run, std::size_t done, const safety::FaultMonitor& monitor) {
  const ArmScenario& scenario = run.scenario;
  PosturesResult r;
  r.peak_operator_torque_Nm = run.peak_operator_torque_Nm;
  r.peak_muscle_force_N = run.envelope.peak_muscle_force_N();
  r.min_wire_tension_N = run.envelope.min_tension_N();
  add_arm_envelope_checks(scenario, run.joints, run.envelope, r.verdict);
  // The start-up (vent, tare and the refill, under the operator's hands) lasts until the operator lets go.
  const double startup_end_s = run.script.operator_hands.moves.front().duration_s;
  const auto startup_end = std::min(done, static_cast<std::size_t>(std::llround(startup_end_s / scenario.period_s)));
  for (std::size_t j = 0; j < run.judged.size(); ++j) {
    safety::add_startup_checks(arm_joint_names(scenario)[run.judged[j]], run.angle[j], scenario.period_s, startup_end, scenario.verdict,
                               r.verdict);
  }
  const std::vector<double> release_s = postures_release_times_s(scenario);
  const auto window = static_cast<std::size_t>(std::llround(scenario.observe_s / scenario.period_s));
  for (std::size_t i = 0; i < scenario.postures.size(); ++i) {
    PostureResult p;
    p.name = scenario.postures[i].name;
    const auto k0 = static_cast<std::size_t>(std::llround(release_s[i] / scenario.period_s));
    if (k0 > done) continue;  // a run ended early analyses what it has
    const std::size_t k1 = std::min(k0 + window, done);
    for (std::size_t j = 0; j < run.judged.size(); ++j) p.joints.push_back(analyse_posture_joint(run, i, j, k0, k1, r.verdict));
    r.postures.push_back(p);
  }
  r.fault_flags = monitor.flags();
  r.faults = monitor.count();
  r.fault_reason = monitor.run_reason();
  r.check_peaks = monitor.peaks();
  r.first_fault_flag = monitor.first().flag;
  safety::add_supervisor_check(monitor, r.verdict);
  r.within_limits = r.verdict.passed();
  return r;
}

}  // namespace

PosturesResult run_postures_on(const ArmScenario& scenario, io::Backend& backend, sim::ArmBackend* sim, runtime::RowSink* log,
                               const runtime::CycleHooks& hooks) {
  const double duration_s = postures_duration_s(scenario);
  const auto steps = static_cast<std::size_t>(std::llround(duration_s / scenario.period_s));
  PosturesRun run(scenario, sim, steps);
  safety::LimitedBackend limited(backend, scenario.limits, run.joints);
  io::SensorState state;
  io::Command command;
  std::vector<runtime::LifecycleEvent> lifecycle;
  const runtime::CycleHooks loop_hooks = runtime::recording_lifecycle(
      runtime::resuming(runtime::with_lifecycle(hooks, scenario.lifecycle), [&run] { run.controller.resume(); }), lifecycle);
  const auto wall_start = std::chrono::steady_clock::now();
  const std::size_t done = runtime::run_cycles(
      limited, loop_hooks, steps, state, command, [&](std::size_t) { run.step(state, command); },
      [&](std::size_t k) { run.hold(k); },
      [&](std::size_t k, const io::Command& sent, std::uint32_t limit_flags) {
        // The operator lets go of the arm only when the run is ready: every joint carried, no fault shown.
        if (sim) sim->keep_hands(!limited.monitor().ready(state.joint_count));
        run.observe(k, state, sent, limit_flags, limited.monitor().flags(), log);
      });
  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  PosturesResult r = analyse_postures(run, done, limited.monitor());
  r.lifecycle = std::move(lifecycle);
  r.realtime_factor = duration_s / std::max(wall_s, 1e-9);
  return r;
}

}  // namespace peha::experiments
