#pragma once
/// \file
/// Experiment E4 (docs/right-arm.md, paper Section V): the exoskeleton's elbow follows a person's elbow.
/// A goniometer on the person's elbow is sampled at 200 Hz (noise and quantisation included); its
/// reading is low-passed by a Butterworth filter and differentiated (control::FilteredDerivative),
/// and the inverse dynamics of the forearm + hand (the controller's own nominal arm model) turn
/// angle, velocity and acceleration into the elbow's torque command. The shoulder keeps gravity
/// compensation, the wrist is held at constant pressure. In the paper's variant the path is open
/// loop: nothing feeds the exoskeleton's own elbow angle back, so the figures measure how well the
/// torque chain (model, filter, allocation, Bowden compensation, valves) alone reproduces the
/// person's movement. A second variant adds an impedance toward the person's angle (beyond the paper).
///
/// The person's movement is either synthetic (minimum-jerk flexion/extension from the scenario's
/// `goniometer.movements`) or a recorded goniometer CSV (`t_s` and `elbow_angle_deg` or
/// `elbow_angle_rad`, sampled at the configured rate).

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
  double duration_s() const { return static_cast<double>(measured_rad.size()) / sample_rate_Hz; }
};

/// The synthetic person of a scenario movement; noise and quantisation drawn from `seed`.
GoniometerTrace synthesize_goniometer(const ArmScenario::Goniometer& g, const ArmScenario::Goniometer::Movement& m,
                                      std::uint64_t seed);

/// Reads a recorded goniometer CSV (`#` comment lines, a header with `t_s` and one of
/// `elbow_angle_deg` / `elbow_angle_rad`, then rows). The samples must be evenly spaced at
/// `sample_rate_Hz` (within 2 %), finite and inside [min_rad, max_rad] (the exoskeleton's elbow
/// range). Throws calibration::DataError naming file, line and column; nothing is half-read.
GoniometerTrace read_goniometer_csv(const std::filesystem::path& path, double sample_rate_Hz, double min_rad,
                                    double max_rad);

/// Writes `trace.measured_rad` in the format read_goniometer_csv reads (t_s, elbow_angle_deg).
void write_goniometer_csv(const std::filesystem::path& path, const GoniometerTrace& trace);

/// How the elbow torque is made from the goniometer.
enum class GoniometerVariant {
  kOpenLoop,  ///< the paper: inverse dynamics of the person's filtered movement, nothing fed back
  kFeedback,  ///< beyond the paper: + an impedance from the exoskeleton's encoder toward the person
};
const char* to_string(GoniometerVariant v);

struct GoniometerResult {
  std::string name;
  GoniometerVariant variant = GoniometerVariant::kOpenLoop;
  double rms_error_deg = 0;     ///< RMS of exo elbow - person's elbow while the person moves and after
  double max_error_deg = 0;     ///< largest |exo elbow - person's elbow| over the same window
  double delay_s = 0;           ///< lag that best aligns the exo's elbow with the person's
  double rms_error_aligned_deg = 0;  ///< RMS error after shifting by delay_s (shape, not lag)
  double filter_delay_s = 0;    ///< the Butterworth's group delay at DC (part of delay_s)
  double range_deg = 0;         ///< the person's range of movement in the window
  double peak_torque_command_Nm = 0;  ///< elbow, from the inverse dynamics
  double peak_muscle_force_N = 0;     ///< any muscle, plant truth
  double min_wire_tension_N = 0;      ///< any wire, plant truth
  double peak_motor_torque_Nm = 0;
  double shoulder_excursion_deg = 0;  ///< largest |SFE - SFE at release|: does the shoulder hold?
  double realtime_factor = 0;
  /// The safety envelope's checks (safety/verdict.hpp) and the tracking figures (RMS and max error)
  /// against the scenario's `verdict:` thresholds.
  safety::Verdict verdict;
  bool within_limits = false;         ///< verdict.passed()
};

const std::vector<std::string>& goniometer_log_columns();

/// Runs E4 for one trace on the in-process simulated arm. `log` (optional) gets one row per cycle.
GoniometerResult run_goniometer(const ArmScenario& scenario, const GoniometerTrace& trace, GoniometerVariant variant,
                                runtime::RowSink* log);

/// The goniometer's reading (rad) at time t_s of an E4 run: the trace's first sample during
/// settle_s, then the trace, then its last sample. What the board emulator puts on the goniometer's
/// AD channel.
double goniometer_reading(const ArmScenario& scenario, const GoniometerTrace& trace, double t_s) noexcept;
/// How long an E4 run of `trace` lasts: settle_s + the trace + tail_s.
double goniometer_run_duration_s(const ArmScenario& scenario, const GoniometerTrace& trace);
/// The simulated arm of an E4 run: shoulder at goniometer.sfe_deg, elbow where the person starts,
/// the operator holding it until settle_s - 1.
sim::ArmPlantParams goniometer_plant_params(const ArmScenario& scenario, const GoniometerTrace& trace);

/// A goniometer angle (rad) as a function of the run's time (s).
using GoniometerSource = std::function<double(double t_s)>;

/// E4 on any backend. `reading` gives the goniometer (sampled every 1/sample_rate_Hz); `person`
/// the person's true elbow for the figures (empty: the goniometer's reading is all that is known,
/// as over the board). `sim` (optional) is the in-process arm for truth figures; without it the
/// exoskeleton's elbow is its encoder and forces are the load cells'.
GoniometerResult run_goniometer_on(const ArmScenario& scenario, const std::string& name, GoniometerVariant variant, double duration_s,
                                   io::Backend& backend, const sim::ArmBackend* sim, const GoniometerSource& reading,
                                   const GoniometerSource& person, runtime::RowSink* log, const runtime::CycleHooks& hooks = {});

}  // namespace peha::experiments
