#include "peha/safety/fault_monitor.hpp"

#include "peha/models/units.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>

namespace peha::safety {
namespace {

/// A check on a floor: floor / value (a value at or below a thousandth of the floor: 1000).
double below_ratio(double floor, double value) noexcept {
  if (floor <= 0) return 0.0;
  return value > 1e-3 * floor ? floor / value : 1e3;
}

/// pressure_rise escalates to pressure_high (vent) at this x its threshold (check_pressure_rise).
constexpr double kRiseVentFactor = 3.0;

int index_of(std::uint32_t flag) noexcept { return flag ? std::countr_zero(flag) : 0; }

/// The flag's row of kChecks (its lowest bit's), or null for none or a bit past the table.
const CheckInfo* row_of(std::uint32_t flag) noexcept {
  return flag && index_of(flag) < kFaultFlagCount ? &kChecks[static_cast<std::size_t>(index_of(flag))] : nullptr;
}

}  // namespace

const char* fault_flag_name(std::uint32_t flag) noexcept {
  const CheckInfo* row = row_of(flag);
  return row ? row->name : "none";
}

SafeAction safe_action(std::uint32_t flag) noexcept {
  const CheckInfo* row = row_of(flag);
  return row ? row->action : SafeAction::kNone;
}

const char* safe_action_name(SafeAction a) noexcept {
  switch (a) {
    case SafeAction::kHold: return "hold";
    case SafeAction::kDescend: return "descend";
    case SafeAction::kVent: return "vent";
    default: return "none";
  }
}

void read_monitor_params(config::Map& root, MonitorParams& p) {
  // Two fault authorities shared the word: the plausibility monitor (here) and the lifecycle
  // supervisor (runtime::Supervisor, the scenario's lifecycle:).
  root.refuse_moved("supervisor", "the plausibility monitor's thresholds are the plausibility: section now (the lifecycle "
                                  "supervisor's watchdog and recovery ramp are lifecycle:)");
  if (!root.has("plausibility")) return;
  using models::deg_to_rad, models::rad_to_deg;
  config::Map m = root.map("plausibility");
  // The checks protect the person: no scenario switches them off (a test does, through CheckOverrides).
  if (m.has("enabled")) {
    m.fail("enabled", "the plausibility monitor cannot be switched off from a scenario (its checks protect the person); remove the key");
  }
  p.tension_arm_s = m.number_or("tension_arm_s", p.tension_arm_s, {0, 5});
  p.tension_taut_deadline_s = m.number_or("tension_taut_deadline_s", p.tension_taut_deadline_s, {1, 30});
  p.force_ceiling_window_s = m.number_or("force_ceiling_window_s", p.force_ceiling_window_s, {0.005, 0.2});
  p.loadcell_zero_max_N = m.number_or("loadcell_zero_max_N", p.loadcell_zero_max_N, {5, 500});
  p.loadcell_zero_confirm_s = m.number_or("loadcell_zero_confirm_s", p.loadcell_zero_confirm_s, {0.01, 1});
  p.tension_taut_fraction = m.number_or("tension_taut_fraction", p.tension_taut_fraction, {0, 2});
  p.confirm_cycles = static_cast<int>(m.number_or("confirm_cycles", p.confirm_cycles, {1, 20}));
  p.loadcell_stuck_cycles = static_cast<int>(m.number_or("loadcell_stuck_cycles", p.loadcell_stuck_cycles, {2, 200}));
  p.loadcell_saturated_N = m.number_or("loadcell_saturated_N", p.loadcell_saturated_N, {100, 10000});
  p.loadcell_tolerance_N = m.number_or("loadcell_tolerance_N", p.loadcell_tolerance_N, {0, 500});
  p.loadcell_tolerance_fraction = m.number_or("loadcell_tolerance_fraction", p.loadcell_tolerance_fraction, {0, 1});
  p.loadcell_step_N = m.number_or("loadcell_step_N", p.loadcell_step_N, {1, 2000});
  p.loadcell_step_filter_s = m.number_or("loadcell_step_filter_s", p.loadcell_step_filter_s, {0.002, 1});
  p.loadcell_step_noise_filter_s = m.number_or("loadcell_step_noise_filter_s", p.loadcell_step_noise_filter_s, {0.0005, 0.02});
  p.loadcell_drift_N = m.number_or("loadcell_drift_N", p.loadcell_drift_N, {20, 500});
  p.loadcell_drift_filter_s = m.number_or("loadcell_drift_filter_s", p.loadcell_drift_filter_s, {0.01, 5});
  p.loadcell_drift_settle_s = m.number_or("loadcell_drift_settle_s", p.loadcell_drift_settle_s, {0, 10});
  p.loadcell_drift_arm_s = m.number_or("loadcell_drift_arm_s", p.loadcell_drift_arm_s, {0, 10});
  p.loadcell_drift_still_radps = deg_to_rad(m.number_or("loadcell_drift_still_degps", rad_to_deg(p.loadcell_drift_still_radps), {0.1, 10}));
  p.loadcell_drift_leak_N_per_s = m.number_or("loadcell_drift_leak_N_per_s", p.loadcell_drift_leak_N_per_s, {0, 5});
  p.loadcell_drift_max_rate_N_per_s = m.number_or("loadcell_drift_max_rate_N_per_s", p.loadcell_drift_max_rate_N_per_s, {5, 200});
  p.tension_floor_fraction = m.number_or("tension_floor_fraction", p.tension_floor_fraction, {0, 1});
  p.pressure_tolerance_Pa = m.number_or("pressure_tolerance_MPa", p.pressure_tolerance_Pa * 1e-6, {0.001, 0.3}) * 1e6;
  p.pressure_rise_Pa = m.number_or("pressure_rise_MPa", p.pressure_rise_Pa * 1e-6, {0.001, 0.3}) * 1e6;
  p.pressure_rise_filter_s = m.number_or("pressure_rise_filter_s", p.pressure_rise_filter_s, {0.0005, 1});
  p.valve_dead_time_s = m.number_or("valve_dead_time_s", p.valve_dead_time_s, {0, 0.05});
  p.valve_lag_s = m.number_or("valve_lag_s", p.valve_lag_s, {1e-4, 2});
  p.valve_rate_Pa_per_s = m.number_or("valve_rate_MPa_per_s", p.valve_rate_Pa_per_s * 1e-6, {0.01, 100}) * 1e6;
  p.valve_slow_factor = m.number_or("valve_slow_factor", p.valve_slow_factor, {1.0, 10.0});
  p.valve_fast_factor = m.number_or("valve_fast_factor", p.valve_fast_factor, {0.1, 1.0});
  p.encoder_max_step_rad = deg_to_rad(m.number_or("encoder_max_step_deg", rad_to_deg(p.encoder_max_step_rad), {0.01, 10}));
  p.encoder_frozen_cycles = static_cast<int>(m.number_or("encoder_frozen_cycles", p.encoder_frozen_cycles, {2, 200}));
  p.encoder_frozen_speed_radps = deg_to_rad(m.number_or("encoder_frozen_speed_degps", rad_to_deg(p.encoder_frozen_speed_radps), {0.1, 100}));
  p.encoder_disagree_rad = deg_to_rad(m.number_or("encoder_disagree_deg", rad_to_deg(p.encoder_disagree_rad), {0.01, 10}));
  p.max_joint_speed_radps = deg_to_rad(m.number_or("max_joint_speed_degps", rad_to_deg(p.max_joint_speed_radps), {1, 600}));
  p.range_margin_rad = deg_to_rad(m.number_or("range_margin_deg", rad_to_deg(p.range_margin_rad), {0, 10}));
  p.range_lead_s = m.number_or("range_lead_s", p.range_lead_s, {0.01, 0.5});
  p.range_brake_radps2 = deg_to_rad(m.number_or("range_brake_degps2", rad_to_deg(p.range_brake_radps2), {200, 20000}));
  p.supply_low_fraction = m.number_or("supply_low_fraction", p.supply_low_fraction, {0, 1});
  p.supply_lost_fraction = m.number_or("supply_lost_fraction", p.supply_lost_fraction, {0, p.supply_low_fraction});
  p.motor_tolerance_Nm = m.number_or("motor_tolerance_Nm", p.motor_tolerance_Nm, {0.001, 10});
  p.motor_window_cycles = static_cast<int>(m.number_or("motor_window_cycles", p.motor_window_cycles, {1, FaultMonitor::kMotorWindow}));
  p.descent_speed_radps = deg_to_rad(m.number_or("descent_speed_degps", rad_to_deg(p.descent_speed_radps), {0.5, 30}));
  p.descent_force_rate_N_per_s = m.number_or("descent_force_rate_N_per_s", p.descent_force_rate_N_per_s, {1, 5000});
  p.descent_gain_N_per_radps = m.number_or("descent_gain_N_per_radps", p.descent_gain_N_per_radps, {0, 20000});
  p.descent_force_slew_N_per_s = m.number_or("descent_force_slew_N_per_s", p.descent_force_slew_N_per_s, {10, 1e6});
  p.descent_floor_fraction = m.number_or("descent_floor_fraction", p.descent_floor_fraction, {0, 1});
  p.descent_damping_Nms_per_rad = m.number_or("descent_damping_Nms_per_rad", p.descent_damping_Nms_per_rad, {0, 100});
  p.descent_trim_rate_per_s = m.number_or("descent_trim_rate_per_s", p.descent_trim_rate_per_s, {0, 50});
  p.descent_lifted_bleed_fraction = m.number_or("descent_lifted_bleed_fraction", p.descent_lifted_bleed_fraction, {0, 1});
  p.descent_stop_margin_rad = deg_to_rad(m.number_or("descent_stop_margin_deg", rad_to_deg(p.descent_stop_margin_rad), {0.5, 20}));
  p.speed_filter_Hz = m.number_or("speed_filter_Hz", p.speed_filter_Hz, {0.5, 200});
  // A runaway is judged above the descent speed and below a fall's (the speed check's 90 deg/s on E1).
  p.descent_runaway_speed_radps =
      deg_to_rad(m.number_or("descent_runaway_speed_degps", rad_to_deg(p.descent_runaway_speed_radps), {2.0 * rad_to_deg(p.descent_speed_radps), 90}));
  p.descent_runaway_window_s = m.number_or("descent_runaway_window_s", p.descent_runaway_window_s, {0.02, 1});
  m.finish();
}

void FaultMonitor::raise(std::uint32_t flag, int joint, int muscle, double value, double threshold) noexcept {
  if (!on(flag)) return;
  // Every joint a check names, even under a flag already latched: the governor stops trusting its cells.
  faulted_joints_ |= joint >= 0 && joint < io::kMaxJoints ? 1u << joint : ~0u;
  if (flags_ & flag) return;
  if (flags_ == 0) {
    first_ = {flag, joint, muscle, value, threshold, t_s_, sequence_};
    ++count_;
    io::copy_used(held_, last_sent_);
    for (int j = 0; j < held_.joint_count && j < io::kMaxJoints; ++j) {
      io::JointCommand& h = held_.joints[static_cast<std::size_t>(j)];
      h.motor_torque_Nm = 0.0;
      const JointState& js = joints_[static_cast<std::size_t>(j)];
      if (js.carried || !js.has_found) continue;
      // Start-up (vent, tare, refill): restore what held the limb before the run began.
      h.agonist_pressure_Pa = js.found_Pa[0];
      h.antagonist_pressure_Pa = js.found_Pa[1];
    }
  }
  flags_ |= flag;
  const SafeAction a = (overrides_.vented & flag) ? SafeAction::kVent : safe_action(flag);
  if (a > action_) action_ = a;
  if (first_.flag == flag) {
    std::snprintf(reason_, sizeof reason_, "%s joint %d%s: %.4g (threshold %.4g) at %.3f s -> %s", fault_flag_name(flag), joint,
                  muscle == 0 ? " agonist" : muscle == 1 ? " antagonist" : "", value, threshold, t_s_, safe_action_name(action_));
    if (count_ == 1) std::memcpy(run_reason_, reason_, sizeof reason_);
  }
}

FaultMonitor::PerPeriod FaultMonitor::per_period(const MonitorParams& p, double period_s) noexcept {
  auto cycles = [&](double s) { return std::clamp(static_cast<int>(std::lround(s / period_s)), 0, kMaxDelay - 1); };
  auto alpha = [&](double tau_s) { return 1.0 - std::exp(-period_s / tau_s); };
  PerPeriod pp;
  pp.delay_cycles = cycles(p.valve_dead_time_s);
  pp.slow_delay_cycles = cycles(p.valve_slow_factor * p.valve_dead_time_s);
  pp.valve_alpha = alpha(p.valve_lag_s);
  pp.slow_valve_alpha = alpha(p.valve_slow_factor * p.valve_lag_s);
  pp.fast_delay_cycles = cycles(p.valve_fast_factor * p.valve_dead_time_s);
  pp.fast_valve_alpha = alpha(p.valve_fast_factor * p.valve_lag_s);
  pp.step_alpha = alpha(p.loadcell_step_filter_s);  // the step check's level filter (also the rise check's)
  pp.step_fast_alpha = alpha(p.loadcell_step_noise_filter_s);
  pp.rise_alpha = alpha(p.pressure_rise_filter_s);
  pp.drift_alpha = alpha(p.loadcell_drift_filter_s);
  pp.drift_slow_alpha = alpha(4.0 * p.loadcell_drift_filter_s);
  // Windows in samples (no cap at kMaxDelay: they count samples, they are no delay line).
  auto samples = [&](double s) { return static_cast<int>(std::lround(s / period_s)); };
  pp.zero_cycles = std::max(p.confirm_cycles, samples(p.loadcell_zero_confirm_s));
  pp.over_ceiling_cycles = std::max(1, samples(p.force_ceiling_window_s));
  pp.runaway_cycles = std::max(1, samples(p.descent_runaway_window_s));
  return pp;
}

DescendGovernorModel FaultMonitor::governor_model(const MonitorParams& p, double period_s, const CheckOverrides& o) noexcept {
  // An operator lifting the joint moves it up faster than it is let down (the old integral: never).
  const double lift_speed_radps = o.governor_bleeds_while_lifted ? std::numeric_limits<double>::infinity() : p.descent_speed_radps;
  return {.speed_radps = p.descent_speed_radps,
          .force_rate_N_per_s = p.descent_force_rate_N_per_s,
          .gain_N_per_radps = p.descent_gain_N_per_radps,
          .floor_fraction = p.descent_floor_fraction,
          .force_slew_N_per_s = p.descent_force_slew_N_per_s,
          .damping_Nms_per_rad = p.descent_damping_Nms_per_rad,
          .stop_margin_rad = p.descent_stop_margin_rad,
          .lift_speed_radps = lift_speed_radps,
          .lifted_bleed_fraction = p.descent_lifted_bleed_fraction,
          .trim_rate_per_s = p.descent_trim_rate_per_s,
          .period_s = period_s};
}

void FaultMonitor::clear() noexcept {
  flags_ = 0;
  faulted_joints_ = 0;
  action_ = SafeAction::kNone;
  first_ = {};
  reason_[0] = '\0';
  synced_ = false;
  for (auto& j : joints_) {
    for (auto& m : j.muscle) {
      m.taut = m.has_level = m.has_drift = m.not_following = false;
      m.disconnected = m.saturated = m.disagree = m.low_tension = m.pressure_low = m.pressure_high = m.same_loadcell = m.step = m.zero_off = m.never_taut = m.over_ceiling = 0;
    }
    j.same_angle = j.runaway = 0;
    j.supply_low = j.supply_lost = j.motor_off = 0;
    j.motor_sent = 0;
    j.follow_since_s = -1;
    j.governor = {};
    // Not carried (an outage, a governed return from a stop): the next sample is what holds the
    // limb now, the start of any safe state after this recovery.
    if (!j.carried) j.has_found = false;
  }
}

/// One muscle of one sample and what its checks derive from it, once.
struct FaultMonitor::MuscleSample {
  int joint = 0, muscle = 0;  ///< muscle: 0 agonist, 1 antagonist
  double cell_N = 0, pressure_Pa = 0;
  double ceiling_N = 0;    ///< the muscle's force ceiling
  double model_N = 0;      ///< the pressure model's force at the measured pressure and angle
  double tolerance_N = 0;  ///< how far the load cell may read from model_N
  double floor_N = 0;      ///< the wire's tension floor
  double taut_N = 0;       ///< at or above: the wire is taut (arms its slack checks)
  double pretension_N = 0;
  double tension_N = 0;    ///< cell_N less the zero the controller subtracts from it
  double supply_Pa = 0;
  bool tension_checked = false;
  bool outputs_follow = false;
  bool arming = false;  ///< the outputs have followed for tension_arm_s: a taut wire arms its slack checks
  bool carried = false;  ///< the joint's start-up is over (FaultMonitor::carried)
  double carried_s = -1;  ///< how long it has been carried (< 0: it is not)
  double followed_s = -1;  ///< how long the outputs have followed (< 0: they do not)
  double still_s = 0;      ///< how long the joint has been still (JointState::still_s)
};

void FaultMonitor::check_sample(const io::SensorState& s, const std::array<const models::JointModel*, io::kMaxJoints>& models,
                                const std::array<double, io::kMaxJoints>& min_angle_rad,
                                const std::array<double, io::kMaxJoints>& max_angle_rad, bool outputs_follow) noexcept {
  t_s_ = s.time_s;
  sequence_ = s.sequence;
  int low_muscles = 0;  // muscles whose pressure stays below the valve's envelope (two or more: the supply)
  for (int j = 0; j < s.joint_count && j < io::kMaxJoints; ++j) {
    const auto ji = static_cast<std::size_t>(j);
    const io::JointSensors& in = s.joints[ji];
    JointState& js = joints_[ji];
    if (!check_finite(j, in)) continue;
    // What holds the limb while peha's outputs do not (before arming, during and after an outage:
    // a board's safe outputs vented it, or it rests on a stop): a fault after the outputs follow
    // again starts from these, not from the commands sent before - the stale pre-outage pressures,
    // at the angle the limb fell to, launched it from stop to stop at 442 deg/s.
    if (!js.has_found || !outputs_follow) {
      js.found_Pa = {std::max(0.0, in.agonist_pressure_Pa), std::max(0.0, in.antagonist_pressure_Pa)};
      js.has_found = true;
    }
    if (!outputs_follow) js.carried = false;  // carried again only once both wires are taut again
    check_encoder(j, in, s.time_s, js);
    // Led only where the safe state brakes the joint: a joint it does not govern (the arm's
    // constant-pressure wrist) is stopped by its own spring, far harder than range_brake_radps2.
    const double nan = std::numeric_limits<double>::quiet_NaN();
    check_range(j, in.angle_rad, params_.governed[ji] ? js.filtered_speed_radps : nan, min_angle_rad[ji], max_angle_rad[ji]);
    check_board_limits(j, in, outputs_follow);  // after the range: a joint beyond it is named joint_range, the board's vent its echo
    if (!outputs_follow) {
      js.follow_since_s = -1;
    } else if (js.follow_since_s < 0) {
      js.follow_since_s = s.time_s;
    }
    const models::JointModel* model = models[ji];
    if (!model) continue;
    check_supply(j, in, *model, js);
    check_motor(j, in, *model, outputs_follow, js);
    const double followed_s = outputs_follow ? s.time_s - js.follow_since_s : -1.0;
    for (int m = 0; m < 2; ++m) {
      const MuscleSample x = muscle_sample(j, m, in, *model, js, followed_s);
      if (check_muscle(x, js.muscle[static_cast<std::size_t>(m)])) ++low_muscles;
    }
    // Carried: both wires taut with the outputs following; where slack is by design (tension not
    // checked), once the outputs have followed for tension_arm_s.
    const bool armed = followed_s >= params_.tension_arm_s;
    if (armed && (!params_.tension_checked[ji] || (js.muscle[0].taut && js.muscle[1].taut))) {
      if (!js.carried) js.carried_since_s = s.time_s;
      js.carried = true;
    }
  }
  check_low_pressures(low_muscles, s.joint_count);
  synced_ = outputs_follow;
  if (action_ == SafeAction::kDescend) govern(s, models, min_angle_rad, max_angle_rad);
}

/// The board's own limits, reported with the sample: a muscle it vented while the outputs follow.
void FaultMonitor::check_board_limits(int j, const io::JointSensors& in, bool outputs_follow) noexcept {
  if (!outputs_follow) return;  // the board's safe outputs vent everything anyway
  for (int m = 0; m < 2; ++m) {
    if (in.board_limits & (m == 0 ? io::kBoardVentedAgonist : io::kBoardVentedAntagonist)) raise(kFaultBoardLimit, j, m, 1.0, 0.0);
  }
}

/// A non-finite sample: no other check can read it.
bool FaultMonitor::check_finite(int j, const io::JointSensors& in) noexcept {
  if (std::isfinite(in.angle_rad) && std::isfinite(in.agonist_loadcell_N) && std::isfinite(in.antagonist_loadcell_N) &&
      std::isfinite(in.agonist_pressure_Pa) && std::isfinite(in.antagonist_pressure_Pa)) {
    return true;
  }
  raise(kFaultNonFiniteSample, j, -1, 0.0, 0.0);
  return false;
}

/// Encoder: one sample's step (jump; a jump measures no speed), the speed it measures (joint_speed,
/// and the filtered speed the governor reads), a count that stops (frozen), the redundant encoder.
void FaultMonitor::check_encoder(int j, const io::JointSensors& in, double t_s, JointState& js) noexcept {
  const MonitorParams& p = params_;
  if (js.has_previous) {
    const double dt_s = std::max(t_s - js.last_t_s, period_s_);
    const double step_rad = in.angle_rad - js.last_angle_rad;
    // Per control period elapsed: over a link that lost two samples a fast joint moves three steps.
    const double max_step_rad = p.encoder_max_step_rad * std::max(1.0, std::round(dt_s / period_s_));
    const bool measured = std::abs(step_rad) <= max_step_rad;
    observe(kFaultEncoderJump, std::abs(step_rad) / max_step_rad);
    if (!measured) raise(kFaultEncoderJump, j, -1, std::abs(step_rad), max_step_rad);
    js.speed_radps = step_rad / dt_s;
    if (measured) {
      const double a = 1.0 - std::exp(-dt_s * 2.0 * 3.14159265358979323846 * p.speed_filter_Hz);
      js.filtered_speed_radps += a * (js.speed_radps - js.filtered_speed_radps);
      js.still_s = std::abs(js.filtered_speed_radps) < p.loadcell_drift_still_radps ? js.still_s + dt_s : 0.0;
      check_speed(j, js);
    }
    check_frozen(j, step_rad, dt_s, t_s, js);
  } else {
    js.last_change_t_s = t_s;
  }
  check_redundant_encoder(j, in, js);
  js.last_angle_rad = in.angle_rad;
  js.last_t_s = t_s;
  js.has_previous = true;
}

/// The same count for encoder_frozen_cycles right after moving faster than encoder_frozen_speed.
void FaultMonitor::check_frozen(int j, double step_rad, double dt_s, double t_s, JointState& js) noexcept {
  const MonitorParams& p = params_;
  if (step_rad != 0.0) {
    js.last_change_speed_radps = step_rad / std::max(t_s - js.last_change_t_s, dt_s);
    js.last_change_t_s = t_s;
    js.same_angle = 0;
    return;
  }
  ++js.same_angle;
  observe(kFaultEncoderFrozen, std::min(static_cast<double>(js.same_angle) / p.encoder_frozen_cycles,
                                        std::abs(js.last_change_speed_radps) / p.encoder_frozen_speed_radps));
  if (js.same_angle >= p.encoder_frozen_cycles && std::abs(js.last_change_speed_radps) > p.encoder_frozen_speed_radps) {
    raise(kFaultEncoderFrozen, j, -1, js.last_change_speed_radps, p.encoder_frozen_speed_radps);
  }
}

/// The redundant encoder on the joint's axis: the two angles stay together while both count.
void FaultMonitor::check_redundant_encoder(int j, const io::JointSensors& in, JointState& js) noexcept {
  if (!std::isfinite(in.redundant_angle_rad)) return;
  const double apart_rad = in.angle_rad - in.redundant_angle_rad;
  observe(kFaultEncoderDisagrees, std::abs(apart_rad) / params_.encoder_disagree_rad);
  js.encoder_apart = std::abs(apart_rad) > params_.encoder_disagree_rad ? js.encoder_apart + 1 : 0;
  if (js.encoder_apart >= params_.confirm_cycles) raise(kFaultEncoderDisagrees, j, -1, apart_rad, params_.encoder_disagree_rad);
}

/// Speed: a falling link (one sample is enough; its step was not a jump).
void FaultMonitor::check_speed(int j, const JointState& js) noexcept {
  observe(kFaultJointSpeed, std::abs(js.speed_radps) / params_.max_joint_speed_radps);
  if (std::abs(js.speed_radps) > params_.max_joint_speed_radps) {
    raise(kFaultJointSpeed, j, -1, std::abs(js.speed_radps), params_.max_joint_speed_radps);
  }
}

/// Range: the angle, led by its speed (MonitorParams::range_lead_s), beyond either end by more than
/// range_margin.
void FaultMonitor::check_range(int j, double angle_rad, double speed_radps, double min_angle_rad, double max_angle_rad) noexcept {
  const double lo_rad = min_angle_rad - params_.range_margin_rad;
  const double hi_rad = max_angle_rad + params_.range_margin_rad;
  if (std::isfinite(speed_radps)) {
    angle_rad += speed_radps * params_.range_lead_s + std::copysign(speed_radps * speed_radps / (2.0 * params_.range_brake_radps2), speed_radps);
  }
  if (params_.range_margin_rad > 0) {
    observe(kFaultJointRange, std::max(min_angle_rad - angle_rad, angle_rad - max_angle_rad) / params_.range_margin_rad);
  }
  if (angle_rad < lo_rad) raise(kFaultJointRange, j, -1, angle_rad, lo_rad);
  if (angle_rad > hi_rad) raise(kFaultJointRange, j, -1, angle_rad, hi_rad);
}

/// Supply, where it is measured: a sensor on the valve manifold sees a failing compressor at once,
/// also at rest, where the check valves keep the muscles' air and no pressure sensor moves.
void FaultMonitor::check_supply(int j, const io::JointSensors& in, const models::JointModel& model, JointState& js) noexcept {
  if (!std::isfinite(in.supply_pressure_Pa)) return;
  const MonitorParams& p = params_;
  const double low_Pa = p.supply_low_fraction * model.supply_pressure_Pa;
  const double lost_Pa = p.supply_lost_fraction * model.supply_pressure_Pa;
  observe(kFaultSupplyLow, below_ratio(low_Pa, in.supply_pressure_Pa));
  observe(kFaultSupplyLoss, below_ratio(lost_Pa, in.supply_pressure_Pa));
  js.supply_low = in.supply_pressure_Pa < low_Pa ? js.supply_low + 1 : 0;
  js.supply_lost = in.supply_pressure_Pa < lost_Pa ? js.supply_lost + 1 : 0;
  // A supply gone at once is a loss, not also a low supply (descend is the stronger safe state).
  if (js.supply_lost >= p.confirm_cycles) {
    raise(kFaultSupplyLoss, j, -1, in.supply_pressure_Pa, lost_Pa);
  } else if (js.supply_low >= p.confirm_cycles && in.supply_pressure_Pa >= lost_Pa) {
    raise(kFaultSupplyLow, j, -1, in.supply_pressure_Pa, low_Pa);
  }
}

/// Motor, where the driver's current monitor is read: the torque it makes against the span of the
/// commands sent while the outputs followed over the last motor_window_cycles (the link's latency).
void FaultMonitor::check_motor(int j, const io::JointSensors& in, const models::JointModel& model, bool outputs_follow,
                               JointState& js) noexcept {
  const MonitorParams& p = params_;
  const bool cut = (in.board_limits & io::kBoardMotorOff) != 0;  // the board's range: not the driver's fault
  if (!outputs_follow || cut) js.motor_sent = 0;
  const int window = std::clamp(p.motor_window_cycles, 1, kMotorWindow);
  if (!model.has_motor || !outputs_follow || cut || !std::isfinite(in.motor_torque_Nm) || js.motor_sent < window) {
    js.motor_off = 0;
    return;
  }
  double lo_Nm = js.sent_motor_Nm[static_cast<std::size_t>(js.motor_head)], hi_Nm = lo_Nm;
  for (int k = 1; k < window; ++k) {
    const double c = js.sent_motor_Nm[static_cast<std::size_t>((js.motor_head + kMotorWindow - k) % kMotorWindow)];
    lo_Nm = std::min(lo_Nm, c);
    hi_Nm = std::max(hi_Nm, c);
  }
  const double off_Nm = std::max(lo_Nm - in.motor_torque_Nm, in.motor_torque_Nm - hi_Nm);
  observe(kFaultMotorDisagrees, off_Nm / p.motor_tolerance_Nm);
  js.motor_off = off_Nm > p.motor_tolerance_Nm ? js.motor_off + 1 : 0;
  if (js.motor_off >= p.confirm_cycles) {
    raise(kFaultMotorDisagrees, j, -1, in.motor_torque_Nm - js.sent_motor_Nm[static_cast<std::size_t>(js.motor_head)], p.motor_tolerance_Nm);
  }
}

FaultMonitor::MuscleSample FaultMonitor::muscle_sample(int j, int m, const io::JointSensors& in, const models::JointModel& model,
                                                       const JointState& js, double followed_s) const noexcept {
  const MonitorParams& p = params_;
  const models::MuscleModel& mm = m == 0 ? model.agonist : model.antagonist;
  MuscleSample x;
  x.joint = j;
  x.muscle = m;
  x.cell_N = m == 0 ? in.agonist_loadcell_N : in.antagonist_loadcell_N;
  x.pressure_Pa = m == 0 ? in.agonist_pressure_Pa : in.antagonist_pressure_Pa;
  x.ceiling_N = models::force_ceiling_N(mm);
  const double eps = models::rigid_contraction(mm, model.pulley_radius_m, m == 0 ? +1 : -1, in.angle_rad);
  x.model_N = models::forward_force_N(mm.pam, x.pressure_Pa, eps);
  x.tolerance_N = p.loadcell_tolerance_N + p.loadcell_tolerance_fraction * std::abs(x.model_N);
  x.floor_N = p.tension_floor_fraction * model.pretension_N;
  x.taut_N = std::max(x.floor_N, p.tension_taut_fraction * model.pretension_N);
  x.pretension_N = model.pretension_N;
  x.supply_Pa = model.supply_pressure_Pa;
  x.tension_checked = p.tension_checked[static_cast<std::size_t>(j)];
  x.outputs_follow = followed_s >= 0;
  x.arming = followed_s >= p.tension_arm_s;
  x.carried = js.carried;
  x.carried_s = js.carried ? t_s_ - js.carried_since_s : -1.0;
  // The wire's tension as its cell tells it: less the zero the controller subtracts (its start-up
  // tare, check_command: a +20 N zero read a slack wire as taut and armed the drift sums through the
  // refill).
  x.tension_N = x.cell_N - js.muscle[static_cast<std::size_t>(m)].zero_N;
  x.followed_s = followed_s;
  x.still_s = js.still_s;
  return x;
}

/// One muscle's checks, in their order; true when its pressure has stayed below the valve's
/// envelope for confirm_cycles (pressure_low, or with another muscle a supply loss).
bool FaultMonitor::check_muscle(const MuscleSample& x, MuscleState& ms) noexcept {
  // Taut arms on the tension low-passed (3x noise armed a wire refilling slowly past the taut level
  // at 12 N, and its floor tripped at once).
  ms.cell_level_N += ms.has_cell_level ? per_period_.step_alpha * (x.cell_N - ms.cell_level_N) : x.cell_N - ms.cell_level_N;
  ms.has_cell_level = true;
  // Tension: a wire's slack checks (and its cell's disconnect) arm once it has been taut since the
  // outputs began to follow: after a vent or at start-up the wires are slack by design.
  if (!x.outputs_follow) ms.taut = false;
  if (x.arming && ms.cell_level_N - ms.zero_N >= x.taut_N) ms.taut = true;
  check_load_cell(x, ms);
  check_tension_floor(x, ms);
  check_startup(x, ms);
  check_load_cell_step(x, ms);
  check_load_cell_drift(x, ms);
  return check_valve(x, ms);
}

/// Load cell: above the muscle's force ceiling, disconnected, saturated, stuck, or disagreeing with
/// the pressure model.
void FaultMonitor::check_load_cell(const MuscleSample& x, MuscleState& ms) noexcept {
  const MonitorParams& p = params_;
  const int j = x.joint, m = x.muscle;
  const double cell = x.cell_N;
  observe(kFaultForceCeiling, cell / x.ceiling_N);
  observe(kFaultLoadcellSaturated, cell / p.loadcell_saturated_N);
  observe(kFaultLoadcellDisagrees, std::abs(cell - x.model_N) / x.tolerance_N);
  if (x.tension_checked && ms.taut) observe(kFaultLoadcellDisconnected, below_ratio(p.loadcell_disconnected_N, cell));
  // Above the ceiling: a real over-force (the pressure model agrees, within the disagreement
  // tolerance) is relieved at once (vent); a reading the pressure model cannot explain is a load-cell
  // fault (descend on the model) - venting a loaded arm drops it.
  if (cell > x.ceiling_N) {
    if (x.model_N >= x.ceiling_N - x.tolerance_N) {
      raise(kFaultForceCeiling, j, m, cell, x.ceiling_N);
    } else {
      raise(kFaultLoadcellDisagrees, j, m, cell - x.model_N, x.tolerance_N);
    }
  }
  // Escalation that does not depend on the model: a reading over the ceiling (below the cell's full
  // scale, which is loadcell_saturated's) for force_ceiling_window_s is a real over-force whatever the
  // model says - a stuck-open valve behind a dead pressure sensor held 2740-2783 N under descend.
  ms.over_ceiling = cell > x.ceiling_N && cell < p.loadcell_saturated_N ? ms.over_ceiling + 1 : 0;
  if (ms.over_ceiling >= per_period_.over_ceiling_cycles) {
    raise(kFaultForceCeiling, j, m, cell, x.ceiling_N);
  }
  // On a joint whose wires may go slack by design (tension not checked: the constant-pressure
  // wrist) a slack wire reads code 0 as a disconnected cell does: not observable, not raised
  // (the arm's identification moved the wrist slack and latched it on muscles -15 %).
  ms.disconnected = x.tension_checked && ms.taut && cell <= p.loadcell_disconnected_N ? ms.disconnected + 1 : 0;
  ms.saturated = cell >= p.loadcell_saturated_N ? ms.saturated + 1 : 0;
  if (ms.disconnected >= p.confirm_cycles) raise(kFaultLoadcellDisconnected, j, m, cell, p.loadcell_disconnected_N);
  if (ms.saturated >= p.confirm_cycles) raise(kFaultLoadcellSaturated, j, m, cell, p.loadcell_saturated_N);
  // Stuck: a taut wire's live cell never repeats itself (noise); a slack wire's cell may sit at code 0.
  ms.same_loadcell = ms.taut && cell > p.loadcell_disconnected_N && cell == ms.last_loadcell_N ? ms.same_loadcell + 1 : 0;
  ms.last_loadcell_N = cell;
  if (ms.taut) observe(kFaultLoadcellStuck, static_cast<double>(ms.same_loadcell + 1) / p.loadcell_stuck_cycles);
  if (ms.same_loadcell + 1 >= p.loadcell_stuck_cycles) raise(kFaultLoadcellStuck, j, m, cell, p.loadcell_stuck_cycles);
  ms.disagree = std::abs(cell - x.model_N) > x.tolerance_N ? ms.disagree + 1 : 0;
  if (ms.disagree >= p.confirm_cycles) raise(kFaultLoadcellDisagrees, j, m, cell - x.model_N, x.tolerance_N);
}

/// Tension: a taut wire's load cell below tension_floor_fraction x pretension (a wire near slack).
void FaultMonitor::check_tension_floor(const MuscleSample& x, MuscleState& ms) noexcept {
  if (x.tension_checked && ms.taut) observe(kFaultTensionFloor, below_ratio(x.floor_N, x.tension_N));
  ms.low_tension = x.tension_checked && ms.taut && x.tension_N < x.floor_N ? ms.low_tension + 1 : 0;
  if (ms.low_tension >= params_.confirm_cycles) raise(kFaultTensionFloor, x.joint, x.muscle, x.tension_N, x.floor_N);
}

/// Start-up, before the joint is carried: the load cell's zero read vented (the pressure model says
/// at most the pretension, the limits' floor), and no checked wire still slack past tension_taut_deadline_s. Both latch before the operator
/// pulls the limb's support (docs/safety.md "Start-up").
void FaultMonitor::check_startup(const MuscleSample& x, MuscleState& ms) noexcept {
  const MonitorParams& p = params_;
  if (x.carried || x.followed_s < 0) {
    ms.zero_off = 0;
    return;
  }
  // Off beyond the range, or below the channel's bottom (a negative zero reads code 0 throughout:
  // a live cell zeroed inside the range reads its noise around a positive offset).
  // Vented: at most the pretension pressure, the limits' floor (below a real muscle's threshold).
  const bool vented = x.model_N <= 1.05 * x.pretension_N;
  const bool off = std::abs(x.cell_N) > p.loadcell_zero_max_N || x.cell_N <= p.loadcell_disconnected_N;
  if (vented) {
    ms.zero_off = off ? ms.zero_off + 1 : 0;  // a sample the pressure noise lifts past the floor counts neither way
    // Code 0 has no magnitude: how much of the window it has lasted.
    observe(kFaultLoadcellZero, std::max(std::abs(x.cell_N) / p.loadcell_zero_max_N,
                                         x.cell_N <= p.loadcell_disconnected_N ? static_cast<double>(ms.zero_off) / per_period_.zero_cycles : 0.0));
  }
  if (ms.zero_off >= per_period_.zero_cycles) {
    raise(kFaultLoadcellZero, x.joint, x.muscle, x.cell_N, p.loadcell_zero_max_N);
  }
  // Never taut and below the floor past the deadline, for as long as the zero check's window: a
  // broken wire reads its noise around 0; an intact one a controller keeps low stays above the floor.
  const bool slack = x.tension_checked && !ms.taut && x.followed_s >= p.tension_taut_deadline_s && x.tension_N < x.floor_N;
  if (x.tension_checked && !ms.taut && x.followed_s >= p.tension_taut_deadline_s) observe(kFaultTensionFloor, below_ratio(x.floor_N, x.tension_N));
  ms.never_taut = slack ? ms.never_taut + 1 : 0;
  if (ms.never_taut >= per_period_.zero_cycles) {
    raise(kFaultTensionFloor, x.joint, x.muscle, x.tension_N, x.floor_N);
  }
}

/// Load-cell step (after the floor, so that a wire break that trips both is named by its floor): the
/// cell leaves the pressure model's company at once. The model follows the measured pressure, so a
/// real force change moves both; a bias or a slipped clamp moves the cell alone. Armed with the slack
/// checks: a start-up vent or refill moves the pressure faster than the muscle's force follows it.
void FaultMonitor::check_load_cell_step(const MuscleSample& x, MuscleState& ms) noexcept {
  const double disagreement_N = x.cell_N - x.model_N;
  if (!ms.has_level || !x.outputs_follow || !ms.taut) {
    ms.disagreement_level_N = ms.disagreement_fast_N = disagreement_N;
    ms.has_level = true;
    ms.step = 0;
    return;
  }
  ms.disagreement_fast_N += per_period_.step_fast_alpha * (disagreement_N - ms.disagreement_fast_N);
  const double jump_N = ms.disagreement_fast_N - ms.disagreement_level_N;
  observe(kFaultLoadcellStep, std::abs(jump_N) / params_.loadcell_step_N);
  ms.step = std::abs(jump_N) > params_.loadcell_step_N ? ms.step + 1 : 0;
  if (ms.step >= params_.confirm_cycles) raise(kFaultLoadcellStep, x.joint, x.muscle, jump_N, params_.loadcell_step_N);
  ms.disagreement_level_N += per_period_.step_alpha * jump_N;
}

/// Drift (issue 29): a cell's zero that creeps, tens of N per second - the step check's level follows
/// it, the disagreement tolerance hides it for tens of seconds, and the force trim follows the cell,
/// so the real force leaves the wanted one until the joint falls. Only the disagreement's changes
/// while the joint has been still for the settle time count (the model's error moves with the
/// operating point, and the muscle relaxes after it stops), summed across still spans both ways.
void FaultMonitor::check_load_cell_drift(const MuscleSample& x, MuscleState& ms) noexcept {
  const MonitorParams& p = params_;
  const double disagreement_N = x.cell_N - x.model_N;
  // Armed loadcell_drift_arm_s after the joint is carried: the start-up refill's last pressure
  // steps near the muscles' threshold move the model's force while the cell stays (3x noise: -100 N
  // at 3.76 s on the upper body's shoulder, 0.35 s after the refill).
  const bool armed = x.carried && ms.taut && x.carried_s >= p.loadcell_drift_arm_s;
  if (!ms.has_drift || !armed) {
    ms.drift_fast_N = ms.drift_last_N = disagreement_N;
    ms.drift_model_fast_N = ms.drift_model_slow_N = x.model_N;
    ms.drift_up_N = ms.drift_down_N = 0;
    ms.has_drift = armed;
    return;
  }
  ms.drift_fast_N += per_period_.drift_alpha * (disagreement_N - ms.drift_fast_N);
  ms.drift_model_fast_N += per_period_.drift_alpha * (x.model_N - ms.drift_model_fast_N);
  ms.drift_model_slow_N += per_period_.drift_slow_alpha * (x.model_N - ms.drift_model_slow_N);
  const bool force_holds =
      std::abs(ms.drift_model_fast_N - ms.drift_model_slow_N) <= p.loadcell_drift_max_rate_N_per_s * 3.0 * p.loadcell_drift_filter_s;
  if (x.still_s >= p.loadcell_drift_settle_s && force_holds) {
    const double change_N = ms.drift_fast_N - ms.drift_last_N;
    const double leak_N = p.loadcell_drift_leak_N_per_s * period_s_;
    ms.drift_up_N = std::max(0.0, ms.drift_up_N + change_N - leak_N);
    ms.drift_down_N = std::max(0.0, ms.drift_down_N - change_N - leak_N);
  }
  ms.drift_last_N = ms.drift_fast_N;  // moving, settling or a force that moves: the change is not counted
  const double drift_N = ms.drift_up_N >= ms.drift_down_N ? ms.drift_up_N : -ms.drift_down_N;
  observe(kFaultLoadcellDrift, std::abs(drift_N) / p.loadcell_drift_N);
  if (std::abs(drift_N) > p.loadcell_drift_N) raise(kFaultLoadcellDrift, x.joint, x.muscle, drift_N, p.loadcell_drift_N);
}

/// Valve: the pressure sensor against what the valve makes of the commands sent (sent() writes them
/// into the delay line): above supply, above or below the envelope of the modelled and the slow valve.
/// True when the pressure has stayed below the envelope for confirm_cycles.
bool FaultMonitor::check_valve(const MuscleSample& x, MuscleState& ms) noexcept {
  const MonitorParams& p = params_;
  const PerPeriod& pp = per_period_;
  const double pressure = x.pressure_Pa;
  observe(kFaultPressureOverSupply, (pressure - x.supply_Pa) / p.pressure_over_supply_Pa);
  if (pressure > x.supply_Pa + p.pressure_over_supply_Pa) {
    raise(kFaultPressureOverSupply, x.joint, x.muscle, pressure, x.supply_Pa + p.pressure_over_supply_Pa);
  }
  if (!x.outputs_follow || !synced_) {  // the valve model restarts from what is measured
    ms.delay.fill(pressure);
    ms.setpoint_Pa = ms.predicted_Pa = ms.slow_setpoint_Pa = ms.slow_predicted_Pa = ms.fast_setpoint_Pa = ms.fast_predicted_Pa = pressure;
    ms.pressure_low = ms.pressure_high = ms.rise = 0;
    ms.has_excess = false;
    ms.above_fast_Pa = 0;
    return false;
  }
  // Advance a modelled valve by one period: the command delay_cycles old, the set-point's rate limit
  // / factor, the lag.
  const double max_step = p.valve_rate_Pa_per_s * period_s_;
  auto advance = [&](int delay_cycles, double factor, double alpha, double& setpoint_Pa, double& predicted_Pa) {
    const double delayed = ms.delay[static_cast<std::size_t>((ms.head + kMaxDelay - delay_cycles) % kMaxDelay)];
    const double step = max_step / factor;
    setpoint_Pa += std::clamp(delayed - setpoint_Pa, -step, step);
    predicted_Pa += alpha * (setpoint_Pa - predicted_Pa);
  };
  advance(pp.delay_cycles, 1.0, pp.valve_alpha, ms.setpoint_Pa, ms.predicted_Pa);
  // The envelope's slow valve: the same command, later, slower, lagging more; and its fast valve:
  // sooner, faster, lagging less (a valve in the 0.5-3 x range leads the model).
  advance(pp.slow_delay_cycles, p.valve_slow_factor, pp.slow_valve_alpha, ms.slow_setpoint_Pa, ms.slow_predicted_Pa);
  advance(pp.fast_delay_cycles, p.valve_fast_factor, pp.fast_valve_alpha, ms.fast_setpoint_Pa, ms.fast_predicted_Pa);
  const double above = pressure - std::max({ms.predicted_Pa, ms.slow_predicted_Pa, ms.fast_predicted_Pa});
  const double below = pressure - std::min({ms.predicted_Pa, ms.slow_predicted_Pa, ms.fast_predicted_Pa});
  ms.above_fast_Pa += pp.rise_alpha * (above - ms.above_fast_Pa);
  observe(kFaultPressureHigh, ms.above_fast_Pa / p.pressure_tolerance_Pa);
  observe(kFaultPressureLow, -below / p.pressure_tolerance_Pa);
  ms.pressure_high = ms.above_fast_Pa > p.pressure_tolerance_Pa && !ms.not_following ? ms.pressure_high + 1 : 0;
  ms.pressure_low = below < -p.pressure_tolerance_Pa ? ms.pressure_low + 1 : 0;
  if (ms.pressure_high >= p.confirm_cycles) raise(kFaultPressureHigh, x.joint, x.muscle, ms.above_fast_Pa, p.pressure_tolerance_Pa);
  check_pressure_rise(x, above, ms);
  return ms.pressure_low >= p.confirm_cycles;
}

/// Rise: the commands hold (both valve models have settled on the newest command), so the pressure
/// should hold too. Only the excess over the upper edge counts (a pressure settling up to the
/// envelope from below is not a rise); its level follows slowly, so a sensor's offset passes.
void FaultMonitor::check_pressure_rise(const MuscleSample& x, double above_Pa, MuscleState& ms) noexcept {
  const MonitorParams& p = params_;
  const double excess_Pa = std::max(above_Pa, 0.0);
  const double newest_Pa = ms.delay[static_cast<std::size_t>(ms.head)];
  const bool settled = std::abs(ms.predicted_Pa - newest_Pa) <= p.pressure_rise_Pa &&
                       std::abs(ms.slow_predicted_Pa - newest_Pa) <= p.pressure_rise_Pa &&
                       std::abs(ms.fast_predicted_Pa - newest_Pa) <= p.pressure_rise_Pa;
  if (!ms.has_excess || !settled) {
    ms.excess_fast_Pa = ms.excess_level_Pa = excess_Pa;
    ms.has_excess = true;
    ms.rise = 0;
    return;
  }
  ms.excess_fast_Pa += per_period_.rise_alpha * (excess_Pa - ms.excess_fast_Pa);
  const double rise_Pa = ms.excess_fast_Pa - ms.excess_level_Pa;
  observe(kFaultPressureRise, rise_Pa / p.pressure_rise_Pa);
  ms.rise = rise_Pa > p.pressure_rise_Pa ? ms.rise + 1 : 0;
  if (ms.rise >= p.confirm_cycles) raise(kFaultPressureRise, x.joint, x.muscle, rise_Pa, p.pressure_rise_Pa);
  // A confirmed rise that goes on past kRiseVentFactor x the threshold is a valve that keeps filling:
  // vent it now (pressure_high), not after the wide tolerance - descended until that, the arm's stuck
  // elbow valve flexed it past its stop. Noise alone stayed below 2.1 x even at 10x (docs/safety.md).
  if (on(kFaultPressureRise) && ms.rise >= p.confirm_cycles && rise_Pa > kRiseVentFactor * p.pressure_rise_Pa) {
    raise(kFaultPressureHigh, x.joint, x.muscle, rise_Pa, kRiseVentFactor * p.pressure_rise_Pa);
  }
  ms.excess_level_Pa += per_period_.step_alpha * (ms.excess_fast_Pa - ms.excess_level_Pa);
}

/// Pressures below the envelope: on two or more muscles at once the supply is lost (also where no
/// supply sensor is read); on one, that muscle's valve or sensor does not follow.
void FaultMonitor::check_low_pressures(int low_muscles, int joint_count) noexcept {
  if (low_muscles >= 2) {
    raise(kFaultSupplyLoss, -1, -1, low_muscles, 2);
    return;
  }
  if (low_muscles != 1) return;
  for (int j = 0; j < joint_count && j < io::kMaxJoints; ++j) {
    for (int m = 0; m < 2; ++m) {
      MuscleState& ms = joints_[static_cast<std::size_t>(j)].muscle[static_cast<std::size_t>(m)];
      if (ms.pressure_low < params_.confirm_cycles) continue;
      raise(kFaultPressureLow, j, m, ms.predicted_Pa, params_.pressure_tolerance_Pa);
      if (flags_ & kFaultPressureLow) ms.not_following = true;
    }
  }
}

bool FaultMonitor::check_command(const io::Command& c, double t_s) noexcept {
  bool ok = true;
  for (int j = 0; j < c.joint_count && j < io::kMaxJoints; ++j) {
    const io::JointCommand& jc = c.joints[static_cast<std::size_t>(j)];
    // The controller's zero, bounded by what the start-up zero check lets pass: a wire judged against
    // another zero than before is judged afresh (its taut arms again). Not once a fault is latched:
    // the controller's commands no longer go out, so a tare it takes then reads a limb the safe state
    // holds loaded (E1 held at start-up by a -50 N zero tared the antagonist's 100 N as its zero).
    for (int m = 0; m < 2 && !flags_; ++m) {
      MuscleState& ms = joints_[static_cast<std::size_t>(j)].muscle[static_cast<std::size_t>(m)];
      const double declared_N = jc.loadcell_zero_N[static_cast<std::size_t>(m)];
      const double max_N = params_.loadcell_zero_max_N;
      const double zero_N = std::isfinite(declared_N) ? std::clamp(declared_N, -max_N, max_N) : 0.0;
      if (std::abs(zero_N - ms.zero_N) > kZeroChange_N) ms.taut = false;
      ms.zero_N = zero_N;
    }
    if (!std::isfinite(jc.agonist_pressure_Pa) || !std::isfinite(jc.antagonist_pressure_Pa) || !std::isfinite(jc.motor_torque_Nm)) {
      if (on(kFaultNonFiniteCommand)) t_s_ = std::max(t_s_, t_s);
      raise(kFaultNonFiniteCommand, j, -1, 0.0, 0.0);
      ok = false;
    }
  }
  return ok;
}

void FaultMonitor::sent(const io::Command& c) noexcept {
  io::copy_used(last_sent_, c);
  for (int j = 0; j < c.joint_count && j < io::kMaxJoints; ++j) {
    JointState& js = joints_[static_cast<std::size_t>(j)];
    const double motor_Nm = c.joints[static_cast<std::size_t>(j)].motor_torque_Nm;
    js.motor_head = (js.motor_head + 1) % kMotorWindow;
    js.sent_motor_Nm[static_cast<std::size_t>(js.motor_head)] = std::isfinite(motor_Nm) ? motor_Nm : 0.0;
    js.motor_sent = std::min(js.motor_sent + 1, kMotorWindow);
    const double p[2] = {c.joints[static_cast<std::size_t>(j)].agonist_pressure_Pa, c.joints[static_cast<std::size_t>(j)].antagonist_pressure_Pa};
    for (int m = 0; m < 2; ++m) {
      MuscleState& ms = js.muscle[static_cast<std::size_t>(m)];
      ms.head = (ms.head + 1) % kMaxDelay;
      ms.delay[static_cast<std::size_t>(ms.head)] = std::isfinite(p[m]) ? p[m] : 0.0;
    }
  }
}

void FaultMonitor::shape(io::Command& c) const noexcept {
  if (action_ == SafeAction::kHold) {
    io::copy_used(c, held_);
    return;
  }
  if (action_ != SafeAction::kDescend) return;
  io::copy_used(c, held_);
  for (int j = 0; j < c.joint_count && j < io::kMaxJoints; ++j) {
    const DescendGovernorData& g = joints_[static_cast<std::size_t>(j)].governor;
    if (!g.started) continue;  // no joint model: hold
    io::JointCommand& o = c.joints[static_cast<std::size_t>(j)];
    o.agonist_pressure_Pa = g.pressure_Pa[0];
    o.antagonist_pressure_Pa = g.pressure_Pa[1];
    o.motor_torque_Nm = g.motor_Nm;
  }
}

void FaultMonitor::govern(const io::SensorState& s, const std::array<const models::JointModel*, io::kMaxJoints>& models,
                          const std::array<double, io::kMaxJoints>& min_angle_rad,
                          const std::array<double, io::kMaxJoints>& max_angle_rad) noexcept {
  for (int j = 0; j < s.joint_count && j < io::kMaxJoints; ++j) {
    const auto ji = static_cast<std::size_t>(j);
    const double angle_rad = s.joints[ji].angle_rad;
    if (!params_.governed[ji] || !models[ji] || !std::isfinite(angle_rad)) continue;
    JointState& js = joints_[ji];
    DescentSample sample{angle_rad, js.filtered_speed_radps, min_angle_rad[ji], max_angle_rad[ji]};
    if (!(faulted_joints_ & (1u << j))) {
      const double cell_N[2] = {s.joints[ji].agonist_loadcell_N, s.joints[ji].antagonist_loadcell_N};
      for (std::size_t m = 0; m < 2; ++m) sample.measured_N[m] = cell_N[m] - js.muscle[m].zero_N;  // NaN stays NaN: model only
    }
    govern_descent(governor_, *models[ji], held_.joints[ji], sample, js.governor);
    // A descent that does not slow: moving down (the carrying muscle lets go toward negative angles
    // when it is the agonist) faster than the runaway speed for its window. The muscle pulling the
    // joint down is vented; the carrying muscle keeps braking (venting it would drop the limb).
    const double down_radps = (js.governor.carrying == 0 ? -1.0 : 1.0) * js.filtered_speed_radps;
    js.runaway = down_radps > params_.descent_runaway_speed_radps ? js.runaway + 1 : 0;
    if (js.runaway >= per_period_.runaway_cycles && on(kFaultDescentRunaway)) {
      raise(kFaultDescentRunaway, j, 1 - js.governor.carrying, down_radps, params_.descent_runaway_speed_radps);
      js.governor.other_vented = true;
    }
  }
}

void FaultMonitor::vent_escalated(io::Command& c) const noexcept {
  if (action_ != SafeAction::kDescend) return;
  for (int j = 0; j < c.joint_count && j < io::kMaxJoints; ++j) {
    const DescendGovernorData& g = joints_[static_cast<std::size_t>(j)].governor;
    if (!g.started || !g.other_vented) continue;
    io::JointCommand& o = c.joints[static_cast<std::size_t>(j)];
    (g.carrying == 0 ? o.antagonist_pressure_Pa : o.agonist_pressure_Pa) = 0.0;
  }
}

}  // namespace peha::safety
