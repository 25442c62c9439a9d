#pragma once
/// \file
/// The `peha` sub-commands, callable from the CLI and from tests.

#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>

namespace peha::app {

struct RunOptions {
  std::filesystem::path config;           ///< scenario YAML
  std::filesystem::path out_root = "out"; ///< run directories go under it
  std::string run_name;                   ///< default: <config stem>-<UTC time stamp>
  std::optional<std::uint64_t> seed;      ///< overrides the scenario's seed
  std::string only_case;                  ///< run only this case (empty: all)
  bool plot = true;                       ///< render plot.png with tools/plot_run.py
  bool video = false;                     ///< an MP4 per case beside its CSV (docs/video.md)
  /// Calibration files for the agonist [0] and antagonist [1] (empty: the config's model). With
  /// any, each case runs with the calibrated parametric model and with parametric + SPGP.
  std::filesystem::path calibration[2];
  std::optional<double> force_trim_rate_1ps;  ///< overrides the config's force trim (0 = off)
  std::string experiment;                     ///< scenarios with sub-experiments (right arm): postures | goniometer | bandwidth
  std::filesystem::path goniometer_csv;       ///< E4: a recorded goniometer CSV instead of the synthetic movements
  /// On the multifunction board: "udp://A.B.C.D:PORT" (empty: the in-process simulator).
  std::string backend;
  std::optional<int> fifo_priority;           ///< real-time loop: SCHED_FIFO priority (0 = don't ask; unset: 80)
  std::optional<int> cpu;                     ///< real-time loop: pin to this CPU (-1 = don't; unset: -1)
  std::string telemetry;                      ///< "udp://A.B.C.D:PORT" of a PlotJuggler UDP server (empty: the scenario's, if any)
  std::vector<std::string> telemetry_signals; ///< --telemetry-signal: log columns or globs (empty: the scenario's, or the default)
  bool telemetry_remote = false;              ///< --telemetry-remote: the telemetry may leave this machine
  std::optional<double> recover_after_s;      ///< unattended operator: recover this long after a fault
  std::vector<std::string> faults;            ///< --fault KIND@T[:TARGET[=VALUE]] (sim/plant_faults.hpp), in-process E1 and E3
  std::filesystem::path gravity_identification;  ///< right arm: the controller's gravity parameters from peha identify-gravity
};

struct EmulatorOptions {
  std::filesystem::path config;  ///< scenario with an mfb: section (the one-DOF rig)
  std::string case_name;         ///< which case's plant (payload); empty: the first
  std::string bind = "127.0.0.1";
  int port = 0;                  ///< 0: any free port (printed)
  std::optional<std::uint64_t> seed;  ///< sensor noise
  double loss = 0, duplicate = 0, reorder = 0, corrupt = 0, delay_ms = 0;
  std::uint64_t fault_seed = 1;
  double estop_at_s = -1, estop_for_s = 1.0;
  double loss_burst_at_s = -1;   ///< simulated time a loss burst starts (< 0: none)
  std::optional<std::uint64_t> loss_burst_packets;  ///< its length in state packets (0: all to the end)
  double bind_retry_s = 0;       ///< the port is taken: retry binding for this long (a rebooting board's successor)
  std::filesystem::path truth_csv;  ///< write the plant's truth per step here when stopped (empty: not)
  std::optional<double> watchdog_ms;  ///< overrides the config's board_watchdog_ms
  double max_runtime_s = 0;
  int sessions = 0;
  int fifo_priority = 70;        ///< the board is a real-time device too: SCHED_FIFO priority (0 = don't ask)
  int cpu = -1;                  ///< pin the board's loop to this CPU (-1 = don't pin)
};

/// `peha mfb-emulator`: serves the MFB protocol over UDP in front of the simulated rig until
/// interrupted (SIGINT/SIGTERM), max_runtime_s, or `sessions` sessions ended; prints its counters.
int mfb_emulator(const EmulatorOptions& options);

/// `peha run`: runs the scenario's experiment (found by its `experiment:` key in the registry),
/// writes out/<run>/ and prints a summary table. An option the experiment does not take is
/// rejected (exit code 2, nothing written). Returns the process exit code (0 when every case ran
/// and every figure of the verdict held, 2 bad input, 3 a figure of the verdict failed, 1 other errors).
int run(const RunOptions& options);

/// Where a procedure runs (`--backend` and the real-time options over a board), as `peha run` takes them.
struct HardwareFlags {
  std::string backend;                    ///< hardware::BackendUri text ("" = sim:)
  int fifo_priority = 80;                 ///< SCHED_FIFO priority of the loop on hardware (0 = don't ask)
  int cpu = -1;                           ///< pin the loop to this CPU (-1 = don't)
  std::optional<double> recover_after_s;  ///< unattended operator: recover this long after a fault
};

struct RecordOptions {
  std::filesystem::path config;  ///< rig scenario YAML with a `calibration:` section
  std::string muscle;            ///< "agonist" or "antagonist"
  std::filesystem::path out;     ///< calibration CSV to write
  std::optional<std::uint64_t> seed;
  HardwareFlags hardware;        ///< the simulated rig (default) or a board
};

/// `peha record-calibration`: runs the triangle-wave excitation on the rig (simulated or a board), writes the CSV.
int record_calibration(const RecordOptions& options);

struct CalibrateCommandOptions {
  std::filesystem::path data;        ///< calibration CSV
  std::filesystem::path out;         ///< calibration YAML to write
  std::filesystem::path report_dir;  ///< default: <out without extension>_report
  std::string muscle;                ///< the muscle (default: the recording's sidecar's; neither: refused)
  int restarts = 300;
  int threads = 2;
  int pseudo_inputs = 50;
  int spgp_iterations = 300;
  bool use_spgp = true;
  bool holdout = true;               ///< false: fit every row (nothing held out)
  std::size_t min_rows = 50;         ///< fewer rows is an error (static maps may have fewer)
  std::uint64_t seed = 1;
  bool plot = true;
  /// E1 scenario (with calibration.acceptance): operating points in the report, and the
  /// closed-loop check on its rig that may refuse the calibration (empty: neither).
  std::filesystem::path scenario;
  /// With `scenario`: the other muscle's calibration YAML, applied (with its SPGP) to the rig's
  /// controller for the closed-loop check, as `peha run` will use the pair (empty: the other muscle
  /// keeps the scenario's model).
  std::filesystem::path other_calibration;
};

/// `peha calibrate`: fits the muscle model to a calibration CSV, writes the file and a report.
int calibrate(const CalibrateCommandOptions& options);

struct IdentifyGravityOptions {
  std::filesystem::path config;  ///< arm scenario with an identification: section
  std::filesystem::path out;     ///< identification YAML to write
  std::optional<std::uint64_t> seed;
  HardwareFlags hardware;        ///< the simulated arm (default) or its boards
};

/// `peha identify-gravity`: the rig procedure on the simulated arm, the fit, the file (docs/identification.md).
/// Exit code 0 = written, 2 = bad config or an identification the fit's checks refuse (nothing written).
int identify_gravity(const IdentifyGravityOptions& options);

struct CheckSensorsOptions {
  std::filesystem::path config;         ///< E1 scenario with a sensor_check: section
  std::filesystem::path out;            ///< corrections YAML to write
  std::optional<double> known_mass_kg;  ///< what the operator says the mass is (default: the section's)
  std::optional<double> lever_m;        ///< its lever (default: the section's)
  std::optional<std::uint64_t> seed;
};

/// `peha check-sensors`: the sensor check on the simulated rig, the corrections file
/// (docs/calibration.md "Sensor check"). Exit code 0 = written, 2 = bad config or refused (nothing written).
int check_sensors(const CheckSensorsOptions& options);

/// `peha check-config`: parses and validates a scenario, prints what it would run. Exit code.
int check_config(const std::filesystem::path& config);

/// `peha keygen --out FILE`: writes a fresh random link key (mfb::write_new_link_key). Exit code 0,
/// or 2 (the file exists, or cannot be written) with the reason on stderr.
int keygen(const std::filesystem::path& out);

struct RobustnessOptions {
  std::filesystem::path config;           ///< robustness YAML (configs/robustness.yaml)
  std::filesystem::path out_root = "out";
  std::string run_name;                   ///< default: <config stem>-<UTC time stamp>
  std::optional<int> threads;             ///< overrides the file's threads
  std::string only_variant;               ///< run only this variant (empty: all)
  std::string only_mode;                  ///< run only this mode (empty: the file's modes)
  bool keep_calibrations = false;         ///< write the calibrated mode's recordings and calibrations
  bool plot = true;                       ///< render heatmap.png with tools/plot_robustness.py
};

/// `peha robustness`: E1 and E3 over plant variants x payloads x seeds (docs/robustness.md);
/// writes robustness.md, robustness.csv and heatmap.png. Exit code 0 when every mode met its goal
/// share, 3 when one missed it, 2 bad config.
int robustness(const RobustnessOptions& options);

struct FalseAlarmsOptions {
  std::filesystem::path config;           ///< false-alarm YAML (configs/false_alarms.yaml)
  std::filesystem::path out_root = "out";
  std::string run_name;                   ///< default: <config stem>-<UTC time stamp>
  std::optional<int> threads;             ///< overrides the file's threads
  std::optional<int> seeds;               ///< overrides the file's seeds (per case and noise scale)
  std::optional<int> variant_seeds;       ///< overrides the file's variant_seeds
  bool plot = true;                       ///< render margins.png with tools/plot_false_alarms.py
};

/// `peha false-alarms`: every plausibility check's largest ratio to its threshold on fault-free runs
/// (docs/safety.md "False alarms"); writes false_alarms.md, false_alarms.csv and margins.png. Exit
/// code 0 when no check trips at x1 or x3 noise and every margin at x1 holds, 3 otherwise, 2 bad config.
int false_alarms(const FalseAlarmsOptions& options);

struct FaultsOptions {
  std::filesystem::path config;           ///< E1 or arm scenario (configs/e1_one_dof.yaml, configs/right_arm.yaml, configs/upper_body.yaml)
  std::filesystem::path out_root = "out";
  std::string run_name;                   ///< default: <config stem>-<UTC time stamp>
  std::string case_name;                  ///< E1 case (default: the first)
  std::vector<std::string> kinds;         ///< only these fault kinds (default: all)
  std::vector<std::string> moments;       ///< only these moments (default: E1 holding, push, after_release; E3 holding, moving)
  bool plot = true;                       ///< render faults.png with tools/plot_faults.py
  /// Instead of the in-process matrix: the link's faults, E1 over UDP to `peha mfb-emulator` started
  /// as a child process (faults_link.md, faults_link.csv; docs/safety.md "The link's faults").
  bool link = false;
  std::vector<std::string> link_faults;   ///< with --link: only these rows (default: all)
};

/// `peha faults`: the fault matrix in process on E1 or, for an arm scenario, E3 (docs/safety.md);
/// with `link`, E1's link faults over UDP instead. Exit 0 when the nominal run raised nothing and
/// every fault was detected within 5 cycles with no limit exceeded (or one physics forbids any safe
/// state to keep) - with `link`: every row met its designed outcome - else 3; 2 bad input.
int faults(const FaultsOptions& options);

/// Runs a command body and maps what it throws to the exit codes every command documents:
/// 2 for bad input (config or data), 1 for anything else (after a message on stderr).
int with_exit_codes(const std::function<int()>& body);

}  // namespace peha::app
