// `peha faults`: the fault matrix on E1 in process (docs/safety.md): every injectable fault at
// each moment, its detection, safe state and what the plant did; a table, a CSV and a PNG.
#include "peha/app/commands.hpp"
#include "peha/app/cli_checks.hpp"
#include "peha/app/run_dir.hpp"
#include "peha/experiments/faults/fault_matrix.hpp"
#include "peha/experiments/run_request.hpp"

#include <fmt/format.h>

#include <cmath>
#include <cstdio>

namespace peha::app {

int faults(const FaultsOptions& options) {
  return with_exit_codes([&] {
    const config::Document doc = config::Document::load_file(options.config);
    const experiments::E1Scenario scenario = experiments::read_e1(doc);
    experiments::FaultMatrixOptions m;
    m.case_name = options.case_name;
    for (const std::string& k : options.kinds) {
      bool found = false;
      for (sim::FaultKind kind : sim::all_fault_kinds()) {
        if (k == sim::fault_kind_name(kind)) m.kinds.push_back(kind), found = true;
      }
      if (!found) throw UsageError(fmt::format("--fault-kind '{}': expected one of {}", k, sim::fault_kind_list()));
    }
    m.moments = options.moments;
    RunDir run_dir(options.config, options.out_root, options.run_name);
    const std::filesystem::path dir = run_dir.create(scenario.seed);
    fmt::print("peha faults: {} (E1 in process, plausibility stage on); output {}\n", doc.name(), dir.string());
    std::fflush(stdout);
    std::size_t n = 0;
    const auto rows = experiments::run_fault_matrix(scenario, m, [&](const experiments::FaultRow& r) {
      fmt::print("  [{}] {:<22} {:<14} {:<13}: {:<24} {:>4} cycles, {:<7} peak {:>6.0f} N, {:>6.1f} deg/s, T_min {:>6.1f} N, "
                 "limits exceeded {}{}{}\n",
                 ++n, r.fault, r.target, r.moment, r.detected ? r.flag : "NOT DETECTED",
                 std::isfinite(r.detection_cycles) ? fmt::format("{:.0f}", r.detection_cycles) : "-", r.safe_state, r.peak_force_N,
                 r.peak_speed_degps, r.min_tension_N, r.limits_exceeded, r.physics_forbids.empty() ? "" : " (physics forbids)",
                 r.log_complete ? "" : ", LOG INCOMPLETE");
      std::fflush(stdout);
    });
    experiments::write_fault_matrix(dir, rows, doc.name());
    std::size_t missed = 0, slow = 0, exceeded = 0, forbidden = 0, false_alarm = 0;
    for (const auto& r : rows) {
      if (r.fault == "none") {
        false_alarm += r.detected;
        continue;
      }
      missed += !r.detected;
      slow += r.detected && r.detection_cycles > 5;
      exceeded += r.limits_exceeded > 0;
      forbidden += !r.physics_forbids.empty();
    }
    fmt::print("\nnominal run faulted: {}; faults not detected: {}; detected later than 5 cycles: {}; rows with a limit exceeded: {} "
               "({} physics forbids, {} misses of the designed outcome)\nwritten: {}/faults.md, faults.csv\n",
               false_alarm ? "YES" : "no", missed, slow, exceeded, forbidden, exceeded - forbidden, dir.string());
    if (options.plot) experiments::plot_with("plot_faults.py", dir);
    run_dir.link_latest();
    return false_alarm + missed + slow + (exceeded - forbidden) == 0 ? 0 : 3;
  });
}

}  // namespace peha::app
