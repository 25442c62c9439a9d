#pragma once
/// \file
/// Experiment E4 (docs/right-arm.md, docs/upper-body.md, paper Section V): the exoskeleton's elbow
/// follows a person's elbow - or each of the scenario's `goniometer.joints` (both elbows of the upper
/// body) its own goniometer. Each goniometer is sampled at 200 Hz (noise and quantisation included);
/// its reading is low-passed by a Butterworth filter and differentiated (control::FilteredDerivative),
/// and the inverse dynamics of the controller's own nominal arm model turn angle, velocity and
/// acceleration into the driven joint's torque command (the derivatives smoothed, the reference
/// extrapolated at the control rate). The held joints get their row of the same inverse dynamics plus
/// an impedance toward the scenario's held posture (the wrists keep their constant pressure). In the paper's variant the path is open
/// loop: nothing feeds the exoskeleton's own elbow angle back, so the figures measure how well the
/// torque chain (model, filter, allocation, Bowden compensation, valves) alone reproduces the
/// person's movement. A second variant adds an impedance toward the person's angle (beyond the paper).
///
/// The person's movement is either synthetic (minimum-jerk flexion/extension from the scenario's
/// `goniometer.movements`) or a recorded goniometer CSV (`t_s` and `elbow_angle_deg` or
/// `elbow_angle_rad`, sampled at the configured rate) that drives every driven joint alike.

#include "peha/runtime/csv_log.hpp"
#include "peha/experiments/e3_postures/postures.hpp"

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

namespace peha::experiments {

/// What the goniometer delivers, sample by sample, and what the person's elbow really did.
struct GoniometerTrace {
  std::string name;                 ///< e.g. "slow", or the recorded file's stem
  double sample_rate_Hz = 200;
  std::vector<double> measured_rad; ///< the goniometer's readings, one per sample
  std::vector<double> truth_rad;    ///< the person's elbow at each sample (= measured for a recording)
  /// What the person means to do: truth_rad without the person's tremor (= truth_rad for a recording
  /// or a person without one). E4's tracking figures are judged against it: a tremor is not followed.
  std::vector<double> voluntary_rad;
  double duration_s() const { return static_cast<double>(measured_rad.size()) / sample_rate_Hz; }
};

/// The synthetic person of a scenario movement; noise and quantisation drawn from `seed`.
GoniometerTrace synthesize_goniometer(const ArmScenario::Goniometer& g, const ArmScenario::Goniometer::Movement& m,
                                      std::uint64_t seed);
/// The person's movement `m` on every driven joint (goniometer.joints order): the same movement, each
/// goniometer with its own noise - the first drawn from `seed` (a one-joint run is
/// synthesize_goniometer's), the k-th from goniometer_noise_seed(seed, k).
std::vector<GoniometerTrace> synthesize_goniometers(const ArmScenario::Goniometer& g, const ArmScenario::Goniometer::Movement& m,
                                                    std::uint64_t seed);
/// The noise seed of the k-th driven joint's goniometer: `seed` for k = 0.
std::uint64_t goniometer_noise_seed(std::uint64_t seed, std::size_t k) noexcept;

/// Reads a recorded goniometer CSV (a header with `t_s` and one of `elbow_angle_deg` /
/// `elbow_angle_rad`, then rows; `#` lines, as older recordings have, are skipped). The samples must be evenly spaced at
/// `sample_rate_Hz` (within 2 %), finite and inside [min_rad, max_rad] (the exoskeleton's elbow
/// range). Throws calibration::DataError naming file, line and column; nothing is half-read.
GoniometerTrace read_goniometer_csv(const std::filesystem::path& path, double sample_rate_Hz, double min_rad,
                                    double max_rad);

/// Writes `trace.measured_rad` in the format read_goniometer_csv reads (t_s, elbow_angle_deg), the
/// header first; the recording's name and sample rate go to the sidecar `<path>.meta.json`.
void write_goniometer_csv(const std::filesystem::path& path, const GoniometerTrace& trace);

/// How each driven joint's torque is made from its goniometer.
enum class GoniometerVariant {
  kOpenLoop,  ///< the paper: inverse dynamics of the person's filtered movement, nothing fed back
  kFeedback,  ///< beyond the paper: + an impedance from the exoskeleton's encoder toward the person
};
const char* to_string(GoniometerVariant v);

/// The figures of one driven joint (the elbows on the upper body) in an E4 run.
struct GoniometerJointResult {
  std::string joint;            ///< io joint, e.g. "R_EFE"
  double rms_error_deg = 0;     ///< RMS of exo joint - person's joint from the release to the end
  double max_error_deg = 0;     ///< largest |exo joint - person's joint| over the same window
  double delay_s = 0;           ///< lag that best aligns the exo's joint with the person's
  double rms_error_aligned_deg = 0;  ///< RMS error after shifting by delay_s (shape, not lag)
  double range_deg = 0;         ///< the person's range of movement in the window
  double peak_torque_command_Nm = 0;  ///< from the inverse dynamics (+ impedance)
  double min_wire_tension_N = 0;      ///< this joint's wires, plant truth (load cells over the board)
  /// Largest |q - q at release| of the held joints of its side (goniometer.angles_deg): do they hold?
  double held_excursion_deg = 0;
  /// RMS of the torque command above goniometer.thresholds.command_hf_above_Hz, from the release on, Nm
  double command_hf_rms_Nm = 0;
  /// Lag of the (smoothed) command behind the un-smoothed one, by cross-correlation, s
  double command_delay_s = 0;
};

/// One joint's figure of an E4 run that is not a driven joint's: a held joint's excursion (deg), a
/// passive joint's peak speed (deg/s).
struct GoniometerJointFigure {
  std::string joint;
  double value = 0;
};

struct GoniometerResult {
  std::string name;
  GoniometerVariant variant = GoniometerVariant::kOpenLoop;
  std::vector<GoniometerJointResult> joints;  ///< one per driven joint, goniometer.joints order
  double filter_delay_s = 0;    ///< the Butterworth's group delay at DC (part of each delay_s)
  double peak_muscle_force_N = 0;     ///< any muscle, plant truth
  double min_wire_tension_N = 0;      ///< any wire, plant truth
  double peak_motor_torque_Nm = 0;
  double realtime_factor = 0;
  /// The run's lifecycle transitions (runtime::Supervisor: the link's faults, the recoveries), oldest first.
  std::vector<runtime::LifecycleEvent> lifecycle;
  std::vector<GoniometerJointFigure> held;     ///< each held joint's largest |q - q at release|, deg
  std::vector<GoniometerJointFigure> passive;  ///< each joint at a constant pressure: peak |speed| after the release, deg/s
  /// The safety envelope's checks (safety/verdict.hpp) and each driven joint's tracking figures
  /// ("R_EFE tracking RMS error", "... max error") against the scenario's `verdict:` thresholds; the
  /// torque command's high-frequency RMS and smoothing delay, each held joint's excursion and each
  /// passive joint's peak speed against `goniometer.thresholds`.
  safety::Verdict verdict;
  bool within_limits = false;         ///< verdict.passed()
  std::uint32_t fault_flags = 0;      ///< safety::FaultFlag bits latched at the end
  safety::CheckPeaks check_peaks{};   ///< every check's largest ratio to its threshold (FaultMonitor::peaks)
  std::uint32_t first_fault_flag = 0;  ///< the run's first latched FaultFlag (0: none; FaultMonitor::first)
};

/// The per-cycle log's columns: t_s, operator_active; per driven joint its goniometer, filter,
/// command and angle (person_elbow_deg, ..., elbow_encoder_deg); per held joint its angle and gravity
/// torque (plant_<joint>_deg, tau_<joint>_gravity_Nm); per driven joint its actuator (tau_motor_cmd_Nm,
/// ..., plant_antagonist_force_N); plant_tension_min_N; then per io joint what a replay needs and
/// the columns above lack (hardware::kSensorColumns, kCommandColumns: "angle_rad", ..., "sfe_angle_rad",
/// ..., "wfe_tau_motor_cmd_Nm"). Each joint's columns start with goniometer_log_prefix.
std::vector<std::string> goniometer_log_columns(const ArmScenario& scenario);
/// An io joint's column prefix in E4's log: none for the one driven joint of a single-elbow run
/// ("person_elbow_deg"), else its log name (arm_log_prefix: "r_efe_", "sfe_").
std::string goniometer_log_prefix(const ArmScenario& scenario, std::size_t io_joint);
/// What E4 declares to the hardware door: arm_hardware on `plant` (one board: the goniometers' AD
/// channels are on it) with goniometer_log_prefix as each joint's log prefix (replay:).
hardware::HardwareRequest goniometer_hardware(const ArmScenario& scenario, const sim::ArmPlantParams& plant);

/// Runs E4 on the in-process simulated arm (the door's sim:), one trace per driven joint
/// (goniometer.joints order, all of the same length). `log` (optional) gets one row per cycle. Throws
/// std::invalid_argument on a wrong number of traces.
GoniometerResult run_goniometer(const ArmScenario& scenario, const std::vector<GoniometerTrace>& traces, GoniometerVariant variant,
                                runtime::RowSink* log);
/// The same on the door's in-process `hw`: the simulated arm of `traces` (goniometer_hardware with
/// goniometer_plant_params), or a recorded E4 log (replay:), whose goniometer columns are then the
/// readings and the person (logged_goniometers); `traces` give the run's length and name.
GoniometerResult run_goniometer(const ArmScenario& scenario, const std::vector<GoniometerTrace>& traces, GoniometerVariant variant,
                                const hardware::Hardware& hw, runtime::RowSink* log);

/// The goniometer's reading (rad) at time t_s of an E4 run: the trace's first sample during
/// settle_s, then the trace, then its last sample. What the board emulator puts on the goniometer's
/// AD channel.
double goniometer_reading(const ArmScenario& scenario, const GoniometerTrace& trace, double t_s) noexcept;
/// How long an E4 run of `trace` lasts: settle_s + the trace + tail_s.
double goniometer_run_duration_s(const ArmScenario& scenario, const GoniometerTrace& trace);
/// The simulated arm of an E4 run: the held joints at goniometer.angles_deg, each driven joint where
/// its person starts (traces in goniometer.joints order), the operator holding it until settle_s - 1.
sim::ArmPlantParams goniometer_plant_params(const ArmScenario& scenario, const std::vector<GoniometerTrace>& traces);

/// A goniometer angle (rad) as a function of the run's time (s).
using GoniometerSource = std::function<double(double t_s)>;

/// Each driven joint's goniometer as a recorded E4 log has it (goniometer.joints order; column
/// <goniometer_log_prefix>goniometer_deg): at time t the row of t_s = t, or the last before it.
/// Throws std::runtime_error naming a missing column.
std::vector<GoniometerSource> logged_goniometers(const ArmScenario& scenario, const std::filesystem::path& log);

/// E4 on any backend. `readings` give each driven joint's goniometer (goniometer.joints order, sampled
/// every 1/sample_rate_Hz); `persons` the person's true joints for the figures (empty: the goniometers'
/// readings are all that is known, as over the board). `sim` (optional) is the in-process arm for
/// truth figures; without it the exoskeleton's joints are its encoders and forces are the load cells'.
/// Throws std::invalid_argument on a wrong number of readings or persons.
GoniometerResult run_goniometer_on(const ArmScenario& scenario, const std::string& name, GoniometerVariant variant, double duration_s,
                                   io::Backend& backend, sim::ArmBackend* sim, const std::vector<GoniometerSource>& readings,
                                   const std::vector<GoniometerSource>& persons, runtime::RowSink* log,
                                   const runtime::CycleHooks& hooks = {});

}  // namespace peha::experiments
