#include "peha/experiments/sensor_check/sensor_check.hpp"

#include "peha/control/one_dof_gravity.hpp"
#include "peha/hardware/door.hpp"
#include "peha/models/units.hpp"
#include "peha/safety/limited_backend.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

namespace peha::experiments {

namespace {

constexpr const char* kMuscle[2] = {"agonist", "antagonist"};
/// After the pin, the sweeps: up to check + sweep, down to check - sweep (measured: sweep 1), up to
/// check + sweep (measured: sweep 0), then the pressure held. Each ends when the encoder gets there.
struct Leg {
  double direction;    ///< +1 up, -1 down
  int measured_sweep;  ///< 0 up, 1 down, -1 not measured
};
constexpr Leg kLegs[3] = {{+1, -1}, {-1, 1}, {+1, 0}};

/// The longest a leg may take: the travel at the sweep speed, plus the breakaway (the pressure ramps
/// through the cable's stiction band first).
double leg_limit_s(const SensorCheckParams& p) noexcept { return 2.0 * p.sweep_rad / p.sweep_speed_radps + 6.0; }

/// The torque the agonist holds with the antagonist vented: the known mass's and the link's own (the
/// scenario's gravity model of the link).
double known_torque_Nm(const E1Scenario& s, const SensorCheckParams& p, double angle_rad) {
  control::OneDofGravityModel g = s.controller.gravity;
  g.payload_mass_kg = p.known_mass_kg;
  g.payload_lever_m = p.lever_m;
  return control::gravity_torque_Nm(g, angle_rad);
}

}  // namespace

double SensorCheckParams::duration_s() const noexcept { return pin_s + 3.0 * leg_limit_s(*this); }

SensorCheckParams read_sensor_check(config::Map map) {
  SensorCheckParams p;
  p.known_mass_kg = map.number("known_mass_kg", {0.1, 20.0});
  p.lever_m = map.number("lever_m", {0.01, 2.0});
  p.check_angle_rad = models::deg_to_rad(map.number("check_angle_deg", {-30.0, 30.0}));
  p.sweep_rad = models::deg_to_rad(map.number("sweep_deg", {0.5, 15.0}));
  p.sweep_speed_radps = models::deg_to_rad(map.number("sweep_speed_degps", {0.1, 20.0}));
  p.window_rad = models::deg_to_rad(map.number("window_deg", {0.05, models::rad_to_deg(p.sweep_rad) * 0.8}));
  p.min_speed_fraction = map.number("min_speed_fraction", {0.0, 1.0});
  p.antagonist_force_N = map.number("antagonist_force_N", {10.0, 2000.0});
  p.vent_s = map.number("vent_s", {0.0, 10.0});
  p.tare_s = map.number("tare_s", {0.05, 10.0});
  p.pin_s = map.number("pin_s", {p.vent_s + p.tare_s + 0.1, 30.0});
  p.force_gain_Pa_per_N_s = map.number("force_gain_MPa_per_N_s", {0.0, 1.0}) * 1e6;
  p.speed_integral_Pa_per_rad = map.number("speed_integral_MPa_per_deg", {0.0, 1.0}) * 1e6 * models::kDegPerRad;
  p.speed_gain_Pa_s_per_rad = map.number("speed_gain_MPa_s_per_deg", {0.0, 1.0}) * 1e6 * models::kDegPerRad;
  map.finish();
  return p;
}

sim::OneDofRigParams sensor_check_plant_params(const SensorCheckParams& params, sim::OneDofRigParams plant, double placed_mass_kg) {
  plant.payload_kg = placed_mass_kg;
  plant.unknown_payload_kg = 0.0;
  plant.initial_angle_rad = 0.0;
  plant.finger.pushes.clear();
  plant.finger.stiffness_N_per_m = kClampStiffness_N_per_m;
  plant.finger.damping_Ns_per_m = kClampDamping_Ns_per_m;
  plant.finger.max_force_N = kClampMaxForce_N;
  sim::FingerPush pin;  // the rig's pin through link and frame at 0 while the muscles vent, the cells tare and the agonist refills
  pin.name = "pin";
  pin.start_s = 0.0;
  pin.duration_s = params.pin_s;
  pin.move_s = 0.1;
  pin.target_angle_rad = 0.0;
  pin.clamp = true;
  plant.finger.pushes.push_back(pin);
  return plant;
}

const std::vector<std::string>& sensor_check_log_columns() {
  static const std::vector<std::string> columns = {"t_s", "angle_rad", "leg", "agonist_loadcell_N", "antagonist_loadcell_N",
                                                   "agonist_pressure_MPa", "antagonist_pressure_MPa", "agonist_pressure_cmd_MPa",
                                                   "antagonist_pressure_cmd_MPa", "measured_sweep", "limit_flags"};
  return columns;
}

SensorCheckRun record_sensor_check_run(const E1Scenario& scenario, const SensorCheckParams& p, int run, io::Backend& backend,
                                       const runtime::CycleHooks& hooks, runtime::RowSink* log) {
  const models::JointModel& joint = scenario.controller.joint;
  const double period_s = backend.info().period_s;
  const auto steps = static_cast<std::size_t>(std::llround(p.duration_s() / period_s));
  const safety::LimitsModel limits = e1_recording_limits(scenario);
  const safety::JointModels joints{&joint};
  safety::LimitedBackend limited(backend, limits, joints);
  control::VelocityEstimator velocity;
  velocity.cutoff_Hz = scenario.controller.velocity_cutoff_Hz;
  io::SensorState state;
  io::Command command;
  command.joint_count = 1;

  const double r = joint.pulley_radius_m;
  const double supply = joint.supply_pressure_Pa;
  // Run 2: the antagonist held at its model's pressure for the known force at the check angle.
  const double antagonist_Pa =
      run == 1 ? models::muscle_pressure(joint.antagonist, p.antagonist_force_N, models::rigid_contraction(joint.antagonist, r, -1, p.check_angle_rad), supply).pressure_Pa
               : 0.0;
  const double antagonist_force_N = run == 1 ? p.antagonist_force_N : 0.0;

  SensorCheckRun out;
  double zero_sum[2] = {0, 0}, code0[2] = {0, 0}, zero_n = 0;
  double sum[2][2] = {}, n[2] = {0, 0};
  double hold_Pa = 0, t0 = 0;
  bool started_refill = false;
  int leg = 0;                // the leg running (3: done)
  double leg_start_s = p.pin_s;
  int measured = -1;  // the sweep this cycle's sample went into (-1: none)
  auto step = [&](std::size_t k) {
    const io::JointSensors& s = state.joints[0];
    if (k == 0) t0 = state.time_s;
    const double t = state.time_s - t0;
    const double omega = velocity.update(s.angle_rad, k == 0 ? 0.0 : period_s);
    const double cells[2] = {s.agonist_loadcell_N, s.antagonist_loadcell_N};
    command.joints[0] = {0.0, 0.0, 0.0};  // vented, the motor off
    measured = -1;
    if (t < p.vent_s + p.tare_s) {
      if (t >= p.vent_s) {
        for (int i = 0; i < 2; ++i) zero_sum[i] += cells[i], code0[i] += cells[i] <= 0.0 ? 1.0 : 0.0;
        zero_n += 1;
      }
      return;
    }
    if (t < p.pin_s) {
      // On the pin: the agonist refills until its cell (less the zero just found) reads what carries the link.
      const double target_N = known_torque_Nm(scenario, p, 0.0) / r + antagonist_force_N;
      const double zero_N = zero_n > 0 ? zero_sum[0] / zero_n : 0.0;
      if (!started_refill) {
        hold_Pa = models::muscle_pressure(joint.agonist, target_N, models::rigid_contraction(joint.agonist, r, +1, 0.0), supply).pressure_Pa;
        started_refill = true;
      }
      hold_Pa = std::clamp(hold_Pa + p.force_gain_Pa_per_N_s * (target_N - (cells[0] - zero_N)) * period_s, 0.0, supply);
    } else if (leg < 3) {
      const Leg& l = kLegs[leg];
      const double end_rad = p.check_angle_rad + l.direction * p.sweep_rad;
      if (l.direction * (s.angle_rad - end_rad) >= 0.0) {
        ++leg;
        leg_start_s = t;
      } else if (t - leg_start_s > leg_limit_s(p)) {
        out.timed_out_leg = leg;
        leg = 3;
      } else {
        // A velocity loop: the pressure ramps while the cable sticks, and the speed error damps the slide.
        const double error_radps = l.direction * p.sweep_speed_radps - omega;
        hold_Pa = std::clamp(hold_Pa + p.speed_integral_Pa_per_rad * error_radps * period_s, 0.0, supply);
        // Measured: the link sliding the leg's way, near the check angle.
        if (l.measured_sweep >= 0 && std::abs(s.angle_rad - p.check_angle_rad) <= p.window_rad &&
            l.direction * omega >= p.min_speed_fraction * p.sweep_speed_radps) {
          for (int i = 0; i < 2; ++i) sum[l.measured_sweep][i] += cells[i];
          n[l.measured_sweep] += 1;
          measured = l.measured_sweep;
        }
        command.joints[0].agonist_pressure_Pa = std::clamp(hold_Pa + p.speed_gain_Pa_s_per_rad * error_radps, 0.0, supply);
        command.joints[0].antagonist_pressure_Pa = antagonist_Pa;
        return;
      }
    }
    command.joints[0].agonist_pressure_Pa = hold_Pa;
    command.joints[0].antagonist_pressure_Pa = antagonist_Pa;
  };
  auto hold = [](std::size_t) {};
  std::array<double, 11> row{};
  auto observe = [&](std::size_t, const io::Command& sent, std::uint32_t flags) {
    if (!log) return;
    const io::JointSensors& s = state.joints[0];
    row = {state.time_s, s.angle_rad, static_cast<double>(leg), s.agonist_loadcell_N, s.antagonist_loadcell_N, s.agonist_pressure_Pa * 1e-6,
           s.antagonist_pressure_Pa * 1e-6, sent.joints[0].agonist_pressure_Pa * 1e-6, sent.joints[0].antagonist_pressure_Pa * 1e-6,
           static_cast<double>(measured), static_cast<double>(flags)};
    log->push_row(row);
  };
  runtime::run_cycles(limited, hooks, steps, state, command, step, hold, observe);
  for (int i = 0; i < 2; ++i) {
    out.zero_N[i] = zero_n > 0 ? zero_sum[i] / zero_n : 0.0;
    out.code0_fraction[i] = zero_n > 0 ? code0[i] / zero_n : 1.0;
    for (int w = 0; w < 2; ++w) out.reading_N[w][i] = n[w] > 0 ? sum[w][i] / n[w] - out.zero_N[i] : 0.0;
  }
  out.samples[0] = n[0];
  out.samples[1] = n[1];
  out.faults = limited.monitor().count();
  if (out.faults > 0) out.fault_reason = limited.monitor().run_reason();
  return out;
}

SensorCheckResult fit_sensor_check(const E1Scenario& scenario, const SensorCheckParams& p, const std::array<SensorCheckRun, 2>& runs) {
  SensorCheckResult res;
  res.runs = runs;
  const double max_zero_N = scenario.controller.allocation.loadcell_check.max_tare_N;
  for (int k = 0; k < 2; ++k) {
    const SensorCheckRun& run = runs[k];
    if (run.faults > 0) throw SensorCheckRejected(fmt::format("run {}: the plausibility monitor stopped it: {}", k, run.fault_reason));
    for (int i = 0; i < 2; ++i) {
      if (run.code0_fraction[i] >= p.max_code0_fraction) {
        throw SensorCheckRejected(fmt::format(
            "run {}: the {} load cell reads code 0 on {:.0f} % of the vented samples: its zero is below the channel's range and "
            "cannot be seen or corrected here; set the amplifier's offset (or the channel map's range) so a slack wire reads above 0 N",
            k, kMuscle[i], 100 * run.code0_fraction[i]));
      }
      if (std::abs(run.zero_N[i]) > max_zero_N) {
        throw SensorCheckRejected(fmt::format("run {}: the {} load cell reads {:.1f} N vented, beyond the tare's {:.0f} N (loadcell_check.max_tare_N)",
                                              k, kMuscle[i], run.zero_N[i], max_zero_N));
      }
    }
    if (run.timed_out_leg >= 0) {
      throw SensorCheckRejected(fmt::format("run {}: the link did not reach the end of sweep {} ({}) within {:.0f} s", k, run.timed_out_leg,
                                            kLegs[run.timed_out_leg].direction > 0 ? "up" : "down", leg_limit_s(p)));
    }
    for (int w = 0; w < 2; ++w) {
      if (run.samples[w] < 10) {
        throw SensorCheckRejected(fmt::format("run {}: the link never slid {} through {:.1f} +- {:.1f} deg (moving at >= {:.0f} % of the sweep speed)",
                                              k, w == 0 ? "up" : "down", models::rad_to_deg(p.check_angle_rad), models::rad_to_deg(p.window_rad),
                                              100 * p.min_speed_fraction));
      }
    }
  }
  calibration::SensorCorrections& c = res.corrections;
  for (int i = 0; i < 2; ++i) c.loadcell_zero_N[i] = (runs[0].zero_N[i] + runs[1].zero_N[i]) / 2.0;
  const double r = scenario.controller.joint.pulley_radius_m;
  // Agonist (run 0, the antagonist vented): the geometric mean of up and down is the static force (the
  // capstan ratio cancels), and the torque it holds is the known mass's plus the link's own (the
  // scenario's gravity model of the link).
  auto static_reading = [](const SensorCheckRun& run, int i) { return std::sqrt(std::max(0.0, run.reading_N[0][i] * run.reading_N[1][i])); };
  const double g0 = static_reading(runs[0], 0);
  res.known_torque_Nm = known_torque_Nm(scenario, p, p.check_angle_rad);
  c.loadcell_gain[0] = g0 * r / res.known_torque_Nm;
  res.capstan_ratio = std::sqrt(runs[0].reading_N[0][0] / runs[0].reading_N[1][0]);  // up F k, down F / k
  // Antagonist (run 1, the same mass and angle): the torque the agonist now carries beyond gravity is
  // the antagonist's, each wire's pulley end on its sweep F/k or F k.
  const double tau_Nm = res.known_torque_Nm;
  const double k = res.capstan_ratio;
  const double up = r * runs[1].reading_N[0][0] / (c.loadcell_gain[0] * k) - tau_Nm;    // r_rig B_up k_b
  const double down = r * runs[1].reading_N[1][0] * k / c.loadcell_gain[0] - tau_Nm;   // r_rig B_down / k_b
  if (!(up > 0 && down > 0)) {
    throw SensorCheckRejected(fmt::format("run 1: the agonist carried no more than the mass ({:.2f} / {:.2f} Nm beyond {:.2f} Nm): the antagonist "
                                          "pulled nothing the agonist could see", up, down, tau_Nm));
  }
  c.loadcell_gain[1] = r * static_reading(runs[1], 1) / std::sqrt(up * down);
  c.source = fmt::format("peha check-sensors: known mass {} kg at {} m, check angle {:.1f} deg", p.known_mass_kg, p.lever_m,
                         models::rad_to_deg(p.check_angle_rad));
  for (int i = 0; i < 2; ++i) {
    if (!(c.loadcell_gain[i] >= calibration::kMinLoadcellGain && c.loadcell_gain[i] <= calibration::kMaxLoadcellGain)) {
      throw SensorCheckRejected(fmt::format("the {} load cell's effective gain {:.3f} is outside {}..{}: a wrong known mass or lever, a wrong channel "
                                            "map range or a damaged cell", kMuscle[i], c.loadcell_gain[i], calibration::kMinLoadcellGain,
                                            calibration::kMaxLoadcellGain));
    }
  }
  return res;
}

SensorCheckResult check_sensors(const E1Scenario& scenario, const SensorCheckParams& params, const sim::OneDofRigParams& plant,
                                double placed_mass_kg, const std::function<void(const std::string&)>& progress,
                                const std::function<runtime::RowSink*(int run)>& log) {
  std::array<SensorCheckRun, 2> runs;
  const char* what[2] = {"the known mass", "the known mass against the antagonist"};
  for (int k = 0; k < 2; ++k) {
    const hardware::Hardware rig = hardware::open_backend(
        hardware::BackendUri{}, one_dof_rig_hardware(scenario.period_s, scenario.link, sensor_check_plant_params(params, plant, placed_mass_kg)));
    runs[k] = record_sensor_check_run(scenario, params, k, *rig.backend, runtime::with_lifecycle({}, scenario.lifecycle), log ? log(k) : nullptr);
    if (progress) progress(fmt::format("run {} ({}): done", k, what[k]));
  }
  return fit_sensor_check(scenario, params, runs);
}

}  // namespace peha::experiments
