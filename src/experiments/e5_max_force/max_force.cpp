#include "peha/experiments/e5_max_force/max_force.hpp"
#include "peha/io/backend.hpp"
#include "peha/experiments/common/log_row.hpp"
#include "peha/experiments/common/mujoco_lock.hpp"
#include "peha/experiments/e1_gravity/e1_gravity.hpp"
#include "peha/experiments/common/scenario_header.hpp"

#include "peha/models/model_config.hpp"
#include "peha/models/units.hpp"
#include "peha/safety/limited_backend.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>

namespace peha::experiments {
const char* to_string(E5Stop stop) noexcept {
  switch (stop) {
    case E5Stop::kNone: return "none (the ramp's own pressure went out)";
    case E5Stop::kForceCeiling: return "limits: pressure ceiling from the muscle model's force ceiling";
    case E5Stop::kSupply: return "limits: pressure ceiling at the supply";
    case E5Stop::kRateLimit: return "limits: pressure rate limit";
    case E5Stop::kSupervisor: return "supervisor: outputs not active (safe outputs)";
  }
  return "?";
}

E5Scenario read_e5(const config::Document& doc) {
  config::Map root = doc.root();
  E5Scenario s;
  const ScenarioHeader header = read_scenario_header(root, "max_force_ramp");
  s.description = header.description;
  s.seed = header.seed;

  config::Map run = root.map("run");
  s.period_s = run.number("control_period_s", {1e-4, 0.1});
  s.duration_s = run.number("duration_s", {0.1, 3600.0});
  run.finish();

  config::Map ramp = root.map("ramp");
  s.ramp.muscle = ramp.choice("muscle", {"agonist", "antagonist"}) == "agonist" ? 0 : 1;
  s.ramp.start_s = ramp.number("start_s", {0.0, s.duration_s});
  s.ramp.start_pressure_Pa = ramp.number("start_pressure_MPa", {0.0, 1.0}) * 1e6;
  s.ramp.rate_Pa_per_s = ramp.number("rate_MPa_per_s", {0.001, 10.0}) * 1e6;
  s.ramp.other_pressure_Pa = ramp.number("other_pressure_MPa", {0.0, 1.0}) * 1e6;
  ramp.finish();

  config::Map limits = root.map("limits");
  const double supply_Pa = limits.number("supply_pressure_MPa", {0.1, 1.0}) * 1e6;
  s.limits = read_one_joint_limits(limits, s.period_s);
  const safety::JointLimits& jl = s.limits.joints[0];
  if (s.ramp.rate_Pa_per_s >= jl.pressure_rate_Pa_per_s) {
    throw config::Error(fmt::format("{}: ramp.rate_MPa_per_s {} must be below limits.pressure_rate_MPa_per_s {}: the rate limit "
                                    "would shape the ramp", doc.name(), s.ramp.rate_Pa_per_s * 1e-6, jl.pressure_rate_Pa_per_s * 1e-6));
  }

  config::Map ctl = root.map("controller");
  const double pretension_N = ctl.number("pretension_N", {0.0, 500.0});
  s.joint = models::read_joint_model(ctl, "joint", supply_Pa, pretension_N);
  ctl.finish();

  config::Map plant = root.map("plant");
  s.plant = sim::read_one_dof_rig(plant, s.period_s, supply_Pa);
  s.plant.payload_kg = 0.0;  // the clamp holds the link: no payload
  s.plant.seed = s.seed;
  s.verdict = safety::read_verdict_thresholds(root);
  safety::read_monitor_params(root, s.limits.monitor);  // the supervisor's plausibility stage (docs/safety.md)
  s.lifecycle = runtime::read_lifecycle(root);
  s.telemetry = runtime::read_telemetry(root);

  for (config::Map c : root.maps("cases", 1, 16)) {
    E5Case e;
    e.name = c.string("name");
    e.locked_angle_rad = models::deg_to_rad(c.number("locked_angle_deg", {models::rad_to_deg(jl.min_angle_rad), models::rad_to_deg(jl.max_angle_rad)}));
    c.finish();
    s.cases.push_back(e);
  }
  if (root.has("mfb")) s.link = mfb::read_link_config(root.map("mfb"));
  root.finish();
  return s;
}

const std::vector<std::string>& e5_log_columns() {
  static const std::vector<std::string> columns = {
      "t_s", "angle_rad", "ramp_pressure_cmd_MPa", "agonist_pressure_cmd_MPa", "antagonist_pressure_cmd_MPa",
      "agonist_pressure_MPa", "antagonist_pressure_MPa", "agonist_loadcell_N", "antagonist_loadcell_N",
      "ceiling_pressure_MPa", "force_limit_N", "stop", "plant_agonist_force_N", "plant_antagonist_force_N", "limit_flags"};
  return columns;
}

sim::OneDofRigParams e5_plant_params(const E5Scenario& scenario, const E5Case& c) {
  sim::OneDofRigParams p = scenario.plant;
  p.initial_angle_rad = c.locked_angle_rad;
  return p;
}

hardware::HardwareRequest e5_hardware(const E5Scenario& scenario, const E5Case& c) {
  return one_dof_rig_hardware(scenario.period_s, scenario.link, e5_plant_params(scenario, c));
}

E5Result run_e5_case(const E5Scenario& scenario, const E5Case& c, runtime::RowSink* log) {
  std::unique_ptr<sim::OneDofRigBackend> plant;
  {
    const std::lock_guard lock(mujoco_load_mutex());
    plant = std::make_unique<sim::OneDofRigBackend>(e5_plant_params(scenario, c));
  }
  return run_e5_on(scenario, c, *plant, plant.get(), log);
}

namespace {

using io::kNaN;

/// E5's log row: e5_log_columns, the same names in order.
struct E5LogRow {
  double t_s, angle_rad, ramp_pressure_cmd_MPa, agonist_pressure_cmd_MPa, antagonist_pressure_cmd_MPa, agonist_pressure_MPa,
      antagonist_pressure_MPa, agonist_loadcell_N, antagonist_loadcell_N, ceiling_pressure_MPa, force_limit_N, stop,
      plant_agonist_force_N, plant_antagonist_force_N, limit_flags;
};

/// One E5 case: its per-cycle step (the ramp), its per-cycle observation (what capped the ramp, the
/// envelope, the log row) and the per-cycle buffers analyse_e5 reads, sized before the loop: step,
/// hold and observe allocate nothing. `r` gathers the running figures (peaks, missed samples).
struct E5Run {
  E5Run(const E5Scenario& scenario, const E5Case& c, const sim::OneDofRigBackend* sim, std::size_t steps)
      : scenario(scenario),
        c(c),
        sim(sim),
        jm(scenario.joint),
        side(scenario.ramp.muscle),
        ramped(side == 0 ? jm.agonist : jm.antagonist),
        force(steps + 1, kNaN),
        pressure(steps + 1, kNaN),
        sent_pressure(steps + 1, kNaN),
        cap(steps + 1, E5Stop::kNone) {
    r.case_name = c.name;
    r.muscle = side == 0 ? "agonist" : "antagonist";
    r.locked_angle_deg = models::rad_to_deg(c.locked_angle_rad);
    r.limit_N = models::force_ceiling_N(ramped);
    r.from_truth = sim != nullptr;
  }

  // The test's input, as the paper's: the ramped muscle's pressure rises without end, the other
  // muscle is held at a constant pressure (its wire taut), the motor is off.
  void step(const io::SensorState& state, io::Command& command) noexcept {
    requested_Pa = scenario.ramp.start_pressure_Pa + scenario.ramp.rate_Pa_per_s * std::max(0.0, state.time_s - scenario.ramp.start_s);
    const double other_Pa = scenario.ramp.other_pressure_Pa;
    command.joint_count = 1;
    io::JointCommand& cmd = command.joints[0];
    cmd.agonist_pressure_Pa = side == 0 ? requested_Pa : other_Pa;
    cmd.antagonist_pressure_Pa = side == 0 ? other_Pa : requested_Pa;
    cmd.motor_torque_Nm = 0.0;
  }

  void hold() noexcept { ++r.missed_samples; }

  void observe(std::size_t k, const io::SensorState& state, const io::Command& sent, std::uint32_t flags, bool outputs_active,
               runtime::RowSink* log) {
    const io::JointSensors& s = state.joints[0];
    const io::JointCommand& out = sent.joints[0];
    const sim::OneDofRigTruth* t = sim ? &sim->sampled_truth() : nullptr;
    force[k] = side == 0 ? s.agonist_loadcell_N : s.antagonist_loadcell_N;
    pressure[k] = side == 0 ? s.agonist_pressure_Pa : s.antagonist_pressure_Pa;
    sent_pressure[k] = side == 0 ? out.agonist_pressure_Pa : out.antagonist_pressure_Pa;
    r.max_clamp_deflection_deg = std::max(r.max_clamp_deflection_deg, models::rad_to_deg(std::abs(s.angle_rad - c.locked_angle_rad)));
    const double eps = models::rigid_contraction(ramped, jm.pulley_radius_m, side == 0 ? +1 : -1, s.angle_rad);
    const safety::PressureBand band = safety::pressure_band(ramped, jm, eps);
    cap[k] = stop_of(sent_pressure[k], flags, band, outputs_active);
    safety::JointSample j;
    if (t) {
      j = {{t->muscle_force_N[0], t->muscle_force_N[1]}, std::min(t->pulley_tension_min_N[0], t->pulley_tension_min_N[1]),
           {t->pressure_Pa[0], t->pressure_Pa[1]}, t->motor_torque_Nm, t->angle_rad};
      r.peak_truth_force_N = std::max(r.peak_truth_force_N, t->muscle_force_N[side]);
    } else {
      j = {{s.agonist_loadcell_N, s.antagonist_loadcell_N}, std::min(s.agonist_loadcell_N, s.antagonist_loadcell_N),
           {s.agonist_pressure_Pa, s.antagonist_pressure_Pa}, out.motor_torque_Nm, s.angle_rad};
    }
    envelope.observe(0, j);
    if (log) {
      const E5LogRow row{.t_s = state.time_s, .angle_rad = s.angle_rad, .ramp_pressure_cmd_MPa = requested_Pa * 1e-6,
                         .agonist_pressure_cmd_MPa = out.agonist_pressure_Pa * 1e-6, .antagonist_pressure_cmd_MPa = out.antagonist_pressure_Pa * 1e-6,
                         .agonist_pressure_MPa = s.agonist_pressure_Pa * 1e-6, .antagonist_pressure_MPa = s.antagonist_pressure_Pa * 1e-6,
                         .agonist_loadcell_N = s.agonist_loadcell_N, .antagonist_loadcell_N = s.antagonist_loadcell_N,
                         .ceiling_pressure_MPa = band.ceiling_Pa * 1e-6, .force_limit_N = r.limit_N, .stop = static_cast<double>(cap[k]),
                         .plant_agonist_force_N = t ? t->muscle_force_N[0] : kNaN, .plant_antagonist_force_N = t ? t->muscle_force_N[1] : kNaN,
                         .limit_flags = static_cast<double>(flags)};
      log->push_row(as_columns(row));
    }
  }

  /// What capped the ramp this cycle (the supervisor shapes before the limits, the gate after).
  E5Stop stop_of(double sent_Pa, std::uint32_t flags, const safety::PressureBand& band, bool outputs_active) const noexcept {
    if (!outputs_active) return E5Stop::kSupervisor;
    if (!(sent_Pa < requested_Pa - 1.0)) return E5Stop::kNone;  // (a NaN too)
    if ((flags & safety::kPressureLimited) && sent_Pa >= band.ceiling_Pa - 1.0) {
      return band.ceiling_is_supply ? E5Stop::kSupply : E5Stop::kForceCeiling;
    }
    if (flags & safety::kRateLimited) return E5Stop::kRateLimit;
    return E5Stop::kSupervisor;  // changed before the limits: the supervisor's ramp
  }

  const E5Scenario& scenario;
  const E5Case& c;
  const sim::OneDofRigBackend* sim;
  const models::JointModel& jm;
  const int side;  ///< the ramped muscle: 0 agonist, 1 antagonist
  const models::MuscleModel& ramped;
  std::vector<double> force, pressure, sent_pressure;  ///< the ramped muscle's per cycle: load cell N, pressure Pa, sent Pa
  std::vector<E5Stop> cap;                             ///< what capped the ramp, per cycle
  double requested_Pa = 0;                             ///< the ramp's pressure this cycle
  safety::Envelope envelope;
  E5Result r;
};

/// The held force's figures from the load cell, `done` the last cycle. The limit is reached when the
/// limits first cap the ramp (not the supervisor: over a link its first cycle may wait for outputs); the force then holds at its final value (mean of the last second); it
/// is "at the limit" from the first cycle after which it stays within at_limit_band_N of that value
/// to the end.
void held_force_figures(const E5Run& run, std::size_t done, E5Result& r) {
  const double nan = kNaN, period_s = run.scenario.period_s;
  const std::vector<double>& force = run.force;
  const auto span = std::min(done, static_cast<std::size_t>(std::llround(1.0 / period_s)));
  double held_sum = 0;
  std::size_t held_n = 0;
  for (std::size_t k = done - span; k <= done; ++k) {
    if (!std::isnan(force[k])) held_sum += force[k], ++held_n;
  }
  r.held_force_N = held_n ? held_sum / static_cast<double>(held_n) : nan;
  std::size_t reach = done + 1, hold_from = done + 1;
  for (std::size_t k = 0; k <= done; ++k) {
    if (!std::isnan(force[k])) r.peak_force_N = std::max(r.peak_force_N, force[k]);
    if (reach > done && run.cap[k] != E5Stop::kNone && run.cap[k] != E5Stop::kSupervisor) reach = k;
  }
  for (std::size_t k = done + 1; k-- > 0;) {  // back from the end while the force holds
    if (std::isnan(force[k])) continue;
    if (std::abs(force[k] - r.held_force_N) > run.scenario.verdict.at_limit_band_N) break;
    hold_from = k;
  }
  std::size_t count = 0;
  double p_sum = 0, cmd_sum = 0;
  for (std::size_t k = hold_from; k <= done; ++k) {
    if (std::isnan(force[k])) continue;
    ++count;
    p_sum += run.pressure[k];
    cmd_sum += run.sent_pressure[k];
    ++r.stop_counts[static_cast<int>(run.cap[k])];
  }
  r.overshoot_N = std::max(0.0, r.peak_force_N - r.limit_N);
  r.overshoot_pct = 100.0 * r.overshoot_N / r.limit_N;
  r.shortfall_N = r.limit_N - r.held_force_N;
  r.reach_s = reach <= done ? static_cast<double>(reach) * period_s : nan;
  r.settle_s = reach <= done ? static_cast<double>(std::max(hold_from, reach) - reach) * period_s : nan;
  r.time_at_limit_s = reach <= done ? static_cast<double>(done - std::max(hold_from, reach)) * period_s : 0.0;
  r.pressure_at_limit_MPa = count ? p_sum / static_cast<double>(count) * 1e-6 : nan;
  r.pressure_cmd_at_limit_MPa = count ? cmd_sum / static_cast<double>(count) * 1e-6 : nan;
  r.ceiling_share_pct = count ? 100.0 * static_cast<double>(r.stop_counts[static_cast<int>(E5Stop::kForceCeiling)]) / count : 0.0;
  r.stop = static_cast<E5Stop>(std::max_element(std::begin(r.stop_counts), std::end(r.stop_counts)) - std::begin(r.stop_counts));
}

/// E5's figures and verdict from a case's buffers, `done` its last cycle.
E5Result analyse_e5(const E5Run& run, std::size_t done, const safety::LimitedBackend& limited) {
  E5Result r = run.r;
  std::copy(std::begin(limited.data().counts), std::end(limited.data().counts), std::begin(r.limit_counts));
  if (!r.from_truth) r.peak_truth_force_N = kNaN;
  held_force_figures(run, done, r);
  const safety::VerdictThresholds& th = run.scenario.verdict;
  r.verdict.thresholds = th;
  const std::string m = r.muscle;
  r.verdict.at_most(m + " held force short of the ceiling", "N", r.shortfall_N, th.max_force_shortfall_N);
  r.verdict.at_most(m + " overshoot over the force ceiling", "N", r.overshoot_N, th.max_force_overshoot_N);
  r.verdict.at_most(m + " time from reaching the limit to holding", "s", r.settle_s, th.max_settle_s);
  r.verdict.at_least(m + " time at the limit", "s", r.time_at_limit_s, th.min_time_at_limit_s);
  r.verdict.at_least(m + " held cycles capped by the force ceiling", "%", r.ceiling_share_pct, th.min_ceiling_share_pct);
  const safety::JointModels joints{&run.jm};
  safety::add_envelope_checks(run.scenario.limits, joints, sim::one_dof_rig_joint_names(), run.envelope, th, r.verdict);
  safety::add_supervisor_check(limited.monitor(), r.verdict);
  r.passed = r.verdict.passed();
  return r;
}

}  // namespace

E5Result run_e5_on(const E5Scenario& scenario, const E5Case& c, io::Backend& backend, const sim::OneDofRigBackend* sim,
                   runtime::RowSink* log, const runtime::CycleHooks& hooks) {
  const safety::JointModels joints{&scenario.joint};
  safety::LimitedBackend limited(backend, scenario.limits, joints);
  const auto steps = static_cast<std::size_t>(std::llround(scenario.duration_s / scenario.period_s));
  E5Run run(scenario, c, sim, steps);
  io::SensorState state;
  io::Command command;
  const auto wall_start = std::chrono::steady_clock::now();
  const std::size_t done = runtime::run_cycles(
      limited, runtime::with_lifecycle(hooks, scenario.lifecycle), steps, state, command, [&](std::size_t) { run.step(state, command); },
      [&](std::size_t) { run.hold(); },
      [&](std::size_t k, const io::Command& sent, std::uint32_t flags) { run.observe(k, state, sent, flags, limited.status().active, log); });
  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  E5Result r = analyse_e5(run, done, limited);
  r.simulated_s = static_cast<double>(done) * scenario.period_s;
  r.realtime_factor = r.simulated_s / std::max(wall_s, 1e-9);
  return r;
}

}  // namespace peha::experiments
