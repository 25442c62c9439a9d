// `peha check-sensors`: the one-DOF rig's sensor check on the simulated rig, written as the
// corrections file an E1 scenario loads.
#include "peha/app/cli_checks.hpp"
#include "peha/app/commands.hpp"
#include "peha/calibration/sensor_corrections.hpp"
#include "peha/experiments/sensor_check/sensor_check.hpp"
#include "peha/models/units.hpp"

#include <fmt/format.h>

#include <memory>
#include <vector>

namespace peha::app {

int check_sensors(const CheckSensorsOptions& options) {
  return with_exit_codes([&] {
    const config::Document doc = config::Document::load_file(options.config);
    const std::vector<std::filesystem::path> inputs = scenario_inputs(options.config);
    refuse_unsafe_output(options.out, inputs);
    // Each run's per-cycle log beside the file: <out>.run<k>.csv; none may replace what the scenario reads.
    auto log_path = [&](int k) { return std::filesystem::path(options.out).replace_extension(fmt::format(".run{}.csv", k)); };
    for (int k = 0; k < 2; ++k) refuse_unsafe_output(log_path(k), inputs, "--out (its .run<k>.csv)");
    experiments::E1Scenario scenario = experiments::read_e1(doc);
    if (!scenario.sensor_check) {
      fmt::print(stderr, "config error: {}: no sensor_check: section (the procedure to run)\n", doc.name());
      return 2;
    }
    experiments::SensorCheckParams params = *scenario.sensor_check;
    const double placed_kg = params.known_mass_kg;  // the simulated rig carries the section's mass
    if (options.known_mass_kg) params.known_mass_kg = *options.known_mass_kg;
    if (options.lever_m) params.lever_m = *options.lever_m;
    sim::OneDofRigParams plant = scenario.plant;
    if (options.seed) plant.seed = *options.seed;
    fmt::print("peha check-sensors: {} on the simulated rig: known mass {} kg at {} m, swept +-{:.1f} deg around {:.1f} deg at {:.1f} deg/s, "
               "2 runs of {:.1f} s\n",
               options.config.string(), params.known_mass_kg, params.lever_m, models::rad_to_deg(params.sweep_rad),
               models::rad_to_deg(params.check_angle_rad), models::rad_to_deg(params.sweep_speed_radps), params.duration_s());
    experiments::SensorCheckResult r;
    const auto rows = static_cast<std::size_t>(params.duration_s() / scenario.period_s) + 2;
    std::vector<std::unique_ptr<runtime::CsvLog>> logs;
    for (int k = 0; k < 2; ++k) logs.push_back(std::make_unique<runtime::CsvLog>(experiments::sensor_check_log_columns(), rows));
    if (options.out.has_parent_path()) std::filesystem::create_directories(options.out.parent_path());
    try {
      r = experiments::check_sensors(
          scenario, params, plant, placed_kg, [](const std::string& line) { fmt::print("  {}\n", line); },
          [&](int k) { return logs[static_cast<std::size_t>(k)].get(); });
      for (int k = 0; k < 2; ++k) logs[static_cast<std::size_t>(k)]->write(log_path(k), {fmt::format("peha check-sensors run {}", k)});
    } catch (const experiments::SensorCheckRejected& e) {
      for (int k = 0; k < 2; ++k) logs[static_cast<std::size_t>(k)]->write(log_path(k), {fmt::format("peha check-sensors run {} (refused)", k)});
      fmt::print(stderr, "refused: {}; {} not written\n", e.what(), options.out.string());
      return 2;
    }
    const char* names[2] = {"agonist", "antagonist"};
    fmt::print("  {:<4} {:>16} {:>16} {:>22} {:>22}\n", "run", "zero ago/ant N", "code 0 %", "up ago/ant N", "down ago/ant N");
    for (int k = 0; k < 2; ++k) {
      const experiments::SensorCheckRun& run = r.runs[k];
      fmt::print("  {:<4} {:>7.2f} / {:>6.2f} {:>7.0f} / {:>6.0f} {:>9.1f} / {:>9.1f} {:>9.1f} / {:>9.1f}\n", k, run.zero_N[0], run.zero_N[1],
                 100 * run.code0_fraction[0], 100 * run.code0_fraction[1], run.reading_N[0][0], run.reading_N[0][1], run.reading_N[1][0],
                 run.reading_N[1][1]);
    }
    fmt::print("  known torque {:.3f} Nm; the agonist cable's capstan ratio {:.3f}\n", r.known_torque_Nm, r.capstan_ratio);
    const double r_ratio = scenario.controller.joint.pulley_radius_m / plant.joint.pulley_radius_m;
    const sim::MusclePlantParams* truth[2] = {&plant.joint.agonist, &plant.joint.antagonist};
    for (int i = 0; i < 2; ++i) {
      fmt::print("  {:<10} zero {:7.2f} N, effective gain {:.4f} (the simulated rig's truth: offset {:.2f} N, gain x r_controller/r_rig {:.4f})\n",
                 names[i], r.corrections.loadcell_zero_N[i], r.corrections.loadcell_gain[i], truth[i]->loadcell_offset_N,
                 truth[i]->loadcell_gain * r_ratio);
    }
    r.corrections.source += fmt::format("; {} seed {}", options.config.filename().string(), plant.seed);
    calibration::write_sensor_corrections(options.out, r.corrections);
    fmt::print("written: {} (use: controller: sensor_corrections: {} in the scenario)\n", options.out.string(), options.out.string());
    return 0;
  });
}

}  // namespace peha::app
