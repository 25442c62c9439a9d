#include "peha/experiments/e6_bandwidth/bandwidth_report.hpp"

#include "peha/models/units.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <cmath>
#include <fstream>

namespace peha::experiments {

bool write_bandwidth_report(const std::filesystem::path& bode_csv, const std::vector<BandwidthResult>& results) {
  std::ofstream csv(bode_csv);
  csv << "variant,frequency_Hz,gain,gain_dB,phase_deg,gain_at_joint,gain_at_joint_dB,phase_at_joint_deg\n";
  fmt::print("\n{:>8}  {:>10} {:>10}   {:>10} {:>10}   | after the cable: {:>8} {:>9}   {:>8} {:>9}\n", "f/Hz", "PAM gain", "PAM phase",
             "hyb gain", "hyb phase", "PAM gain", "PAM phase", "hyb gain", "hyb phase");
  for (std::size_t i = 0; i < results[0].bode.size(); ++i) {
    const auto& p = results[0].bode[i];
    const auto& h = results[1].bode[i];
    const auto& pj = results[0].bode_at_joint[i];
    const auto& hj = results[1].bode_at_joint[i];
    fmt::print("{:>8.2f}  {:>10.3f} {:>9.1f}°   {:>10.3f} {:>9.1f}°   |                  {:>8.3f} {:>8.1f}°   {:>8.3f} {:>8.1f}°\n",
               p.frequency_Hz, p.gain, p.phase_deg, h.gain, h.phase_deg, pj.gain, pj.phase_deg, hj.gain, hj.phase_deg);
  }
  bool safe = true;
  // "> f": never fell below -3 dB up to the last frequency; "< f": below it already at the first.
  auto bound = [](const std::vector<BodePoint>& bode, bool reached) {
    return reached ? "" : bode.front().gain < 1.0 / std::sqrt(2.0) ? "< " : "> ";
  };
  for (const auto& r : results) {
    for (std::size_t i = 0; i < r.bode.size(); ++i) {
      const BodePoint& p = r.bode[i];
      const BodePoint& j = r.bode_at_joint[i];
      csv << fmt::format("{},{:.4g},{:.6g},{:.4f},{:.3f},{:.6g},{:.4f},{:.3f}\n", r.variant, p.frequency_Hz, p.gain, 20 * std::log10(p.gain),
                         p.phase_deg, j.gain, 20 * std::log10(j.gain), j.phase_deg);
    }
    // The one verdict (each muscle's own ceiling, the tension floor, supply, motor rating, range).
    safe = safe && r.within_limits;
    fmt::print("{:<9} -3 dB bandwidth {}{:.2f} Hz (at the joint, after the cable: {}{:.2f} Hz); peak muscle force {:.0f} N, "
               "min wire tension {:.1f} N, peak motor {:.2f} Nm: {}\n{}",
               r.variant, bound(r.bode, r.reached_3dB), r.bandwidth_3dB_Hz, bound(r.bode_at_joint, r.reached_3dB_at_joint),
               r.bandwidth_3dB_at_joint_Hz,
               r.peak_muscle_force_N, r.min_wire_tension_N, r.peak_motor_torque_Nm, r.within_limits ? "OK" : "VIOLATED",
               r.verdict.failures());
  }
  return safe;
}

int run_bandwidth_experiment(const config::Document& doc, const ArmScenario& scenario, const RunRequest& request) {
  if (scenario.bandwidth.frequencies_Hz.empty()) {
    fmt::print(stderr, "error: {} has no bandwidth: section (E6's joint, posture and sweep; docs/right-arm.md)\n", doc.name());
    return 2;
  }
  const std::filesystem::path dir = request.open_run_dir(scenario.seed);
  const auto& b = scenario.bandwidth;
  std::vector<std::string> locked;
  for (std::size_t i = 0; i < b.locked_rad.size(); ++i) {
    if (!std::isnan(b.locked_rad[i])) locked.push_back(fmt::format("{} {:.0f}", arm_joint_names(scenario)[i], models::rad_to_deg(b.locked_rad[i])));
  }
  fmt::print("peha run: {} --experiment bandwidth (E6)\n  {} swept; locked at {} deg; gravity torque "
             "+ {:.1f} Nm sine at {} frequencies, PAM-only and hybrid\n",
             doc.name(), arm_joint_names(scenario)[static_cast<std::size_t>(b.joint)], fmt::join(locked, ", "), b.amplitude_Nm,
             b.frequencies_Hz.size());
  std::vector<BandwidthResult> results;
  for (bool hybrid : {false, true}) results.push_back(run_bandwidth(scenario, hybrid));
  const bool safe = write_bandwidth_report(dir / "bode.csv", results);  // closed: the plotter reads it next
  if (request.plot) plot_with("plot_bode.py", dir);
  fmt::print("written: {}/bode.csv, config.yaml\n", dir.string());
  return safe ? 0 : 3;
}

}  // namespace peha::experiments
