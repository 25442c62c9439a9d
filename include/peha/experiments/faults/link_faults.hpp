#pragma once
/// \file
/// The link's faults (`peha faults --link`, docs/safety.md "The link's faults"): E1 over real UDP to
/// `peha mfb-emulator` in its own process, one short run per fault injected on the link or the board
/// (random loss, duplicates, reordering, corruption, delay, the e-stop input, the board stalled or
/// killed), with the supervisor's plausibility stage on. Per row: whether and by what the host
/// noticed it, how long after the injection, what the sensors saw after it (peak load cell, peak
/// joint speed, lowest load cell), limits exceeded, whether the log is complete, and the host's link
/// counters.

#include "peha/experiments/e1_gravity/e1_gravity.hpp"

#include <cstdint>
#include <filesystem>
#include <functional>
#include <limits>
#include <optional>
#include <string>
#include <vector>

namespace peha::experiments {

struct LinkFaultRow {
  std::string fault;          ///< "none", "loss_1pct", "board_killed", ...
  std::string injects;        ///< what was done, in words
  double fault_time_s = 0;    ///< host time of the injection (0: from the start, for the whole run)
  bool expect_detection = false;  ///< the designed outcome: a fault (true) or riding it out (false)
  bool detected = false;      ///< the run went to fault (lifecycle) or the plausibility stage latched a flag
  std::string by;             ///< the first fault's reason from the lifecycle ("-" when none)
  double detection_ms = 0;    ///< from the injection to the first fault (NaN: none, or injected from the start)
  double detection_cycles = 0;
  /// From the injection to the outputs' safe state [ms]: the host's disabled command at its fault
  /// (the board disarms on it), or - host killed - the board's own watchdog trip. NaN: none.
  double safe_ms = std::numeric_limits<double>::quiet_NaN();
  /// The designed outcome's detector: the first fault's reason must start with this ("": any).
  std::string expect_by;
  /// The designed outcome's bound on safe_ms (NaN: none).
  double max_safe_ms = std::numeric_limits<double>::quiet_NaN();
  double peak_force_N = 0;    ///< highest load cell after the injection (the host's sensors: no plant truth over UDP)
  double peak_speed_degps = 0;  ///< highest |velocity estimate| after the injection
  double min_tension_N = 0;   ///< lowest load cell after the injection (and after the start-up tare's slack)
  int limits_exceeded = 0;    ///< failed envelope checks of the run's verdict
  std::string limits;         ///< those checks, described ("" when none)
  std::string physics_forbids;  ///< as FaultRow: why no safe state avoids a limit (the e-stop), else empty
  /// Every cycle to the end logged (a row per cycle with a new sample) or held (no sample), no row dropped.
  bool log_complete = false;
  std::uint64_t lost = 0, late = 0, corrupt = 0, duplicate = 0, stale = 0, foreign = 0, unauthenticated = 0, accepted = 0;
  /// The designed outcome held: detected exactly when expected (by the designed detector, and safe
  /// within the designed time, where the row names them), and no limit exceeded unless physics forbids.
  bool outcome_met() const {
    return detected == expect_detection && (!detected || expect_by.empty() || by.starts_with(expect_by)) &&
           (!(max_safe_ms >= 0) || (safe_ms >= 0 && safe_ms <= max_safe_ms)) && (limits_exceeded == 0 || !physics_forbids.empty());
  }
};

struct LinkFaultOptions {
  std::filesystem::path peha_binary;  ///< what to start as `mfb-emulator` (the command: /proc/self/exe)
  std::filesystem::path config;       ///< the scenario file, as both processes read it
  std::string case_name;              ///< E1 case (default: the first)
  double fault_at_s = 2.5;            ///< injection time (after the start-up vent, tare and refill)
  double after_fault_s = 1.5;         ///< each run ends this long after the injection
  std::vector<std::string> faults;    ///< only these rows (default: all of link_fault_names()); "none" always runs first
  std::filesystem::path dir;          ///< run directory: each row's log under link/<fault>/
  std::uint64_t seed = 1;             ///< the emulator's --fault-seed
  /// Deliberately broken settings, to show that a row can fail (tests): the emulator's watchdog
  /// (--watchdog-ms) and the host's (host_watchdog_ms) instead of the scenario's. The designed
  /// outcomes stay the scenario's.
  std::optional<double> board_watchdog_ms, host_watchdog_ms;
};

/// The rows the link section can run, in order (without "none").
const std::vector<std::string>& link_fault_names();

/// Runs the nominal row and each link fault. Throws std::invalid_argument for an unknown fault name,
/// std::runtime_error when the emulator does not start or no board answers. `progress` (optional)
/// gets each row as it finishes.
std::vector<LinkFaultRow> run_link_faults(const E1Scenario& scenario, const LinkFaultOptions& options,
                                          const std::function<void(const LinkFaultRow&)>& progress = {});

/// faults_link.md (table + summary) and faults_link.csv in `dir`.
void write_link_faults(const std::filesystem::path& dir, const std::vector<LinkFaultRow>& rows, const std::string& scenario_name,
                       const LinkFaultOptions& options);

}  // namespace peha::experiments
