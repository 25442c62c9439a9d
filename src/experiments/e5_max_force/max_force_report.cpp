#include "peha/experiments/e5_max_force/max_force_report.hpp"
#include "peha/experiments/e5_max_force/max_force_realtime.hpp"

#include <fmt/format.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <optional>

namespace peha::experiments {

void write_e5_summary(const std::filesystem::path& path, const std::vector<E5Result>& results) {
  std::ofstream out(path);
  out << "case,muscle,locked_angle_deg,limit_N,peak_force_N,overshoot_N,overshoot_pct,max_overshoot_N,held_force_N,shortfall_N,"
         "max_shortfall_N,peak_truth_force_N,"
         "reach_s,settle_s,max_settle_s,time_at_limit_s,min_time_at_limit_s,at_limit_band_N,pressure_at_limit_MPa,"
         "pressure_cmd_at_limit_MPa,ceiling_share_pct,min_ceiling_share_pct,stop,max_clamp_deflection_deg,from_truth,"
         "missed_samples,passed,failed_checks\n";
  for (const auto& r : results) {
    const safety::VerdictThresholds& t = r.verdict.thresholds;
    std::size_t failed = 0;
    for (const auto& c : r.verdict.checks) failed += !c.passed();
    out << fmt::format("{},{},{:.2f},{:.1f},{:.2f},{:.2f},{:.3f},{:.1f},{:.2f},{:.2f},{:.1f},{:.2f},{:.3f},{:.3f},{:.3f},{:.3f},{:.3f},{:.1f},{:.4f},{:.4f},"
                       "{:.2f},{:.1f},\"{}\",{:.4f},{},{},{},{}\n",
                       r.case_name, r.muscle, r.locked_angle_deg, r.limit_N, r.peak_force_N, r.overshoot_N, r.overshoot_pct,
                       t.max_force_overshoot_N, r.held_force_N, r.shortfall_N, t.max_force_shortfall_N, r.peak_truth_force_N, r.reach_s, r.settle_s, t.max_settle_s, r.time_at_limit_s,
                       t.min_time_at_limit_s, t.at_limit_band_N, r.pressure_at_limit_MPa, r.pressure_cmd_at_limit_MPa,
                       r.ceiling_share_pct, t.min_ceiling_share_pct, to_string(r.stop), r.max_clamp_deflection_deg,
                       r.from_truth ? 1 : 0, r.missed_samples, r.passed ? 1 : 0, failed);
  }
}

bool print_e5_table(const std::vector<E5Result>& results) {
  bool all = true;
  fmt::print("\n{:<20} {:>9} {:>9} {:>14} {:>9} {:>9} {:>10} {:>9}  {}\n", "case", "limit N", "peak N", "overshoot", "reach s",
             "settle s", "at limit s", "P MPa", "verdict");
  for (const auto& r : results) {
    all = all && r.passed;
    fmt::print("{:<20} {:>9.0f} {:>9.1f} {:>7.1f} N {:>4.2f}% {:>9.2f} {:>9.3f} {:>10.2f} {:>9.3f}  {}\n", r.case_name, r.limit_N,
               r.peak_force_N, r.overshoot_N, r.overshoot_pct, r.reach_s, r.settle_s, r.time_at_limit_s, r.pressure_at_limit_MPa,
               r.passed ? "OK" : "FAIL");
    fmt::print("{:<20} held at {:.1f} N ({:.1f} N short of the ceiling); stopped by: {} ({:.1f} % of the held cycles); peak plant "
               "force {:.1f} N; clamp moved {:.3f} deg\n", "", r.held_force_N, r.shortfall_N,
               to_string(r.stop), r.ceiling_share_pct, r.peak_truth_force_N, r.max_clamp_deflection_deg);
    std::string lines = r.verdict.describe_all();
    fmt::print("{}", lines);
  }
  return all;
}

}  // namespace peha::experiments
