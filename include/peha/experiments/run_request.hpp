#pragma once
/// \file
/// What every experiment's run sequence gets from the command line (`peha run`), and the few
/// things they share: the real-time options over the board, the board run's printout, the Python
/// plot tools and a progress bar. The run directory is opened through `RunRequest::open_run_dir`,
/// once the experiment has loaded and checked everything, so a rejected run leaves no trace.

#include "peha/experiments/common/board_run.hpp"
#include "peha/runtime/realtime_harness.hpp"

#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace peha::experiments {

struct RunRequest {
  std::filesystem::path config;                 ///< the scenario YAML (named in the logs' headers)
  std::optional<std::uint64_t> seed;            ///< overrides the scenario's seed
  std::string only_case;                        ///< run only this case / movement (empty: all)
  std::filesystem::path calibration[2];         ///< E1: agonist [0] and antagonist [1] calibration files (empty: none)
  std::optional<double> force_trim_rate_1ps;    ///< overrides the controller's force trim rate (0 = off)
  std::filesystem::path goniometer_csv;         ///< E4: a recorded goniometer CSV instead of the synthetic movements
  std::filesystem::path gravity_identification; ///< right arm: identified gravity parameters (peha identify-gravity)
  bool plot = true;                             ///< render the figures with tools/*.py
  /// The hardware (hardware::BackendUri): "" or "sim:" in process, "udp://A.B.C.D:PORT[,...]" a
  /// real-time run on the board(s), "replay:<log.csv>" a recorded run fed to the controller.
  std::string backend;
  std::string telemetry;                        ///< "udp://A.B.C.D:PORT" of a PlotJuggler server (empty: the scenario's, if any)
  std::vector<std::string> telemetry_signals;   ///< --telemetry-signal: log columns or globs (empty: the scenario's, or the default)
  bool telemetry_remote = false;                ///< allow a non-loopback telemetry destination
  int fifo_priority = 80;                       ///< SCHED_FIFO priority of the loop (0 = don't ask)
  int cpu = -1;                                 ///< pin the loop to this CPU (-1 = don't)
  std::optional<double> recover_after_s;        ///< unattended operator: recover this long after a fault
  std::vector<std::string> faults;              ///< --fault specs (sim/plant_faults.hpp), parsed by the experiment
  /// Creates the run directory (with the copy of the config and `seed`, the seed used) and returns
  /// it. Called once, when everything is loaded and checked.
  std::function<std::filesystem::path(std::uint64_t seed)> open_run_dir;
  /// Where the run's folder will be once complete (the run writes into a partial folder first and is
  /// put in place at its end): the paths printed for the user. Empty: the folder open_run_dir gave.
  std::filesystem::path run_folder;
};

/// --backend (through hardware::BackendUri) and the real-time options; nullopt (after a message)
/// when malformed. The telemetry is the run's (telemetry_options).
std::optional<HardwareRunOptions> realtime_options(const RunRequest& request);
/// The run's telemetry: the scenario's `telemetry:` section `scenario` with the command line over it
/// (--telemetry, --telemetry-signal, --telemetry-remote), checked against the per-cycle log's
/// `columns` (with the harness's own signals `on_boards`). nullopt after a message naming the
/// scenario `doc_name` (an unknown signal names the closest column), before anything is written.
std::optional<runtime::TelemetryOptions> telemetry_options(const std::string& doc_name, const runtime::TelemetryOptions& scenario,
                                                          const std::vector<std::string>& columns, const RunRequest& request, bool on_boards);
/// True if --backend gave one address per board of `link` or one for all (mfb::board_endpoints);
/// otherwise prints why (naming the scenario `doc_name`) and returns false.
bool check_board_addresses(const std::string& doc_name, const mfb::LinkConfig& link, const HardwareRunOptions& realtime);

/// The run's hardware (--backend, through the door), checked before anything is written: on boards
/// or a replay one case of the `cases` selected (a board serves one plant, a log is one run), on
/// boards the scenario's mfb: section `link` and one address per board. False (after a message,
/// naming the scenario `doc_name`) when the request cannot run; `realtime` is set only on boards.
bool check_hardware(const std::string& doc_name, const mfb::LinkConfig* link, const std::vector<std::string>& cases, const RunRequest& request,
                    hardware::BackendUri& uri, std::optional<HardwareRunOptions>& realtime);

/// What a real-time run on the board measured, printed after its experiment's table; writes the
/// timing statistics to `timing_dir`.
void print_realtime(const BoardRunResult& rr, const std::filesystem::path& timing_dir);

/// What a replay (--backend replay:<log.csv>) gave: rows replayed, the largest difference of the
/// controller's commands from the recorded ones; writes both side by side to `commands_csv`.
void print_replay(const hardware::ReplayBackend& replay, const std::filesystem::path& commands_csv);

/// Renders a figure with one of tools/*.py on Debian's Python: `tool dir args...`. A failed plot is
/// a warning: the data files it would read are complete either way.
void plot_with(const char* tool, const std::filesystem::path& dir, const std::vector<std::string>& args = {});

/// Progress of long work: a live bar on a terminal, a line per 10 % when the output is a log.
class ProgressPrinter {
 public:
  explicit ProgressPrinter(std::string what);
  void update(double done, double total, const std::string& detail = "");

 private:
  std::string what_;
  bool tty_;
  int last_ = -1;
};

}  // namespace peha::experiments
