#include "peha/experiments/calibration_recording/excitation.hpp"

#include "peha/control/one_dof_gravity.hpp"
#include "peha/models/units.hpp"
#include "peha/runtime/control_loop.hpp"

#include <array>
#include <cmath>
#include <stdexcept>
#include <utility>

namespace peha::experiments {

ExcitationParams read_excitation(config::Map map) {
  ExcitationParams e;
  e.min_pressure_Pa = map.number("min_pressure_MPa", {0.0, 1.0}) * 1e6;
  e.max_pressure_Pa = map.number("max_pressure_MPa", {e.min_pressure_Pa * 1e-6 + 0.01, 1.0}) * 1e6;
  e.period_s = map.number("period_s", {0.5, 600.0});
  e.duration_s = map.number("duration_s", {e.period_s, 3600.0});
  e.other_pressure_Pa = map.number("other_pressure_MPa", {0.0, 1.0}) * 1e6;
  e.other_pressure_at_min_Pa = map.number_or("other_pressure_at_min_MPa", e.other_pressure_Pa * 1e-6, {0.0, 1.0}) * 1e6;
  e.sample_rate_Hz = map.number("sample_rate_Hz", {1.0, 10000.0});
  e.payload_kg = map.number("payload_kg", {0.0, 20.0});
  if (map.has("tare_s")) {
    e.tare_s = map.number("tare_s", {0.05, 10.0});
    e.vent_s = map.number("vent_s", {0.0, 10.0});
  }
  if (map.has("operating_points")) {
    for (config::Map m : map.maps("operating_points", 1, 32)) {
      ExcitationSegment g;
      g.min_pressure_Pa = m.number("min_pressure_MPa", {0.0, 1.0}) * 1e6;
      g.max_pressure_Pa = m.number("max_pressure_MPa", {g.min_pressure_Pa * 1e-6 + 0.01, 1.0}) * 1e6;
      g.period_s = m.number("period_s", {0.5, 600.0});
      g.duration_s = m.number("duration_s", {g.period_s, 3600.0});
      g.other_pressure_Pa = m.number("other_pressure_MPa", {0.0, 1.0}) * 1e6;
      g.other_pressure_at_min_Pa = m.number_or("other_pressure_at_min_MPa", g.other_pressure_Pa * 1e-6, {0.0, 1.0}) * 1e6;
      if (m.has("clamp_angle_deg")) g.clamp_angle_rad = models::deg_to_rad(m.number("clamp_angle_deg", {-90.0, 90.0}));
      m.finish();
      e.segments.push_back(g);
    }
  }
  map.finish();
  return e;
}

double ExcitationParams::total_duration_s() const noexcept {
  double t = excitation_start_s() + duration_s;
  for (const ExcitationSegment& g : segments) t += g.duration_s;
  return t;
}

CalibrationAcceptance read_calibration_acceptance(config::Map map) {
  CalibrationAcceptance a;
  for (double deg : map.numbers("angles_deg", {-90.0, 90.0}, 1, 16)) a.angles_rad.push_back(models::deg_to_rad(deg));
  a.hold_s = map.number("hold_s", {0.5, 60.0});
  a.settle_s = map.number("settle_s", {0.0, a.hold_s - 0.1});
  a.max_force_tracking_rms_N = map.number("max_force_tracking_rms_N", {0.1, 2000.0});
  a.max_force_tracking_rms_fraction = map.number("max_force_tracking_rms_fraction", {0.0, 1.0});
  a.min_tension_fraction = map.number("min_tension_fraction", {0.0, 10.0});
  map.finish();
  return a;
}

namespace {

/// 0 at t = 0, 1 at half a period, 0 again at a full period.
double triangle_unit(double period_s, double t_s) noexcept {
  const double phase = std::fmod(std::max(t_s, 0.0), period_s) / period_s;
  return phase < 0.5 ? 2.0 * phase : 2.0 - 2.0 * phase;
}

/// The segment running at t (the main triangle as a segment) and t relative to its start.
std::pair<ExcitationSegment, double> segment_at(const ExcitationParams& e, double t_s) noexcept {
  ExcitationSegment current{e.min_pressure_Pa, e.max_pressure_Pa, e.period_s, e.duration_s, e.other_pressure_Pa,
                            e.other_pressure_at_min_Pa};
  double start = 0.0;
  for (const ExcitationSegment& g : e.segments) {
    if (t_s < start + current.duration_s) break;
    start += current.duration_s;
    current = g;
  }
  return {current, t_s - start};
}

}  // namespace

double triangle_pressure_Pa(const ExcitationParams& e, double t_s) noexcept {
  const auto [g, t] = segment_at(e, t_s);
  return g.min_pressure_Pa + (g.max_pressure_Pa - g.min_pressure_Pa) * triangle_unit(g.period_s, t);
}

double other_pressure_Pa(const ExcitationParams& e, double t_s) noexcept {
  const auto [g, t] = segment_at(e, t_s);
  return g.other_pressure_at_min_Pa + (g.other_pressure_Pa - g.other_pressure_at_min_Pa) * triangle_unit(g.period_s, t);
}

const std::vector<std::string>& recording_log_columns() {
  static const std::vector<std::string> columns = {"t_s", "angle_rad", "agonist_loadcell_N", "antagonist_loadcell_N", "agonist_pressure_MPa",
                                                   "antagonist_pressure_MPa", "agonist_pressure_cmd_MPa", "antagonist_pressure_cmd_MPa",
                                                   "limit_flags"};
  return columns;
}

calibration::Dataset record_excitation(io::Backend& backend, const models::JointModel& joint, int side,
                          const ExcitationParams& excitation, const safety::LimitsModel& limits,
                          const std::function<void(double)>& progress, const runtime::CycleHooks& hooks, runtime::RowSink* log) {
  const double period_s = backend.info().period_s;
  const double ratio = 1.0 / (excitation.sample_rate_Hz * period_s);
  const auto every = static_cast<long>(std::lround(ratio));
  if (every < 1 || std::abs(ratio - static_cast<double>(every)) > 1e-9) {
    throw std::invalid_argument("calibration sample rate must divide the control rate");
  }
  const models::MuscleModel& muscle = side > 0 ? joint.agonist : joint.antagonist;
  const auto steps = static_cast<long>(std::llround(excitation.total_duration_s() / period_s));

  calibration::Dataset data;
  const auto rows = static_cast<std::size_t>(steps / every + 1);
  for (auto* v : {&data.t_s, &data.pressure_Pa, &data.angle_rad, &data.contraction, &data.force_N,
                  &data.wire_velocity_mps}) {
    v->reserve(rows);
  }
  const safety::JointModels joints{&joint};
  safety::LimitedBackend limited(backend, limits, joints);
  control::VelocityEstimator velocity;
  io::SensorState state;
  io::Command command;
  command.joint_count = 1;
  double t0 = 0.0;  // the first sample's time: the data's time starts at 0
  bool have_t0 = false;
  // The tare: vented for vent_s, then the recorded muscle's load cell averaged over tare_s.
  const auto start_steps = static_cast<long>(std::llround(excitation.excitation_start_s() / period_s));
  const auto vent_steps = static_cast<long>(std::llround(excitation.vent_s / period_s));
  double zero_sum_N = 0.0;
  long zero_samples = 0;
  long next_report = 0;
  auto step = [&](std::size_t kk) {
    const auto k = static_cast<long>(kk);
    const io::JointSensors& s = state.joints[0];
    if (!have_t0) t0 = state.time_s, have_t0 = true;
    const double omega = velocity.update(s.angle_rad, k == 0 ? 0.0 : period_s);
    const double reading_N = side > 0 ? s.agonist_loadcell_N : s.antagonist_loadcell_N;
    if (k < start_steps) {
      if (k >= vent_steps) {
        zero_sum_N += reading_N;
        ++zero_samples;
      }
      command.joints[0] = {0.0, 0.0, 0.0};  // vented (the limits keep the pretension floor's pressure)
    } else {
      if (k == start_steps && zero_samples > 0) data.loadcell_zero_N = zero_sum_N / static_cast<double>(zero_samples);
      const long j = k - start_steps;  // the excitation's own step
      if (j % every == 0) {
        data.t_s.push_back(state.time_s - t0);
        data.pressure_Pa.push_back(side > 0 ? s.agonist_pressure_Pa : s.antagonist_pressure_Pa);
        data.angle_rad.push_back(s.angle_rad);
        data.contraction.push_back(models::rigid_contraction(muscle, joint.pulley_radius_m, side, s.angle_rad));
        data.force_N.push_back(reading_N - data.loadcell_zero_N);
        data.wire_velocity_mps.push_back(models::wire_velocity_mps(joint.pulley_radius_m, side, omega));
      }
      const double excited = triangle_pressure_Pa(excitation, static_cast<double>(j) * period_s);
      const double other = other_pressure_Pa(excitation, static_cast<double>(j) * period_s);
      command.joints[0].agonist_pressure_Pa = side > 0 ? excited : other;
      command.joints[0].antagonist_pressure_Pa = side > 0 ? other : excited;
      command.joints[0].motor_torque_Nm = 0.0;
    }
    if (progress && k >= next_report) {
      progress(static_cast<double>(k) / steps);
      next_report += std::max(1L, steps / 10);
    }
  };
  auto hold = [](std::size_t) {};
  std::array<double, 9> row{};
  auto observe = [&](std::size_t, const io::Command& sent, std::uint32_t flags) {
    if (!log) return;
    const io::JointSensors& s = state.joints[0];
    row = {state.time_s, s.angle_rad, s.agonist_loadcell_N, s.antagonist_loadcell_N, s.agonist_pressure_Pa * 1e-6, s.antagonist_pressure_Pa * 1e-6,
           sent.joints[0].agonist_pressure_Pa * 1e-6, sent.joints[0].antagonist_pressure_Pa * 1e-6, static_cast<double>(flags)};
    log->push_row(row);
  };
  runtime::run_cycles(limited, hooks, static_cast<std::size_t>(steps), state, command, step, hold, observe);
  if (progress) progress(1.0);
  // Data recorded after a fault is the safe state's, not the excitation's: not a calibration's.
  if (limited.monitor().count() > 0) {
    throw std::runtime_error(std::string("the plausibility monitor stopped the recording: ") + limited.monitor().run_reason() +
                             " (nothing written; docs/safety.md)");
  }
  return data;
}

}  // namespace peha::experiments
