// `peha identify-gravity`: an arm's (or the upper body's) gravity parameters identified by the rig procedure.
#include "peha/app/cli_checks.hpp"
#include "peha/app/commands.hpp"
#include "peha/app/hardware_flags.hpp"
#include "peha/calibration/gravity_identification.hpp"
#include "peha/experiments/arm_identification/arm_identification.hpp"
#include "peha/models/units.hpp"

#include <fmt/format.h>

#include <algorithm>

namespace peha::app {

int identify_gravity(const IdentifyGravityOptions& options) {
  return with_exit_codes([&] {
    const config::Document doc = config::Document::load_file(options.config);
    experiments::ArmScenario scenario = experiments::read_arm_scenario(doc);
    std::vector<std::filesystem::path> inputs = scenario_inputs(options.config);
    inputs.push_back(scenario.gravity_identification_file);
    refuse_unsafe_output(options.out, inputs);
    if (!scenario.faults.empty()) {
      fmt::print(stderr, "config error: {}: its faults: list is injected in E3 and E4 (--experiment postures, goniometer) only, not in the "
                         "identification: remove it for this run\n", options.config.string());
      return 2;
    }
    if (!scenario.identification) {
      fmt::print(stderr, "config error: {}: no identification: section (the postures to identify on)\n", options.config.string());
      return 2;
    }
    if (options.seed) scenario.plant.seed = scenario.seed = *options.seed;
    const auto& id = *scenario.identification;
    std::string swept;
    for (const std::size_t i : id.joints) swept += (swept.empty() ? "" : " ") + scenario.plant.actuated[i];
    fmt::print("peha identify-gravity: {} ({} postures, each swept up and down over +-{:.1f} deg at {:.1f} deg/s on {}; prior: the body "
               "file's arm model{})\n",
               options.config.string(), id.postures.size(), id.sweep_rad * models::kDegPerRad, id.sweep_speed_radps * models::kDegPerRad, swept,
               scenario.gravity_identification_file.empty() ? std::string()
                                                            : ", not " + scenario.gravity_identification_file.string() + " (the config's)");
    std::optional<experiments::HardwareRunOptions> hw =
        procedure_hardware(options.hardware, options.config, scenario.link, "the procedure moves the arm", options.out);
    if (!hw) return 2;
    const bool on_board = hw->backend.kind == hardware::BackendKind::kBoards;
    const auto progress = [](const std::string& line) { fmt::print("  {}\n", line); };
    experiments::ArmIdentificationResult r;
    try {
      if (on_board) {
        // The board's per-cycle log and timing go beside the identification file, which is written only after a clean run.
        fmt::print("  on {} in real time\n", hw->backend.describe());
        const experiments::ArmScenario procedure = experiments::identification_scenario(scenario);
        const experiments::IdentificationRealtimeResult rr = experiments::record_identification_realtime(
            procedure, *hw, std::filesystem::path(options.out).replace_extension(".cycles.csv"), progress);
        experiments::print_realtime(rr, hw->dir / "timing_identification");
        if (!rr.verdict.passed()) {
          fmt::print(stderr, "error: the identification run faulted ({}): its torques are not the controller's; {} not written\n",
                     rr.verdict.failures(), options.out.string());
          return 3;
        }
        r = experiments::fit_identification(procedure, rr.recording);
      } else {
        r = experiments::identify_arm_gravity(scenario, scenario.plant, progress);
      }
    } catch (const calibration::GravityIdentificationRejected& e) {
      fmt::print(stderr, "{}; {} not written\n", e.what(), options.out.string());
      return 2;
    }
    const calibration::GravityIdentification& f = r.fit;
    fmt::print("  {:<16} {:<8} {:>10} {:>10} {:>10} {:>19} {:>9} {:>8}\n", "posture", "joint", "measured", "identified", "nominal",
               "up / down *", "capstan k", "slowest");
    for (std::size_t i = 0; i < r.measurements.size(); ++i) {
      const auto& m = r.measurements[i];
      const auto k = static_cast<Eigen::Index>(i);
      for (std::size_t j = 0; j < m.joints.size(); ++j) {
        const experiments::IdentificationJoint& mj = m.joints[j];
        const auto e = static_cast<Eigen::Index>(j);
        fmt::print("  {:<16} {:<8} {:>7.3f} Nm {:>7.3f} Nm {:>7.3f} Nm {:>7.3f} / {:>7.3f} Nm {:>9.3f} {:>6.0f} %\n", j == 0 ? m.name : "",
                   r.joint_names[j], mj.tau_mean_Nm, f.predicted_Nm(k, e), f.prior_Nm(k, e), mj.tau_Nm[0], mj.tau_Nm[1], mj.friction_ratio,
                   100 * std::min(mj.speed_fraction[0], mj.speed_fraction[1]));
      }
    }
    fmt::print("  * muscle side: r0 (F_agonist - F_antagonist) + motor while sweeping up / down; their difference is the cables' friction; "
               "slowest: the joint's lowest mean speed in a window, of the reference's\n");
    fmt::print("fit: {} rows, {} identified directions, residual RMS {:.3f} Nm (max {:.3f}); the nominal model's RMS {:.3f} Nm; "
               "largest change vs nominal {:.1f} %\n",
               f.rows, f.rank, f.residual_rms_Nm, f.residual_max_Nm, f.prior_rms_Nm, 100 * f.max_change_fraction);
    std::string sv;
    for (Eigen::Index i = 0; i < f.singular_values.size(); ++i) sv += fmt::format(" {:.3g}", f.singular_values[i]);
    fmt::print("  singular values of the scaled regressor:{} (identified: >= {:.3g} x the largest)\n", sv,
               scenario.identification->rank_tolerance);
    for (std::size_t k = 0; k < f.names.size(); ++k) {
      const auto i = static_cast<Eigen::Index>(k);
      if (f.std[i] <= 0 && f.theta[i] == f.prior[i]) continue;  // not seen by the data: the nominal value stays
      fmt::print("  {:<16} {:>9.4f} +- {:.4f} (nominal {:.4f})\n", f.names[k], f.theta[i], f.std[i], f.prior[i]);
    }
    if (options.out.has_parent_path()) std::filesystem::create_directories(options.out.parent_path());
    calibration::write_gravity_identification(
        options.out, scenario.nominal_arm, r.samples, f,
        fmt::format("peha identify-gravity --config {} seed {} ({:.0f} s on the rig)", options.config.string(), scenario.seed, r.duration_s));
    fmt::print("written: {} (use: peha run --config {} --gravity-identification {})\n", options.out.string(), options.config.string(),
               options.out.string());
    return 0;
  });
}

}  // namespace peha::app
