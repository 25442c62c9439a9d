#pragma once
/// \file
/// The robustness matrix (docs/robustness.md): E1 and E3 on plant variants x payloads x seeds,
/// each judged by the experiment's own verdict, with the goals of issue 10 reported beside it.
/// A variant changes only the plant (the truth); the controller keeps its nominal model. In the
/// calibrated feed-forward mode the controller's muscle models come from a calibration recorded and
/// fitted on that variant (the code of `peha record-calibration` and `peha calibrate`).

#include "peha/config/reader.hpp"
#include "peha/experiments/e1_gravity/e1_gravity.hpp"
#include "peha/experiments/arm/arm_scenario.hpp"

#include <cstdint>
#include <filesystem>
#include <functional>
#include <limits>
#include <string>
#include <vector>

namespace peha::experiments {

/// One plant variant: factors on the nominal plant (1 = unchanged) and offsets (0 = unchanged).
struct PlantVariant {
  std::string name;
  double cable_friction_scale = 1;   ///< kinetic and static friction of every cable
  double valve_time_scale = 1;       ///< dead time and lag of every valve
  double muscle_strength_scale = 1;  ///< gain (force per pressure) of every muscle's static law
  double wire_stiffness_scale = 1;   ///< every inner wire + housing
  double loadcell_bias_N = 0;        ///< added to every load cell (plant knob loadcell_offset_N)
  /// One sensor's own calibration error (equal errors on both cells cancel in a torque balance):
  /// added to that muscle's load cell of every joint, N, and its gain, x.
  double agonist_loadcell_bias_N = 0, antagonist_loadcell_bias_N = 0;
  double agonist_loadcell_gain_scale = 1, antagonist_loadcell_gain_scale = 1;
  double pulley_radius_scale = 1;    ///< every joint's pulley (the controller keeps its nominal radius)
  double sensor_noise_scale = 1;     ///< load-cell and pressure-sensor noise
  double link_mass_scale = 1;        ///< E1: the link (as the payload with the same gravity torque); E3: the exoskeleton's links
  double payload_scale = 1;          ///< E1: the case's payload; E3: the mannequin arm - the controller is not told
  double extra_payload_kg = 0;       ///< E1: at the payload; E3: in the hand - the controller is not told
  /// The plant's gravity differs from the controller's model: with no position feedback a
  /// feed-forward controller cannot meet a static torque target (docs/robustness.md).
  bool changes_gravity() const noexcept {
    return link_mass_scale != 1 || payload_scale != 1 || extra_payload_kg != 0;
  }
  /// No cable friction at all: nothing holds a joint still but the controller's torque balance, so with
  /// no position feedback any error of its gravity model moves the joint (a neutral equilibrium: the
  /// feed-forward follows the joint wherever it goes); drift and static error are out of reach.
  bool removes_friction() const noexcept { return cable_friction_scale == 0; }
};

enum class RobustnessMode {
  kE1Default,       ///< E1 with the scenario's controller (force trim on)
  kE1CalibratedFF,  ///< E1 on the paper's pure feed-forward after calibrating both muscles on the variant
  kE3,              ///< E3 postures with the arm scenario's controller as shipped
  kE3Identified,    ///< E3 after identifying the arm's gravity parameters on the variant (peha identify-gravity)
};
/// Every mode, in the order the file's `modes:` and the table list them.
inline constexpr RobustnessMode kRobustnessModes[] = {RobustnessMode::kE1Default, RobustnessMode::kE1CalibratedFF,
                                                      RobustnessMode::kE3, RobustnessMode::kE3Identified};
const char* to_string(RobustnessMode m);
/// The modes' names, ", "-separated (for messages).
std::string robustness_mode_names();

struct RobustnessGoal {
  double max_static_error_pct = 5;   ///< |static torque error| at every release
  double min_tension_fraction = 0.5; ///< lowest wire tension / pretension
  double min_share = 1.0;            ///< of the variants that must meet both
};

struct RobustnessConfig {
  std::filesystem::path e1_config, arm_config;
  std::vector<RobustnessMode> modes;
  std::vector<PlantVariant> variants;
  std::vector<std::uint64_t> seeds;
  std::vector<std::string> e1_cases;   ///< E1 cases (payloads) to run (`e1_case: NAME`: one); empty: all of the scenario's
  int threads = 2;                     ///< worker threads over the cases
  int calibration_restarts = 30;       ///< LM restarts per muscle in the calibrated mode
  int calibration_pseudo_inputs = 50;  ///< SPGP pseudo-inputs
  int calibration_spgp_iterations = 300;  ///< SPGP optimiser iterations
  double e1_duration_s = 0;            ///< > 0: shorten the E1 scenario (tests); 0: the scenario's
  /// Not empty: the calibrated mode writes each variant's recordings and calibrations here
  /// (<variant>-seed<N>-<muscle>.csv/.yaml), refused ones included, to be inspected or replotted.
  std::filesystem::path keep_calibrations_dir;
  RobustnessGoal goal_default{5, 0.5, 1.0};
  RobustnessGoal goal_calibrated{10, 0.2, 0.9};
  RobustnessGoal goal_e3{5, 0.5, 1.0};
  RobustnessGoal goal_e3_identified{5, 0.5, 1.0};
};

/// Reads a robustness file (configs/robustness.yaml); throws config::Error.
RobustnessConfig read_robustness(const config::Document& doc);

/// One variant x payload x mode x seed.
struct RobustnessRow {
  std::string variant, mode, payload;
  std::uint64_t seed = 1;
  double static_error_pct = 0;   ///< worst |static torque error| over the releases, % of gravity (NaN: not measured)
  double breakaway_error_pct = 0;///< E1: the hardware estimate from the breakaway probes (NaN: none)
  /// E3: worst |controller's gravity torque - plant's| at rest, % of the plant's (truth): the static
  /// error no feed-forward can remove (NaN: not measured)
  double model_gravity_error_pct = std::numeric_limits<double>::quiet_NaN();
  double drift_deg = 0;          ///< worst |drift| over the releases (and joints)
  double min_tension_N = 0;
  double tension_fraction = 0;   ///< min_tension_N / the joint's pretension (worst joint)
  bool verdict = false;          ///< the experiment's verdict
  bool goal = false;             ///< the goal of this mode (static error and tension)
  bool physics_forbids = false;  ///< physics forbids the goal to a controller without position feedback (physics_reason says why)
  std::string physics_reason;    ///< why physics forbids it ("" when it does not)
  std::string failures;          ///< the verdict's failed figures, "; "-separated
  double seconds = 0;            ///< wall time of the case
};

struct RobustnessResult {
  std::vector<RobustnessRow> rows;
  /// Per mode: variants x payloads x seeds that met the goal, and how many ran.
  /// The share is judged over the cases physics allows: a case marked physics_forbids that misses
  /// the goal is reported (table, note, verdict FAIL) but not counted against the required share.
  struct Share {
    std::string mode;
    std::size_t met = 0, total = 0;
    std::size_t forbidden = 0;  ///< physics_forbids and the goal missed
    double required = 1;
    std::size_t judged() const noexcept { return total - forbidden; }
    bool ok() const noexcept { return judged() && static_cast<double>(met) >= required * static_cast<double>(judged()); }
  };
  std::vector<Share> shares;
};

/// Reads one variant mapping (name and the factors above; the same keys as the matrix's `variants:`).
PlantVariant read_plant_variant(config::Map m);

/// The plant of an E1 case under `v` (the controller is untouched).
sim::OneDofRigParams e1_variant_plant(const E1Scenario& scenario, const E1Case& c, const PlantVariant& v);
/// The arm scenario's plant under `v`.
sim::ArmPlantParams arm_variant_plant(const ArmScenario& scenario, const PlantVariant& v);

/// Runs the matrix; `progress(done, total, line)` after each case (from the worker threads, serialised).
RobustnessResult run_robustness(const RobustnessConfig& config,
                                const std::function<void(std::size_t, std::size_t, const std::string&)>& progress = {});

/// robustness.csv (one row per case) and robustness.md (the table, the shares against the goals).
void write_robustness(const std::filesystem::path& dir, const RobustnessConfig& config, const RobustnessResult& result);

}  // namespace peha::experiments
