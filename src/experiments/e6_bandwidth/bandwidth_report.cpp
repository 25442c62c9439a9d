#include "peha/experiments/e6_bandwidth/bandwidth_report.hpp"

#include "peha/experiments/arm/arm_contract.hpp"
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
    const PassBand& band = r.pass_band_at_joint;
    const std::string at_joint = band.empty() ? std::string("none")
                                              : fmt::format("{}{:.2f} to {}{:.2f} Hz", band.open_low ? "< " : "", band.low_Hz,
                                                            band.open_high ? "> " : "", band.high_Hz);
    fmt::print("{:<9} -3 dB bandwidth {}{:.2f} Hz (at the joint, after the cable: {}{:.2f} Hz; -3 dB band {}); peak muscle force {:.0f} N, "
               "min wire tension {:.1f} N, peak motor {:.2f} Nm: {}\n{}",
               r.variant, bound(r.bode, r.reached_3dB), r.bandwidth_3dB_Hz, bound(r.bode_at_joint, r.reached_3dB_at_joint),
               r.bandwidth_3dB_at_joint_Hz, at_joint,
               r.peak_muscle_force_N, r.min_wire_tension_N, r.peak_motor_torque_Nm, r.within_limits ? "OK" : "VIOLATED",
               r.verdict.failures());
  }
  return safe;
}

namespace {

/// E6: the joint's torque sweep, PAM-only and hybrid, in process only.
class BandwidthJob final : public ExperimentRun {
 public:
  BandwidthJob(const config::Document& doc, const RunRequest& request)
      : scenario_(arm_scenario_for_run(doc, request, "E6 (bandwidth)", false)), doc_name_(doc.name()) {
    if (scenario_.bandwidth.frequencies_Hz.empty()) {
      throw RequestError(fmt::format("{} has no bandwidth: section (E6's joint, posture and sweep; docs/right-arm.md)", doc.name()));
    }
  }

  std::uint64_t seed() const override { return scenario_.seed; }
  const mfb::LinkConfig* link() const override { return nullptr; }  // in process only
  std::vector<std::string> case_names() const override { return {}; }

  void print_header(const RunContext& ctx, const std::vector<std::size_t>&) const override {
    const auto& b = scenario_.bandwidth;
    std::vector<std::string> locked;
    for (std::size_t i = 0; i < b.locked_rad.size(); ++i) {
      if (!std::isnan(b.locked_rad[i])) locked.push_back(fmt::format("{} {:.0f}", arm_joint_names(scenario_)[i], models::rad_to_deg(b.locked_rad[i])));
    }
    fmt::print("peha run: {} --experiment bandwidth (E6), output {}\n  {} swept; locked at {} deg; gravity torque "
               "+ {:.1f} Nm sine at {} frequencies, PAM-only and hybrid\n",
               doc_name_, ctx.shown_dir().string(), arm_joint_names(scenario_)[static_cast<std::size_t>(b.joint)], fmt::join(locked, ", "),
               b.amplitude_Nm, b.frequencies_Hz.size());
  }

  void run_case(std::size_t, const RunContext&) override {
    for (bool hybrid : {false, true}) results_.push_back(run_bandwidth(scenario_, hybrid));
  }

  Conclusion conclude(const RunContext& ctx) override {
    write_bandwidth_report(ctx.dir / "bode.csv", results_);  // closed: the plotter reads it next
    Conclusion c{0, "bode.csv, config.yaml", "plot_bode.py", {}, 0, {}};
    for (const BandwidthResult& r : results_) c.failed_figures += failed_figures(r.verdict);
    return c;
  }

 private:
  ArmScenario scenario_;
  std::string doc_name_;
  std::vector<BandwidthResult> results_;
};

}  // namespace

std::unique_ptr<ExperimentRun> make_bandwidth_run(const config::Document& doc, const RunRequest& request) {
  return std::make_unique<BandwidthJob>(doc, request);
}

}  // namespace peha::experiments
