// Gravity identification (calibration/gravity_identification.hpp) on synthetic torques: the
// plant's exact gravity torques, measured at the shoulder and the elbow, from the nominal prior.
#include "peha/calibration/gravity_identification.hpp"

#include "peha/models/exoskeleton.hpp"
#include "peha/models/gravity_parameters.hpp"
#include "peha/models/units.hpp"

#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <unistd.h>

namespace peha::calibration {
namespace {

using ::testing::HasSubstr;

models::BodyConfig shipped_arm() {
  return models::read_body(config::Document::load_file(PEHA_SOURCE_DIR "/configs/arm/right_arm_body.yaml"));
}

Eigen::VectorXd q_of(double sfe, double efe, double wfe) {
  Eigen::VectorXd q = Eigen::VectorXd::Zero(5);
  q << models::deg_to_rad(sfe), models::deg_to_rad(efe), models::deg_to_rad(wfe), 0, 0;
  return q;
}

/// The identification postures of configs/right_arm.yaml, with the wrist sagging as it does on the rig.
std::vector<GravitySample> samples_of(const models::ArmModel& truth, double shoulder_gain = 1.0) {
  const double p[][3] = {{0, 15, -15}, {-45, 30, -12}, {-85, 90, -14}, {20, 60, -16}, {-30, 100, -5},
                         {0, 60, -17},  {-60, 45, -10}, {10, 120, 3},   {45, 20, -8}};
  models::ArmData data(truth);
  std::vector<GravitySample> out;
  for (const auto& a : p) {
    GravitySample s;
    s.name = fmt::format("({}, {})", a[0], a[1]);
    s.q_rad = q_of(a[0], a[1], a[2]);
    const Eigen::VectorXd& tau = models::gravity_torque(truth, data, s.q_rad);
    s.tau_Nm = Eigen::Vector2d(shoulder_gain * tau[0], tau[1]);
    out.push_back(s);
  }
  return out;
}

// From the plant's exact torques the fit finds the plant's gravity: on E3's postures (not used in
// the fit) the identified shoulder and elbow torques are within 0.5 % of the plant's, where the
// nominal model is 6-12 % off. Six base parameters are identified (two per link of a planar chain).
TEST(GravityIdentification, RecoversThePlantsGravityFromItsTorques) {
  const models::BodyConfig arm = shipped_arm();
  const models::ArmModel nominal = arm.controller.model(), plant = arm.plant.model();
  const GravityIdentification fit = identify_gravity(nominal, samples_of(plant), {});
  EXPECT_EQ(fit.rank, 6);
  EXPECT_LT(fit.residual_rms_Nm, 1e-3);
  EXPECT_GT(fit.prior_rms_Nm, 0.5);
  const models::ArmModel identified = models::with_gravity_parameters(nominal, fit.theta);
  models::ArmData a(identified), b(plant), c(nominal);
  double worst_identified = 0, best_nominal = 1e9;
  for (const Eigen::VectorXd& q : {q_of(0, 0, -17), q_of(-45, 30, -12), q_of(-90, 90, -14), q_of(20, 60, -16)}) {
    const Eigen::VectorXd t_plant = models::gravity_torque(plant, b, q);
    const Eigen::VectorXd t_id = models::gravity_torque(identified, a, q);
    const Eigen::VectorXd t_nom = models::gravity_torque(nominal, c, q);
    for (int j = 0; j < 2; ++j) {
      if (std::abs(t_plant[j]) < 1.0) continue;
      worst_identified = std::max(worst_identified, std::abs(t_id[j] / t_plant[j] - 1.0));
      best_nominal = std::min(best_nominal, std::abs(t_nom[j] / t_plant[j] - 1.0));
    }
  }
  EXPECT_LT(worst_identified, 0.005);
  EXPECT_GT(best_nominal, 0.05);
}

// Torques with the wrong sign (e.g. agonist and antagonist channels swapped): every torque would move
// by 200 % of the nominal model's, far beyond the 30 % a real arm differs by: refused.
TEST(GravityIdentification, RefusesTorquesOfTheWrongSign) {
  const models::BodyConfig arm = shipped_arm();
  std::vector<GravitySample> s = samples_of(arm.plant.model());
  for (GravitySample& g : s) g.tau_Nm = -g.tau_Nm;
  try {
    identify_gravity(arm.controller.model(), s, {});
    FAIL() << "a sign error was accepted";
  } catch (const GravityIdentificationRejected& e) {
    EXPECT_THAT(e.what(), HasSubstr("wrong lever, sign or channel"));
  }
}

// The shoulder's torque computed with a pulley radius twice the real one (a wrong lever): the
// shoulder's torques would move by about 100 % of the nominal model's: refused.
TEST(GravityIdentification, RefusesAShoulderTorqueWithTheWrongLever) {
  const models::BodyConfig arm = shipped_arm();
  EXPECT_THROW(identify_gravity(arm.controller.model(), samples_of(arm.plant.model(), 2.0), {}), GravityIdentificationRejected);
  // 1.1: within what a real arm differs by, and a rigid arm can have it: accepted.
  EXPECT_NO_THROW(identify_gravity(arm.controller.model(), samples_of(arm.plant.model(), 1.1), {}));
}

// The file carries the parameters by name; read back for the same arm it gives the same gravity, and
// a file for another arm (different joints) or with an unknown key is refused with its place.
TEST(GravityIdentification, FileRoundTripAndStrictReading) {
  const models::BodyConfig arm = shipped_arm();
  const models::ArmModel nominal = arm.controller.model();
  const std::vector<GravitySample> s = samples_of(arm.plant.model());
  const GravityIdentification fit = identify_gravity(nominal, s, {});
  const std::filesystem::path path = std::filesystem::temp_directory_path() / fmt::format("peha_gravity_id_{}.yaml", getpid());
  write_gravity_identification(path, nominal, s, fit, "test");
  const models::ArmModel back = read_gravity_identification(config::Document::load_file(path), nominal);
  models::ArmData a(back), b(nominal);
  Eigen::MatrixXd Y(nominal.dof(), models::gravity_parameter_count(nominal));
  for (const GravitySample& g : s) {
    models::gravity_regressor(nominal, b, g.q_rad, Y);
    EXPECT_LT((models::gravity_torque(back, a, g.q_rad) - Y * fit.theta).cwiseAbs().maxCoeff(), 1e-6);
  }
  std::ifstream in(path);
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::filesystem::remove(path);
  const std::string bad_arm = std::string(text).replace(text.find("R_WAA"), 5, "R_XYZ");
  EXPECT_THROW(read_gravity_identification(config::Document::load_string(bad_arm), nominal), config::Error);
  EXPECT_THROW(read_gravity_identification(config::Document::load_string(text + "colour: red\n"), nominal), config::Error);
  // measured_joints names the joints behind each sample's torques: one of this arm's, once each, as
  // many as the samples list.
  ASSERT_NE(text.find("measured_joints: R_SFE,R_EFE"), std::string::npos) << text;
  for (const char* bad : {"measured_joints: R_SFE,R_XYZ", "measured_joints: R_SFE,R_SFE", "measured_joints: R_SFE"}) {
    const std::string t = std::string(text).replace(text.find("measured_joints: R_SFE,R_EFE"), 28, bad);
    EXPECT_THROW(read_gravity_identification(config::Document::load_string(t), nominal), config::Error) << bad;
  }
}

}  // namespace
}  // namespace peha::calibration
