#pragma once
/// \file
/// Experiment E1 (docs/e1-gravity-compensation.md, paper Fig. 9): gravity compensation of the one-DOF PEHA rig with each
/// payload of the scenario. The operator holds the link while compensation starts, then pushes it up
/// and down with a finger and lets go; with feed-forward compensation only (no position feedback) it
/// should stay where it was left. The scenario is entirely configuration (configs/e1_one_dof.yaml).

#include "peha/hardware/door.hpp"
#include "peha/experiments/calibration_recording/excitation.hpp"
#include "peha/experiments/sensor_check/sensor_check_params.hpp"
#include "peha/config/reader.hpp"
#include "peha/control/one_dof_gravity.hpp"
#include "peha/mfb/link_config.hpp"
#include "peha/runtime/log_telemetry.hpp"
#include "peha/runtime/control_loop.hpp"
#include "peha/runtime/lifecycle.hpp"
#include "peha/runtime/csv_log.hpp"
#include "peha/safety/limits.hpp"
#include "peha/safety/verdict.hpp"
#include "peha/sim/one_dof_rig.hpp"

#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace peha::experiments {

struct E1Case {
  std::string name;     ///< used in file names, e.g. "payload_2.5kg"
  double payload_kg = 0;
};

struct E1Scenario {
  std::string description;
  std::uint64_t seed = 1;
  double period_s = 1e-3;
  double duration_s = 20;
  double drift_window_s = 5;
  control::OneDofControllerModel controller;  ///< payload filled in per case
  safety::VerdictThresholds verdict;          ///< the optional `verdict:` section (defaults when absent)
  /// Per finger push (same order as plant.finger.pushes): 0 a normal push, +1 / -1 a breakaway
  /// probe up / down (`breakaway: up|down`): a slow force ramp that measures the finger force needed
  /// to start the link moving; probes are not releases (no drift figure).
  std::vector<int> probe_direction;
  safety::LimitsModel limits;
  sim::OneDofRigParams plant;                 ///< payload filled in per case
  std::vector<E1Case> cases;
  /// Optional `calibration:` section: the excitation of each muscle for `peha record-calibration`
  /// (index 0 agonist, 1 antagonist).
  std::optional<experiments::ExcitationParams> excitation[2];
  /// Optional `calibration.acceptance`: the closed-loop check a calibration must pass
  /// (experiments/calibration_recording/acceptance.hpp).
  std::optional<experiments::CalibrationAcceptance> acceptance;
  /// Optional `sensor_check:` section: the procedure of `peha check-sensors`.
  std::optional<experiments::SensorCheckParams> sensor_check;
  /// Optional `mfb:` section: how the scenario runs on the multifunction board over UDP.
  std::optional<mfb::LinkConfig> link;
  /// The lifecycle supervisor's parameters (`lifecycle:`): the same in process and on the board.
  runtime::SupervisorParams lifecycle;
  /// `controller.sensor_corrections`: the load-cell corrections file the controller uses (empty: none).
  std::filesystem::path sensor_corrections_file;
  /// The scenario's live telemetry (`telemetry:`, runtime::read_telemetry): what streams unless the command line says otherwise.
  runtime::TelemetryOptions telemetry;
};

/// Reads a whole E1 scenario file; throws config::Error on anything the schema does not accept.
E1Scenario read_e1(const config::Document& doc);
/// Empty when the lifting muscle alone (no motor: a safe state has none), by the controller's
/// model at the limits' supply, carries case `c`'s payload plus its pretension at every angle of
/// the range; otherwise why not (read_e1 refuses such a case before anything runs).
std::string e1_case_beyond_the_muscles(const E1Scenario& s, const E1Case& c);
/// The same for an experiment that shares E1's scenario (e.g. `wire_creep`): `experiment:` must be
/// `experiment`, and `extra` reads that experiment's own root sections before the root is finished.
E1Scenario read_e1(const config::Document& doc, const char* experiment, const std::function<void(config::Map&)>& extra);

struct E1Release {
  std::string push;           ///< the push that ended
  double time_s = 0;          ///< when the finger let go
  double angle_deg = 0;       ///< joint angle at release
  double drift_deg = 0;       ///< angle drift_window_s after release minus angle at release
  double max_excursion_deg = 0;  ///< largest |angle - angle at release| in the window
  /// Closest the joint came to either end of the limits' range in the window (deg; negative: past it).
  double stop_distance_deg = 0;
  /// The plant's gravity torque at the angle at the end of the window (truth, Nm, what holding needs).
  double gravity_torque_Nm = 0;
  /// Static torque error at rest, plant truth: the torque the friction holds (minus MuJoCo's
  /// friction and limit constraint torque) averaged over the last second of the window; + = the
  /// actuators push up more than gravity needs. NaN without the simulator's truth.
  double static_torque_error_Nm = 0;
  double static_torque_error_pct = 0;  ///< 100 x static_torque_error_Nm / |gravity_torque_Nm|
};

/// What a person can measure on hardware: the finger force at the link tip needed to start the link
/// moving up and down (breakaway probes), and the static torque error it implies. With the net
/// torque error r (+ = up) held by a friction band f: F_up L = f - r, F_down L = f + r, so
/// r = (F_down - F_up) L / 2 and f = (F_up + F_down) L / 2.
struct E1Breakaway {
  bool measured = false;              ///< both probes ran and both broke the link away
  double force_up_N = 0, force_down_N = 0;   ///< finger force at breakaway (NaN: it never broke away)
  double friction_band_Nm = 0;        ///< f
  double torque_error_Nm = 0;         ///< r, the estimate
  double torque_error_pct = 0;        ///< 100 r / |gravity torque| (plant's, at the probes' start angles)
  double truth_error_pct = 0;         ///< the truth figure (as E1Release) at rest just before the probes, mean of both
};

struct E1Result {
  std::string case_name;
  double payload_kg = 0;
  std::vector<E1Release> releases;
  double peak_finger_force_N = 0;       ///< over the pushes that move the link (not the holds)
  double peak_muscle_force_N[2] = {0, 0};   ///< plant truth, agonist and antagonist
  double min_wire_tension_N = 0;        ///< lowest tension on either wire anywhere (plant truth)
  double max_pressure_MPa = 0;          ///< highest chamber pressure (plant truth)
  double peak_motor_torque_Nm = 0;
  E1Breakaway breakaway;                ///< from the probes, if the scenario has them
  /// RMS of (commanded muscle force - load cell) over the run after the first second, agonist and
  /// antagonist: how well the muscle model turns force requests into forces.
  double force_tracking_rms_N[2] = {0, 0};
  double min_angle_deg = 0;             ///< lowest joint angle reached (plant truth)
  double max_angle_deg = 0;             ///< highest joint angle reached (plant truth)
  /// The envelope's checks (safety/verdict.hpp) and, per release, drift, distance to a stop and the
  /// static torque error against the scenario's `verdict:` thresholds.
  safety::Verdict verdict;
  std::uint64_t faults = 0;      ///< faults the supervisor's plausibility stage latched (a faulted run fails)
  std::uint32_t fault_flags = 0; ///< safety::FaultFlag bits latched at the end
  std::string fault_reason;      ///< the first fault: flag, joint, muscle, value, threshold, time, safe state
  safety::CheckPeaks check_peaks{};  ///< every check's largest ratio to its threshold (FaultMonitor::peaks)
  std::uint32_t first_fault_flag = 0;  ///< the run's first latched FaultFlag (0: none; FaultMonitor::first)
  /// The run's lifecycle transitions (runtime::Supervisor: the link's faults, the recoveries), oldest first.
  std::vector<runtime::LifecycleEvent> lifecycle;
  bool within_limits = false;           ///< verdict.passed(): every figure held
  double realtime_factor = 0;           ///< simulated time / wall time
  double simulated_s = 0;
  /// Where the figures come from: the simulator's truth (in-process) or, over a real backend
  /// (UDP to the MFB), the sensors: encoder angle, load cells, pressure sensors, commanded motor
  /// torque; the finger's force is then unknown (NaN) and wire tension is the load cells' reading.
  bool from_truth = true;
  std::uint64_t missed_samples = 0;     ///< cycles the backend had no new sample (command held)
  std::uint64_t limit_counts[5] = {0, 0, 0, 0, 0};  ///< by safety::LimitFlag bit
  /// Start-up tare (loadcell_check.tare_s > 0): the offsets subtracted from the load cells
  /// (agonist, antagonist), and until when the wires were slack on purpose (vent, tare, refill;
  /// their tension is not judged before this instant). 0 without a tare.
  double loadcell_tare_N[2] = {0, 0};
  double tare_slack_s = 0;
};

/// Column names of the per-cycle log.
const std::vector<std::string>& e1_log_columns();

/// Runs one case on the in-process simulated rig (as fast as it computes). `log` (optional)
/// receives one row per control cycle.
E1Result run_e1_case(const E1Scenario& scenario, const E1Case& c, runtime::RowSink* log);

/// Runs one case on any backend: the same controller, limits and analysis. `sim` (optional) is
/// the in-process rig when `backend` is it, for truth figures; without it the figures come from
/// the sensors (see E1Result::from_truth). A cycle whose read() fails re-sends the last command.
E1Result run_e1_on(const E1Scenario& scenario, const E1Case& c, io::Backend& backend, sim::OneDofRigBackend* sim,
                   runtime::RowSink* log, const runtime::CycleHooks& hooks = {});

/// What a run on the one-DOF rig declares to the hardware door: its one joint, `period_s`, the
/// scenario's `link` (one board), the simulated rig `plant` (sim:), unprefixed log columns (replay:).
/// E1's, E5's and the recording's requests.
hardware::HardwareRequest one_dof_rig_hardware(double period_s, const std::optional<mfb::LinkConfig>& link, const sim::OneDofRigParams& plant);

/// What a case declares to the hardware door (hardware::open_backend): the rig's one joint, the
/// scenario's period and mfb: section (one board), its simulated rig with the case's payload (sim:),
/// the log's unprefixed sensor columns (replay:).
hardware::HardwareRequest e1_hardware(const E1Scenario& scenario, const E1Case& c);

/// The controller's model of a case (the scenario's, with the case's payload).
control::OneDofControllerModel e1_controller_model(const E1Scenario& scenario, const E1Case& c);
/// The simulated rig's parameters for a case (the scenario's plant with the case's payload).
sim::OneDofRigParams e1_plant_params(const E1Scenario& scenario, const E1Case& c);

/// Loads a corrections file of `peha check-sensors` (calibration/sensor_corrections.hpp) into the
/// controller's load-cell corrections; its zeros are checked against the tare's max_tare_N.
void use_sensor_corrections(E1Scenario& scenario, const std::filesystem::path& path);

/// Switches the start-up load-cell tare off in a scenario whose controller carries calibrated
/// muscle models. The tare assumes the vented muscles make no force: the limits layer keeps each
/// muscle at its model's pretension pressure, which in the configured (nominal) model lies below the
/// real muscle's pressure threshold. A calibrated model is right there: it holds the real pretension
/// during the "vent" (nominal rig: +61 N antagonist, +7 N agonist), and the tare would subtract it as
/// an offset. A calibration's forces are raw load-cell readings, so the calibration already fixes
/// each load cell's zero (a load-cell bias is part of the fitted model).
void use_calibration_loadcell_zero(E1Scenario& scenario);

/// The calibration recording of muscle `index` (0 agonist, 1 antagonist) on the simulated rig
/// `plant` (its finger pushes cleared, the excitation's payload set): the excitation of the
/// scenario's `calibration:` section through the scenario's limits and the controller's joint
/// geometry. What `peha record-calibration` and the robustness matrix record. Throws
/// config::Error when the scenario has no such section.
calibration::Dataset record_e1_muscle(const E1Scenario& scenario, sim::OneDofRigParams plant, int index,
                                      const std::function<void(double)>& progress = {});
/// The simulated rig of the calibration recording of muscle `index`: `plant` with the excitation's
/// payload, no finger pushes, and the clamp for the tare and each clamped segment - what the
/// operator's pin does on the real rig (also what `peha mfb-emulator --case calibration_<muscle>`
/// serves). Throws config::Error when the scenario has no such section.
sim::OneDofRigParams e1_recording_plant_params(const E1Scenario& scenario, sim::OneDofRigParams plant, int index);
/// What the calibration recording of muscle `index` declares to the hardware door: E1's rig, its
/// simulated form the pinned rig of e1_recording_plant_params with `plant`.
hardware::HardwareRequest e1_recording_hardware(const E1Scenario& scenario, const sim::OneDofRigParams& plant, int index);
/// The limits of a recording: the scenario's, with the plausibility monitor off (the excitation
/// sweeps a muscle far from the controller's model on purpose).
safety::LimitsModel e1_recording_limits(const E1Scenario& scenario);

/// The torque (Nm) that holds the plant's link still at `angle_rad` against gravity (MuJoCo's
/// qfrc_bias at rest, the plant's MJCF with its payload): the truth the static torque error is a
/// percentage of.
double e1_plant_gravity_torque_Nm(const sim::OneDofRigParams& plant, double angle_rad);

}  // namespace peha::experiments
