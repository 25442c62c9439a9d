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
#include "peha/experiments/arm/arm_scenario.hpp"

#include <functional>
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

/// Runs the procedure on the in-process arm `plant` (the truth is not read) and fits. Throws
/// calibration::GravityIdentificationRejected when a joint stuck in a window (moved slower than
/// min_speed_fraction x the reference), a fault was latched, or the fit's checks fail; config::Error
/// without an `identification:` section. `progress` gets one line per posture.
ArmIdentificationResult identify_arm_gravity(const ArmScenario& scenario, const sim::ArmPlantParams& plant,
                                             const std::function<void(const std::string&)>& progress = {});

}  // namespace peha::experiments
