#pragma once
/// \file
/// Experiments on the simulated right arm (SPEC §7): E3 "postures" - the operator moves the arm with
/// its mannequin to several postures and lets go; with gravity compensation tau = J^T G and no
/// position feedback it should stay. The scenario is configs/right_arm.yaml.

#include "peha/config/reader.hpp"
#include "peha/control/arm_controller.hpp"
#include "peha/runtime/csv_log.hpp"
#include "peha/runtime/e1_gravity.hpp"  // CycleHooks, LinkConfig
#include "peha/safety/limits.hpp"
#include "peha/sim/right_arm.hpp"

#include <optional>
#include <string>
#include <vector>

namespace peha::runtime {

struct ArmPosture {
  std::string name;
  double sfe_rad = 0;
  double efe_rad = 0;
};

struct ArmScenario {
  std::string description;
  std::optional<LinkConfig> link;   ///< optional `mfb:` section: the board link
  std::uint64_t seed = 1;
  double period_s = 1e-3;
  control::ArmControllerModel controller;
  safety::LimitsModel limits;
  sim::RightArmPlantParams plant;
  double move_s = 2.5, hold_s = 1.0, observe_s = 10.0;
  std::vector<ArmPosture> postures;
  /// E6: sine-sweep torque commands on one joint with the arm locked at a posture (a torque bench).
  struct Bandwidth {
    int joint = 1;                      ///< io joint (1 = R_EFE)
    double sfe_rad = -1.5707963, efe_rad = 1.5707963;  ///< locked posture
    double amplitude_Nm = 2.0;          ///< sine amplitude on top of the gravity torque
    std::vector<double> frequencies_Hz;
    double min_cycles = 4, min_duration_s = 2.0;  ///< per frequency (the first cycle is not analysed)
  } bandwidth;
  /// E4: the exoskeleton's elbow driven by a person's elbow angle, measured by a goniometer.
  struct Goniometer {
    double sfe_rad = -1.5707963;    ///< shoulder posture (held by gravity compensation)
    double sample_rate_Hz = 200;    ///< goniometer sampling
    double noise_rad = 0.0087;      ///< standard deviation of the goniometer's noise
    double resolution_rad = 0.0017; ///< quantisation step of its reading
    int filter_order = 2;           ///< Butterworth low-pass before the derivatives
    double cutoff_Hz = 6.0;
    double settle_s = 3.0;          ///< the person holds still this long before the recording plays;
                                    ///< the operator's hands hold the arm for the first settle_s - 1 s
    double tail_s = 2.0;            ///< the last angle is held this long after the recording ends
    double max_delay_s = 0.4;       ///< longest lag the delay estimate searches
    /// Beyond the paper: a joint-space impedance from the exoskeleton's elbow encoder toward the
    /// filtered goniometer angle, added to the inverse-dynamics torque in the `feedback` variant:
    /// tau += K (q_person - q_exo) + D (qd_person - qd_exo). The paper's variant is pure replay.
    double feedback_stiffness_Nm_per_rad = 40.0;
    double feedback_damping_Nms_per_rad = 2.0;
    /// A synthetic movement: from_rad -> to_rad -> from_rad on minimum-jerk paths of move_s each,
    /// pause_s at each end, `repetitions` times.
    struct Movement {
      std::string name;
      double from_rad = 0.7, to_rad = 1.75, move_s = 2.0, pause_s = 0.5;
      int repetitions = 3;
    };
    std::vector<Movement> movements;
  } goniometer;
};

/// Reads configs/right_arm.yaml (and the body file it names); throws config::Error.
ArmScenario read_arm_scenario(const config::Document& doc);

struct PostureResult {
  std::string name;
  double target_deg[2] = {0, 0};      ///< SFE, EFE the operator aimed at
  double released_deg[2] = {0, 0};    ///< where the arm was at release (plant truth)
  double drift_deg[2] = {0, 0};       ///< angle observe_s after release minus at release
  double max_excursion_deg[2] = {0, 0};
};

struct PosturesResult {
  std::vector<PostureResult> postures;
  double peak_muscle_force_N = 0;     ///< any muscle, plant truth
  double min_wire_tension_N = 0;      ///< any wire, plant truth
  double peak_operator_torque_Nm = 0;
  double realtime_factor = 0;
  bool within_limits = false;         ///< every force/tension/pressure/motor limit held
};

struct BodePoint {
  double frequency_Hz = 0;
  double gain = 0;        ///< |delivered / desired| of the torque at this frequency
  double phase_deg = 0;   ///< arg(delivered / desired)
};

struct BandwidthResult {
  std::string variant;                 ///< "pam_only" or "hybrid"
  std::vector<BodePoint> bode;
  double bandwidth_3dB_Hz = 0;         ///< where the gain first falls below 1/sqrt(2) (log-interpolated);
                                       ///< the highest frequency tested if it never does
  bool reached_3dB = false;
  double peak_muscle_force_N = 0;
  double min_wire_tension_N = 0;
  double peak_motor_torque_Nm = 0;
};

/// E6: the torque bandwidth of one joint, PAM-only (no motor, no low-pass split) or hybrid.
BandwidthResult run_bandwidth(const ArmScenario& scenario, bool hybrid);

const std::vector<std::string>& arm_log_columns();

/// One actuated joint at one cycle, as the arm's safety figures need it: from the simulator's truth
/// when there is one, else from what the host has (load cells, pressure sensors, the command).
struct ArmJointSample {
  double muscle_force_N[2] = {0, 0};  ///< agonist, antagonist: muscle force (truth) or load cell
  double min_tension_N = 0;           ///< lowest along either wire (truth) or the lower load cell
  double pressure_Pa[2] = {0, 0};     ///< chamber (truth) or sensor
  double motor_torque_Nm = 0;         ///< delivered (truth) or commanded
};
ArmJointSample arm_joint_sample(const io::SensorState& state, const io::Command& command, const sim::RightArmTruth* truth,
                                std::size_t joint) noexcept;
/// The joint's force ceilings, supply pressure and motor rating held in `sample`.
bool arm_joint_within_limits(const ArmScenario& scenario, std::size_t joint, const ArmJointSample& sample) noexcept;

/// E3 on the in-process simulated arm. `log` (optional) gets one row per control cycle.
PosturesResult run_postures(const ArmScenario& scenario, RowSink* log);

/// The simulated arm of E3: the scenario's plant with the operator's script (hold at the start,
/// then carry the arm to each posture, hold, let go) - also what `peha mfb-emulator` simulates.
sim::RightArmPlantParams postures_plant_params(const ArmScenario& scenario);
/// When the operator lets go of each posture, s (E3's script), and the whole run's length.
std::vector<double> postures_release_times_s(const ArmScenario& scenario);
double postures_duration_s(const ArmScenario& scenario);

/// E3 on any backend. `sim` (optional) is the in-process arm when `backend` is it (truth figures);
/// without it the drift comes from the joint encoders, forces and tensions from the load cells, and
/// the operator is where the script puts them. A cycle whose read() fails holds the last command.
PosturesResult run_postures_on(const ArmScenario& scenario, io::Backend& backend, const sim::RightArmBackend* sim, RowSink* log,
                               const CycleHooks& hooks = {});

}  // namespace peha::runtime
