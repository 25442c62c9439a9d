// The rig procedure of peha identify-gravity on the shipped simulated arm, and E3 with its result.
#include "peha/experiments/arm_identification/arm_identification.hpp"
#include "../support/shipped_scenarios.hpp"
#include "peha/experiments/e3_postures/postures.hpp"

#include "peha/models/gravity_parameters.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace peha::experiments {
namespace {

/// Worst |static torque error| (plant truth) over E3's postures and joints with a judged gravity torque, %;
/// or, with `model`, the worst |controller's gravity torque - plant's| at rest there.
double worst_pct(const PosturesResult& r, double min_gravity_Nm, bool model = false) {
  double worst = 0;
  for (const PostureResult& p : r.postures) {
    for (int j = 0; j < 2; ++j) {
      if (std::abs(p.joints[j].gravity_torque_Nm) < min_gravity_Nm) continue;
      worst = std::max(worst, std::abs(model ? p.joints[j].model_gravity_error_pct : p.joints[j].static_torque_error_pct));
    }
  }
  return worst;
}

// Identified on the shipped arm from what the rig measures (encoders, load cells, motor command) while
// the wires slide: a residual under 0.3 Nm (measured 0.17 Nm; the static two-approach procedure gave
// 0.36 Nm), and per posture a capstan ratio within 10 % of the plant's e^(mu_k psi) = 1.233 (measured
// 1.233-1.285). Then E3 with the identified model, judged by the plant's truth at rest: the
// controller's gravity torque within 2.5 % of the plant's at every judged posture and joint (measured
// <= 1.5 %; the nominal model is 6-12 % light) and every static torque error <= 5 % (measured <= 1.7 %;
// nominal 6-11 %), and the arm stays where it is left (drift < 0.5 deg).
TEST(ArmIdentification, IdentifiedModelHoldsE3WhereTheNominalDoesNot) {
  ArmScenario s = test_support::shipped_right_arm();
  ASSERT_TRUE(s.identification);
  const models::ArmModel shipped_identification = s.controller.arm;
  s.controller.arm = s.nominal_arm;  // from the body file's prior, as on a new rig
  const ArmIdentificationResult id = identify_arm_gravity(s, s.plant);
  EXPECT_EQ(id.joint_names, (std::vector<std::string>{"R_SFE", "R_EFE"}));  // the constant-pressure wrist is not swept
  EXPECT_LT(id.fit.residual_rms_Nm, 0.3);
  EXPECT_EQ(id.fit.rank, 4);  // rank_tolerance 0.1: the two directions the data barely see keep the nominal model
  for (int j = 0; j < 2; ++j) {
    const sim::CablePlantParams& cable = s.plant.actuators[static_cast<std::size_t>(j)].agonist.cable;
    const double k_plant = std::exp(cable.kinetic_friction * cable.wrap_angle_rad);
    for (const IdentificationMeasurement& m : id.measurements) {
      const IdentificationJoint& mj = m.joints[static_cast<std::size_t>(j)];
      EXPECT_NEAR(mj.friction_ratio, k_plant, 0.1 * k_plant) << m.name << " joint " << j;
      EXPECT_GE(std::min(mj.speed_fraction[0], mj.speed_fraction[1]), s.identification->min_speed_fraction) << m.name;
    }
  }

  const double min_gravity = s.verdict.min_gravity_torque_Nm;
  const PosturesResult nominal = run_postures(s, nullptr);
  EXPECT_GT(worst_pct(nominal, min_gravity), 5.0);
  EXPECT_GT(worst_pct(nominal, min_gravity, true), 5.0);
  s.controller.arm = id.identified;
  const PosturesResult identified = run_postures(s, nullptr);
  EXPECT_LE(worst_pct(identified, min_gravity), 5.0);
  EXPECT_LT(worst_pct(identified, min_gravity, true), 2.5);
  for (const PostureResult& p : identified.postures) {
    EXPECT_LT(std::abs(p.joints[0].drift_deg), 0.5) << p.name;
    EXPECT_LT(std::abs(p.joints[1].drift_deg), 0.5) << p.name;
  }

  // The shipped configs/arm/right_arm_gravity.yaml (the controller's arm in configs/right_arm.yaml) is
  // this identification: each gravity parameter within 1 % of its value here (or 0.002 kg m for the
  // small ones), so a change of the arm, the rig or the procedure that leaves it stale fails here.
  // Regenerate: peha identify-gravity --config configs/right_arm.yaml --out <file>, then copy it there.
  const Eigen::VectorXd now = models::gravity_parameters(id.identified);
  const Eigen::VectorXd file = models::gravity_parameters(shipped_identification);
  ASSERT_EQ(now.size(), file.size());
  for (Eigen::Index i = 0; i < now.size(); ++i) {
    EXPECT_NEAR(file[i], now[i], std::max(0.01 * std::abs(now[i]), 0.002)) << "parameter " << i;
  }
}

// The speed check can fail: without the rig's friction feed-forward the PD alone lags the shoulder by
// 5-6 deg and it sticks and slips through a window (measured: 8 % of the reference's speed at
// mid_75), and the identification is refused with the posture, joint and sweep named.
TEST(ArmIdentification, RefusesWhenAJointSticksInAWindow) {
  ArmScenario s = test_support::shipped_right_arm();
  ASSERT_TRUE(s.identification);
  s.identification->friction_learning_gain = 0.0;
  try {
    (void)identify_arm_gravity(s, s.plant);
    FAIL() << "a sticking joint was accepted";
  } catch (const calibration::GravityIdentificationRejected& e) {
    EXPECT_NE(std::string(e.what()).find("of the reference's speed"), std::string::npos) << e.what();
  }
}


// The identification does not run the monitor's drift check (a swept joint stuck by stiction while
// the PD ramps its force is no drift): a cell whose zero creeps is the fit's to refuse. The shoulder
// agonist's zero drifting 1 N/s from 20 s on (a tenth of the fault matrix's drift) is refused by the
// residual (measured 1.29 Nm RMS > 0.5; 3 N/s: 3.9 Nm; 10 N/s latches loadcell_disagrees at 108.7 s).
TEST(ArmIdentification, RefusesADriftingLoadCell) {
  ArmScenario s = test_support::shipped_right_arm();
  ASSERT_TRUE(s.identification);
  s.plant.faults.push_back({.kind = sim::FaultKind::kLoadcellDrift, .time_s = 20.0, .joint = 0, .muscle = 0, .value = 1.0});
  try {
    const ArmIdentificationResult id = identify_arm_gravity(s, s.plant);
    FAIL() << "a drifting load cell was accepted: residual " << id.fit.residual_rms_Nm << " Nm";
  } catch (const calibration::GravityIdentificationRejected& e) {
    EXPECT_NE(std::string(e.what()).find("not those of a rigid arm"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace peha::experiments
