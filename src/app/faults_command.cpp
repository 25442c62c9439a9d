// `peha faults`: the fault matrix in process (docs/safety.md) on E1 (a gravity_compensation_1dof
// scenario) or E3 (an arm scenario): every injectable fault at each moment, its detection,
// safe state and what the plant did; a table, a CSV and a PNG.
#include "peha/app/commands.hpp"
#include "peha/app/cli_checks.hpp"
#include "peha/app/registry.hpp"
#include "peha/app/run_dir.hpp"
#include "peha/experiments/faults/fault_matrix.hpp"
#include "peha/experiments/faults/link_faults.hpp"
#include "peha/experiments/run_request.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <cmath>
#include <cstdio>
#include <stdexcept>

namespace peha::app {
namespace {

/// Throws UsageError unless every --moment is one of `moments` (the experiment's).
void check_moments(const std::vector<std::string>& wanted, const std::vector<experiments::FaultMoment>& moments, const char* experiment) {
  try {
    experiments::select_fault_moments(moments, wanted, experiment);
  } catch (const std::invalid_argument& e) {
    throw UsageError(fmt::format("--moment: {}", e.what()));
  }
}

/// Throws UsageError, listing the scenario's cases, unless `name` is empty or one of them.
void check_case(const std::string& name, const experiments::E1Scenario& e1, const config::Document& doc) {
  if (name.empty()) return;
  std::vector<std::string> names;
  for (const experiments::E1Case& c : e1.cases) {
    if (c.name == name) return;
    names.push_back(c.name);
  }
  throw UsageError(fmt::format("--case: no case named '{}' in {}; its cases: {}", name, doc.name(), fmt::join(names, ", ")));
}

/// `--link`: E1's link faults over UDP, the emulator a child process (this binary).
int link_faults(const FaultsOptions& options, const config::Document& doc) {
  if (!options.moments.empty() || !options.kinds.empty()) throw UsageError("--link runs the link's faults: --moment and --fault-kind are for the in-process matrix");
  const experiments::E1Scenario e1 = experiments::read_e1(doc);
  if (!e1.link) throw UsageError(fmt::format("--link: {} has no mfb: section (channel map, key, watchdogs)", doc.name()));
  check_case(options.case_name, e1, doc);
  RunDir run_dir(options.config, options.out_root, options.run_name, scenario_inputs(options.config));
  experiments::LinkFaultOptions o;
  o.peha_binary = std::filesystem::read_symlink("/proc/self/exe");
  o.config = std::filesystem::absolute(options.config);
  o.case_name = options.case_name.empty() ? e1.cases.front().name : options.case_name;
  o.faults = options.link_faults;
  o.seed = e1.seed;
  o.dir = run_dir.create(e1.seed);
  fmt::print("peha faults --link: {} (E1 over UDP to `peha mfb-emulator` in its own process, plausibility stage on, watchdogs host {:g} ms / "
             "board {:g} ms); output {}\n", doc.name(), e1.lifecycle.host_watchdog_s * 1e3, e1.link->board_watchdog_s * 1e3, o.dir.string());
  std::fflush(stdout);
  std::size_t n = 0;
  auto print_row = [&](const experiments::LinkFaultRow& r) {
    fmt::print("  [{}] {:<18} {:<8}: {:<48} {:>7} ms, safe {:>7} ms, peak {:>6.0f} N, {:>6.1f} deg/s, T_min {:>6.1f} N, limits exceeded {}{}; "
               "lost {}, late {}, corrupt {}, duplicate {}, stale {}, foreign {}{}\n",
               ++n, r.fault, r.expect_detection ? "fault" : "ride out", r.detected ? r.by : "not detected",
               std::isfinite(r.detection_ms) ? fmt::format("{:.1f}", r.detection_ms) : "-",
               std::isfinite(r.safe_ms) ? fmt::format("{:.1f}", r.safe_ms) : "-", r.peak_force_N, r.peak_speed_degps, r.min_tension_N,
               r.limits_exceeded, r.log_complete ? "" : ", LOG INCOMPLETE", r.lost, r.late, r.corrupt, r.duplicate, r.stale, r.foreign,
               r.outcome_met() ? "" : "  <- designed outcome MISSED");
    if (!r.limits.empty()) fmt::print("      exceeded: {}\n", r.limits);
    std::fflush(stdout);
  };
  const auto rows = experiments::run_link_faults(e1, o, print_row);
  experiments::write_link_faults(o.dir, rows, doc.name(), o);
  std::size_t missed = 0;
  for (const auto& r : rows) missed += !r.outcome_met();
  run_dir.commit();
  fmt::print("\nrows: {}; designed outcome missed: {}\nwritten: {}/faults_link.md, faults_link.csv\n", rows.size(), missed, run_dir.path().string());
  return missed == 0 ? 0 : 3;
}

}  // namespace

int faults(const FaultsOptions& options) {
  return with_exit_codes([&] {
    const config::Document doc = config::Document::load_file(options.config);
    // The scenario's kind says which experiment's matrix runs, as for `peha run`.
    const std::string kind = find_experiment(doc).key;
    if (kind != "gravity_compensation_1dof" && kind != "arm") {
      throw UsageError(fmt::format("{} is a {} scenario: peha faults runs E1 (gravity_compensation_1dof) or E3 (arm)", doc.name(), kind));
    }
    const bool arm = kind == "arm";
    if (options.link) {
      if (arm) throw UsageError("--link runs E1 over UDP: give a gravity_compensation_1dof scenario (configs/e1_one_dof.yaml)");
      return link_faults(options, doc);
    }
    if (!options.link_faults.empty()) throw UsageError("--link-fault needs --link");
    experiments::FaultMatrixOptions m;
    m.case_name = options.case_name;
    for (const std::string& k : options.kinds) {
      bool found = false;
      for (sim::FaultKind fault : sim::all_fault_kinds()) {
        if (k == sim::fault_kind_name(fault)) m.kinds.push_back(fault), found = true;
      }
      if (!found) throw UsageError(fmt::format("--fault-kind '{}': expected one of {}", k, sim::fault_kind_list()));
    }
    m.moments = options.moments;
    std::optional<experiments::E1Scenario> e1;
    std::optional<experiments::ArmScenario> e3;
    if (arm) {
      if (!options.case_name.empty()) throw UsageError("--case: E3 has no cases (it is for an E1 scenario's payload case)");
      e3 = experiments::read_arm_scenario(doc);
      check_moments(m.moments, experiments::e3_fault_moments(*e3), "E3");
    } else {
      e1 = experiments::read_e1(doc);
      check_case(options.case_name, *e1, doc);
      check_moments(m.moments, experiments::e1_fault_moments(*e1), "E1");
    }
    RunDir run_dir(options.config, options.out_root, options.run_name, scenario_inputs(options.config));
    const std::filesystem::path dir = run_dir.create(arm ? e3->seed : e1->seed);
    fmt::print("peha faults: {} ({} in process, plausibility stage on{}); output {}\n", doc.name(), arm ? "E3 postures on the arm scenario" : "E1",
               arm ? fmt::format(", faults on {}", experiments::kE3FaultJoint) : std::string(), dir.string());
    std::fflush(stdout);
    std::size_t n = 0;
    auto print_row = [&](const experiments::FaultRow& r) {
      auto at = [&](const std::string& joint) { return arm ? fmt::format(" {:<5}", joint) : std::string(); };  // the arm: which joint
      fmt::print("  [{}] {:<22} {:<14} {:<13}: {:<24} {:>4} cycles, {:<7} peak {:>6.0f} N{}, {:>6.1f} deg/s{}, T_min {:>6.1f} N{}, "
                 "limits exceeded {}{}{}\n",
                 ++n, r.fault, r.target, r.moment, r.detected ? r.flag : "NOT DETECTED",
                 std::isfinite(r.detection_cycles) ? fmt::format("{:.0f}", r.detection_cycles) : "-", r.safe_state, r.peak_force_N,
                 at(r.peak_force_joint), r.peak_speed_degps, at(r.peak_speed_joint), r.min_tension_N, at(r.min_tension_joint),
                 r.limits_exceeded, r.physics_forbids.empty() ? "" : " (physics forbids)", r.log_complete ? "" : ", LOG INCOMPLETE");
      std::fflush(stdout);
    };
    const auto rows = arm ? experiments::run_fault_matrix(*e3, m, print_row) : experiments::run_fault_matrix(*e1, m, print_row);
    experiments::write_fault_matrix(dir, rows, doc.name(), m.after_fault_s, m.slow_after_fault_s);
    std::size_t missed = 0, slow = 0, exceeded = 0, forbidden = 0, false_alarm = 0;
    for (const auto& r : rows) {
      if (r.fault == "none") {
        false_alarm += r.detected;
        continue;
      }
      missed += !r.detected;
      slow += r.detected && r.detection_cycles > r.prompt_cycles;
      exceeded += r.limits_exceeded > 0;
      forbidden += !r.physics_forbids.empty();
    }
    fmt::print("\nnominal run faulted: {}; faults not detected: {}; detected later than 5 cycles (or the flag's own window): {}; rows with a limit exceeded: {} "
               "({} physics forbids, {} misses of the designed outcome)\nwritten: {}/faults.md, faults.csv\n",
               false_alarm ? "YES" : "no", missed, slow, exceeded, forbidden, exceeded - forbidden, dir.string());
    if (options.plot) experiments::plot_with("plot_faults.py", dir);
    run_dir.commit();
    fmt::print("run folder: {}\n", run_dir.path().string());
    return false_alarm + missed + slow + (exceeded - forbidden) == 0 ? 0 : 3;
  });
}

}  // namespace peha::app
