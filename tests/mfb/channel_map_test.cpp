#include "peha/mfb/channel_map.hpp"

#include "peha/models/anthropometry.hpp"
#include "peha/models/units.hpp"

#include "../support/alloc_counter.hpp"
#include "../support/replaced.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>
#include <string>
#include <vector>

namespace peha::mfb {
namespace {

using ::testing::HasSubstr;

constexpr double kPi = std::numbers::pi;

// The backends' joints: sim:one_dof_rig reports "joint"; sim:arm (the right arm) the three actuated joints
// of the arm, in the order of models::kRightArmJointNames.
const std::vector<std::string> kRigJoints = {"joint"};
const std::vector<std::string> kArmJoints = {models::kRightArmJointNames[models::kSFE],
                                             models::kRightArmJointNames[models::kEFE],
                                             models::kRightArmJointNames[models::kWFE]};

ChannelMap rig_map() {
  return read_channel_map(config::Document::load_file(PEHA_SOURCE_DIR "/configs/mfb/one_dof_rig.yaml"), kRigJoints);
}
ChannelMap arm_map() {
  return read_channel_map(config::Document::load_file(PEHA_SOURCE_DIR "/configs/mfb/right_arm.yaml"), kArmJoints);
}

// A small complete map of one joint "knee". The rejection tests mutate one line of it and assert on
// the line numbers below (1-based, as in the messages).
const std::string kKnee = R"(# test map
analog_inputs:
  - {channel: 0, signal: knee.agonist_loadcell, unit: N, scale: 0.1, offset: 0}
  - {channel: 1, signal: knee.antagonist_loadcell, unit: N, scale: 0.1, offset: 0}
  - {channel: 2, signal: knee.agonist_pressure, unit: kPa, range: [0, 1000]}
  - {channel: 3, signal: knee.antagonist_pressure, unit: bar, scale: 1.0e-4, offset: 0}
analog_outputs:
  - {channel: 0, signal: knee.agonist_valve, unit: MPa, range: [0, 1]}
  - {channel: 1, signal: knee.antagonist_valve, unit: MPa, range: [0, 1]}
  - {channel: 2, signal: knee.motor, unit: Nm, scale: 1.0e-4, offset: -3.2768}
encoders:
  - {channel: 0, joint: knee, counts_per_rev: 2000, gear: 35, sign: 1, offset_deg: 0}
digital:
  enable_output: {line: 0, active: high}
  estop_input: {line: 0, active: low}
)";

using testing::replaced;

ChannelMap load(const std::string& text, const std::vector<std::string>& joints = {"knee"}) {
  return read_channel_map(config::Document::load_string(text, "configs/mfb/knee.yaml"), joints);
}

/// The error reading `text` gives ("" if none).
std::string error_of(const std::string& text, const std::vector<std::string>& joints = {"knee"}) {
  try {
    load(text, joints);
  } catch (const config::Error& e) {
    return e.what();
  }
  return "";
}

/// The error after replacing the first `from` in the knee map by `to`.
std::string error_after(const std::string& from, const std::string& to) {
  return error_of(replaced(kKnee, from, to));
}

/// Pointers to every AD / DA channel of a joint, for loops over all of them.
constexpr AnalogChannel JointChannels::*kAd[] = {&JointChannels::agonist_loadcell, &JointChannels::antagonist_loadcell,
                                                 &JointChannels::agonist_pressure,
                                                 &JointChannels::antagonist_pressure, &JointChannels::goniometer};
constexpr AnalogChannel JointChannels::*kDa[] = {&JointChannels::agonist_valve, &JointChannels::antagonist_valve,
                                                 &JointChannels::motor};

double uniform(std::mt19937_64& rng, double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(rng); }

// ---------------------------------------------------------------- the shipped maps

TEST(ChannelMapFiles, OneDofRigMapLoadsWithTheSimulatedSensorRanges) {
  const ChannelMap m = rig_map();
  ASSERT_EQ(m.joint_count(), 1);
  const JointChannels& j = m.joint(0);
  EXPECT_DOUBLE_EQ(j.agonist_loadcell.max_si(), 5000.0 * 65534 / 65535);  // top valid code: 65534
  EXPECT_DOUBLE_EQ(j.antagonist_loadcell.scale_SI, 1000.0 / 65535);
  EXPECT_DOUBLE_EQ(j.agonist_pressure.scale_SI, 1.0e6 / 65535);         // MPa converted to Pa
  EXPECT_DOUBLE_EQ(j.motor.to_si(32768), 0.0);                            // offset binary
  EXPECT_NEAR(j.agonist_valve.to_si(52428), 0.8e6, j.agonist_valve.scale_SI);  // supply, 25 % below full scale
  EXPECT_DOUBLE_EQ(j.encoder.counts_per_rev * j.encoder.gear, 70000.0);  // plant encoder_counts_per_rev
  EXPECT_FALSE(m.has_goniometer(0));
}

TEST(ChannelMapFiles, RightArmMapLoadsWithAllEightDaChannelsAndNoWristMotor) {
  const ChannelMap m = arm_map();
  ASSERT_EQ(m.joint_count(), 3);
  EXPECT_TRUE(m.joint(0).motor.mapped());
  EXPECT_TRUE(m.joint(1).motor.mapped());
  EXPECT_FALSE(m.joint(2).motor.mapped());  // R_WFE: a PAM pair only
  std::vector<int> da_used(kDaChannels, 0);
  for (int j = 0; j < 3; ++j) {
    for (auto member : kDa) {
      if ((m.joint(j).*member).mapped()) ++da_used[static_cast<std::size_t>((m.joint(j).*member).channel)];
    }
    EXPECT_DOUBLE_EQ(m.joint(j).encoder.counts_per_rev * m.joint(j).encoder.gear, 70000.0);
  }
  EXPECT_EQ(da_used, std::vector<int>(kDaChannels, 1));
  EXPECT_DOUBLE_EQ(m.joint(2).agonist_loadcell.scale_SI, 1000.0 / 65535);  // DMSP-10 load cells on the wrist
}

// ---------------------------------------------------------------- conversions

// SI -> codes -> SI for random values within every channel's range; each comes back within half a
// code (half a count for encoders), which is the best a 16-bit (or integer) channel can do.
TEST(ChannelMap, InputsRoundTripWithinHalfACode) {
  for (const ChannelMap& m : {rig_map(), arm_map()}) {
    std::mt19937_64 rng(7);
    for (int trial = 0; trial < 1000; ++trial) {
      io::SensorState s;
      s.joint_count = m.joint_count();
      for (int j = 0; j < m.joint_count(); ++j) {
        const JointChannels& c = m.joint(j);
        io::JointSensors& js = s.joints[static_cast<std::size_t>(j)];
        js.angle_rad = uniform(rng, -kPi, kPi);
        js.agonist_loadcell_N = uniform(rng, c.agonist_loadcell.min_si(), c.agonist_loadcell.max_si());
        js.antagonist_loadcell_N = uniform(rng, c.antagonist_loadcell.min_si(), c.antagonist_loadcell.max_si());
        js.agonist_pressure_Pa = uniform(rng, c.agonist_pressure.min_si(), c.agonist_pressure.max_si());
        js.antagonist_pressure_Pa = uniform(rng, c.antagonist_pressure.min_si(), c.antagonist_pressure.max_si());
      }
      BoardInputs in;
      m.encode_inputs(s, false, in);
      io::SensorState back;
      ASSERT_TRUE(m.decode_inputs(in, back));
      ASSERT_EQ(back.joint_count, m.joint_count());
      for (int j = 0; j < m.joint_count(); ++j) {
        const JointChannels& c = m.joint(j);
        const io::JointSensors& a = s.joints[static_cast<std::size_t>(j)];
        const io::JointSensors& b = back.joints[static_cast<std::size_t>(j)];
        const auto half = [](const AnalogChannel& ch) { return 0.5 * std::abs(ch.scale_SI) * (1 + 1e-9); };
        EXPECT_NEAR(b.angle_rad, a.angle_rad, 0.5 * std::abs(c.encoder.rad_per_count) * (1 + 1e-9));
        EXPECT_NEAR(b.agonist_loadcell_N, a.agonist_loadcell_N, half(c.agonist_loadcell));
        EXPECT_NEAR(b.antagonist_loadcell_N, a.antagonist_loadcell_N, half(c.antagonist_loadcell));
        EXPECT_NEAR(b.agonist_pressure_Pa, a.agonist_pressure_Pa, half(c.agonist_pressure));
        EXPECT_NEAR(b.antagonist_pressure_Pa, a.antagonist_pressure_Pa, half(c.antagonist_pressure));
      }
    }
  }
}

TEST(ChannelMap, OutputsRoundTripWithinHalfACodeWithoutClamping) {
  for (const ChannelMap& m : {rig_map(), arm_map()}) {
    std::mt19937_64 rng(11);
    for (int trial = 0; trial < 1000; ++trial) {
      io::Command cmd;
      cmd.joint_count = m.joint_count();
      for (int j = 0; j < m.joint_count(); ++j) {
        const JointChannels& c = m.joint(j);
        io::JointCommand& jc = cmd.joints[static_cast<std::size_t>(j)];
        jc.agonist_pressure_Pa = uniform(rng, c.agonist_valve.min_si(), c.agonist_valve.max_si());
        jc.antagonist_pressure_Pa = uniform(rng, c.antagonist_valve.min_si(), c.antagonist_valve.max_si());
        jc.motor_torque_Nm = c.motor.mapped() ? uniform(rng, c.motor.min_si(), c.motor.max_si()) : 0.0;
      }
      BoardOutputs out;
      ASSERT_EQ(m.encode_outputs(cmd, true, out), 0);
      io::Command back;
      m.decode_outputs(out, back);
      ASSERT_EQ(back.joint_count, m.joint_count());
      for (int j = 0; j < m.joint_count(); ++j) {
        const JointChannels& c = m.joint(j);
        const io::JointCommand& a = cmd.joints[static_cast<std::size_t>(j)];
        const io::JointCommand& b = back.joints[static_cast<std::size_t>(j)];
        const auto half = [](const AnalogChannel& ch) { return 0.5 * std::abs(ch.scale_SI) * (1 + 1e-9); };
        EXPECT_NEAR(b.agonist_pressure_Pa, a.agonist_pressure_Pa, half(c.agonist_valve));
        EXPECT_NEAR(b.antagonist_pressure_Pa, a.antagonist_pressure_Pa, half(c.antagonist_valve));
        if (c.motor.mapped()) {
          EXPECT_NEAR(b.motor_torque_Nm, a.motor_torque_Nm, half(c.motor));
        }
      }
    }
  }
}

// The simulators quantise like the board: a 16-bit sensor reads code/65535 * full scale and the
// encoder floor(angle * 70000 / 2 pi) counts (sim::quantize_16bit, sim::encoder_angle_rad). The
// emulator must turn those readings back into exactly those codes, so the example maps reproduce
// the simulated sensors bit for bit.
TEST(ChannelMapFiles, EmulatorReproducesTheSimulatedSensorCodesExactly) {
  const ChannelMap m = rig_map();
  constexpr double kAgonistRange_N = 5000.0, kAntagonistRange_N = 1000.0, kPressureRange_Pa = 1.0e6;
  constexpr double kCountsPerRad = 70000.0 / (2.0 * kPi);
  for (int code : {0, 1, 12345, 32768, 52428, 65534}) {
    for (std::int32_t counts : {-17500, -1, 0, 1, 4321, 35000}) {
      io::SensorState s;
      s.joint_count = 1;
      io::JointSensors& js = s.joints[0];
      js.agonist_loadcell_N = code / 65535.0 * kAgonistRange_N;
      js.antagonist_loadcell_N = code / 65535.0 * kAntagonistRange_N;
      js.agonist_pressure_Pa = code / 65535.0 * kPressureRange_Pa;
      js.antagonist_pressure_Pa = code / 65535.0 * kPressureRange_Pa;
      js.angle_rad = counts / kCountsPerRad;
      BoardInputs in;
      m.encode_inputs(s, false, in);
      for (int ch = 0; ch < 4; ++ch) EXPECT_EQ(in.ad[static_cast<std::size_t>(ch)], code) << "AD " << ch;
      EXPECT_EQ(in.encoder[0], counts);
    }
  }
}

// 70000 / 4 counts are a quarter joint revolution through 2000 counts/rev and 35:1; the sign flips
// it and the offset adds to it.
TEST(ChannelMap, EncoderAngleFollowsCountsGearSignAndOffset) {
  BoardInputs in;
  in.encoder[0] = 70000 / 4;
  io::SensorState s;
  ASSERT_TRUE(load(kKnee).decode_inputs(in, s));
  EXPECT_NEAR(s.joints[0].angle_rad, kPi / 2, 1e-12);

  ASSERT_TRUE(load(replaced(kKnee, "sign: 1", "sign: -1")).decode_inputs(in, s));
  EXPECT_NEAR(s.joints[0].angle_rad, -kPi / 2, 1e-12);

  ASSERT_TRUE(load(replaced(kKnee, "offset_deg: 0", "offset_deg: 10")).decode_inputs(in, s));
  EXPECT_NEAR(s.joints[0].angle_rad, kPi / 2 + models::deg_to_rad(10), 1e-12);

  // Gear 7 instead of 35: five times the angle per count.
  ASSERT_TRUE(load(replaced(kKnee, "gear: 35", "gear: 7")).decode_inputs(in, s));
  EXPECT_NEAR(s.joints[0].angle_rad, 5 * kPi / 2, 1e-12);
}

// kPa and bar are converted to Pa at load: 1000 kPa full scale is 1e6 Pa at code 65535; 1e-4 bar per
// code is 10 Pa per code.
TEST(ChannelMap, PressureUnitsAreConvertedToPascal) {
  const ChannelMap m = load(kKnee);
  BoardInputs in;
  in.ad[2] = 65535;
  in.ad[3] = 1000;
  io::SensorState s;
  ASSERT_TRUE(m.decode_inputs(in, s));
  EXPECT_DOUBLE_EQ(s.joints[0].agonist_pressure_Pa, 1.0e6);
  EXPECT_DOUBLE_EQ(s.joints[0].antagonist_pressure_Pa, 1.0e4);
}

// The rig's valves span 0..1 MPa and the motor +-3 Nm: 2 MPa, -0.1 MPa and 5 Nm are outside and are
// clamped to the rails, each counted once; in-range values count nothing.
TEST(ChannelMap, ClampsDaCodesToTheRailsAndCountsEachClampedChannel) {
  const ChannelMap m = rig_map();
  io::Command cmd;
  cmd.joint_count = 1;
  cmd.joints[0] = {2.0e6, -0.1e6, 5.0};
  BoardOutputs out;
  EXPECT_EQ(m.encode_outputs(cmd, true, out), 3);
  EXPECT_EQ(out.da[0], 65535);
  EXPECT_EQ(out.da[1], 0);
  EXPECT_EQ(out.da[2], 65535);

  cmd.joints[0] = {0.8e6, 0.0, -2.5};
  EXPECT_EQ(m.encode_outputs(cmd, true, out), 0);
  EXPECT_EQ(out.da[0], 52428);  // 0.8 MPa / (1 MPa / 65535) = 52428.0
  EXPECT_EQ(out.da[1], 0);
  EXPECT_EQ(out.da[2], 5461);   // (-2.5 + 3) / (3 / 32768) = 5461.33
}

// A NaN that slipped past the limits must not reach a valve as an arbitrary code: it gets the safe
// code (vent / 0 Nm) and counts as clamped.
TEST(ChannelMap, NonFiniteCommandGetsTheSafeCodeAndIsCounted) {
  const ChannelMap m = rig_map();
  io::Command cmd;
  cmd.joint_count = 1;
  cmd.joints[0] = {std::nan(""), 0.3e6, std::nan("")};
  BoardOutputs out;
  EXPECT_EQ(m.encode_outputs(cmd, true, out), 2);
  EXPECT_EQ(out.da[0], m.safe_outputs().da[0]);
  EXPECT_EQ(out.da[2], m.safe_outputs().da[2]);
}

TEST(ChannelMap, SafeOutputsDecodeToZeroPressureAndTorqueWithEnableOff) {
  for (const ChannelMap& m : {rig_map(), arm_map(), load(kKnee)}) {
    const BoardOutputs safe = m.safe_outputs();
    EXPECT_FALSE(m.enable_active(safe));
    io::Command cmd;
    m.decode_outputs(safe, cmd);
    for (int j = 0; j < m.joint_count(); ++j) {
      const JointChannels& c = m.joint(j);
      const io::JointCommand& jc = cmd.joints[static_cast<std::size_t>(j)];
      EXPECT_NEAR(jc.agonist_pressure_Pa, 0.0, 0.5 * c.agonist_valve.scale_SI);
      EXPECT_NEAR(jc.antagonist_pressure_Pa, 0.0, 0.5 * c.antagonist_valve.scale_SI);
      EXPECT_NEAR(jc.motor_torque_Nm, 0.0, c.motor.mapped() ? 0.5 * c.motor.scale_SI : 0.0);
    }
  }
  // The shipped maps put 0 Pa and 0 Nm exactly on a code.
  io::Command cmd;
  arm_map().decode_outputs(arm_map().safe_outputs(), cmd);
  for (int j = 0; j < 3; ++j) {
    EXPECT_EQ(cmd.joints[static_cast<std::size_t>(j)].agonist_pressure_Pa, 0.0);
    EXPECT_EQ(cmd.joints[static_cast<std::size_t>(j)].motor_torque_Nm, 0.0);
  }
}

TEST(ChannelMap, CommandForAnotherJointCountGivesSafeOutputs) {
  const ChannelMap m = arm_map();
  io::Command cmd;
  cmd.joint_count = 2;
  cmd.joints[0] = {0.5e6, 0.5e6, 1.0};
  BoardOutputs out;
  EXPECT_EQ(m.encode_outputs(cmd, true, out), -1);
  EXPECT_EQ(out.da, m.safe_outputs().da);
  EXPECT_FALSE(m.enable_active(out));
}

// The wrist has no motor channel: its motor command changes no DA code, counts no clamp, and the
// emulator reads 0 Nm back.
TEST(ChannelMap, MotorCommandOnAJointWithoutMotorIsIgnored) {
  const ChannelMap m = arm_map();
  io::Command cmd;
  cmd.joint_count = 3;
  BoardOutputs without;
  ASSERT_EQ(m.encode_outputs(cmd, true, without), 0);
  cmd.joints[2].motor_torque_Nm = 1.0;
  BoardOutputs with;
  EXPECT_EQ(m.encode_outputs(cmd, true, with), 0);
  EXPECT_EQ(with.da, without.da);
  io::Command back;
  m.decode_outputs(with, back);
  EXPECT_EQ(back.joints[2].motor_torque_Nm, 0.0);
}

TEST(ChannelMap, EnableAndEstopLinesFollowTheirActiveLevels) {
  // Shipped: enable line 0 active high; e-stop line 0 active low (normally closed chain).
  const ChannelMap m = rig_map();
  io::Command cmd;
  cmd.joint_count = 1;
  BoardOutputs out;
  m.encode_outputs(cmd, true, out);
  EXPECT_EQ(out.digital_out, 0b1);
  EXPECT_TRUE(m.enable_active(out));
  m.encode_outputs(cmd, false, out);
  EXPECT_EQ(out.digital_out, 0b0);
  EXPECT_FALSE(m.enable_active(out));
  BoardInputs in;
  in.digital_in = 0b0;  // wire open or button pressed
  EXPECT_TRUE(m.estop_active(in));
  in.digital_in = 0b1;
  EXPECT_FALSE(m.estop_active(in));
  io::SensorState s;
  s.joint_count = 1;
  m.encode_inputs(s, true, in);
  EXPECT_EQ(in.digital_in, 0b0);
  m.encode_inputs(s, false, in);
  EXPECT_EQ(in.digital_in, 0b1);

  // Enable on line 5 active low, e-stop on line 3 active high.
  const ChannelMap k = load(replaced(replaced(kKnee, "{line: 0, active: high}", "{line: 5, active: low}"),
                                     "{line: 0, active: low}", "{line: 3, active: high}"));
  k.encode_outputs(cmd, true, out);
  EXPECT_EQ(out.digital_out, 0);
  k.encode_outputs(cmd, false, out);
  EXPECT_EQ(out.digital_out, 1 << 5);
  EXPECT_EQ(k.safe_outputs().digital_out, 1 << 5);
  in.digital_in = 1 << 3;
  EXPECT_TRUE(k.estop_active(in));
  in.digital_in = static_cast<std::uint8_t>(~(1 << 3));
  EXPECT_FALSE(k.estop_active(in));
}

// The shipped maps declare code 65535 implausible on every sensor (over range): one such channel
// makes the whole sample invalid, and the state the caller holds stays as it was.
TEST(ChannelMap, SensorAtItsUpperRailFailsDecodeAndLeavesTheStateUntouched) {
  const ChannelMap m = arm_map();
  BoardInputs in;
  in.ad.fill(30000);
  io::SensorState s;
  s.joint_count = 3;
  s.joints[1].antagonist_loadcell_N = 123.0;
  s.sequence = 42;
  in.ad[5] = 65535;  // R_EFE.antagonist_loadcell
  const io::SensorState before = s;
  EXPECT_FALSE(m.decode_inputs(in, s));
  EXPECT_EQ(m.implausible_ad_channels(in), 1u << 5);
  EXPECT_EQ(s.joints[1].antagonist_loadcell_N, 123.0);
  EXPECT_EQ(s.joint_count, before.joint_count);
  EXPECT_EQ(s.sequence, before.sequence);
  in.ad[5] = 65534;
  EXPECT_TRUE(m.decode_inputs(in, s));
  EXPECT_EQ(m.implausible_ad_channels(in), 0u);
  // Code 0 is valid (slack wire, vented muscle); an unmapped channel at a rail is nobody's business.
  in.ad[0] = 0;
  in.ad[15] = 65535;
  EXPECT_TRUE(m.decode_inputs(in, s));
}

// A potentiometer goniometer on AD 4, -135..135 deg over the codes: the middle code reads ~0, the top
// 135 deg. It is read on its own (io::JointSensors has no field for it) and fed by the emulator with
// the joint angle.
TEST(ChannelMap, GoniometerIsReadInItsUnitAndConvertedToRadians) {
  const ChannelMap m = load(replaced(kKnee, "analog_outputs:",
                                     "  - {channel: 4, signal: knee.goniometer, unit: deg, range: [-135, 135]}\n"
                                     "analog_outputs:"));
  ASSERT_TRUE(m.has_goniometer(0));
  BoardInputs in;
  in.ad[4] = 65535;
  EXPECT_NEAR(m.goniometer_rad(in, 0), models::deg_to_rad(135), 1e-12);
  io::SensorState s;
  s.joint_count = 1;
  s.joints[0].angle_rad = 0.5;
  m.encode_inputs(s, false, in);
  EXPECT_NEAR(m.goniometer_rad(in, 0), 0.5, 0.5 * m.joint(0).goniometer.scale_SI);
  EXPECT_FALSE(m.has_goniometer(1));
  EXPECT_TRUE(std::isnan(m.goniometer_rad(in, 1)));
  EXPECT_FALSE(rig_map().has_goniometer(0));
}

// STYLE.md principle 3: the conversions run in the 1 kHz loop and must not touch the heap.
TEST(ChannelMap, ConversionsAllocateNothing) {
  const ChannelMap m = arm_map();
  BoardInputs in;
  BoardOutputs out;
  io::SensorState s;
  s.joint_count = 3;
  io::Command cmd;
  cmd.joint_count = 3;
  const std::size_t allocations = testing::allocations_during([&] {
    for (int k = 0; k < 1000; ++k) {
      cmd.joints[0].agonist_pressure_Pa = 100.0 * k;
      m.encode_outputs(cmd, true, out);
      m.decode_outputs(out, cmd);
      s.joints[1].angle_rad = 1e-3 * k;
      m.encode_inputs(s, false, in);
      m.decode_inputs(in, s);
      m.estop_active(in);
      m.enable_active(out);
      m.goniometer_rad(in, 0);
      out = m.safe_outputs();
    }
  });
  EXPECT_EQ(allocations, 0u);
}

// ---------------------------------------------------------------- rejected at load

TEST(ChannelMapReader, AcceptsTheKneeMap) { EXPECT_EQ(error_of(kKnee), ""); }

TEST(ChannelMapReader, RejectsAChannelIndexOutOfRange) {
  EXPECT_THAT(error_after("{channel: 3, signal: knee.antagonist_pressure", "{channel: 16, signal: knee.antagonist_pressure"),
              HasSubstr("configs/mfb/knee.yaml:6:15: analog_inputs[3].channel: expected a number in [0, 15], found 16"));
  EXPECT_THAT(error_after("{channel: 2, signal: knee.motor", "{channel: 8, signal: knee.motor"),
              HasSubstr("knee.yaml:10:15: analog_outputs[2].channel: expected a number in [0, 7], found 8"));
  EXPECT_THAT(error_after("{channel: 0, joint: knee", "{channel: -1, joint: knee"),
              HasSubstr("knee.yaml:12:15: encoders[0].channel: expected a number in [0, 7], found -1"));
}

TEST(ChannelMapReader, RejectsAChannelUsedTwice) {
  EXPECT_THAT(error_after("{channel: 3, signal: knee.antagonist_pressure", "{channel: 2, signal: knee.antagonist_pressure"),
              HasSubstr("knee.yaml:6:15: analog_inputs[3].channel: AD channel 2 is already used by 'knee.agonist_pressure'"));
  EXPECT_THAT(error_after("{channel: 2, signal: knee.motor", "{channel: 0, signal: knee.motor"),
              HasSubstr("knee.yaml:10:15: analog_outputs[2].channel: DA channel 0 is already used by 'knee.agonist_valve'"));
}

TEST(ChannelMapReader, RejectsASignalMappedTwice) {
  EXPECT_THAT(error_after("signal: knee.antagonist_pressure", "signal: knee.agonist_pressure"),
              HasSubstr("knee.yaml:6:26: analog_inputs[3].signal: 'knee.agonist_pressure' is mapped twice (first to AD channel 2)"));
}

TEST(ChannelMapReader, RejectsAnUnknownJoint) {
  EXPECT_THAT(error_after("signal: knee.motor", "signal: ankle.motor"),
              HasSubstr("knee.yaml:10:26: analog_outputs[2].signal: unknown joint 'ankle' in 'ankle.motor'; "
                        "the backend's joints are knee"));
  EXPECT_THAT(error_after("joint: knee", "joint: ankle"),
              HasSubstr("knee.yaml:12:25: encoders[0].joint: unknown joint 'ankle'; the backend's joints are knee"));
}

TEST(ChannelMapReader, RejectsAnUnknownQuantityOrOneOfTheOtherDirection) {
  EXPECT_THAT(error_after("signal: knee.agonist_loadcell", "signal: knee.agonist_torque"),
              HasSubstr("knee.yaml:3:26: analog_inputs[0].signal: unknown analog input quantity 'agonist_torque' in "
                        "'knee.agonist_torque'; expected one of agonist_loadcell, antagonist_loadcell, agonist_pressure, "
                        "antagonist_pressure, goniometer"));
  // A valve is an output: on an AD channel it is unknown.
  EXPECT_THAT(error_after("signal: knee.agonist_loadcell", "signal: knee.agonist_valve"),
              HasSubstr("knee.yaml:3:26: analog_inputs[0].signal: unknown analog input quantity 'agonist_valve'"));
  EXPECT_THAT(error_after("signal: knee.agonist_loadcell", "signal: agonist_loadcell"),
              HasSubstr("knee.yaml:3:26: analog_inputs[0].signal: expected '<joint>.<quantity>', found 'agonist_loadcell'"));
}

TEST(ChannelMapReader, RejectsAJointWithoutItsRequiredSignals) {
  EXPECT_THAT(error_after("  - {channel: 2, signal: knee.agonist_pressure, unit: kPa, range: [0, 1000]}\n", ""),
              HasSubstr("knee.yaml:3:3: analog_inputs: no AD channel for 'knee.agonist_pressure' "
                        "(every joint needs both forces and both pressures)"));
  EXPECT_THAT(error_after("  - {channel: 1, signal: knee.antagonist_valve, unit: MPa, range: [0, 1]}\n", ""),
              HasSubstr("knee.yaml:8:3: analog_outputs: no DA channel for 'knee.antagonist_valve' (every joint needs both valves)"));
  // A second joint "hip" with all its AD and DA channels but no encoder.
  const std::string two = replaced(
      replaced(kKnee, "analog_outputs:",
               "  - {channel: 4, signal: hip.agonist_loadcell, unit: N, scale: 0.1, offset: 0}\n"
               "  - {channel: 5, signal: hip.antagonist_loadcell, unit: N, scale: 0.1, offset: 0}\n"
               "  - {channel: 6, signal: hip.agonist_pressure, unit: Pa, scale: 20, offset: 0}\n"
               "  - {channel: 7, signal: hip.antagonist_pressure, unit: Pa, scale: 20, offset: 0}\n"
               "analog_outputs:"),
      "encoders:",
      "  - {channel: 3, signal: hip.agonist_valve, unit: Pa, scale: 20, offset: 0}\n"
      "  - {channel: 4, signal: hip.antagonist_valve, unit: Pa, scale: 20, offset: 0}\n"
      "encoders:");
  EXPECT_EQ(error_of(two, {"knee", "hip"}).find("configs/mfb/knee.yaml:18:3: encoders: no encoder for joint 'hip' "
                                                "(every joint needs exactly one that is not redundant)"),
            0u)
      << error_of(two, {"knee", "hip"});
}

TEST(ChannelMapReader, RejectsASecondEncoderForAJoint) {
  EXPECT_THAT(error_after("digital:", "  - {channel: 1, joint: knee, counts_per_rev: 500, gear: 1, sign: 1, offset_deg: 0}\ndigital:"),
              HasSubstr("knee.yaml:13:25: encoders[1].joint: joint 'knee' already has its encoder channel 0 (one, and at most one redundant, per joint)"));
  // One redundant encoder per joint is accepted; a second is not, and a redundant one alone is no encoder.
  const std::string redundant = "  - {channel: 1, joint: knee, counts_per_rev: 16384, gear: 1, sign: 1, offset_deg: 0, redundant: true}\n";
  EXPECT_EQ(error_of(replaced(kKnee, "digital:", redundant + "digital:")), "");
  EXPECT_THAT(error_after("digital:", redundant + "  - {channel: 2, joint: knee, counts_per_rev: 16384, gear: 1, sign: 1, offset_deg: 0, redundant: true}\ndigital:"),
              HasSubstr("encoders[2].joint: joint 'knee' already has a redundant encoder channel 1"));
}

// The redundant joint-side encoder is decoded beside the primary one (NaN where a joint has none)
// and written back by the emulator's encode_inputs.
TEST(ChannelMap, ARedundantEncoderIsDecodedBesideThePrimaryAndEncodedBack) {
  BoardInputs in;
  in.encoder[0] = 70000 / 4;
  io::SensorState s;
  ASSERT_TRUE(load(kKnee).decode_inputs(in, s));
  EXPECT_TRUE(std::isnan(s.joints[0].redundant_angle_rad));
  const ChannelMap m = load(replaced(kKnee, "digital:",
                                     "  - {channel: 1, joint: knee, counts_per_rev: 16384, gear: 1, sign: 1, offset_deg: 0, redundant: true}\ndigital:"));
  in.encoder[1] = 16384 / 8;
  ASSERT_TRUE(m.decode_inputs(in, s));
  EXPECT_NEAR(s.joints[0].angle_rad, kPi / 2, 1e-12);
  EXPECT_NEAR(s.joints[0].redundant_angle_rad, kPi / 4, 1e-12);
  BoardInputs back;
  m.encode_inputs(s, false, back);
  EXPECT_EQ(back.encoder[0], 70000 / 4);
  EXPECT_EQ(back.encoder[1], 16384 / 8);
}

TEST(ChannelMapReader, RejectsAZeroOrNonFiniteScale) {
  EXPECT_THAT(error_after("scale: 0.1", "scale: 0"),
              HasSubstr("knee.yaml:3:65: analog_inputs[0].scale: expected a nonzero number"));
  EXPECT_THAT(error_after("scale: 0.1", "scale: .nan"), HasSubstr("knee.yaml:3:65: analog_inputs[0].scale: expected a number in"));
  EXPECT_THAT(error_after("scale: 0.1", "scale: inf"), HasSubstr("knee.yaml:3:65: analog_inputs[0].scale: expected a number in"));
  EXPECT_THAT(error_after("range: [0, 1000]", "range: [0, 0]"),
              HasSubstr("knee.yaml:5:67: analog_inputs[2].range: the values at code 0 and code 65535 must differ"));
}

TEST(ChannelMapReader, RejectsNonPositiveCountsPerRevAndGear) {
  EXPECT_THAT(error_after("counts_per_rev: 2000", "counts_per_rev: 0"),
              HasSubstr("knee.yaml:12:47: encoders[0].counts_per_rev: expected a number in [1, "));
  EXPECT_THAT(error_after("gear: 35", "gear: 0"), HasSubstr("knee.yaml:12:59: encoders[0].gear: expected a number in [0.001, "));
  EXPECT_THAT(error_after("gear: 35", "gear: -35"), HasSubstr("knee.yaml:12:59: encoders[0].gear: expected a number in"));
}

TEST(ChannelMapReader, RejectsASignOtherThanPlusOrMinusOne) {
  EXPECT_THAT(error_after("sign: 1", "sign: 0"), HasSubstr("knee.yaml:12:69: encoders[0].sign: expected +1 or -1, found 0"));
  EXPECT_THAT(error_after("sign: 1", "sign: 2"), HasSubstr("knee.yaml:12:69: encoders[0].sign: expected a number in [-1, 1], found 2"));
}

TEST(ChannelMapReader, RejectsADigitalLineOutsideTheByte) {
  EXPECT_THAT(error_after("{line: 0, active: high}", "{line: 8, active: high}"),
              HasSubstr("knee.yaml:14:25: digital.enable_output.line: expected a number in [0, 7], found 8"));
  EXPECT_THAT(error_after("{line: 0, active: low}", "{line: 0, active: open}"),
              HasSubstr("knee.yaml:15:34: digital.estop_input.active: expected one of {high, low}, found 'open'"));
}

TEST(ChannelMapReader, RejectsEnableOrEstopDeclaredTwice) {
  EXPECT_THAT(error_after("  estop_input:", "  enable_output: {line: 1, active: high}\n  estop_input:"),
              HasSubstr("knee.yaml:15:3: digital.enable_output: duplicate key"));
  EXPECT_THAT(error_of(kKnee + "  estop_input: {line: 1, active: low}\n"),
              HasSubstr("knee.yaml:16:3: digital.estop_input: duplicate key"));
}

TEST(ChannelMapReader, ReadsTheProcedureKeyOnALineOfItsOwn) {
  EXPECT_FALSE(load(kKnee).procedure_key_line().has_value());  // optional: none, the range always vents
  const ChannelMap keyed = load(kKnee + "  procedure_key_input: {line: 3, active: high}\n");
  ASSERT_TRUE(keyed.procedure_key_line().has_value());
  EXPECT_EQ(keyed.procedure_key_line()->line, 3);
  EXPECT_TRUE(keyed.procedure_key_line()->active_high);
  EXPECT_THAT(error_of(kKnee + "  procedure_key_input: {line: 0, active: high}\n"),
              HasSubstr("digital.procedure_key_input: line 0 is the e-stop's: the key needs an input of its own"));
}

// `speed_vent:` is optional per joint: without it no speed ceiling (0); with it both fields, within
// their bounds, and nothing else.
TEST(ChannelMapReader, ReadsASpeedVentWithinItsBounds) {
  const std::string limits = "board_limits:\n  - {joint: knee, agonist_force_N: 2000, antagonist_force_N: 630, agonist_pressure_MPa: 0.8, "
                             "antagonist_pressure_MPa: 0.8, pressure_rise_MPa_per_s: 10, force_lead_ms: 25, motor_torque_Nm: 2.5, "
                             "angle_deg: [-45, 45]";
  EXPECT_EQ(load(kKnee + limits + "}\n").joint(0).board_limits.speed_ceiling_rad_per_s, 0.0);
  const BoardLimits l = load(kKnee + limits + ", speed_vent: {ceiling_deg_per_s: 450, lead_ms: 60}}\n").joint(0).board_limits;
  EXPECT_NEAR(l.speed_ceiling_rad_per_s, 450.0 * std::numbers::pi / 180.0, 1e-12);
  EXPECT_NEAR(l.speed_lead_s, 0.060, 1e-12);
  EXPECT_THAT(error_of(kKnee + limits + ", speed_vent: {ceiling_deg_per_s: 0, lead_ms: 60}}\n"),
              HasSubstr("board_limits[0].speed_vent.ceiling_deg_per_s"));
  EXPECT_THAT(error_of(kKnee + limits + ", speed_vent: {ceiling_deg_per_s: 450, lead_ms: 2000}}\n"),
              HasSubstr("board_limits[0].speed_vent.lead_ms"));
  EXPECT_THAT(error_of(kKnee + limits + ", speed_vent: {ceiling_deg_per_s: 450}}\n"), HasSubstr("board_limits[0].speed_vent.lead_ms"));
  EXPECT_THAT(error_of(kKnee + limits + ", speed_vent: {ceiling_deg_per_s: 450, lead_ms: 60, brake_deg_per_s2: 500}}\n"),
              HasSubstr("board_limits[0].speed_vent.brake_deg_per_s2: unknown key"));
}

TEST(ChannelMapReader, RejectsUnknownKeys) {
  EXPECT_THAT(error_after("scale: 0.1, offset: 0}", "scale: 0.1, offset: 0, gain: 2}"),
              HasSubstr("knee.yaml:3:81: analog_inputs[0].gain: unknown key"));
  EXPECT_THAT(error_after("unit: MPa, range: [0, 1]}", "unit: MPa, range: [0, 1], valid_codes: [0, 65534]}"),
              HasSubstr("knee.yaml:8:72: analog_outputs[0].valid_codes: unknown key"));
  EXPECT_THAT(error_after("  estop_input:", "  brake_output: {line: 1, active: high}\n  estop_input:"),
              HasSubstr("knee.yaml:15:3: digital.brake_output: unknown key"));
  EXPECT_THAT(error_of(kKnee + "board: mfb2\n"), HasSubstr("knee.yaml:16:1: board: unknown key"));
}

TEST(ChannelMapReader, RejectsAUnitOfTheWrongDimension) {
  EXPECT_EQ(error_after("unit: bar", "unit: N"),
            "configs/mfb/knee.yaml:6:58: analog_inputs[3].unit: expected a pressure unit (Pa, kPa, MPa, bar) for "
            "'knee.antagonist_pressure', found 'N'");
  EXPECT_THAT(error_after("unit: Nm", "unit: N"),
              HasSubstr("knee.yaml:10:44: analog_outputs[2].unit: expected a torque unit (Nm) for 'knee.motor', found 'N'"));
  EXPECT_THAT(error_after("signal: knee.agonist_loadcell, unit: N", "signal: knee.agonist_loadcell, unit: kN"),
              HasSubstr("analog_inputs[0].unit: expected a force unit (N) for 'knee.agonist_loadcell', found 'kN'"));
}

// The watchdog must be able to vent the valves and stop the motor: a DA range without 0 Pa / 0 Nm
// is refused.
TEST(ChannelMapReader, RejectsAnOutputThatCannotSendZero) {
  EXPECT_THAT(error_after("{channel: 0, signal: knee.agonist_valve, unit: MPa, range: [0, 1]}",
                          "{channel: 0, signal: knee.agonist_valve, unit: MPa, range: [0.1, 1]}"),
              HasSubstr("knee.yaml:8:64: analog_outputs[0].range: 0 MPa must be within the channel's range [0.1, 1] MPa"));
  EXPECT_THAT(error_after("offset: -3.2768", "offset: 0.5"),
              HasSubstr("knee.yaml:10:71: analog_outputs[2].offset: 0 Nm must be within the channel's range [0.5, 7.0535] Nm"));
}

TEST(ChannelMapReader, RejectsAmbiguousOrMissingConversion) {
  EXPECT_THAT(error_after("range: [0, 1000]}", "range: [0, 1000], scale: 1}"),
              HasSubstr("knee.yaml:5:67: analog_inputs[2].range: give either range or scale and offset, not both"));
  EXPECT_THAT(error_after(", scale: 0.1, offset: 0}", "}"),
              HasSubstr("knee.yaml:3:5: analog_inputs[0]: expected scale and offset (physical = offset + scale * code), or range"));
  EXPECT_THAT(error_after("scale: 0.1, offset: 0}", "scale: 0.1}"),
              HasSubstr("knee.yaml:3:5: analog_inputs[0].offset: missing required key"));
}

TEST(ChannelMapReader, RejectsInvalidValidCodes) {
  EXPECT_THAT(error_after("range: [0, 1000]}", "range: [0, 1000], valid_codes: [100, 50]}"),
              HasSubstr("knee.yaml:5:91: analog_inputs[2].valid_codes: expected two integer codes [min, max] with min < max, "
                        "found [100, 50]"));
  EXPECT_THAT(error_after("range: [0, 1000]}", "range: [0, 1000], valid_codes: [0, 70000]}"),
              HasSubstr("analog_inputs[2].valid_codes[1]: expected a number in [0, 65535], found 70000"));
}

TEST(ChannelMapReader, RejectsBadJointNamesFromTheCaller) {
  EXPECT_THROW(load(kKnee, {}), std::invalid_argument);
  EXPECT_THROW(load(kKnee, {"knee", "knee"}), std::invalid_argument);
}

}  // namespace
}  // namespace peha::mfb
