#pragma once
// E1-like in-process runs and the figures that tell a stable controller from a broken one (issue
// 10): drift and settling after each release, any run toward a stop, the static torque error at
// rest from the plant's truth, and the lowest wire tension. Shared by the Bowden-stability and the
// load-cell tests.
#include "peha/experiments/e1_gravity/e1_gravity.hpp"
#include "peha/models/units.hpp"

#include <algorithm>
#include <array>
#include <cstdio>
#include <cmath>
#include <limits>
#include <span>
#include <string>
#include <vector>

namespace peha::testing {

/// Keeps every row of an E1 log.
class KeepRows final : public runtime::RowSink {
 public:
  void push_row(std::span<const double> row) noexcept override { rows.emplace_back(row.begin(), row.end()); }
  std::vector<std::vector<double>> rows;
};

struct E1Figures {
  double worst_drift_deg = 0;          ///< largest |drift| over the releases
  double worst_static_error_pct = 0;   ///< largest |torque the friction/constraint holds at rest| / gravity torque
  bool settled = true;                 ///< at rest (angle range < 0.02 deg) over the last 0.5 s of every release window
  double min_tension_N = 0;            ///< lowest wire tension anywhere (plant truth), over the whole run
  double min_tension_after_start_N = 0;  ///< the same from the end of the first push (E1's start-up hold) on
  double max_abs_angle_deg = 0;        ///< farthest the link went from horizontal (plant truth)
  /// Largest swing back after a release: in each release window, how far the link came back from
  /// the farthest point it had reached in either direction (0 for a monotone drift), deg.
  double worst_swing_back_deg = 0;
  double max_speed_after_release_radps = 0;  ///< fastest the link moved in a release window (plant truth)
  bool verdict_passed = false;         ///< E1's own verdict
  /// Largest |load cell - pressure model at the measured pressure| / the check's tolerance over the
  /// run after its first second, agonist and antagonist (unfiltered; the check low-passes it).
  double worst_disagreement[2] = {0, 0};
};

inline std::string describe(const E1Figures& f) {
  char buffer[512];
  std::snprintf(buffer, sizeof buffer,
                "drift %.3f deg, static error %.1f %%, settled %d, min tension %.1f N (after start-up %.1f N), max |angle| %.1f deg, "
                "swing back %.2f deg, max speed %.3f rad/s, verdict %s, load cell vs model %.2f / %.2f of the tolerance",
                f.worst_drift_deg, f.worst_static_error_pct, f.settled ? 1 : 0, f.min_tension_N, f.min_tension_after_start_N,
                f.max_abs_angle_deg, f.worst_swing_back_deg, f.max_speed_after_release_radps, f.verdict_passed ? "OK" : "FAIL",
                f.worst_disagreement[0], f.worst_disagreement[1]);
  return buffer;
}

/// Runs one E1 case in-process and measures its figures from the plant's truth.
inline E1Figures run_e1_figures(const experiments::E1Scenario& scenario, const experiments::E1Case& c) {
  KeepRows log;
  const experiments::E1Result r = experiments::run_e1_case(scenario, c, &log);
  const auto& columns = experiments::e1_log_columns();
  auto column = [&](const char* name) {
    return static_cast<std::size_t>(std::find(columns.begin(), columns.end(), name) - columns.begin());
  };
  const std::size_t t_col = column("t_s"), angle_col = column("plant_angle_rad"), constraint_col = column("plant_constraint_Nm");
  const std::size_t tension_col[2] = {column("plant_agonist_tension_N"), column("plant_antagonist_tension_N")};
  const control::OneDofControllerModel model = experiments::e1_controller_model(scenario, c);

  E1Figures f;
  f.min_tension_N = r.min_wire_tension_N;
  f.max_abs_angle_deg = std::max(std::abs(r.min_angle_deg), std::abs(r.max_angle_deg));
  f.verdict_passed = r.verdict.passed();
  const std::size_t lc_col[2] = {column("agonist_loadcell_N"), column("antagonist_loadcell_N")};
  const std::size_t p_col[2] = {column("agonist_pressure_MPa"), column("antagonist_pressure_MPa")};
  const std::size_t encoder_col = column("angle_rad");
  const control::LoadcellCheck& check = model.allocation.loadcell_check;
  for (const auto& row : log.rows) {
    if (row[t_col] < 1.0) continue;
    for (int i = 0; i < 2; ++i) {
      const models::MuscleModel& m = i == 0 ? model.joint.agonist : model.joint.antagonist;
      const double eps = models::rigid_contraction(m, model.joint.pulley_radius_m, i == 0 ? 1 : -1, row[encoder_col]);
      const double f_model = models::forward_force_N(m.pam, row[p_col[i]] * 1e6, eps);
      const double tolerance = check.tolerance_N + check.tolerance_fraction * f_model;
      f.worst_disagreement[i] = std::max(f.worst_disagreement[i], std::abs(row[lc_col[i]] - f_model) / tolerance);
    }
  }
  for (const auto& rel : r.releases) f.worst_drift_deg = std::max(f.worst_drift_deg, std::abs(rel.drift_deg));

  const auto& pushes = scenario.plant.finger.pushes;
  f.min_tension_after_start_N = std::numeric_limits<double>::infinity();
  for (const auto& row : log.rows) {
    if (row[t_col] < pushes.front().start_s + pushes.front().duration_s) continue;
    f.min_tension_after_start_N = std::min({f.min_tension_after_start_N, row[tension_col[0]], row[tension_col[1]]});
  }
  for (std::size_t i = 0; i < pushes.size(); ++i) {
    const double released_s = pushes[i].start_s + pushes[i].duration_s;
    double end_s = std::min(released_s + scenario.drift_window_s, scenario.duration_s);
    if (i + 1 < pushes.size()) end_s = std::min(end_s, pushes[i + 1].start_s);
    double lowest = 1e9, highest = -1e9, constraint_sum = 0, gravity_sum = 0;
    int n = 0;
    double window_min = 1e9, window_max = -1e9, previous_angle = std::numeric_limits<double>::quiet_NaN(), previous_t = 0;
    for (const auto& row : log.rows) {
      const double t = row[t_col];
      if (t >= released_s && t < end_s) {
        const double a = row[angle_col];
        window_min = std::min(window_min, a);
        window_max = std::max(window_max, a);
        f.worst_swing_back_deg = std::max(f.worst_swing_back_deg, models::rad_to_deg(std::min(window_max - a, a - window_min)));
        if (!std::isnan(previous_angle) && t > previous_t) {
          f.max_speed_after_release_radps = std::max(f.max_speed_after_release_radps, std::abs(a - previous_angle) / (t - previous_t));
        }
        previous_angle = a;
        previous_t = t;
      }
      if (t < end_s - 0.5 || t >= end_s) continue;
      lowest = std::min(lowest, row[angle_col]);
      highest = std::max(highest, row[angle_col]);
      constraint_sum += row[constraint_col];
      gravity_sum += control::gravity_torque_Nm(model.gravity, row[angle_col]);
      ++n;
    }
    if (n == 0) continue;
    if (models::rad_to_deg(highest - lowest) > 0.02) f.settled = false;
    f.worst_static_error_pct = std::max(f.worst_static_error_pct, 100.0 * std::abs(constraint_sum / gravity_sum));
  }
  return f;
}

/// The shipped E1 scenario.
inline experiments::E1Scenario e1_scenario() {
  return experiments::read_e1(config::Document::load_file(PEHA_SOURCE_DIR "/configs/e1_one_dof.yaml"));
}

/// Scales both cables' kinetic and static friction of the plant (never the controller's model).
inline void scale_plant_cable_friction(experiments::E1Scenario& s, double factor) {
  for (sim::MusclePlantParams* m : {&s.plant.joint.agonist, &s.plant.joint.antagonist}) {
    m->cable.kinetic_friction *= factor;
    m->cable.static_friction *= factor;
  }
}

}  // namespace peha::testing
