#include "peha/safety/verdict.hpp"

#include "../support/nominal_models.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <numbers>

namespace peha::safety {
namespace {

using ::testing::HasSubstr;

struct OneJoint {
  LimitsModel limits;
  models::JointModel joint = testing::rig_joint();
  JointModels joints{};
  OneJoint() {
    limits.joint_count = 1;
    limits.joints[0].min_angle_rad = -0.8;
    limits.joints[0].max_angle_rad = 0.8;
    joint.pretension_N = 60.0;
    joints[0] = &joint;
  }
  /// The verdict of one sample with these figures.
  Verdict judge(double agonist_N, double antagonist_N, double tension_N, const VerdictThresholds& t = {}) const {
    Envelope e;
    e.observe(0, {{agonist_N, antagonist_N}, tension_N, {0.2e6, 0.2e6}, 1.0, 0.0});
    Verdict v;
    add_envelope_checks(limits, joints, {"joint"}, e, t, v);
    return v;
  }
};

// Each muscle is judged against its own configured ceiling: 700 N passes the DMSP-40 (2000 N) and
// fails the DMSP-10 (630 N); the failure names the muscle and its own limit.
TEST(Verdict, EachMuscleHasItsOwnCeiling) {
  const OneJoint rig;
  EXPECT_TRUE(rig.judge(700.0, 100.0, 50.0).passed());
  const Verdict v = rig.judge(100.0, 700.0, 50.0);
  EXPECT_FALSE(v.passed());
  EXPECT_THAT(v.failures(), HasSubstr("joint antagonist peak force 700 N > 630 N"));
  EXPECT_EQ(v.failures().find("agonist peak force 100"), std::string::npos);
}

// The tension floor is a fraction of the configured pretension, not just > 0: with 60 N pretension
// and the default 0.5, 31 N passes and 29 N fails; a stricter fraction from the configuration moves it.
TEST(Verdict, TensionFloorIsAFractionOfThePretension) {
  const OneJoint rig;
  EXPECT_TRUE(rig.judge(500.0, 100.0, 31.0).passed());
  const Verdict low = rig.judge(500.0, 100.0, 29.0);
  EXPECT_FALSE(low.passed());
  EXPECT_THAT(low.failures(), HasSubstr("joint lowest wire tension 29 N < 30 N"));
  VerdictThresholds strict;
  strict.min_tension_fraction = 0.6;
  EXPECT_FALSE(rig.judge(500.0, 100.0, 31.0, strict).passed());
}

// Every figure of the envelope can fail on its own: a pressure above the 0.8 MPa supply, a motor
// torque above its 2.5 Nm rating, an angle past the range (+ tolerance) - each names itself.
TEST(Verdict, EveryEnvelopeFigureCanFail) {
  const OneJoint rig;
  auto judge = [&](const JointSample& s) {
    Envelope e;
    e.observe(0, s);
    Verdict v;
    add_envelope_checks(rig.limits, rig.joints, {"joint"}, e, {}, v);
    return v;
  };
  const JointSample ok{{500.0, 100.0}, 50.0, {0.3e6, 0.2e6}, 1.0, 0.1};
  EXPECT_TRUE(judge(ok).passed()) << judge(ok).failures();
  JointSample s = ok;
  s.pressure_Pa[1] = 0.85e6;
  EXPECT_THAT(judge(s).failures(), HasSubstr("joint highest pressure 0.85 MPa > 0.8 MPa"));
  s = ok;
  s.motor_torque_Nm = -2.6;
  EXPECT_THAT(judge(s).failures(), HasSubstr("joint peak motor torque 2.6 Nm > 2.5 Nm"));
  s = ok;
  s.angle_rad = -0.85;
  EXPECT_THAT(judge(s).failures(), HasSubstr("joint lowest angle"));
  s = ok;
  s.angle_rad = 0.85;
  EXPECT_THAT(judge(s).failures(), HasSubstr("joint highest angle"));
}

// A NaN figure (a broken sensor or model) fails, never passes silently.
TEST(Verdict, NanFiguresFail) {
  const OneJoint rig;
  EXPECT_FALSE(rig.judge(500.0, 100.0, std::numeric_limits<double>::quiet_NaN()).passed());
  Verdict v;
  v.at_most("drift", "deg", std::numeric_limits<double>::quiet_NaN(), 0.5);
  EXPECT_FALSE(v.passed());
}

// The verdict: section: defaults when absent, each key optional, unknown keys and bad values
// rejected with file:line:column.
TEST(Verdict, ThresholdsComeFromTheConfigurationWithDefaults) {
  {
    config::Map root = config::Document::load_string("other: 1\n").root();
    const VerdictThresholds t = read_verdict_thresholds(root);
    EXPECT_EQ(t.max_drift_deg, VerdictThresholds{}.max_drift_deg);
    EXPECT_EQ(t.min_tension_fraction, 0.5);
    EXPECT_EQ(t.max_static_torque_error_pct, 5.0);
  }
  {
    config::Map root = config::Document::load_string("verdict: {max_drift_deg: 0.2, min_tension_fraction: 0.3}\n").root();
    const VerdictThresholds t = read_verdict_thresholds(root);
    EXPECT_EQ(t.max_drift_deg, 0.2);
    EXPECT_EQ(t.min_tension_fraction, 0.3);
    EXPECT_EQ(t.max_tracking_rms_deg, VerdictThresholds{}.max_tracking_rms_deg);
  }
  config::Map unknown = config::Document::load_string("verdict: {max_drift: 0.2}\n", "s.yaml").root();
  try {
    read_verdict_thresholds(unknown);
    FAIL() << "unknown key accepted";
  } catch (const config::Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("s.yaml:1:"));
    EXPECT_THAT(e.what(), HasSubstr("max_drift"));
  }
  config::Map negative = config::Document::load_string("verdict: {max_drift_deg: -1}\n", "s.yaml").root();
  EXPECT_THROW(read_verdict_thresholds(negative), config::Error);
}

}  // namespace
}  // namespace peha::safety
