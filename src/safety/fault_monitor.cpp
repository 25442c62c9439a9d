#include "peha/safety/fault_monitor.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>

namespace peha::safety {
namespace {

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
  if (!root.has("supervisor")) return;
  constexpr double kDeg = 3.14159265358979323846 / 180.0;
  config::Map m = root.map("supervisor");
  p.enabled = m.boolean_or("enabled", p.enabled);
  p.tension_arm_s = m.number_or("tension_arm_s", p.tension_arm_s, {0, 60});
  p.tension_taut_fraction = m.number_or("tension_taut_fraction", p.tension_taut_fraction, {0, 2});
  p.confirm_cycles = static_cast<int>(m.number_or("confirm_cycles", p.confirm_cycles, {1, 100}));
  p.loadcell_stuck_cycles = static_cast<int>(m.number_or("loadcell_stuck_cycles", p.loadcell_stuck_cycles, {2, 1000}));
  p.loadcell_saturated_N = m.number_or("loadcell_saturated_N", p.loadcell_saturated_N, {100, 20000});
  p.loadcell_tolerance_N = m.number_or("loadcell_tolerance_N", p.loadcell_tolerance_N, {0, 5000});
  p.loadcell_tolerance_fraction = m.number_or("loadcell_tolerance_fraction", p.loadcell_tolerance_fraction, {0, 10});
  p.loadcell_step_N = m.number_or("loadcell_step_N", p.loadcell_step_N, {1, 1e5});
  p.loadcell_step_filter_s = m.number_or("loadcell_step_filter_s", p.loadcell_step_filter_s, {0.002, 10});
  p.tension_floor_fraction = m.number_or("tension_floor_fraction", p.tension_floor_fraction, {0, 1});
  p.pressure_tolerance_Pa = m.number_or("pressure_tolerance_MPa", p.pressure_tolerance_Pa * 1e-6, {0.001, 1}) * 1e6;
  p.pressure_rise_Pa = m.number_or("pressure_rise_MPa", p.pressure_rise_Pa * 1e-6, {0.001, 1}) * 1e6;
  p.pressure_rise_filter_s = m.number_or("pressure_rise_filter_s", p.pressure_rise_filter_s, {0.0005, 1});
  p.valve_dead_time_s = m.number_or("valve_dead_time_s", p.valve_dead_time_s, {0, 0.05});
  p.valve_lag_s = m.number_or("valve_lag_s", p.valve_lag_s, {1e-4, 2});
  p.valve_rate_Pa_per_s = m.number_or("valve_rate_MPa_per_s", p.valve_rate_Pa_per_s * 1e-6, {0.01, 100}) * 1e6;
  p.valve_slow_factor = m.number_or("valve_slow_factor", p.valve_slow_factor, {1.0, 10.0});
  p.encoder_max_step_rad = m.number_or("encoder_max_step_deg", p.encoder_max_step_rad / kDeg, {0.01, 90}) * kDeg;
  p.encoder_frozen_cycles = static_cast<int>(m.number_or("encoder_frozen_cycles", p.encoder_frozen_cycles, {2, 1000}));
  p.encoder_frozen_speed_radps = m.number_or("encoder_frozen_speed_degps", p.encoder_frozen_speed_radps / kDeg, {0.1, 1000}) * kDeg;
  p.encoder_disagree_rad = m.number_or("encoder_disagree_deg", p.encoder_disagree_rad / kDeg, {0.01, 90}) * kDeg;
  p.max_joint_speed_radps = m.number_or("max_joint_speed_degps", p.max_joint_speed_radps / kDeg, {1, 2000}) * kDeg;
  p.range_margin_rad = m.number_or("range_margin_deg", p.range_margin_rad / kDeg, {0, 45}) * kDeg;
  p.supply_low_fraction = m.number_or("supply_low_fraction", p.supply_low_fraction, {0, 1});
  p.supply_lost_fraction = m.number_or("supply_lost_fraction", p.supply_lost_fraction, {0, p.supply_low_fraction});
  p.motor_tolerance_Nm = m.number_or("motor_tolerance_Nm", p.motor_tolerance_Nm, {0.001, 100});
  p.motor_window_cycles = static_cast<int>(m.number_or("motor_window_cycles", p.motor_window_cycles, {1, FaultMonitor::kMotorWindow}));
  p.descent_speed_radps = m.number_or("descent_speed_degps", p.descent_speed_radps / kDeg, {0.5, 180}) * kDeg;
  p.descent_force_rate_N_per_s = m.number_or("descent_force_rate_N_per_s", p.descent_force_rate_N_per_s, {1, 5000});
  p.descent_gain_N_per_radps = m.number_or("descent_gain_N_per_radps", p.descent_gain_N_per_radps, {0, 20000});
  p.descent_force_slew_N_per_s = m.number_or("descent_force_slew_N_per_s", p.descent_force_slew_N_per_s, {10, 1e6});
  p.descent_floor_fraction = m.number_or("descent_floor_fraction", p.descent_floor_fraction, {0, 1});
  p.descent_damping_Nms_per_rad = m.number_or("descent_damping_Nms_per_rad", p.descent_damping_Nms_per_rad, {0, 100});
  p.descent_stop_margin_rad = m.number_or("descent_stop_margin_deg", p.descent_stop_margin_rad / kDeg, {0.5, 45}) * kDeg;
  p.speed_filter_Hz = m.number_or("speed_filter_Hz", p.speed_filter_Hz, {0.5, 200});
  m.finish();
}

void FaultMonitor::raise(std::uint32_t flag, int joint, int muscle, double value, double threshold) noexcept {
  if (!on(flag) || (flags_ & flag)) return;
  if (flags_ == 0) {
    first_ = {flag, joint, muscle, value, threshold, t_s_, sequence_};
    ++count_;
    io::copy_used(held_, last_sent_);
    for (int j = 0; j < held_.joint_count; ++j) held_.joints[static_cast<std::size_t>(j)].motor_torque_Nm = 0.0;
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
  pp.step_alpha = alpha(p.loadcell_step_filter_s);  // the step check's level filter (also the rise check's)
  pp.rise_alpha = alpha(p.pressure_rise_filter_s);
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
          .period_s = period_s};
}

void FaultMonitor::clear() noexcept {
  flags_ = 0;
  action_ = SafeAction::kNone;
  first_ = {};
  reason_[0] = '\0';
  synced_ = false;
  for (auto& j : joints_) {
    for (auto& m : j.muscle) {
      m.taut = m.has_level = false;
      m.disconnected = m.saturated = m.disagree = m.low_tension = m.pressure_low = m.pressure_high = m.same_loadcell = m.step = 0;
    }
    j.same_angle = 0;
    j.supply_low = j.supply_lost = j.motor_off = 0;
    j.motor_sent = 0;
    j.follow_since_s = -1;
    j.governor = {};
  }
}

void FaultMonitor::check_sample(const io::SensorState& s, const std::array<const models::JointModel*, io::kMaxJoints>& models,
                                const std::array<double, io::kMaxJoints>& min_angle_rad,
                                const std::array<double, io::kMaxJoints>& max_angle_rad, bool outputs_follow) noexcept {
  t_s_ = s.time_s;
  sequence_ = s.sequence;
  const MonitorParams& p = params_;
  if (!p.enabled) return;
  const PerPeriod& pp = per_period_;
  int low_muscles = 0;
  for (int j = 0; j < s.joint_count && j < io::kMaxJoints; ++j) {
    const auto ji = static_cast<std::size_t>(j);
    const io::JointSensors& in = s.joints[ji];
    JointState& js = joints_[ji];
    const models::JointModel* model = models[ji];
    const double cells[2] = {in.agonist_loadcell_N, in.antagonist_loadcell_N};
    const double pressures[2] = {in.agonist_pressure_Pa, in.antagonist_pressure_Pa};
    if (!std::isfinite(in.angle_rad) || !std::isfinite(cells[0]) || !std::isfinite(cells[1]) || !std::isfinite(pressures[0]) ||
        !std::isfinite(pressures[1])) {
      raise(kFaultNonFiniteSample, j, -1, 0.0, 0.0);
      continue;
    }
    // Encoder: jump, speed, frozen, range.
    if (js.has_previous) {
      const double dt = std::max(s.time_s - js.last_t_s, period_s_);
      const double step = in.angle_rad - js.last_angle_rad;
      if (std::abs(step) > p.encoder_max_step_rad) raise(kFaultEncoderJump, j, -1, std::abs(step), p.encoder_max_step_rad);
      js.speed_radps = step / dt;
      const double a = 1.0 - std::exp(-dt * 2.0 * 3.14159265358979323846 * p.speed_filter_Hz);
      if (std::abs(step) <= p.encoder_max_step_rad) js.filtered_speed_radps += a * (js.speed_radps - js.filtered_speed_radps);
      if (std::abs(js.speed_radps) > p.max_joint_speed_radps && std::abs(step) <= p.encoder_max_step_rad) {
        raise(kFaultJointSpeed, j, -1, std::abs(js.speed_radps), p.max_joint_speed_radps);
      }
      if (step == 0.0) {
        ++js.same_angle;
        if (js.same_angle >= p.encoder_frozen_cycles && std::abs(js.last_change_speed_radps) > p.encoder_frozen_speed_radps) {
          raise(kFaultEncoderFrozen, j, -1, js.last_change_speed_radps, p.encoder_frozen_speed_radps);
        }
      } else {
        js.last_change_speed_radps = step / std::max(s.time_s - js.last_change_t_s, dt);
        js.last_change_t_s = s.time_s;
        js.same_angle = 0;
      }
    } else {
      js.last_change_t_s = s.time_s;
    }
    // The redundant encoder on the joint's axis: the two angles stay together while both count.
    if (std::isfinite(in.redundant_angle_rad)) {
      const double apart_rad = in.angle_rad - in.redundant_angle_rad;
      js.encoder_apart = std::abs(apart_rad) > p.encoder_disagree_rad ? js.encoder_apart + 1 : 0;
      if (js.encoder_apart >= p.confirm_cycles) raise(kFaultEncoderDisagrees, j, -1, apart_rad, p.encoder_disagree_rad);
    }
    js.last_angle_rad = in.angle_rad;
    js.last_t_s = s.time_s;
    js.has_previous = true;
    if (in.angle_rad < min_angle_rad[ji] - p.range_margin_rad) raise(kFaultJointRange, j, -1, in.angle_rad, min_angle_rad[ji] - p.range_margin_rad);
    if (in.angle_rad > max_angle_rad[ji] + p.range_margin_rad) raise(kFaultJointRange, j, -1, in.angle_rad, max_angle_rad[ji] + p.range_margin_rad);
    if (!outputs_follow) {
      js.follow_since_s = -1;
    } else if (js.follow_since_s < 0) {
      js.follow_since_s = s.time_s;
    }
    if (!model) continue;
    // Supply, where it is measured: a sensor on the valve manifold sees a failing compressor at once,
    // also at rest, where the check valves keep the muscles' air and no pressure sensor moves.
    if (std::isfinite(in.supply_pressure_Pa)) {
      const double low_Pa = p.supply_low_fraction * model->supply_pressure_Pa;
      const double lost_Pa = p.supply_lost_fraction * model->supply_pressure_Pa;
      js.supply_low = in.supply_pressure_Pa < low_Pa ? js.supply_low + 1 : 0;
      js.supply_lost = in.supply_pressure_Pa < lost_Pa ? js.supply_lost + 1 : 0;
      // A supply gone at once is a loss, not also a low supply (descend is the stronger safe state).
      if (js.supply_lost >= p.confirm_cycles) {
        raise(kFaultSupplyLoss, j, -1, in.supply_pressure_Pa, lost_Pa);
      } else if (js.supply_low >= p.confirm_cycles && in.supply_pressure_Pa >= lost_Pa) {
        raise(kFaultSupplyLow, j, -1, in.supply_pressure_Pa, low_Pa);
      }
    }
    // Motor, where the driver's current monitor is read: the torque it makes against the span of the
    // commands sent while the outputs followed over the last motor_window_cycles (the link's latency).
    if (!outputs_follow) js.motor_sent = 0;
    const int window = std::clamp(p.motor_window_cycles, 1, kMotorWindow);
    if (model->has_motor && outputs_follow && std::isfinite(in.motor_torque_Nm) && js.motor_sent >= window) {
      double lo_Nm = js.sent_motor_Nm[static_cast<std::size_t>(js.motor_head)], hi_Nm = lo_Nm;
      for (int k = 1; k < window; ++k) {
        const double c = js.sent_motor_Nm[static_cast<std::size_t>((js.motor_head + kMotorWindow - k) % kMotorWindow)];
        lo_Nm = std::min(lo_Nm, c);
        hi_Nm = std::max(hi_Nm, c);
      }
      const double off_Nm = std::max(lo_Nm - in.motor_torque_Nm, in.motor_torque_Nm - hi_Nm);
      js.motor_off = off_Nm > p.motor_tolerance_Nm ? js.motor_off + 1 : 0;
      if (js.motor_off >= p.confirm_cycles) {
        raise(kFaultMotorDisagrees, j, -1, in.motor_torque_Nm - js.sent_motor_Nm[static_cast<std::size_t>(js.motor_head)], p.motor_tolerance_Nm);
      }
    } else {
      js.motor_off = 0;
    }
    for (int m = 0; m < 2; ++m) {
      MuscleState& ms = js.muscle[static_cast<std::size_t>(m)];
      const models::MuscleModel& mm = m == 0 ? model->agonist : model->antagonist;
      const double cell = cells[m], pressure = pressures[m];
      // Load cell. Above the ceiling: a real over-force (the pressure model agrees, within the
      // disagreement tolerance) is relieved at once (vent); a reading the pressure model cannot
      // explain is a load-cell fault (descend on the model) - venting a loaded arm drops it.
      const double ceiling = models::force_ceiling_N(mm);
      const double eps = models::rigid_contraction(mm, model->pulley_radius_m, m == 0 ? +1 : -1, in.angle_rad);
      const double model_N = models::forward_force_N(mm.pam, pressure, eps);
      const double tolerance = p.loadcell_tolerance_N + p.loadcell_tolerance_fraction * std::abs(model_N);
      if (cell > ceiling) {
        if (model_N >= ceiling - tolerance) {
          raise(kFaultForceCeiling, j, m, cell, ceiling);
        } else {
          raise(kFaultLoadcellDisagrees, j, m, cell - model_N, tolerance);
        }
      }
      // A wire is checked for slack (and its cell for a disconnect) once it has been taut since the
      // outputs began to follow: after a vent or at start-up the wires are slack by design.
      const double floor_N = p.tension_floor_fraction * model->pretension_N;
      if (!outputs_follow) ms.taut = false;
      if (outputs_follow && s.time_s - js.follow_since_s >= p.tension_arm_s &&
          cell >= std::max(floor_N, p.tension_taut_fraction * model->pretension_N)) {
        ms.taut = true;
      }
      // On a joint whose wires may go slack by design (tension not checked: the constant-pressure
      // wrist) a slack wire reads code 0 as a disconnected cell does: not observable, not raised
      // (the arm's identification moved the wrist slack and latched it on muscles -15 %).
      ms.disconnected = p.tension_checked[ji] && ms.taut && cell <= p.loadcell_disconnected_N ? ms.disconnected + 1 : 0;
      ms.saturated = cell >= p.loadcell_saturated_N ? ms.saturated + 1 : 0;
      if (ms.disconnected >= p.confirm_cycles) raise(kFaultLoadcellDisconnected, j, m, cell, p.loadcell_disconnected_N);
      if (ms.saturated >= p.confirm_cycles) raise(kFaultLoadcellSaturated, j, m, cell, p.loadcell_saturated_N);
      // Stuck: a taut wire's live cell never repeats itself (noise); a slack wire's cell may sit at code 0.
      ms.same_loadcell = ms.taut && cell > p.loadcell_disconnected_N && cell == ms.last_loadcell_N ? ms.same_loadcell + 1 : 0;
      ms.last_loadcell_N = cell;
      if (ms.same_loadcell + 1 >= p.loadcell_stuck_cycles) raise(kFaultLoadcellStuck, j, m, cell, p.loadcell_stuck_cycles);
      ms.disagree = std::abs(cell - model_N) > tolerance ? ms.disagree + 1 : 0;
      if (ms.disagree >= p.confirm_cycles) raise(kFaultLoadcellDisagrees, j, m, cell - model_N, tolerance);
      ms.low_tension = p.tension_checked[ji] && ms.taut && cell < floor_N ? ms.low_tension + 1 : 0;
      if (ms.low_tension >= p.confirm_cycles) raise(kFaultTensionFloor, j, m, cell, floor_N);
      // Step (after the floor, so that a wire break that trips both is named by its floor): the cell leaves the pressure model's company at once. The model follows the measured
      // pressure, so a real force change moves both; a bias or a slipped clamp moves the cell alone.
      const double disagreement_N = cell - model_N;
      // Armed with the slack checks (outputs followed for tension_arm_s, wire taut since): a start-up
      // vent or refill moves the pressure faster than the muscle's force follows it.
      if (!ms.has_level || !outputs_follow || !ms.taut) {
        ms.disagreement_level_N = disagreement_N;
        ms.has_level = true;
        ms.step = 0;
      } else {
        const double jump_N = disagreement_N - ms.disagreement_level_N;
        ms.step = std::abs(jump_N) > p.loadcell_step_N ? ms.step + 1 : 0;
        if (ms.step >= p.confirm_cycles) raise(kFaultLoadcellStep, j, m, jump_N, p.loadcell_step_N);
        ms.disagreement_level_N += pp.step_alpha * jump_N;
      }
      // Pressure sensor against the valve's dynamics.
      if (pressure > model->supply_pressure_Pa + p.pressure_over_supply_Pa) {
        raise(kFaultPressureOverSupply, j, m, pressure, model->supply_pressure_Pa + p.pressure_over_supply_Pa);
      }
      if (!outputs_follow || !synced_) {  // the valve model restarts from what is measured
        ms.delay.fill(pressure);
        ms.setpoint_Pa = ms.predicted_Pa = ms.slow_setpoint_Pa = ms.slow_predicted_Pa = pressure;
        ms.pressure_low = ms.pressure_high = ms.rise = 0;
        ms.has_excess = false;
        continue;
      }
      // Advance the valve model by one period with the delayed command (written by sent()).
      const double delayed = ms.delay[static_cast<std::size_t>((ms.head + kMaxDelay - pp.delay_cycles) % kMaxDelay)];
      const double max_step = p.valve_rate_Pa_per_s * period_s_;
      ms.setpoint_Pa += std::clamp(delayed - ms.setpoint_Pa, -max_step, max_step);
      ms.predicted_Pa += pp.valve_alpha * (ms.setpoint_Pa - ms.predicted_Pa);
      // The envelope's slow valve: the same command, later, slower, lagging more.
      const double slow_delayed = ms.delay[static_cast<std::size_t>((ms.head + kMaxDelay - pp.slow_delay_cycles) % kMaxDelay)];
      const double slow_step = max_step / p.valve_slow_factor;
      ms.slow_setpoint_Pa += std::clamp(slow_delayed - ms.slow_setpoint_Pa, -slow_step, slow_step);
      ms.slow_predicted_Pa += pp.slow_valve_alpha * (ms.slow_setpoint_Pa - ms.slow_predicted_Pa);
      const double above = pressure - std::max(ms.predicted_Pa, ms.slow_predicted_Pa);
      const double below = pressure - std::min(ms.predicted_Pa, ms.slow_predicted_Pa);
      ms.pressure_high = above > p.pressure_tolerance_Pa ? ms.pressure_high + 1 : 0;
      ms.pressure_low = below < -p.pressure_tolerance_Pa ? ms.pressure_low + 1 : 0;
      if (ms.pressure_high >= p.confirm_cycles) raise(kFaultPressureHigh, j, m, above, p.pressure_tolerance_Pa);
      if (ms.pressure_low >= p.confirm_cycles) ++low_muscles;
      // Rise: the commands hold (both valve models have settled on the newest command), so the
      // pressure should hold too. Only the excess over the upper edge counts (a pressure settling up
      // to the envelope from below is not a rise); its level follows slowly, so a sensor's offset passes.
      const double excess_Pa = std::max(above, 0.0);
      const double newest_Pa = ms.delay[static_cast<std::size_t>(ms.head)];
      const bool settled = std::abs(ms.predicted_Pa - newest_Pa) <= p.pressure_rise_Pa &&
                           std::abs(ms.slow_predicted_Pa - newest_Pa) <= p.pressure_rise_Pa;
      if (!ms.has_excess || !settled) {
        ms.excess_fast_Pa = ms.excess_level_Pa = excess_Pa;
        ms.has_excess = true;
        ms.rise = 0;
      } else {
        ms.excess_fast_Pa += pp.rise_alpha * (excess_Pa - ms.excess_fast_Pa);
        const double rise_Pa = ms.excess_fast_Pa - ms.excess_level_Pa;
        ms.rise = rise_Pa > p.pressure_rise_Pa ? ms.rise + 1 : 0;
        if (ms.rise >= p.confirm_cycles) raise(kFaultPressureRise, j, m, rise_Pa, p.pressure_rise_Pa);
        ms.excess_level_Pa += pp.step_alpha * (ms.excess_fast_Pa - ms.excess_level_Pa);
      }
    }
  }
  if (low_muscles >= 2) {
    raise(kFaultSupplyLoss, -1, -1, low_muscles, 2);
  } else if (low_muscles == 1) {
    for (int j = 0; j < s.joint_count && j < io::kMaxJoints; ++j) {
      for (int m = 0; m < 2; ++m) {
        const MuscleState& ms = joints_[static_cast<std::size_t>(j)].muscle[static_cast<std::size_t>(m)];
        if (ms.pressure_low >= p.confirm_cycles) raise(kFaultPressureLow, j, m, ms.predicted_Pa, p.pressure_tolerance_Pa);
      }
    }
  }
  synced_ = outputs_follow;
  if (action_ == SafeAction::kDescend) govern(s, models, min_angle_rad, max_angle_rad);
}

bool FaultMonitor::check_command(const io::Command& c, double t_s) noexcept {
  bool ok = true;
  for (int j = 0; j < c.joint_count && j < io::kMaxJoints; ++j) {
    const io::JointCommand& jc = c.joints[static_cast<std::size_t>(j)];
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
    const DescentSample sample{angle_rad, js.filtered_speed_radps, min_angle_rad[ji], max_angle_rad[ji]};
    govern_descent(governor_, *models[ji], held_.joints[ji], sample, js.governor);
  }
}

}  // namespace peha::safety
