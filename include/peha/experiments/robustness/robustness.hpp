#pragma once
/// \file
/// The robustness matrix (docs/robustness.md): E1 and E3 on plant variants x payloads x seeds, and E4
/// on plant variants x paces plus persons, each judged by the experiment's own verdict, with the goals
/// of issues 10 and 31 reported beside it.
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
  /// A load cell's zero below its channel's bottom: vented it reads code 0, so neither the start-up
  /// tare nor the sensor check can see how far below it is (docs/robustness.md).
  bool zero_below_channel() const noexcept { return loadcell_bias_N < 0 || agonist_loadcell_bias_N < 0 || antagonist_loadcell_bias_N < 0; }
};

enum class RobustnessMode {
  kE1Default,       ///< E1 with the scenario's controller (force trim on)
  kE1CalibratedFF,  ///< E1 on the paper's pure feed-forward after calibrating both muscles on the variant
  kE1SensorChecked, ///< E1 as kE1Default after the sensor check on the variant (peha check-sensors) corrected its load cells
  kE3,              ///< E3 postures with the arm scenario's controller as shipped
  kE3Identified,    ///< E3 after identifying the arm's gravity parameters on the variant (peha identify-gravity)
  kE4,              ///< E4, the goniometer-driven elbow (its feedback variant), on the variants' plants and the persons
};
/// Every mode, in the order the file's `modes:` and the table list them.
inline constexpr RobustnessMode kRobustnessModes[] = {RobustnessMode::kE1Default, RobustnessMode::kE1CalibratedFF,
                                                      RobustnessMode::kE1SensorChecked, RobustnessMode::kE3,
                                                      RobustnessMode::kE3Identified, RobustnessMode::kE4};
const char* to_string(RobustnessMode m);
/// The modes' names, ", "-separated (for messages).
std::string robustness_mode_names();

struct RobustnessGoal {
  double max_static_error_pct = 5;   ///< |static torque error| at every release
  double min_tension_fraction = 0.5; ///< lowest wire tension / pretension
  double min_share = 1.0;            ///< of the variants that must meet both
};

/// A person of E4 in the matrix (`e4.paces` and `e4.persons`): a movement - the arm scenario's, by
/// name, or its own - with an optional tremor, and the person's own arm (the user's segments in the
/// plant; the controller keeps its nominal model: it is not told who wears it).
struct GoniometerPerson {
  std::string name;
  std::string scenario_movement;  ///< the arm scenario's goniometer.movements entry ("" = `movement` below)
  ArmScenario::Goniometer::Movement movement;  ///< own movement, or only its tremor on the scenario's
  double segment_length_scale = 1;  ///< the user's forearm, hand and upper arm: centre of mass x s, inertia x s^2
  double segment_mass_scale = 1;    ///< their masses and inertias x s
};

/// The person's movement: the scenario's (with the person's tremor) or its own, inside the range of
/// every driven joint. Throws config::Error naming the person.
ArmScenario::Goniometer::Movement person_movement(const ArmScenario& scenario, const GoniometerPerson& person);

/// E4's section of the matrix (`e4:`): its plant variants, each run at every pace, and its persons,
/// each run on the variant named `nominal`.
struct E4Matrix {
  std::vector<std::string> variants;       ///< names from `variants:` (empty: every one)
  std::vector<GoniometerPerson> paces;     ///< the arm scenario's movements (`paces: [slow, brisk]`)
  std::vector<GoniometerPerson> persons;   ///< faster strokes, tremor, another anthropometry
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
  RobustnessGoal goal_sensor_checked{5, 0.5, 1.0};
  RobustnessGoal goal_e3{5, 0.5, 1.0};
  RobustnessGoal goal_e3_identified{5, 0.5, 1.0};
  E4Matrix e4;
  /// E4's goal: its own verdict (every figure, thresholds from the arm scenario) in this share of the
  /// cases physics allows (issue 31: 0.9).
  double e4_min_share = 0.9;
};

/// Reads a robustness file (configs/robustness.yaml); throws config::Error.
RobustnessConfig read_robustness(const config::Document& doc);

/// E4's figures of a case (docs/right-arm.md, E4), the driven elbow's (NaN on E1/E3 rows).
struct GoniometerFigures {
  double rms_error_deg = std::numeric_limits<double>::quiet_NaN();     ///< exo - person, from the release
  double max_error_deg = std::numeric_limits<double>::quiet_NaN();
  double delay_ms = std::numeric_limits<double>::quiet_NaN();          ///< lag that best aligns exo and person
  double command_hf_rms_Nm = std::numeric_limits<double>::quiet_NaN(); ///< torque command above 10 Hz
  double held_excursion_deg = std::numeric_limits<double>::quiet_NaN();///< the held shoulder
  double passive_speed_degps = std::numeric_limits<double>::quiet_NaN();///< the passive wrist's peak speed
  double person_speed_degps = std::numeric_limits<double>::quiet_NaN();///< the person's peak speed (truth)
};

/// One variant x payload (E4: person) x mode x seed.
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
  GoniometerFigures e4;          ///< E4 rows only
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
/// Another person's arm in the plant (GoniometerPerson): the user's segments, not the exoskeleton's,
/// with their centres of mass x length_scale, masses x mass_scale, inertias x mass_scale x length_scale^2.
void scale_user_arm(sim::ArmPlantParams& p, double length_scale, double mass_scale);

/// The scenarios the modes run: E1's with its selected cases, and the arm's (each read only when a
/// mode runs it).
struct RobustnessScenarios {
  E1Scenario e1;
  ArmScenario arm;
  std::vector<std::size_t> cases;  ///< E1's cases the matrix runs, by index
};
/// Reads the scenarios `config` names and checks E4's persons against the arm's; throws config::Error.
RobustnessScenarios read_robustness_scenarios(const RobustnessConfig& config);

/// Runs the matrix; `progress(done, total, line)` after each case (from the worker threads, serialised).
RobustnessResult run_robustness(const RobustnessConfig& config,
                                const std::function<void(std::size_t, std::size_t, const std::string&)>& progress = {});
/// The same on scenarios already read (read_robustness_scenarios).
RobustnessResult run_robustness(const RobustnessConfig& config, const RobustnessScenarios& scenarios,
                                const std::function<void(std::size_t, std::size_t, const std::string&)>& progress = {});

/// robustness.csv (one row per case) and robustness.md (the table, the shares against the goals).
void write_robustness(const std::filesystem::path& dir, const RobustnessConfig& config, const RobustnessResult& result);

}  // namespace peha::experiments
