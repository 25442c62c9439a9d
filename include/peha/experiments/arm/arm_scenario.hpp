#pragma once
/// \file
/// An arm scenario (configs/right_arm.yaml, configs/upper_body.yaml): controller, limits, simulated plant and the
/// sections of E3 (postures), E4 (goniometer) and E6 (bandwidth), read once and shared by the
/// three experiments; and the per-joint sample their safety figures are computed from.

#include "peha/config/reader.hpp"
#include "peha/control/arm_controller.hpp"
#include "peha/control/tremor_filter.hpp"
#include "peha/runtime/log_telemetry.hpp"
#include "peha/runtime/csv_log.hpp"
#include "peha/mfb/link_config.hpp"
#include "peha/runtime/control_loop.hpp"
#include "peha/safety/limits.hpp"
#include "peha/safety/verdict.hpp"
#include "peha/sim/arm_plant.hpp"

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace peha::experiments {

/// A posture: a target angle per io (driven) joint, rad; NaN = not set (E3's operator leaves it free).
struct ArmPosture {
  std::string name;
  std::vector<double> target_rad;
};

struct ArmScenario {
  std::string description;
  std::optional<mfb::LinkConfig> link;   ///< optional `mfb:` section: the board link
  /// The lifecycle supervisor's parameters (`lifecycle:`): the same in process and on the board.
  runtime::SupervisorParams lifecycle;
  /// The scenario's live telemetry (`telemetry:`, runtime::read_telemetry): what streams unless the command line says otherwise.
  runtime::TelemetryOptions telemetry;
  std::uint64_t seed = 1;
  double period_s = 1e-3;
  control::ArmControllerModel controller;
  safety::VerdictThresholds verdict;     ///< the optional `verdict:` section (defaults when absent)
  safety::LimitsModel limits;
  sim::ArmPlantParams plant;
  double move_s = 2.5, hold_s = 1.0, observe_s = 10.0;
  std::vector<ArmPosture> postures;
  /// E3's plant faults (the optional `faults:` list, `peha run --fault`; sim/plant_faults.hpp, joints
  /// R_SFE, R_EFE, R_WFE, times within E3's script): postures_plant_params puts them in the simulated
  /// arm, E3's step applies controller_nan. E4, E6 and identify-gravity refuse a scenario with faults.
  std::vector<sim::PlantFault> faults;
  /// Not read from the file: E3 ends at this time when > 0 (the fault matrix's shortened runs), s.
  double postures_stop_s = 0;
  /// E6: sine-sweep torque commands on one joint with the arm locked at a posture (a torque bench).
  struct Bandwidth {
    int joint = 1;                      ///< io joint swept (`joint:` names it, e.g. R_EFE or L_SAA): a peha or pam_pair joint
    /// The locked posture, one per io joint, rad; NaN = not locked (`angles_deg:`, by arm joint for
    /// every side or by io joint, as E3's postures). The swept joint is always named.
    std::vector<double> locked_rad;
    double amplitude_Nm = 2.0;          ///< sine amplitude on top of the gravity torque
    std::vector<double> frequencies_Hz;
    double min_cycles = 4, min_duration_s = 2.0;  ///< per frequency (the first cycle is not analysed)
    /// The verdict: the hybrid's -3 dB band of the torque the joint receives (after the cables)
    /// reaches at least this high, Hz (`min_hybrid_band_at_joint_Hz`; 0 = not judged).
    double min_hybrid_band_at_joint_Hz = 0;
  } bandwidth;
  /// E4: the exoskeleton's joints (the elbows) driven by a person's joint angles, each measured by its
  /// own goniometer.
  struct Goniometer {
    /// The io joints driven by a goniometer each (`joints: [R_EFE, L_EFE]`), peha or pam_pair joints.
    std::vector<int> joints;
    /// The posture of the other joints, one per io joint, rad; NaN = not named (`angles_deg:`, by arm
    /// joint for every side or by io joint, as E3's postures): the operator holds them there until
    /// the release, then the inverse dynamics plus `hold`'s impedance (or a constant pressure) holds them.
    std::vector<double> held_rad;
    double sample_rate_Hz = 200;    ///< goniometer sampling
    double noise_rad = 0.0087;      ///< standard deviation of the goniometer's noise
    double resolution_rad = 0.0017; ///< quantisation step of its reading
    int filter_order = 2;           ///< Butterworth low-pass before the derivatives
    double cutoff_Hz = 6.0;
    double settle_s = 3.0;          ///< the person holds still this long before the recording plays;
                                    ///< the operator's hands hold the arm for the first settle_s - 1 s
    double tail_s = 2.0;            ///< the last angle is held this long after the recording ends
    double max_delay_s = 0.4;       ///< longest lag the delay estimate searches
    /// Beyond the paper: a joint-space impedance from each driven joint's encoder toward its
    /// filtered goniometer angle, added to the inverse-dynamics torque in the `feedback` variant:
    /// tau += K (q_person - q_exo) + D (qd_person - qd_exo). The paper's variant is pure replay.
    double feedback_stiffness_Nm_per_rad = 40.0;
    double feedback_damping_Nms_per_rad = 2.0;
    /// Smoothing of each driven joint's torque command (`smoothing:`): the goniometer's rate (a noisy
    /// derivative) through a second Butterworth low-pass of this order at the goniometer's rate; the
    /// inverse dynamics' acceleration from a constant-acceleration Kalman filter of the goniometer
    /// (control/motion_estimator.hpp) whose jerk has this spectral density, rad^2/s^5; between samples
    /// the reference is extrapolated at the control rate (no staircase) and the inverse dynamics run
    /// every cycle; the command through a last low-pass at the control rate.
    int smoothing_order = 2;
    double rate_cutoff_Hz = 8.0;
    double acceleration_jerk_density_rad2ps5 = 25.0;
    double command_cutoff_Hz = 60.0;
    /// The exoskeleton's joint rate the impedances damp (`feedback`'s and `hold`'s D): E4's own
    /// first-order low-pass of the encoder's backward differences at this cut-off, Hz (the
    /// controller's own estimate, 20 Hz, lagged the damping enough to feed the loop's 10-20 Hz activity).
    double encoder_velocity_cutoff_Hz = 100.0;
    /// The PAMs' share of E4's torque (the allocation's pam_cutoff_Hz while E4 runs), Hz: a brisk
    /// stroke moves the torque by 60-100 Nm/s; behind the allocation's 5 Hz the 2.5 Nm motor saturated
    /// through each stroke and the wrist whipped. Only E4: a slower share keeps a user's PD and E3's
    /// shoulder wire taut through a torque's sign change (at 10-40 Hz the PD example's fell to 13-19 N).
    double pam_cutoff_Hz = 40.0;
    /// The held joints (angles_deg; not held at a constant pressure) get the shoulder's row of the same
    /// inverse dynamics (the forearm's reaction, gravity included) plus this impedance toward their
    /// posture: tau = ID + K (q_held - q) - D qd (`hold:`).
    double hold_stiffness_Nm_per_rad = 0.0;
    double hold_damping_Nms_per_rad = 0.0;
    /// After the operator's recovery from an outage (`rejoin:`) each driven joint's reference starts
    /// where the joint is and moves toward the person at rate_radps, never more than lead_rad from the
    /// joint's measured angle (a joint held by the cable's stiction does not wind the impedance up
    /// against it), until it reaches a person moving slower than that rate; each held joint's posture
    /// starts where the joint is and closes its gap at the same rate. No catch-up lunge.
    double rejoin_rate_radps = 0.5;
    double rejoin_lead_rad = 0.09;
    /// The person's tremor taken out of each goniometer's reading before the filter (`tremor:`,
    /// control/tremor_filter.hpp): the exoskeleton follows the voluntary movement. Absent: the
    /// reading as it is.
    std::optional<control::TremorFilterParams> tremor;
    /// E4's own figures' thresholds (`thresholds:`), judged in its verdict with the tracking figures.
    double max_held_excursion_deg = 2.0;      ///< each held joint: largest |q - q at release|
    double max_passive_speed_degps = 400.0;   ///< each joint held at a constant pressure (the wrist): peak |speed|
    double command_hf_above_Hz = 10.0;        ///< "high frequency" of the torque command starts here
    double max_command_hf_rms_Nm = 0.1;       ///< RMS of each driven joint's command above command_hf_above_Hz
    double max_command_delay_s = 0.05;        ///< lag of the smoothed command behind the un-smoothed one (cross-correlation)
    /// A synthetic movement: from_rad -> to_rad -> from_rad on minimum-jerk paths of move_s each,
    /// pause_s at each end, `repetitions` times (the same movement for every driven joint; inside
    /// each one's range).
    struct Movement {
      std::string name;
      double from_rad = 0.7, to_rad = 1.75, move_s = 2.0, pause_s = 0.5;
      int repetitions = 3;
      /// A tremor on top of the movement (the person's, not the goniometer's): A sin(2 pi f t) over the
      /// whole recording (`tremor_amplitude_deg`, `tremor_frequency_Hz`; 0 = none).
      double tremor_amplitude_rad = 0.0, tremor_frequency_Hz = 0.0;
    };
    std::vector<Movement> movements;
  } goniometer;
  /// `peha identify-gravity` (docs/identification.md): the rig drives the arm with its own controller
  /// plus a PD on the encoders slowly up and then down through each posture (every swept joint at
  /// once) and measures the torques while the cables slide. Optional section `identification:`.
  struct Identification {
    /// The io joints the rig sweeps and measures: every joint with a PEHA or PAM-pair actuator (a
    /// constant-pressure hold cannot follow a torque), in io order.
    std::vector<std::size_t> joints;
    std::vector<ArmPosture> postures;   ///< each names an angle for every swept joint (NaN for the others)
    double sweep_rad = 0.14;            ///< each sweep runs from this far below the posture to this far above (every swept joint), and back
    double sweep_speed_radps = 0.14;    ///< the reference's speed while cruising through the posture
    double ramp_s = 0.5;                ///< the reference speeds up and slows down over this at each end of a sweep
    double window_rad = 0.044;          ///< averaged while the reference is within this of the posture
    double move_s = 2.5;                ///< to the start of a posture's sweeps
    double settle_s = 0.5;              ///< at rest before each sweep
    double min_speed_fraction = 0.5;    ///< refuse when a joint moved slower than this x the reference in a window (the cables held it)
    /// After each window, this x the PD's mean torque in it joins the rig's friction feed-forward for
    /// that direction (0: PD alone).
    double friction_learning_gain = 0.8;
    /// The rig's own PAMs' share of the torque (the allocation's pam_cutoff_Hz while it sweeps), Hz:
    /// its PD on the encoders slides the cables slowly; at the arm's 40 Hz the PAMs followed the PD's
    /// stick-slip and the elbow slid at 37-47 % of the reference's speed in a window (refused).
    double pam_cutoff_Hz = 5.0;
    std::vector<double> stiffness_Nm_per_rad;  ///< per swept joint: the PD while the rig drives the arm
    std::vector<double> damping_Nms_per_rad;
    double max_residual_rms_Nm = 0.5;   ///< refuse a fit with a larger residual
    double max_change_fraction = 0.3;   ///< refuse a fit that moves a torque by more than this vs the nominal model
    double rank_tolerance = 0.05;       ///< directions with a singular value below this x the largest keep the nominal model
  };
  std::optional<Identification> identification;
  /// The controller's arm before a gravity identification replaced its bodies (the identification's prior).
  models::ArmModel nominal_arm;
  /// The identification file `controller.gravity_identification` named (empty: none).
  std::filesystem::path gravity_identification_file;
};

/// `scenario` with the controller's arm from the identification file `path` (its bodies replaced by the
/// identified gravity parameters, nominal_arm kept). Throws config::Error.
void use_gravity_identification(ArmScenario& scenario, const std::filesystem::path& path);

/// Reads one movement of `goniometer.movements` (or a person of the robustness matrix): name, from_deg,
/// to_deg (inside [lo_deg, hi_deg]), move_s, pause_s, repetitions and the optional tremor; throws
/// config::Error. Leaves `m` unfinished: the caller may read more keys, then calls finish().
ArmScenario::Goniometer::Movement read_goniometer_movement(config::Map& m, double lo_deg, double hi_deg);

/// Reads configs/right_arm.yaml (and the body file it names); throws config::Error.
ArmScenario read_arm_scenario(const config::Document& doc);

/// The io joints of the right arm as the board's channel map names them (R_SFE, R_EFE, R_WFE).
const std::vector<std::string>& arm_joint_names(const ArmScenario& scenario);

/// One actuated joint at one cycle for the safety envelope: from the simulator's truth when there is
/// one (the sample's, `sampled_truth()`), else from what the host has (load cells, pressure sensors,
/// encoders, the command as sent).
safety::JointSample arm_joint_sample(const io::SensorState& state, const io::Command& sent, const sim::ArmTruth* truth,
                                     std::size_t joint) noexcept;
/// The joint set-ups of `model`'s actuated joints, for the limits stage and the envelope (pointers
/// into `model`, which must outlive their use).
safety::JointModels arm_joint_models(const control::ArmControllerModel& model) noexcept;
/// The start of every right-arm experiment's verdict (E3, E4, E6): the scenario's thresholds and the
/// envelope's checks of the arm's joints (own ceilings, tension floor, supply, motor rating, range).
void add_arm_envelope_checks(const ArmScenario& scenario, const safety::JointModels& joints,
                             const safety::Envelope& envelope, safety::Verdict& verdict);

}  // namespace peha::experiments
