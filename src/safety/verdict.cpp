#include "peha/safety/verdict.hpp"

#include "peha/models/units.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace peha::safety {

bool Check::passed() const noexcept {
  switch (rule) {
    case Rule::kAtMost: return value <= limit;
    case Rule::kAbove: return value > limit;
    case Rule::kAtLeast: return value >= limit;
    case Rule::kWithin: return value >= lower && value <= limit;
  }
  return false;
}

std::string Check::describe() const {
  switch (rule) {
    case Rule::kAtMost: return fmt::format("{} {:.4g} {} {} {:.4g} {}", figure, value, unit, passed() ? "<=" : ">", limit, unit);
    case Rule::kAbove: return fmt::format("{} {:.4g} {} {} {:.4g} {}", figure, value, unit, passed() ? ">" : "<=", limit, unit);
    case Rule::kAtLeast: return fmt::format("{} {:.4g} {} {} {:.4g} {}", figure, value, unit, passed() ? ">=" : "<", limit, unit);
    case Rule::kWithin:
      return fmt::format("{} {:.4g} {} {} [{:.4g}, {:.4g}] {}", figure, value, unit, passed() ? "in" : "outside", lower, limit, unit);
  }
  return figure;
}

void Verdict::at_most(std::string figure, std::string unit, double value, double limit) {
  checks.push_back({std::move(figure), std::move(unit), value, limit, 0.0, Check::Rule::kAtMost});
}
void Verdict::above(std::string figure, std::string unit, double value, double limit) {
  checks.push_back({std::move(figure), std::move(unit), value, limit, 0.0, Check::Rule::kAbove});
}
void Verdict::at_least(std::string figure, std::string unit, double value, double limit) {
  checks.push_back({std::move(figure), std::move(unit), value, limit, 0.0, Check::Rule::kAtLeast});
}

const Check* Verdict::find(const std::string& figure) const noexcept {
  for (const Check& c : checks) {
    if (c.figure == figure) return &c;
  }
  return nullptr;
}

std::string Verdict::describe_all() const {
  std::string out;
  for (const Check& c : checks) out += fmt::format("  {} {}\n", c.passed() ? "ok  " : "FAIL", c.describe());
  return out;
}

VerdictThresholds read_verdict_thresholds(config::Map& root) {
  VerdictThresholds t;
  if (!root.has("verdict")) return t;
  config::Map v = root.map("verdict");
  t.max_drift_deg = v.number_or("max_drift_deg", t.max_drift_deg, {0.0, 180.0});
  t.stop_margin_deg = v.number_or("stop_margin_deg", t.stop_margin_deg, {0.0, 90.0});
  t.max_static_torque_error_pct = v.number_or("max_static_torque_error_pct", t.max_static_torque_error_pct, {0.0, 1000.0});
  t.min_gravity_torque_Nm = v.number_or("min_gravity_torque_Nm", t.min_gravity_torque_Nm, {0.0, 1000.0});
  t.min_tension_fraction = v.number_or("min_tension_fraction", t.min_tension_fraction, {0.0, 10.0});
  t.max_tracking_rms_deg = v.number_or("max_tracking_rms_deg", t.max_tracking_rms_deg, {0.0, 180.0});
  t.max_tracking_error_deg = v.number_or("max_tracking_error_deg", t.max_tracking_error_deg, {0.0, 360.0});
  t.at_limit_band_N = v.number_or("at_limit_band_N", t.at_limit_band_N, {0.0, 1000.0});
  t.max_force_overshoot_N = v.number_or("max_force_overshoot_N", t.max_force_overshoot_N, {0.0, 1000.0});
  t.max_force_shortfall_N = v.number_or("max_force_shortfall_N", t.max_force_shortfall_N, {0.0, 2000.0});
  t.max_settle_s = v.number_or("max_settle_s", t.max_settle_s, {0.0, 3600.0});
  t.min_time_at_limit_s = v.number_or("min_time_at_limit_s", t.min_time_at_limit_s, {0.0, 3600.0});
  t.min_ceiling_share_pct = v.number_or("min_ceiling_share_pct", t.min_ceiling_share_pct, {0.0, 100.0});
  t.max_startup_excursion_deg = v.number_or("max_startup_excursion_deg", t.max_startup_excursion_deg, {0.0, 90.0});
  t.max_startup_speed_degps = v.number_or("max_startup_speed_degps", t.max_startup_speed_degps, {0.0, 1000.0});
  v.finish();
  return t;
}

void Verdict::within(std::string figure, std::string unit, double value, double lower, double upper) {
  checks.push_back({std::move(figure), std::move(unit), value, upper, lower, Check::Rule::kWithin});
}

bool Verdict::passed() const noexcept {
  return !checks.empty() && std::all_of(checks.begin(), checks.end(), [](const Check& c) { return c.passed(); });
}

std::string Verdict::failures() const {
  std::string out;
  for (const Check& c : checks) {
    if (!c.passed()) out += c.describe() + "\n";
  }
  if (checks.empty()) out = "no figure was checked\n";
  return out;
}

void Envelope::observe(std::size_t joint, const JointSample& s) noexcept {
  Joint& j = joints[joint];
  // NaN never improves a peak and must fail the check: carried through as NaN.
  for (int m = 0; m < 2; ++m) {
    j.peak_muscle_force_N[m] = std::isnan(s.muscle_force_N[m]) ? s.muscle_force_N[m] : std::max(j.peak_muscle_force_N[m], s.muscle_force_N[m]);
  }
  // Every figure: a NaN sample makes the figure NaN for good (std::min/max would drop it).
  auto low = [](double& figure, double v) { figure = std::isnan(v) || std::isnan(figure) ? std::numeric_limits<double>::quiet_NaN() : std::min(figure, v); };
  auto high = [](double& figure, double v) { figure = std::isnan(v) || std::isnan(figure) ? std::numeric_limits<double>::quiet_NaN() : std::max(figure, v); };
  low(j.min_tension_N, s.min_tension_N);
  high(j.max_pressure_Pa, s.pressure_Pa[0]);
  high(j.max_pressure_Pa, s.pressure_Pa[1]);
  high(j.peak_motor_torque_Nm, std::abs(s.motor_torque_Nm));
  low(j.min_angle_rad, s.angle_rad);
  high(j.max_angle_rad, s.angle_rad);
  ++j.samples;
}

double Envelope::peak_muscle_force_N() const noexcept {
  double peak = 0.0;
  for (const Joint& j : joints) peak = std::max({peak, j.peak_muscle_force_N[0], j.peak_muscle_force_N[1]});
  return peak;
}

double Envelope::min_tension_N() const noexcept {
  double low = std::numeric_limits<double>::infinity();
  for (const Joint& j : joints) {
    if (j.samples) low = std::min(low, j.min_tension_N);
  }
  return low;
}

void add_envelope_checks(const LimitsModel& model, const JointModels& joints, const std::vector<std::string>& names,
                         const Envelope& envelope, const VerdictThresholds& thresholds, Verdict& v) {
  using models::kDegPerRad;
  for (int i = 0; i < model.joint_count; ++i) {
    const auto j = static_cast<std::size_t>(i);
    const models::JointModel& jm = *joints[j];
    const Envelope::Joint& e = envelope.joints[j];
    const std::string name = j < names.size() ? names[j] : fmt::format("joint {}", i);
    v.at_most(name + " agonist peak force", "N", e.peak_muscle_force_N[0], models::force_ceiling_N(jm.agonist));
    v.at_most(name + " antagonist peak force", "N", e.peak_muscle_force_N[1], models::force_ceiling_N(jm.antagonist));
    // Strictly above 0 as well: with a pretension of 0 a slack wire still fails.
    const bool slack_only = (thresholds.slack_check_only_joints >> j) & 1u;
    v.at_least(name + (slack_only ? " lowest wire tension (constant-pressure hold: slack check)" : " lowest wire tension"), "N",
               e.min_tension_N, slack_only ? 1e-9 : std::max(thresholds.min_tension_fraction * jm.pretension_N, 1e-9));
    v.at_most(name + " highest pressure", "MPa", e.max_pressure_Pa * 1e-6, jm.supply_pressure_Pa * 1e-6);
    v.at_most(name + " peak motor torque", "Nm", e.peak_motor_torque_Nm, (jm.has_motor ? jm.motor_max_torque_Nm : 0.0) + 1e-12);
    const JointLimits& lim = model.joints[j];
    v.within(name + " lowest angle", "deg", e.min_angle_rad * kDegPerRad, (lim.min_angle_rad - kRangeTolerance_rad) * kDegPerRad,
             (lim.max_angle_rad + kRangeTolerance_rad) * kDegPerRad);
    v.within(name + " highest angle", "deg", e.max_angle_rad * kDegPerRad, (lim.min_angle_rad - kRangeTolerance_rad) * kDegPerRad,
             (lim.max_angle_rad + kRangeTolerance_rad) * kDegPerRad);
  }
}

void add_supervisor_check(const FaultMonitor& monitor, Verdict& v) {
  const std::string reason = monitor.run_reason();
  v.at_most(monitor.count() ? "supervisor faults (first: " + reason + ")" : std::string("supervisor faults"), "",
            static_cast<double>(monitor.count()), 0.0);
}

void add_startup_checks(const std::string& joint, std::span<const double> angle_rad, double period_s, std::size_t end,
                        const VerdictThresholds& thresholds, Verdict& verdict) {
  if (angle_rad.empty()) return;
  end = std::min(end, angle_rad.size() - 1);
  const auto window = std::max<std::size_t>(1, static_cast<std::size_t>(std::llround(kStartupSpeedWindow_s / period_s)));
  double excursion_rad = 0, speed_radps = 0;
  for (std::size_t k = 0; k <= end; ++k) {
    excursion_rad = std::max(excursion_rad, std::abs(angle_rad[k] - angle_rad[0]));
    if (k >= window) speed_radps = std::max(speed_radps, std::abs(angle_rad[k] - angle_rad[k - window]) / (static_cast<double>(window) * period_s));
  }
  verdict.at_most(joint + " start-up excursion", "deg", models::rad_to_deg(excursion_rad), thresholds.max_startup_excursion_deg);
  verdict.at_most(joint + " start-up speed", "deg/s", models::rad_to_deg(speed_radps), thresholds.max_startup_speed_degps);
}

}  // namespace peha::safety
