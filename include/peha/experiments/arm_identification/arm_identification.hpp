#pragma once
/// \file
/// The rig procedure of `peha identify-gravity` (docs/identification.md): the right arm's own
/// controller, in commanded-torque mode with its nominal gravity torque plus a PD on the joint
/// encoders, drives the arm to each posture of the scenario's `identification:` section, once from
/// above and once from below (both joints), lets it settle, and averages what the rig measures: the
/// encoders and the load cells (minus their zero) through the controller's pulley radius, plus the
/// motor's command. The cable friction holds the link anywhere in a band; approached from above it
/// sits at one edge, from below at the other, so the mean of the two is the gravity torque. Per
/// muscle the two forces are combined by their geometric mean, which cancels a capstan's
/// multiplicative friction (T e^x and T e^-x) exactly. Nothing of the plant's truth is read.

#include "peha/calibration/gravity_identification.hpp"
#include "peha/experiments/right_arm/arm_scenario.hpp"

#include <functional>
#include <string>
#include <vector>

namespace peha::experiments {

/// One posture's measurement: per side (0 = approached from above, 1 = from below).
struct IdentificationMeasurement {
  std::string name;
  double q_deg[2][3] = {};           ///< side x (SFE, EFE, WFE): encoders at rest
  double tau_Nm[2][2] = {};          ///< side x (SFE, EFE): measured holding torque
  double force_N[2][2][2] = {};      ///< side x joint x muscle: load cell minus its zero
  double tau_mean_Nm[2] = {};        ///< the sample's torque: from the geometric mean forces of both sides
};

struct ArmIdentificationResult {
  std::vector<IdentificationMeasurement> measurements;
  std::vector<calibration::GravitySample> samples;   ///< what the fit used (q: mean of both sides)
  calibration::GravityIdentification fit;
  models::ArmModel identified;      ///< the controller's arm with the identified parameters
  double duration_s = 0;            ///< simulated
  double realtime_factor = 0;
};

/// The simulated arm of the procedure: `plant` with the operator holding the start posture while
/// compensation comes on (as E3), and no operator after.
sim::RightArmPlantParams identification_plant_params(const ArmScenario& scenario, const sim::RightArmPlantParams& plant);

/// Runs the procedure on the in-process arm `plant` (the truth is not read) and fits. Throws
/// calibration::GravityIdentificationRejected when the fit's checks fail, config::Error without an
/// `identification:` section. `progress` gets one line per posture.
ArmIdentificationResult identify_arm_gravity(const ArmScenario& scenario, const sim::RightArmPlantParams& plant,
                                             const std::function<void(const std::string&)>& progress = {});

}  // namespace peha::experiments
