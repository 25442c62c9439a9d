// peha: control software for exoskeletons driven by pneumatic-electric hybrid actuators.
#include "peha/sim/plant_faults.hpp"
#include "peha/app/cli_checks.hpp"
#include "peha/app/commands.hpp"
#include "peha/app/hardware_flags.hpp"
#include "peha/experiments/faults/link_faults.hpp"
#include "peha/experiments/robustness/robustness.hpp"
#include "peha/runtime/interrupt.hpp"

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <mujoco/mujoco.h>

#include <functional>
#include <memory>

namespace {

/// A sub-command: its definition, and what runs it once the command line is parsed.
struct Command {
  CLI::App* app;
  std::function<int()> run;
};

Command add_run(CLI::App& app) {
  struct State {
    peha::app::RunOptions run;
    std::uint64_t seed = 0;
    int rt_priority = 80, cpu = -1;
    double recover_after = 0, trim = 0;
    CLI::Option *seed_opt, *rt_priority_opt, *cpu_opt, *recover_opt, *trim_opt;
  };
  auto s = std::make_shared<State>();
  peha::app::RunOptions& run = s->run;
  CLI::App* run_cmd = app.add_subcommand(
      "run", "Run a scenario (an experiment described in a YAML config) on the simulated exoskeleton.\n"
             "Writes <out>/<run>/: one per-cycle CSV log per case (time first, units in column names),\n"
             "config.yaml (the config it ran with), summary.csv and plot.png; prints a summary table.\n"
             "The scenario's experiment: key picks the experiment (gravity_compensation_1dof = E1; max_force_ramp =\n"
             "E5; wire_creep = the creep estimator off/on over 30 min of E1, docs/creep.md; arm = E3, E4 or E6 by\n"
             "--experiment); an option that experiment does not take is an error, never ignored.\n"
             "Exit code 0 = ran and every figure of the verdict held, 2 = bad config or an option the experiment\n"
             "does not take (nothing written), 3 = a figure failed (drift, excursion or a run to a stop after a\n"
             "release, E1's static torque error, a muscle's force ceiling, the wire-tension floor, pressure, motor,\n"
             "range, E4's tracking, E5's overshoot, time to hold and time at the force ceiling, the creep estimate's\n"
             "errors and alert times; thresholds in the scenario's verdict: section), 130 = interrupted (Ctrl-C or\n"
             "SIGTERM: the run ends at its next cycle and winds down; a second Ctrl-C quits at once).");
  run_cmd->add_option("-c,--config", run.config, "Scenario YAML, e.g. configs/e1_one_dof.yaml")
      ->required()->check(CLI::ExistingFile);
  run_cmd->add_option("-o,--out", run.out_root, "Directory under which the run directory is created")
      ->capture_default_str();
  run_cmd->add_option("-n,--name", run.run_name, "Run directory name under --out: letters, digits and . _ + - (default: <config stem>-<UTC time>)")
      ->check(peha::app::run_name());
  run_cmd->add_option("--case", run.only_case,
                      "Run only the case with this name (default: all cases): E1 a payload case,\n"
                      "E5 a clamp angle, E4 (--experiment goniometer) a movement");
  s->seed_opt = run_cmd->add_option("--seed", s->seed, "Override the scenario's random seed (sensor noise)")->check(peha::app::unsigned_integer());
  run_cmd->add_flag("!--no-plot", run.plot, "Do not render plot.png (no Python needed)");
  run_cmd->add_flag("--video", run.video, "Also write an MP4 per case beside its CSV (MuJoCo offscreen + ffmpeg; docs/video.md)");
  run_cmd->add_option("--agonist-calibration", run.calibration[0],
                      "E1 only: calibration YAML (from peha calibrate) for the agonist; with a calibration, every case\n"
                      "runs twice: calibrated parametric model alone, and with its SPGP residual")
      ->check(CLI::ExistingFile);
  run_cmd->add_option("--antagonist-calibration", run.calibration[1], "E1 only: calibration YAML for the antagonist")
      ->check(CLI::ExistingFile);
  run_cmd->add_option("--experiment", run.experiment,
                      "Arm scenarios (configs/right_arm.yaml, configs/upper_body.yaml) only: the experiment to run.\n"
                      "postures  = E3: move the arm with its mannequin to each posture, let go, measure the drift\n"
                      "goniometer = E4: a person's elbow, measured by a goniometer at 200 Hz, drives the exoskeleton's\n"
                      "             elbow (each of goniometer.joints) through Butterworth filter, derivatives and inverse\n"
                      "             dynamics; tracking RMS and delay per driven joint\n"
                      "bandwidth = E6: sine-sweep torque on one locked joint, PAM-only vs hybrid, Bode plot, -3 dB")
      ->check(CLI::IsMember({"postures", "goniometer", "bandwidth"}));
  run_cmd->add_option("--goniometer-csv", run.goniometer_csv,
                      "E4 only: replay a recorded goniometer CSV (columns t_s and elbow_angle_deg or elbow_angle_rad,\n"
                      "sampled at the config's goniometer.sample_rate_Hz) instead of the config's synthetic movements;\n"
                      "it drives every joint of goniometer.joints")
      ->check(CLI::ExistingFile);
  run_cmd->add_option("--backend", run.backend,
                      "The hardware the run drives (docs/runtime.md, 'One hardware door'):\n"
                      "sim: (the default) the in-process simulated plant;\n"
                      "replay:<log.csv> a recorded E1 or E5 log's sensor columns fed to the controller, one row a cycle,\n"
                      "its commands written beside the recorded ones (replay_<case>.csv); one case: --case;\n"
                      "udp://A.B.C.D:PORT a multifunction board (or 'peha mfb-emulator'); needs the config's mfb: section.\n"
                      "E1 and E5 (one case: --case), E3 postures, E4 goniometer (one movement: --case slow|brisk); not E6.\n"
                      "A scenario on several boards (mfb: boards:, E3): one address per board in the boards: order,\n"
                      "comma-separated (udp://10.0.0.2:50000,udp://10.0.0.3:50000,...), or one address: board i at its port + i\n"
                      "(what 'peha mfb-emulator --port P' serves).\n"
                      "Runs in real time at the config's control period with timing statistics (docs/runtime.md)");
  s->rt_priority_opt =
      run_cmd->add_option("--rt-priority", s->rt_priority, "With --backend: SCHED_FIFO priority of the loop (0 = don't ask)")
          ->capture_default_str()->check(peha::app::signed_integer())->check(CLI::Range(0, 99));
  s->cpu_opt =
      run_cmd->add_option("--cpu", s->cpu, "With --backend: pin the loop to this CPU (-1 = don't)")->check(peha::app::signed_integer())->capture_default_str();
  run_cmd->add_option("--telemetry", run.telemetry,
                      "Stream the per-cycle log's signals as JSON to a PlotJuggler UDP server, e.g. udp://127.0.0.1:9870\n"
                      "(loopback only unless --telemetry-remote); in process at simulation speed (timestamp = simulated\n"
                      "time), with --backend in real time. Overrides the scenario's telemetry.destination");
  run_cmd->add_option("--telemetry-signal", run.telemetry_signals,
                      "The signals to stream (repeatable, or comma-separated): the log's column names, exactly\n"
                      "(tau_motor_cmd_Nm), a _rad column as _deg (angle_deg), globs (*_loadcell_N), and with --backend\n"
                      "rtt_us and lifecycle_state. Default: the scenario's telemetry.signals, else each joint's angle,\n"
                      "load cells, commanded pressures and motor torque (docs/runtime.md, 'Live telemetry')")
      ->delimiter(',');
  run_cmd->add_flag("--telemetry-remote", run.telemetry_remote,
                    "With --telemetry: allow a destination beyond this machine. The stream is unencrypted and\n"
                    "unauthenticated (the wearer's forces and angles): use it only on a network you trust")
      ->needs("--telemetry");
  s->recover_opt = run_cmd->add_option(
      "--recover-after", s->recover_after,
      "With --backend: the operator's recover command this many s after a fault (unattended runs);\n"
      "without it, type r + Enter on the terminal to recover")->check(peha::app::decimal())->check(CLI::Range(0.0, 3600.0));
  run_cmd->add_option("--fault", run.faults,
                      "E1 and an arm scenario's E3 and E4 (--experiment postures, goniometer), in process only (repeatable): inject a plant\n"
                      "fault KIND@T[:TARGET[=VALUE]] at T s, TARGET [JOINT.]agonist|antagonist for muscle faults, JOINT\n"
                      "for the others (E1: joint; the arm: R_SFE|R_EFE|R_WFE; default the first), VALUE for loadcell_bias\n"
                      "(N), loadcell_drift (N/s), encoder_jump (deg), wire_slip (mm). KIND: " + peha::sim::fault_kind_list() + " (docs/safety.md)");
  run_cmd->add_option("--gravity-identification", run.gravity_identification,
                      "Arm scenarios only: the controller's gravity parameters identified on the rig (a file from\n"
                      "peha identify-gravity) instead of the nominal arm model (docs/identification.md)")
      ->check(CLI::ExistingFile);
  s->trim_opt = run_cmd->add_option(
      "--force-trim-rate", s->trim, "Override the load-cell force trim's rate in 1/s (0 = the paper's pure feed-forward);\n"
               "E1 and an arm scenario's experiments")
      ->check(peha::app::decimal())->check(CLI::Range(0.0, 100.0));
  return {run_cmd, [s] {
            if (*s->seed_opt) s->run.seed = s->seed;
            if (*s->trim_opt) s->run.force_trim_rate_1ps = s->trim;
            if (*s->recover_opt) s->run.recover_after_s = s->recover_after;
            if (*s->rt_priority_opt) s->run.fifo_priority = s->rt_priority;
            if (*s->cpu_opt) s->run.cpu = s->cpu;
            return peha::app::run(s->run);
          }};
}

Command add_record_calibration(CLI::App& app) {
  struct State {
    peha::app::RecordOptions record;
    std::uint64_t seed = 0;
    CLI::Option* seed_opt;
  };
  auto s = std::make_shared<State>();
  peha::app::RecordOptions& record = s->record;
  CLI::App* record_cmd = app.add_subcommand(
      "record-calibration",
      "Drive the paper's triangle-wave pressure excitation on one muscle (the other constant or in\n"
      "antiphase, the link moving with its payload), then the section's operating_points segments (further\n"
      "triangles that visit where the controller works), and log t_s, pressure_MPa, angle_rad, contraction,\n"
      "force_N, wire_velocity_mps at 250 Hz to a calibration CSV. Runs on the simulated rig, or on the\n"
      "board with --backend udp://... (the operator pins the link for the tare and each clamped segment;\n"
      "'peha mfb-emulator --case calibration_<muscle>' serves the simulated rig so); the excitation is the\n"
      "config's calibration.<muscle> section. Exit code 3 = the run on the board faulted (nothing written).");
  record_cmd->add_option("-c,--config", record.config, "Rig scenario YAML with a calibration: section")
      ->required()->check(CLI::ExistingFile);
  record_cmd->add_option("-m,--muscle", record.muscle, "Which muscle to excite")
      ->required()->check(CLI::IsMember({"agonist", "antagonist"}));
  record_cmd->add_option("-o,--out", record.out, "Calibration CSV to write (folders are created)")->required();
  s->seed_opt = record_cmd->add_option("--seed", s->seed, "Override the sensor-noise seed")->check(peha::app::unsigned_integer());
  peha::app::add_hardware_flags(*record_cmd, record.hardware, "the simulated rig");
  return {record_cmd, [s] {
            if (*s->seed_opt) s->record.seed = s->seed;
            return peha::app::record_calibration(s->record);
          }};
}

Command add_calibrate(CLI::App& app) {
  auto options = std::make_shared<peha::app::CalibrateCommandOptions>();
  peha::app::CalibrateCommandOptions& cal = *options;
  CLI::App* cal_cmd = app.add_subcommand(
      "calibrate",
      "Fit a muscle model to a calibration CSV (columns pressure_MPa, contraction, force_N; optional\n"
      "t_s, angle_rad, wire_velocity_mps): the 5 Tendon-spring parameters by Levenberg-Marquardt on the\n"
      "pressure error (best of --restarts random initialisations, on --threads threads), then an SPGP\n"
      "(FITC, ARD) on the residual. Two time-contiguous blocks of ten are held out and the held-out\n"
      "pressure RMS error is reported for the parametric model alone and with the SPGP. Writes the\n"
      "calibration YAML and a report folder (summary.txt, predictions.csv, report.png).\n"
      "Exit code 0 = written, 2 = bad data (nothing written) or a calibration refused by the --scenario's\n"
      "closed-loop check, 1 = other error.");
  cal_cmd->add_option("data", cal.data, "Calibration CSV")->required()->check(CLI::ExistingFile);
  cal_cmd->add_option("-o,--out", cal.out, "Calibration YAML to write")->required();
  cal_cmd->add_option("--report-dir", cal.report_dir, "Report folder (default: <out>_report)");
  cal_cmd->add_option("--muscle", cal.muscle, "The muscle the data are of, stored in the file; peha run refuses a file of another\n"
                                              "muscle (agonist|antagonist on E1's rig). Default: the one the recording's sidecar\n"
                                              "<csv>.meta.json names (peha record-calibration writes it); without either: refused");
  cal_cmd->add_option("--restarts", cal.restarts, "Random LM initialisations")->capture_default_str()->check(peha::app::signed_integer())->check(CLI::Range(1, 100000));
  cal_cmd->add_option("--threads", cal.threads, "Threads running the restarts")->capture_default_str()->check(peha::app::signed_integer())->check(CLI::Range(1, 256));
  cal_cmd->add_option("--pseudo-inputs", cal.pseudo_inputs, "SPGP pseudo-inputs M")->capture_default_str()->check(peha::app::signed_integer())->check(CLI::Range(1, 2000));
  cal_cmd->add_option("--spgp-iterations", cal.spgp_iterations, "SPGP optimiser iterations")->capture_default_str()->check(peha::app::signed_integer())->check(CLI::Range(1, 100000));
  cal_cmd->add_flag("!--no-spgp", cal.use_spgp, "Fit the parametric model only");
  cal_cmd->add_flag("!--no-holdout", cal.holdout, "Fit every row (no held-out figures; for comparisons)");
  cal_cmd->add_option("--min-rows", cal.min_rows, "Fewest rows accepted (static force maps may have fewer than 50)")
      ->capture_default_str()->check(peha::app::signed_integer())->check(CLI::Range(5, 100000000));
  cal_cmd->add_option("--seed", cal.seed, "Seed of the random initialisations and pseudo-inputs")->check(peha::app::unsigned_integer())->capture_default_str();
  cal_cmd->add_flag("!--no-plot", cal.plot, "Do not render report.png");
  cal_cmd->add_option("--scenario", cal.scenario,
                      "E1 scenario (e.g. configs/e1_one_dof.yaml; --muscle agonist|antagonist): the report adds where E1\n"
                      "works (operating_points.csv, the SPGP's std there), and its calibration.acceptance check runs on\n"
                      "its rig: the link clamped at E1's angles on pure feed-forward with this calibration; a failed check refuses the\n"
                      "calibration (exit 2, no calibration YAML written, the report is)")
      ->check(CLI::ExistingFile);
  cal_cmd->add_option("--other-calibration", cal.other_calibration,
                      "With --scenario: the other muscle's calibration YAML, used (with its SPGP) by the closed-loop check as\n"
                      "peha run will use the pair; without it the other muscle keeps the scenario's model")
      ->check(CLI::ExistingFile);
  return {cal_cmd, [options] { return peha::app::calibrate(*options); }};
}

Command add_check_sensors(CLI::App& app) {
  struct State {
    peha::app::CheckSensorsOptions options;
    double mass = 0, lever = 0;
    std::uint64_t seed = 0;
    CLI::Option *mass_opt, *lever_opt, *seed_opt;
  };
  auto s = std::make_shared<State>();
  CLI::App* cmd = app.add_subcommand(
      "check-sensors",
      "The one-DOF rig's sensor check on the simulated rig (the config's sensor_check: section): each load\n"
      "cell's vented zero on the pin, then a known mass swept slowly up and down through the check angle\n"
      "(the link alone, the mass, the mass against the antagonist), giving each cell's gain x pulley-radius\n"
      "product. Writes the corrections file an E1 scenario loads (controller: sensor_corrections: FILE).\n"
      "Exit code 0 = written, 2 = bad config or a check refused (nothing written), 1 = other error.");
  cmd->add_option("-c,--config", s->options.config, "E1 scenario YAML with a sensor_check: section")->required()->check(CLI::ExistingFile);
  cmd->add_option("-o,--out", s->options.out, "Corrections YAML to write (folders are created; never a file the scenario reads)")->required();
  s->mass_opt = cmd->add_option("--known-mass-kg", s->mass, "The mass the operator placed, kg (default: sensor_check.known_mass_kg;\n"
                                                            "the simulated rig carries the section's)")
                    ->check(peha::app::decimal())->check(CLI::Range(0.1, 20.0));
  s->lever_opt = cmd->add_option("--lever-m", s->lever, "Its lever from the joint axis, m (default: sensor_check.lever_m)")
                     ->check(peha::app::decimal())->check(CLI::Range(0.01, 2.0));
  s->seed_opt = cmd->add_option("--seed", s->seed, "Override the sensor-noise seed")->check(peha::app::unsigned_integer());
  return {cmd, [s] {
            if (*s->mass_opt) s->options.known_mass_kg = s->mass;
            if (*s->lever_opt) s->options.lever_m = s->lever;
            if (*s->seed_opt) s->options.seed = s->seed;
            return peha::app::check_sensors(s->options);
          }};
}

Command add_identify_gravity(CLI::App& app) {
  struct State {
    peha::app::IdentifyGravityOptions id;
    std::uint64_t seed = 0;
    CLI::Option* seed_opt;
  };
  auto s = std::make_shared<State>();
  CLI::App* cmd = app.add_subcommand(
      "identify-gravity",
      "Identify an arm's (or the upper body's) gravity parameters on the rig (docs/identification.md): the arm's own\n"
      "controller plus a PD on the encoders sweeps the arm slowly up and down through each posture of the\n"
      "config's identification: section; while the wires slide, the load cells (minus their zero) through the\n"
      "pulley radius plus the motor command give each joint's torque, and the two directions give gravity and\n"
      "the cables' friction ratio. A linear least squares on the gravity regressor tau = Y(q) theta, from the\n"
      "nominal model, gives theta, its std and the residual. Runs on the simulated arm (only what the rig\n"
      "measures is read), or on the board(s) with --backend udp://... ('peha mfb-emulator --case identification'\n"
      "serves the simulated arm so). Use the file with peha run --gravity-identification FILE or the arm config's\n"
      "controller.gravity_identification key.\n"
      "Exit code 0 = written, 2 = bad config or an identification refused (a joint stuck in a window, a fault\n"
      "the supervisor latched, the fit's residual, a torque far from the nominal model's: a wrong lever, sign\n"
      "or channel; nothing written), 1 = other error.");
  cmd->add_option("-c,--config", s->id.config, "Arm scenario YAML with an identification: section, e.g. configs/right_arm.yaml or configs/upper_body.yaml")
      ->required()->check(CLI::ExistingFile);
  cmd->add_option("-o,--out", s->id.out, "Identification YAML to write (folders are created), e.g. out/identification/gravity.yaml")
      ->required();
  s->seed_opt = cmd->add_option("--seed", s->seed, "Override the sensor-noise seed")->check(peha::app::unsigned_integer());
  peha::app::add_hardware_flags(*cmd, s->id.hardware, "the simulated arm");
  return {cmd, [s] {
            if (*s->seed_opt) s->id.seed = s->seed;
            return peha::app::identify_gravity(s->id);
          }};
}

Command add_mfb_emulator(CLI::App& app) {
  struct State {
    peha::app::EmulatorOptions emu;
    std::uint64_t seed = 0;
    double watchdog_ms = 0;
    CLI::Option *seed_opt, *watchdog_opt, *burst_packets_opt;
    std::uint64_t burst_packets = 0;
  };
  auto s = std::make_shared<State>();
  peha::app::EmulatorOptions& emu = s->emu;
  CLI::App* emu_cmd = app.add_subcommand(
      "mfb-emulator",
      "Serve the multifunction board's side of the MFB protocol (docs/mfb-protocol.md) over UDP, with the\n"
      "scenario's simulated plant behind it (the one-DOF rig, or an arm scenario's arm or upper body): AD codes from its sensors,\n"
      "DA codes to its valves and motor driver, encoder counts, through the config's channel map. Its own\n"
      "watchdog puts the outputs in a safe state (motor off, valves vented slowly) when no valid command\n"
      "arrives. Faults can be injected into the state packets it sends. Runs until Ctrl-C, --max-runtime\n"
      "or --sessions. A scenario on several boards (mfb: boards:, e.g. configs/upper_body.yaml) is served\n"
      "from this one process: board i listens on --port + i (each with its channel map, key and watchdog,\n"
      "in its own thread), all in front of one simulated body that steps once every board has its period's\n"
      "command (docs/channel-maps.md).");
  emu_cmd->add_option("-c,--config", emu.config, "Scenario YAML with an mfb: section")->required()->check(CLI::ExistingFile);
  emu_cmd->add_option("--case", emu.case_name, "One-DOF rig: the case whose plant (E1 payload, E5 clamp angle) to simulate (needed when the config\n"
                                               "has several), or calibration_agonist|calibration_antagonist (the rig pinned as peha\n"
                                               "record-calibration needs it). Arm scenarios: postures (E3, the default), identification (peha\n"
                                               "identify-gravity), free (the arm alone: a user's own controller, docs/user-controller.md)\n"
                                               "or goniometer_<movement> (E4)");
  emu_cmd->add_option("--bind", emu.bind, "IPv4 address to listen on")->capture_default_str();
  emu_cmd->add_option("-p,--port", emu.port, "UDP port (0 = any free port; the one taken is printed); several boards: board i at port + i")
      ->capture_default_str()->check(peha::app::signed_integer())->check(CLI::Range(0, 65535));
  s->seed_opt = emu_cmd->add_option("--seed", s->seed, "Override the sensor-noise seed")->check(peha::app::unsigned_integer());
  s->watchdog_opt = emu_cmd->add_option("--watchdog-ms", s->watchdog_ms, "Override the config's board_watchdog_ms")
      ->check(peha::app::decimal())->check(CLI::Range(2.0, 10000.0));
  emu_cmd->add_option("--loss", emu.loss, "Probability a state packet is dropped")->check(peha::app::decimal())->check(CLI::Range(0.0, 1.0));
  emu_cmd->add_option("--duplicate", emu.duplicate, "Probability a state packet is sent twice")->check(peha::app::decimal())->check(CLI::Range(0.0, 1.0));
  emu_cmd->add_option("--reorder", emu.reorder, "Probability a state packet is held back behind the next")->check(peha::app::decimal())->check(CLI::Range(0.0, 1.0));
  emu_cmd->add_option("--corrupt", emu.corrupt, "Probability one bit of a state packet is flipped")->check(peha::app::decimal())->check(CLI::Range(0.0, 1.0));
  emu_cmd->add_option("--delay-ms", emu.delay_ms, "Every state packet leaves this much later")->check(peha::app::decimal())->check(CLI::Range(0.0, 1000.0));
  emu_cmd->add_option("--fault-seed", emu.fault_seed, "Seed of the injected faults")->check(peha::app::unsigned_integer())->capture_default_str();
  emu_cmd->add_option("--estop-at", emu.estop_at_s, "Assert the e-stop input at this simulated time, s")->check(peha::app::decimal())->check(CLI::Range(0.0, 1e6));
  emu_cmd->add_option("--estop-for", emu.estop_for_s, "... for this long, s")->capture_default_str()->check(peha::app::decimal())->check(CLI::Range(0.0, 1e6));
  CLI::Option* burst_at = emu_cmd->add_option("--loss-burst-at", emu.loss_burst_at_s,
                                              "A loss burst: from this simulated time on, drop --loss-burst-packets consecutive\n"
                                              "state packets, s (needs --loss-burst-packets)")
                              ->check(peha::app::decimal())->check(CLI::Range(0.0, 1e6));
  s->burst_packets_opt = emu_cmd->add_option("--loss-burst-packets", s->burst_packets,
                                             "... this many state packets in a row (0 = every one from then on; needs --loss-burst-at)")
                             ->check(peha::app::unsigned_integer())->check(CLI::Range(std::uint64_t{0}, std::uint64_t{1'000'000'000}));
  burst_at->needs(s->burst_packets_opt);
  s->burst_packets_opt->needs(burst_at);
  emu_cmd->add_option("--bind-retry", emu.bind_retry_s, "If --port is taken, retry binding it for this long, s, printing 'waiting for'\n"
                                                       "once: a board that reboots (its successor started before it is gone)")
      ->check(peha::app::decimal())->check(CLI::Range(0.0, 60.0));
  emu_cmd->add_option("--truth-csv", emu.truth_csv, "When stopped, write the plant's truth per step (time, host monotonic ns, each\n"
                                                   "joint's angle and load cells - prefixed by its name when the map has several -,\n"
                                                   "armed, motor off) of the first 10 minutes to this CSV");
  emu_cmd->add_option("--rt-priority", emu.fifo_priority, "SCHED_FIFO priority of the board's loop (0 = don't ask)")
      ->capture_default_str()->check(peha::app::signed_integer())->check(CLI::Range(0, 99));
  emu_cmd->add_option("--cpu", emu.cpu, "Pin the board's loop to this CPU (-1 = don't pin)")
      ->capture_default_str()->check(peha::app::signed_integer())->check(CLI::Range(-1, 1023));
  emu_cmd->add_option("--max-runtime", emu.max_runtime_s, "Stop after this much wall time, s (0 = never)")->check(peha::app::decimal())->check(CLI::Range(0.0, 1e7));
  emu_cmd->add_option("--sessions", emu.sessions, "Stop after this many sessions ended by the watchdog (0 = never)")
      ->check(peha::app::signed_integer())->check(CLI::Range(0, 1000000));
  return {emu_cmd, [s] {
            if (*s->seed_opt) s->emu.seed = s->seed;
            if (*s->watchdog_opt) s->emu.watchdog_ms = s->watchdog_ms;
            if (*s->burst_packets_opt) s->emu.loss_burst_packets = s->burst_packets;
            return peha::app::mfb_emulator(s->emu);
          }};
}

Command add_check_config(CLI::App& app) {
  auto check_path = std::make_shared<std::filesystem::path>();
  CLI::App* check_cmd = app.add_subcommand(
      "check-config", "Parse and validate a scenario YAML (one-DOF rig or arm scenario, with its channel map if it has an\n"
                      "mfb: section; or a robustness matrix with the scenarios it names) without running it. Unknown keys,\n"
                      "missing keys, wrong types and out-of-range values are reported with file:line:column, key path\n"
                      "and reason.");
  check_cmd->add_option("-c,--config", *check_path, "Scenario YAML to check")->required()->check(CLI::ExistingFile);
  return {check_cmd, [check_path] { return peha::app::check_config(*check_path); }};
}

Command add_keygen(CLI::App& app) {
  auto out = std::make_shared<std::filesystem::path>();
  CLI::App* cmd = app.add_subcommand(
      "keygen", "Write a fresh link key for one installation (32 random bytes as 64 hex digits, mode 0600; docs/mfb-protocol.md#authentication):\n"
                "host and board read the same file (the scenario's mfb: key_file). Refuses to overwrite an existing file.\n"
                "The shipped development key is accepted only when every board is on loopback (127.0.0.0/8).");
  cmd->add_option("-o,--out", *out, "The key file to create")->required();
  return {cmd, [out] { return peha::app::keygen(*out); }};
}

Command add_robustness(CLI::App& app) {
  struct State {
    peha::app::RobustnessOptions options;
    int threads = 2;
    CLI::Option* threads_opt = nullptr;
  };
  auto s = std::make_shared<State>();
  CLI::App* cmd = app.add_subcommand(
      "robustness", "Run the robustness matrix (docs/robustness.md): E1 (default controller; pure feed-forward after\n"
                    "recording and calibrating on each variant) and E3 on plant variants x payloads x seeds. Variants\n"
                    "change only the plant. Prints one line per case; writes <out>/<run>/robustness.md (table),\n"
                    "robustness.csv, config.yaml and heatmap.png. Exit code 0 = every mode met its goal share,\n"
                    "3 = a mode missed it, 2 = bad config.");
  cmd->add_option("-c,--config", s->options.config, "Robustness YAML, e.g. configs/robustness.yaml")->required()->check(CLI::ExistingFile);
  cmd->add_option("-o,--out", s->options.out_root, "Directory under which the run directory is created")->capture_default_str();
  cmd->add_option("-n,--name", s->options.run_name, "Run directory name (default: <config stem>-<UTC time>)");
  s->threads_opt = cmd->add_option("--threads", s->threads, "Worker threads over the cases (default: the file's threads:)")
                       ->check(CLI::Range(1, 64));
  cmd->add_option("--variant", s->options.only_variant, "Run only the variant with this name");
  cmd->add_option("--mode", s->options.only_mode, "Run only this mode (it must be on in the file)")
      ->check(CLI::IsMember([] {
        std::vector<std::string> names;
        for (auto m : peha::experiments::kRobustnessModes) names.emplace_back(peha::experiments::to_string(m));
        return names;
      }()));
  cmd->add_flag("--keep-calibrations", s->options.keep_calibrations,
                "e1_calibrated_ff: write each variant's recordings and calibrations (refused ones too) to <run>/calibrations/");
  cmd->add_flag("!--no-plot", s->options.plot, "Do not render heatmap.png (no Python needed)");
  return {cmd, [s] {
            if (*s->threads_opt) s->options.threads = s->threads;
            return peha::app::robustness(s->options);
          }};
}

Command add_false_alarms(CLI::App& app) {
  struct State {
    peha::app::FalseAlarmsOptions options;
    int threads = 2, seeds = 20, variant_seeds = 5;
    CLI::Option *threads_opt = nullptr, *seeds_opt = nullptr, *variant_seeds_opt = nullptr;
  };
  auto s = std::make_shared<State>();
  CLI::App* cmd = app.add_subcommand(
      "false-alarms", "Measure every plausibility check on fault-free runs (docs/safety.md \"False alarms\"): E1 (every payload),\n"
                      "E3 and E4 on the arm scenarios, over seeds, raised sensor noise and the robustness matrix's plant variants.\n"
                      "Per check: runs, trips (false alarms), the largest ratio of its quantity to its threshold, the 99th\n"
                      "percentile, the margin and an estimated rate per hour. Prints one line per run; writes <out>/<run>/\n"
                      "false_alarms.md, false_alarms.csv, config.yaml and margins.png. Exit code 0 = no trip at x1 and x3 noise\n"
                      "and every margin at x1 >= the file's margin_goal, 3 = not, 2 = bad config.");
  cmd->add_option("-c,--config", s->options.config, "False-alarm YAML, e.g. configs/false_alarms.yaml")->required()->check(CLI::ExistingFile);
  cmd->add_option("-o,--out", s->options.out_root, "Directory under which the run directory is created")->capture_default_str();
  cmd->add_option("-n,--name", s->options.run_name, "Run directory name (default: <config stem>-<UTC time>)");
  s->threads_opt = cmd->add_option("--threads", s->threads, "Worker threads over the runs (default: the file's threads:)")->check(CLI::Range(1, 64));
  s->seeds_opt = cmd->add_option("--seeds", s->seeds, "Seeds per case and noise scale (default: the file's seeds:)")->check(CLI::Range(1, 1000));
  s->variant_seeds_opt = cmd->add_option("--variant-seeds", s->variant_seeds, "Seeds per plant variant (default: the file's variant_seeds:; 0: none)")
                             ->check(CLI::Range(0, 1000));
  cmd->add_flag("!--no-plot", s->options.plot, "Do not render margins.png (no Python needed)");
  return {cmd, [s] {
            if (*s->threads_opt) s->options.threads = s->threads;
            if (*s->seeds_opt) s->options.seeds = s->seeds;
            if (*s->variant_seeds_opt) s->options.variant_seeds = s->variant_seeds;
            return peha::app::false_alarms(s->options);
          }};
}

Command add_faults(CLI::App& app) {
  auto o = std::make_shared<peha::app::FaultsOptions>();
  CLI::App* cmd = app.add_subcommand(
      "faults", "Run the fault matrix (docs/safety.md): every fault the simulated plant can inject, at several moments\n"
                "of E1 (the start-up vent and tare, holding, during a push, after a release) or, for an arm scenario, of E3 on the elbow R_EFE\n"
                "(holding a posture, while the operator moves the arm, while the elbow itself moves, with the elbow\n"
                "flexed), in process with the supervisor's plausibility stage on. Prints one line per fault; writes\n"
                "<out>/<run>/faults.md, faults.csv and faults.png. Exit code 0 = no false alarm, every fault detected\n"
                "within 5 cycles, no limit exceeded unless physics forbids it; 3 otherwise; 2 = bad input.");
  cmd->add_option("-c,--config", o->config, "E1 or arm scenario YAML: configs/e1_one_dof.yaml, configs/right_arm.yaml, configs/upper_body.yaml")
      ->required()->check(CLI::ExistingFile);
  cmd->add_option("-o,--out", o->out_root, "Directory under which the run directory is created")->capture_default_str();
  cmd->add_option("-n,--name", o->run_name, "Run directory name (default: <config stem>-<UTC time>)")->check(peha::app::run_name());
  cmd->add_option("--case", o->case_name, "E1 case (default: the first); E3 has none");
  cmd->add_option("--fault-kind", o->kinds, "Only these fault kinds (repeatable)");
  cmd->add_option("--moment", o->moments, "Only these moments (repeatable): E1 startup_vent|tare|holding|push|after_release, E3 holding|moving|elbow_moving|elbow_flexed")
      ->check(CLI::IsMember({"startup_vent", "tare", "holding", "push", "after_release", "moving", "elbow_moving", "elbow_flexed"}));
  cmd->add_flag("!--no-plot", o->plot, "Do not render faults.png (no Python needed)");
  cmd->add_flag("--link", o->link,
                "Instead of the in-process matrix: E1's link faults over UDP (docs/safety.md \"The link's faults\"): starts\n"
                "`peha mfb-emulator` as a child process per row (random loss 1/5 %, loss bursts of 1/5/50/all state\n"
                "packets, duplicates, reordering, corruption, 3 ms delay, the e-stop input, the board stalled 200 ms,\n"
                "killed or rebooted (a fresh emulator on its port), the host killed (peha run as a second child, the\n"
                "board's watchdog observed), a spoofing sender), ~4 s of real time each (~80 s in all); writes\n"
                "<out>/<run>/faults_link.md and faults_link.csv. Exit 3 when a row misses its designed outcome");
  cmd->add_option("--link-fault", o->link_faults, "With --link: only these rows (repeatable; 'none' always runs)")
      ->check(CLI::IsMember(peha::experiments::link_fault_names()));
  return {cmd, [o] { return peha::app::faults(*o); }};
}

Command add_version(CLI::App& app) {
  return {app.add_subcommand("version", "Print peha's and MuJoCo's versions."), [] {
            fmt::print("peha 0.1.0 (MuJoCo {})\n", mj_versionString());
            return 0;
          }};
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "peha - control software for exoskeletons driven by pneumatic-electric hybrid actuators\n"
      "(pneumatic artificial muscles + geared motors, forces through Bowden cables; Noda et al., IROS 2014).\n"
      "Every command runs on the simulated exoskeleton unless told otherwise."};
  app.require_subcommand(1);
  app.set_version_flag("--version", std::string("peha 0.1.0"));

  const Command commands[] = {add_run(app), add_record_calibration(app), add_calibrate(app), add_identify_gravity(app), add_check_sensors(app), add_mfb_emulator(app),
                              add_check_config(app), add_keygen(app), add_robustness(app), add_false_alarms(app), add_faults(app),
                              add_version(app)};
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help and --version exit 0; every usage error exits 2, as a bad file does (docs/architecture.md).
    const int code = app.exit(e);
    return code == 0 ? 0 : 2;
  }
  for (const Command& command : commands) {
    if (!*command.app) continue;
    // The commands that run control loops end them at Ctrl-C and wind down (outputs off, logs
    // flushed); the others (a fit, a check) end at once, as without a handler.
    const std::string name = command.app->get_name();
    if (name != "run" && name != "record-calibration" && name != "identify-gravity" && name != "robustness" && name != "faults" &&
        name != "false-alarms") {
      return command.run();
    }
    const peha::runtime::InterruptHandler interrupt;
    const int code = command.run();
    if (!peha::runtime::interrupt_requested()) return code;
    fmt::print(stderr, "peha {}: interrupted (Ctrl-C): the run ended early, its figures and logs are incomplete (exit {})\n", name,
               peha::runtime::kInterruptedExitCode);
    return peha::runtime::kInterruptedExitCode;
  }
  return 0;
}
