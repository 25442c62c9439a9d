#include "peha/control/startup_tare.hpp"

#include <algorithm>
#include <cmath>

namespace peha::control {

StartupTare start_tare(const LoadcellCheck& check) noexcept {
  StartupTare t;
  if (check.tare_s > 0.0) t.phase = StartupPhase::kVenting;
  return t;
}

bool step_startup_tare(const LoadcellCheck& check, const io::SensorState& s, StartupTare& t) noexcept {
  if (!t.started) {
    t.started = true;
    t.phase_start_s = s.time_s;
  }
  if (t.phase == StartupPhase::kCompensating) {
    if (t.compensating_since_s < 0.0) t.compensating_since_s = s.time_s;
    return false;
  }
  // Venting: the muscles commanded to 0 (the limits layer keeps them at the model's pretension
  // pressure, below the real muscles' threshold: no force), the motor off, the link held. Then the
  // load cells averaged: what they read is their offset.
  const int joints = std::clamp(s.joint_count, 0, io::kMaxJoints);
  const double elapsed_s = s.time_s - t.phase_start_s;
  if (t.phase == StartupPhase::kVenting) {
    if (elapsed_s >= check.vent_s) {
      t.phase = StartupPhase::kTaring;
      t.phase_start_s = s.time_s;
    }
    return true;
  }
  for (int j = 0; j < joints; ++j) {
    if (!std::isfinite(s.joints[j].agonist_loadcell_N) || !std::isfinite(s.joints[j].antagonist_loadcell_N)) return true;
  }
  for (int j = 0; j < joints; ++j) {
    t.sum_N[static_cast<std::size_t>(j)][0] += s.joints[j].agonist_loadcell_N;
    t.sum_N[static_cast<std::size_t>(j)][1] += s.joints[j].antagonist_loadcell_N;
  }
  ++t.samples;
  if (elapsed_s < check.tare_s) return true;
  t.phase = StartupPhase::kCompensating;
  t.compensating_since_s = s.time_s;
  return false;
}

double tare_offset_N(const LoadcellCheck& check, const StartupTare& t, int joint, int muscle) noexcept {
  if (t.samples == 0) return 0.0;
  const double offset_N = t.sum_N[static_cast<std::size_t>(joint)][static_cast<std::size_t>(muscle)] / static_cast<double>(t.samples);
  return std::abs(offset_N) <= check.max_tare_N ? offset_N : 0.0;
}

bool wires_slack_on_purpose(const LoadcellCheck& check, const StartupTare& t, double t_s) noexcept {
  return check.tare_s > 0.0 && (t.compensating_since_s < 0.0 || t_s < t.compensating_since_s + check.refill_s);
}

}  // namespace peha::control
