#pragma once
/// \file
/// The rig procedure of `peha identify-gravity` (docs/identification.md): the right arm's own
/// controller, in commanded-torque mode with its nominal gravity torque plus a PD on the joint
/// encoders, sweeps the arm slowly up and then down through each posture of the scenario's
/// `identification:` section (both joints at once) and averages what the rig measures while the
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

/// One posture's measurement: per sweep (0 = upward, 1 = downward), averaged over the window.
struct IdentificationMeasurement {
  std::string name;
  double q_deg[2][3] = {};           ///< sweep x (SFE, EFE, WFE): encoders
  double speed_fraction[2][2] = {};  ///< sweep x (SFE, EFE): the joint's mean speed / the reference's
  double tau_Nm[2][2] = {};          ///< sweep x (SFE, EFE): r0 (F_agonist - F_antagonist) + motor, muscle-side forces
  double force_N[2][2][2] = {};      ///< sweep x joint x muscle: load cell minus its zero
  double motor_Nm[2][2] = {};        ///< sweep x (SFE, EFE): the motor's command
  double friction_ratio[2] = {};     ///< (SFE, EFE): k = e^(mu psi) the two sweeps agree on
  double tau_mean_Nm[2] = {};        ///< the sample's gravity torque: either sweep's pulley-side torque with that k
};

struct ArmIdentificationResult {
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
