// `peha record-calibration`: the triangle-wave excitation of one muscle on the rig (the simulated
// one, or a board through the hardware door), logged to a calibration CSV.
#include "peha/app/cli_checks.hpp"
#include "peha/app/commands.hpp"
#include "peha/app/hardware_flags.hpp"
#include "peha/calibration/dataset.hpp"
#include "peha/config/csv_sidecar.hpp"
#include "peha/experiments/calibration_recording/excitation.hpp"
#include "peha/experiments/e1_gravity/e1_gravity.hpp"
#include "peha/experiments/e1_gravity/e1_realtime.hpp"
#include "peha/experiments/run_request.hpp"
#include "peha/models/units.hpp"
#include "peha/sim/one_dof_rig.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <memory>

namespace peha::app {

int record_calibration(const RecordOptions& options) {
  return with_exit_codes([&] {
    const config::Document doc = config::Document::load_file(options.config);
    // The CSV, and on the board its cycles log beside it: neither may replace what the scenario reads.
    const std::vector<std::filesystem::path> inputs = scenario_inputs(options.config);
    refuse_unsafe_output(options.out, inputs);
    refuse_unsafe_output(std::filesystem::path(options.out).replace_extension(".cycles.csv"), inputs, "--out (its .cycles.csv)");
    experiments::E1Scenario scenario = experiments::read_e1(doc);
    const int index = options.muscle == "agonist" ? 0 : 1;
    if (!scenario.excitation[index]) {
      fmt::print(stderr, "config error: {}: no calibration.{} section (the excitation to run)\n", doc.name(),
                 options.muscle);
      return 2;
    }
    const experiments::ExcitationParams& e = *scenario.excitation[index];
    sim::OneDofRigParams plant_params = scenario.plant;
    if (options.seed) plant_params.seed = *options.seed;
    std::optional<experiments::HardwareRunOptions> hw =
        procedure_hardware(options.hardware, options.config, scenario.link, "a recording excites a plant", options.out);
    if (!hw) return 2;
    const bool on_board = hw->backend.kind == hardware::BackendKind::kBoards;
    fmt::print("peha record-calibration: {} of {} ({}), {:.0f} s at {:.0f} Hz\n"
               "  triangle {:.2f}..{:.2f} MPa, period {:.1f} s, {:.0f} s; other muscle {:.2f}..{:.2f} MPa (antiphase); payload {} kg\n",
               options.muscle, on_board ? hw->backend.describe() : "the simulated rig", doc.name(), e.total_duration_s(), e.sample_rate_Hz,
               e.min_pressure_Pa * 1e-6, e.max_pressure_Pa * 1e-6, e.period_s, e.duration_s, e.other_pressure_at_min_Pa * 1e-6,
               e.other_pressure_Pa * 1e-6, e.payload_kg);
    for (const experiments::ExcitationSegment& g : e.segments) {
      fmt::print("  then operating points: triangle {:.2f}..{:.2f} MPa, period {:.1f} s, {:.0f} s; other muscle {:.2f}..{:.2f} MPa{}\n",
                 g.min_pressure_Pa * 1e-6, g.max_pressure_Pa * 1e-6, g.period_s, g.duration_s, g.other_pressure_at_min_Pa * 1e-6,
                 g.other_pressure_Pa * 1e-6, std::isfinite(g.clamp_angle_rad) && on_board ? fmt::format(", the link pinned at {:.0f} deg", models::rad_to_deg(g.clamp_angle_rad)) : "");
    }
    calibration::Dataset data;
    if (on_board) {
      // The board's per-cycle log and timing go beside the CSV (hw->dir); the CSV only after a clean run.
      const std::filesystem::path cycles = std::filesystem::path(options.out).replace_extension(".cycles.csv");
      experiments::E1RecordingRealtimeResult r = experiments::record_e1_muscle_realtime(scenario, index, *hw, cycles);
      experiments::print_realtime(r, hw->dir / fmt::format("timing_calibration_{}", options.muscle));
      if (!r.verdict.passed()) {
        fmt::print(stderr, "error: the recording faulted ({}): data recorded across a fault is no calibration's; {} not written\n",
                   r.verdict.failures(), options.out.string());
        return 3;
      }
      data = std::move(r.data);
    } else {
      data = experiments::record_e1_muscle(
          scenario, plant_params, index,
          [&, bar = std::make_shared<experiments::ProgressPrinter>("recording")](double f) { bar->update(f, 1.0); });
    }
    data.muscle = options.muscle;  // peha calibrate takes it from the sidecar
    if (options.out.has_parent_path()) std::filesystem::create_directories(options.out.parent_path());
    calibration::write_dataset(
        options.out, data,
        {fmt::format("peha record-calibration: muscle {} of {}", options.muscle, on_board ? hw->backend.describe() : "the simulated one-DOF rig"),
         fmt::format("config: {}; seed {}", options.config.string(), plant_params.seed),
         "contraction = rigid-wire contraction from the joint encoder with the controller's nominal geometry",
         "force_N = load cell at the muscle; pressure_MPa = valve pressure sensor (gauge)"});
    auto span = [](const std::vector<double>& v) {
      const auto [lo, hi] = std::minmax_element(v.begin(), v.end());
      return std::pair{*lo, *hi};
    };
    const auto [p0, p1] = span(data.pressure_Pa);
    const auto [f0, f1] = span(data.force_N);
    const auto [e0, e1] = span(data.contraction);
    fmt::print("  {} rows -> {} (load-cell zero {:.2f} N and notes in {})\n  pressure {:.3f}..{:.3f} MPa, force {:.0f}..{:.0f} N, "
               "contraction {:.3f}..{:.3f}\n",
               data.size(), options.out.string(), data.loadcell_zero_N, config::csv_sidecar_path(options.out).filename().string(),
               p0 * 1e-6, p1 * 1e-6, f0, f1, e0, e1);
    return 0;
  });
}

}  // namespace peha::app
