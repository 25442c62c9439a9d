#include "peha/experiments/e1_gravity/e1_report.hpp"

#include "peha/calibration/calibration_file.hpp"
#include "peha/experiments/e1_gravity/e1_realtime.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <optional>
#include <utility>

namespace peha::experiments {

std::vector<E1Variant> e1_variants(const E1Scenario& scenario, const std::filesystem::path calibration[2]) {
  std::vector<E1Variant> variants;
  const bool calibrated = !calibration[0].empty() || !calibration[1].empty();
  if (!calibrated) {
    variants.push_back({"", scenario});
  } else {
    E1Scenario parametric = scenario;
    use_calibration_loadcell_zero(parametric);
    E1Scenario with_spgp = parametric;
    bool any_spgp = false;
    for (int i = 0; i < 2; ++i) {
      if (calibration[i].empty()) continue;
      const calibration::MuscleCalibration c = calibration::read_calibration(calibration[i]);
      const safety::JointLimits& range = scenario.limits.joints[0];
      calibration::apply_calibration(c, calibration[i], false, parametric.controller.joint, i, range.min_angle_rad, range.max_angle_rad);
      calibration::apply_calibration(c, calibration[i], true, with_spgp.controller.joint, i, range.min_angle_rad, range.max_angle_rad);
      any_spgp = any_spgp || c.spgp;
      fmt::print("  {} calibration: {} (held-out pressure RMS {:.1f} kPa parametric, {:.1f} kPa with SPGP)\n",
                 i == 0 ? "agonist" : "antagonist", calibration[i].string(),
                 c.stats.heldout_rms_parametric_Pa * 1e-3, c.stats.heldout_rms_spgp_Pa * 1e-3);
    }
    if (scenario.controller.allocation.loadcell_check.tare_s > 0.0) {
      fmt::print("  start-up tare off: the calibrations fix the load cells' zero (their forces are raw load-cell readings)\n");
    }
    variants.push_back({"parametric", parametric});
    if (any_spgp) variants.push_back({"spgp", with_spgp});
  }
  return variants;
}

void write_e1_summary(const std::filesystem::path& path, const std::vector<E1Result>& results) {
  std::ofstream out(path);
  out << "case,payload_kg,release,release_time_s,angle_at_release_deg,drift_deg,max_drift_deg,max_excursion_deg,"
         "stop_distance_deg,stop_margin_deg,gravity_torque_Nm,static_torque_error_Nm,static_torque_error_pct,"
         "max_static_torque_error_pct,peak_finger_force_N,peak_agonist_force_N,agonist_ceiling_N,"
         "peak_antagonist_force_N,antagonist_ceiling_N,min_wire_tension_N,min_wire_tension_limit_N,"
         "max_pressure_MPa,peak_motor_torque_Nm,min_angle_deg,max_angle_deg,breakaway_up_N,breakaway_down_N,"
         "breakaway_static_error_pct,truth_static_error_at_probes_pct,within_limits,failed_checks,"
         "force_tracking_rms_agonist_N,force_tracking_rms_antagonist_N,realtime_factor\n";
  const double nan = std::numeric_limits<double>::quiet_NaN();
  auto limit_of = [](const E1Result& r, const std::string& figure) {
    const safety::Check* c = r.verdict.find(figure);
    return c ? c->limit : std::numeric_limits<double>::quiet_NaN();
  };
  for (const auto& r : results) {
    std::size_t failed = 0;
    for (const auto& c : r.verdict.checks) failed += !c.passed();
    const E1Breakaway& b = r.breakaway;
    for (const auto& rel : r.releases) {
      out << fmt::format("{},{},{},{:.3f},{:.3f},{:.4f},{:.3g},{:.4f},{:.3f},{:.3g},{:.4f},{:.4f},{:.3f},{:.3g},{:.2f},{:.1f},{:.0f},"
                         "{:.1f},{:.0f},{:.2f},{:.2f},{:.4f},{:.3f},{:.2f},{:.2f},{:.2f},{:.2f},{:.3f},{:.3f},{},{},{:.2f},{:.2f},{:.2f}\n",
                         r.case_name, r.payload_kg, rel.push, rel.time_s, rel.angle_deg, rel.drift_deg,
                         r.verdict.thresholds.max_drift_deg, rel.max_excursion_deg, rel.stop_distance_deg,
                         r.verdict.thresholds.stop_margin_deg, rel.gravity_torque_Nm, rel.static_torque_error_Nm,
                         rel.static_torque_error_pct, r.verdict.thresholds.max_static_torque_error_pct,
                         r.peak_finger_force_N, r.peak_muscle_force_N[0], limit_of(r, "joint agonist peak force"),
                         r.peak_muscle_force_N[1], limit_of(r, "joint antagonist peak force"), r.min_wire_tension_N,
                         limit_of(r, "joint lowest wire tension"), r.max_pressure_MPa, r.peak_motor_torque_Nm,
                         r.min_angle_deg, r.max_angle_deg, b.measured || b.force_up_N > 0 ? b.force_up_N : nan,
                         b.measured || b.force_down_N > 0 ? b.force_down_N : nan, b.measured ? b.torque_error_pct : nan,
                         b.measured ? b.truth_error_pct : nan, r.within_limits ? 1 : 0, failed,
                         r.force_tracking_rms_N[0], r.force_tracking_rms_N[1], r.realtime_factor);
    }
  }
}

bool print_e1_table(const std::vector<E1Result>& results) {
  if (!results.empty()) {
    const safety::VerdictThresholds& t = results.front().verdict.thresholds;
    fmt::print("\nverdict thresholds (verdict: section): |drift| <= {} deg, >= {} deg from a stop, |static torque error| <= {} % "
               "of the plant's gravity torque, lowest wire tension >= {} x pretension, each muscle's own force ceiling\n",
               t.max_drift_deg, t.stop_margin_deg, t.max_static_torque_error_pct, t.min_tension_fraction);
  }
  fmt::print("\n{:<26} {:<10} {:>9} {:>10} {:>11} {:>9} {:>10} {:>9} {:>8} {:>8} {:>8} {:>9} {:>9} {:>6}\n", "case", "release",
             "angle/deg", "drift/deg", "excurs/deg", "stop/deg", "tau_err/%", "finger/N", "F_ago/N", "F_ant/N", "T_min/N",
             "Ftrk_ago", "Ftrk_ant", "RTF");
  bool safe = true;
  for (const auto& r : results) {
    for (const auto& rel : r.releases) {
      fmt::print("{:<26} {:<10} {:>9.2f} {:>10.3f} {:>11.3f} {:>9.1f} {:>10.2f} {:>9.1f} {:>8.1f} {:>8.1f} {:>8.2f} {:>8.1f}N {:>8.1f}N {:>6.1f}\n",
                 r.case_name, rel.push, rel.angle_deg, rel.drift_deg, rel.max_excursion_deg, rel.stop_distance_deg,
                 rel.static_torque_error_pct, r.peak_finger_force_N, r.peak_muscle_force_N[0], r.peak_muscle_force_N[1],
                 r.min_wire_tension_N, r.force_tracking_rms_N[0], r.force_tracking_rms_N[1], r.realtime_factor);
    }
    safe = safe && r.within_limits;
    auto limit_of = [&](const std::string& figure) {
      const safety::Check* c = r.verdict.find(figure);
      return c ? c->limit : std::numeric_limits<double>::quiet_NaN();
    };
    auto figure_of = [&](const std::string& figure) {
      const safety::Check* c = r.verdict.find(figure);
      return c ? c->value : std::numeric_limits<double>::quiet_NaN();
    };
    if (r.breakaway.measured) {
      const E1Breakaway& b = r.breakaway;
      fmt::print("{:<26} breakaway (hardware figure): finger {:.1f} N up, {:.1f} N down -> friction band {:.2f} Nm, "
                 "static torque error {:+.2f} Nm = {:+.1f} % of gravity (plant truth before the probes {:+.1f} %)\n",
                 "", b.force_up_N, b.force_down_N, b.friction_band_Nm, b.torque_error_Nm, b.torque_error_pct, b.truth_error_pct);
    } else if (r.breakaway.force_up_N > 0 || r.breakaway.force_down_N > 0) {
      fmt::print("{:<26} breakaway: the link did not break away in one of the probes (up {:.1f} N, down {:.1f} N)\n", "",
                 r.breakaway.force_up_N, r.breakaway.force_down_N);
    }
    if (r.tare_slack_s > 0) {
      fmt::print("{:<26} start-up: load-cell offsets {:+.1f} N (agonist), {:+.1f} N (antagonist) subtracted; wires slack on purpose "
                 "(vented, the link on its support) until {:.2f} s, their tension judged from then on; the link moved {:.2f} deg "
                 "(<= {:g}), at most {:.1f} deg/s (<= {:g})\n",
                 "", r.loadcell_tare_N[0], r.loadcell_tare_N[1], r.tare_slack_s, figure_of("joint start-up excursion"),
                 r.verdict.thresholds.max_startup_excursion_deg, figure_of("joint start-up speed"), r.verdict.thresholds.max_startup_speed_degps);
    }
    fmt::print("{:<26} safety: peak agonist force {:.0f} N (limit {:.0f}), peak antagonist force {:.0f} N (limit {:.0f}), "
               "min wire tension {:.2f} N (>= {:.1f}), max pressure {:.3f} MPa, peak motor {:.2f} Nm, angle {:.1f}..{:.1f} deg: {}\n",
               "", r.peak_muscle_force_N[0], limit_of("joint agonist peak force"), r.peak_muscle_force_N[1],
               limit_of("joint antagonist peak force"), r.min_wire_tension_N, limit_of("joint lowest wire tension"),
               r.max_pressure_MPa, r.peak_motor_torque_Nm, r.min_angle_deg, r.max_angle_deg,
               r.within_limits ? "OK" : "VIOLATED");
    if (!r.within_limits) {
      std::string failures = r.verdict.failures();
      for (std::size_t at = 0; (at = failures.find('\n', at)) != std::string::npos && at + 1 < failures.size(); at += 1) {
        failures.replace(at, 1, "\n" + std::string(27, ' ') + "FAIL ");
        at += 28;
      }
      fmt::print("{:<26} FAIL {}", "", failures);
    }
    fmt::print("{:<26} limits layer shaped the command in: pressure band {} cycles, rate {}, joint range {}, "
               "motor rating {}, non-finite {}\n",
               "", r.limit_counts[2], r.limit_counts[3], r.limit_counts[1], r.limit_counts[4], r.limit_counts[0]);
  }
  return safe;
}

}  // namespace peha::experiments
