#include "peha/models/anthropometry.hpp"
#include "peha/models/exoskeleton.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>

namespace peha::models {
namespace {

constexpr double kTol = 1e-12;

std::string right_arm_yaml() {
  std::ifstream in(std::filesystem::path(PEHA_SOURCE_DIR) / "configs" / "arm" / "right_arm_body.yaml");
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

const ArmBody& body(const ArmModel& m, const std::string& name) {
  for (const auto& b : m.bodies) {
    if (b.name == name) return b;
  }
  throw std::out_of_range(name);
}

double total_mass(const ArmModel& m) {
  double sum = 0;
  for (const auto& b : m.bodies) sum += b.mass_kg;
  return sum;
}

// Winter (2009) Fig. 4.1 / Table 4.1 for a 1.75 m, 70 kg person, written out by hand.
TEST(Anthropometry, DefaultUserEqualsTheTable) {
  const UserArm u = user_arm_from_anthropometry(1.75, 70.0);
  EXPECT_NEAR(u.upper_arm.length_m, 0.3255, kTol);          // 0.186 H
  EXPECT_NEAR(u.upper_arm.mass_kg, 1.96, kTol);             // 0.028 M
  EXPECT_NEAR(u.upper_arm.com_from_proximal_m, 0.141918, kTol);  // 0.436 L
  EXPECT_NEAR(u.upper_arm.radius_of_gyration_m, 0.104811, kTol); // 0.322 L
  EXPECT_NEAR(u.forearm.length_m, 0.2555, kTol);            // 0.146 H
  EXPECT_NEAR(u.forearm.mass_kg, 1.12, kTol);               // 0.016 M
  EXPECT_NEAR(u.forearm.com_from_proximal_m, 0.109865, kTol);    // 0.430 L
  EXPECT_NEAR(u.forearm.radius_of_gyration_m, 0.0774165, kTol);  // 0.303 L
  EXPECT_NEAR(u.hand.length_m, 0.189, kTol);                // 0.108 H
  EXPECT_NEAR(u.hand.mass_kg, 0.42, kTol);                  // 0.006 M
  EXPECT_NEAR(u.hand.com_from_proximal_m, 0.095634, kTol);  // 0.506 L
  EXPECT_NEAR(u.hand.radius_of_gyration_m, 0.056133, kTol); // 0.297 L
  EXPECT_NEAR(u.total_mass_kg(), 3.5, kTol);                // 5.0 % of body mass

  // Long axis: a uniform cylinder of the table's density, e.g. upper arm r = sqrt(m/(pi rho L)).
  const double r = std::sqrt(1.96 / (3.14159265358979323846 * 1070.0 * 0.3255));
  EXPECT_NEAR(u.upper_arm.axial_radius_of_gyration_m, r / std::sqrt(2.0), kTol);
  EXPECT_NEAR(r, 0.0423, 1e-4);  // a plausible upper-arm radius
  const Eigen::Matrix3d I = u.upper_arm.inertia_kgm2();
  EXPECT_NEAR(I(1, 1), 1.96 * 0.104811 * 0.104811, kTol);
  EXPECT_NEAR(I(2, 2), I(1, 1), kTol);
  EXPECT_NEAR(I(0, 0), 0.5 * 1.96 * r * r, kTol);
  EXPECT_EQ(I(0, 1), 0.0);
}

TEST(Anthropometry, ScalesWithHeightAndMass) {
  const UserArm a = user_arm_from_anthropometry(1.60, 55.0);
  EXPECT_NEAR(a.forearm.length_m, 0.146 * 1.60, kTol);
  EXPECT_NEAR(a.hand.mass_kg, 0.006 * 55.0, kTol);
}

TEST(Anthropometry, RejectsBadInputs) {
  EXPECT_THROW(user_arm_from_anthropometry(1.19, 70), std::invalid_argument);
  EXPECT_THROW(user_arm_from_anthropometry(2.21, 70), std::invalid_argument);
  EXPECT_THROW(user_arm_from_anthropometry(1.75, 29.9), std::invalid_argument);
  EXPECT_THROW(user_arm_from_anthropometry(1.75, 200.1), std::invalid_argument);
  EXPECT_THROW(user_arm_from_anthropometry(std::nan(""), 70), std::invalid_argument);
  EXPECT_THROW(user_arm_from_anthropometry(1.75, INFINITY), std::invalid_argument);
  EXPECT_NO_THROW(user_arm_from_anthropometry(1.2, 30));
  EXPECT_NO_THROW(user_arm_from_anthropometry(2.2, 200));
}

TEST(ArmModelBuild, ChainAndBodiesForTheDefaultUser) {
  const UserArm u = user_arm_from_anthropometry(1.75, 70.0);
  const ExoArmParams exo = exo_arm_for_user(u);
  // The exoskeleton alone, shoulder to tip, is under 5 kg (paper §III).
  EXPECT_LT(exo.total_mass_kg(), 5.0);
  EXPECT_NEAR(exo.total_mass_kg(), 3.9, kTol);
  EXPECT_DOUBLE_EQ(exo.upper_link.length_m, u.upper_arm.length_m);
  EXPECT_DOUBLE_EQ(exo.forearm_link.length_m, u.forearm.length_m);

  const ArmModel m = build_arm_model(exo, u, 5.0, true);
  ASSERT_EQ(m.dof(), 5);
  for (int i = 0; i < kRightArmDof; ++i) EXPECT_EQ(m.joints[i].name, kRightArmJointNames[i]);
  EXPECT_TRUE(m.joints[kSFE].active && m.joints[kEFE].active && m.joints[kWFE].active);
  EXPECT_FALSE(m.joints[kWR].active || m.joints[kWAA].active);
  EXPECT_TRUE(m.joints[kSFE].axis.isApprox(Eigen::Vector3d(0, -1, 0)));
  EXPECT_TRUE(m.joints[kEFE].offset_m.isApprox(Eigen::Vector3d(0.3255, 0, 0)));
  EXPECT_TRUE(m.joints[kWFE].offset_m.isApprox(Eigen::Vector3d(0.2555, 0, 0)));
  EXPECT_TRUE(m.joints[kWR].axis.isApprox(Eigen::Vector3d::UnitX()));
  EXPECT_TRUE(m.joints[kWAA].axis.isApprox(Eigen::Vector3d::UnitZ()));

  ASSERT_EQ(m.bodies.size(), 7u);
  // total = exoskeleton 3.9 + user arm 3.5 + payload 5.0
  EXPECT_NEAR(total_mass(m), 3.9 + 3.5 + 5.0, kTol);
  EXPECT_EQ(body(m, "user_forearm").joint, kEFE);
  EXPECT_NEAR(body(m, "user_forearm").com_m.x(), 0.109865, kTol);
  EXPECT_EQ(body(m, "exo_hand").joint, kWAA);
  EXPECT_NEAR(body(m, "exo_upper_arm").com_m.x(), 0.6 * 0.3255, kTol);
  EXPECT_NEAR(body(m, "payload").com_m.x(), 0.095634, kTol);
  EXPECT_GT(body(m, "payload").inertia_kgm2(0, 0), 0.0);

  // Without the user's arm: exoskeleton + payload only; a zero payload stays in the model.
  const ArmModel bare = build_arm_model(exo, u, 0.0, false);
  EXPECT_EQ(bare.bodies.size(), 4u);
  EXPECT_NEAR(total_mass(bare), 3.9, kTol);
  EXPECT_EQ(body(bare, "payload").mass_kg, 0.0);

  EXPECT_THROW(build_arm_model(exo, u, -1.0, true), std::invalid_argument);
  ExoArmParams broken = exo;
  broken.forearm_link.length_m = 0;
  EXPECT_THROW(build_arm_model(broken, u, 0.0, true), std::invalid_argument);
}

TEST(BodyFile, ReadsTheShippedFile) {
  const auto doc = config::Document::load_file(std::filesystem::path(PEHA_SOURCE_DIR) / "configs" / "arm" / "right_arm_body.yaml");
  const BodyConfig c = read_body(doc);
  EXPECT_DOUBLE_EQ(c.controller.user_spec.height_m, 1.75);
  EXPECT_DOUBLE_EQ(c.controller.user_spec.mass_kg, 70.0);
  EXPECT_NEAR(c.controller.user.forearm.mass_kg, 1.12, kTol);
  EXPECT_NEAR(c.controller.exo.upper_link.length_m, 0.3255, kTol);  // from the user
  EXPECT_NEAR(c.controller.exo.total_mass_kg(), 3.9, kTol);
  EXPECT_LT(c.plant.exo.total_mass_kg(), 5.0);
  EXPECT_TRUE(c.controller.include_user_arm);

  // The plant is not the controller's model.
  EXPECT_NE(c.plant.exo.upper_link.mass_kg, c.controller.exo.upper_link.mass_kg);
  EXPECT_NE(c.plant.user.forearm.mass_kg, c.controller.user.forearm.mass_kg);
  EXPECT_NEAR(c.plant.exo.upper_link.length_m, 0.327, kTol);  // explicit length_m
  EXPECT_NEAR(c.plant.exo.hand_piece.length_m, 0.189, kTol);  // from the plant's user

  const ArmModel m = c.controller.model();
  EXPECT_EQ(m.dof(), 5);
  EXPECT_NEAR(total_mass(m), 3.9 + 3.5, kTol);
}

TEST(BodyFile, RejectsUnknownKeys) {
  const std::string text = right_arm_yaml();
  ASSERT_FALSE(text.empty());
  EXPECT_NO_THROW(read_body(config::Document::load_string(text, "right_arm.yaml")));

  // A typo at the top level, inside a section and inside the plant's section.
  EXPECT_THROW(read_body(config::Document::load_string(text + "paylaod_kg: 1.0\n", "right_arm.yaml")),
               config::Error);
  std::string nested = text;
  nested.replace(nested.find("  mass_kg: 70.0"), 0, "  weight_kg: 70.0\n");
  EXPECT_THROW(read_body(config::Document::load_string(nested, "right_arm.yaml")), config::Error);
  std::string in_plant = text;
  in_plant.replace(in_plant.find("  payload_kg: 0.0\n  include_user_arm: true"), 0, "  colour: red\n");
  try {
    read_body(config::Document::load_string(in_plant, "right_arm.yaml"));
    FAIL() << "unknown key accepted";
  } catch (const config::Error& e) {
    EXPECT_NE(std::string(e.what()).find("plant.colour"), std::string::npos) << e.what();
  }
  // Out of range: a 2.5 m user.
  std::string tall = text;
  tall.replace(tall.find("height_m: 1.75"), 14, "height_m: 2.50");
  EXPECT_THROW(read_body(config::Document::load_string(tall, "right_arm.yaml")), config::Error);
}

}  // namespace
}  // namespace peha::models
