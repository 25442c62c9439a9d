#pragma once
/// \file
/// The rig procedure of `peha identify-gravity` (docs/identification.md): the arm's own controller,
/// in commanded-torque mode with its nominal gravity torque plus a PD on the joint encoders, sweeps
/// every joint with a PEHA or PAM-pair actuator (every side at once) slowly up and then down through
/// each posture of the scenario's `identification:` section and averages what the rig measures while the
/// reference crosses the posture: the encoders, the load cells (minus their zero) and the motor's
/// command. While a wire slides, its Bowden friction is fully developed and its direction known: moving
/// up, the pulley end of the agonist's wire carries F/k and the antagonist's F k (k = e^(mu psi), the
/// capstan ratio), moving down the reverse. Up and down then give two equations in the gravity torque
/// and k, solved per posture and joint. Nothing of the plant's truth is read.

#include "peha/calibration/gravity_identification.hpp"
#include "peha/control/arm_controller.hpp"
#include "peha/experiments/common/board_run.hpp"
#include "peha/experiments/arm/arm_scenario.hpp"
#include "peha/io/backend.hpp"
#include "peha/runtime/control_loop.hpp"
#include "peha/runtime/csv_log.hpp"

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace peha::experiments {

/// One swept joint's measurement at one posture: per sweep (0 = upward, 1 = downward), averaged over
/// the window.
struct IdentificationJoint {
  double speed_fraction[2] = {};  ///< the joint's mean speed / the reference's
  double tau_Nm[2] = {};          ///< r0 (F_agonist - F_antagonist) + motor, muscle-side forces
  double force_N[2][2] = {};      ///< sweep x muscle (agonist, antagonist): load cell minus its zero
  double motor_Nm[2] = {};        ///< the motor's command (0 without a motor)
  double friction_ratio = 0;      ///< k = e^(mu psi) the two sweeps agree on
  double tau_mean_Nm = 0;         ///< the sample's gravity torque: either sweep's pulley-side torque with that k
};

/// One posture's measurement.
struct IdentificationMeasurement {
  std::string name;
  std::vector<double> q_deg[2];           ///< sweep x io joint: encoders
  std::vector<IdentificationJoint> joints;  ///< per swept joint (ArmIdentificationResult::joint_names)
};

struct ArmIdentificationResult {
  std::vector<std::string> joint_names;    ///< the swept io joints (R_SFE, ...), in the order of each measurement's joints
  std::vector<IdentificationMeasurement> measurements;
  std::vector<calibration::GravitySample> samples;   ///< what the fit used (q: mean of both sweeps)
  calibration::GravityIdentification fit;
  models::ArmModel identified;      ///< the controller's arm with the identified parameters
  double duration_s = 0;            ///< simulated
  double realtime_factor = 0;
};

/// The simulated arm of the procedure: `plant` with the operator holding the start posture while
/// compensation comes on (as E3), and no operator after.
sim::ArmPlantParams identification_plant_params(const ArmScenario& scenario, const sim::ArmPlantParams& plant);

/// What the procedure's run measured, before the fit: per posture and sweep (0 up, 1 down) the sums
/// over its averaging window (q per io joint; forces, motor and speed per swept joint).
struct IdentificationRecording {
  struct Sums {
    std::vector<double> q;
    std::vector<std::array<double, 2>> force;
    std::vector<double> motor, speed;
    double n = 0;
  };
  std::vector<std::array<Sums, 2>> sums;
  std::unique_ptr<control::ArmController> controller;  ///< the rig's controller (its model and load-cell zeros)
  std::uint64_t faults = 0;        ///< faults the plausibility monitor latched during the run
  std::string fault_reason;
  double duration_s = 0, wall_s = 0;
};

/// The scenario the procedure runs: `given` with the body file's arm model (the fit's prior), whatever
/// identification its controller uses. Throws config::Error without an `identification:` section.
ArmScenario identification_scenario(const ArmScenario& given);
/// How long the procedure runs, s.
double identification_duration_s(const ArmScenario& scenario);
/// Runs the procedure on `backend` (the simulated arm, or the boards in real time with the
/// harness's `hooks`) for `scenario` (from identification_scenario); only what the rig measures is read.
IdentificationRecording record_identification(const ArmScenario& scenario, io::Backend& backend,
                                              const std::function<void(const std::string&)>& progress = {},
                                              const runtime::CycleHooks& hooks = {}, runtime::RowSink* log = nullptr);
/// The per-cycle log of the procedure on hardware: t_s, per io joint (arm_log_prefix) what the
/// controller read (hardware::kSensorColumns) and the commands sent, limit_flags.
std::vector<std::string> identification_log_columns(const ArmScenario& scenario);
/// The fit of a recording. Throws calibration::GravityIdentificationRejected as identify_arm_gravity.
ArmIdentificationResult fit_identification(const ArmScenario& scenario, const IdentificationRecording& recording);

/// Runs the procedure on the in-process arm `plant` (the truth is not read) and fits. Throws
/// calibration::GravityIdentificationRejected when a joint stuck in a window (moved slower than
/// min_speed_fraction x the reference), a fault was latched, or the fit's checks fail; config::Error
/// without an `identification:` section. `progress` gets one line per posture.
ArmIdentificationResult identify_arm_gravity(const ArmScenario& scenario, const sim::ArmPlantParams& plant,
                                             const std::function<void(const std::string&)>& progress = {});

/// The procedure on the hardware `options.backend` (the arm's board or boards) in real time, through
/// the lifecycle supervisor; every cycle logged to `cycles_log` (identification_log_columns, with NaN
/// for what the rig does not measure). `verdict` holds the link faults; the caller fits `recording` only
/// when it passed. `scenario` from identification_scenario.
struct IdentificationRealtimeResult : BoardRunResult {
  IdentificationRecording recording;
  safety::Verdict verdict;
};
IdentificationRealtimeResult record_identification_realtime(const ArmScenario& scenario, const HardwareRunOptions& options,
                                                            const std::filesystem::path& cycles_log,
                                                            const std::function<void(const std::string&)>& progress = {});

}  // namespace peha::experiments
