// Telemetry of any logged signal: names resolved against the log's columns once, the tee at the
// log's row sink streaming the chosen columns of each row over a real UDP socket.
#include "peha/runtime/log_telemetry.hpp"

#include "peha/experiments/e1_gravity/e1_gravity.hpp"
#include "peha/runtime/realtime_harness.hpp"

#include "../support/alloc_counter.hpp"
#include "../support/telemetry_receiver.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>
#include <vector>

namespace peha::runtime {
namespace {

using ::testing::HasSubstr;

const std::vector<std::string> kTelemetryColumns = {"t_s", "angle_rad", "velocity_radps", "agonist_loadcell_N", "antagonist_loadcell_N", "limit_flags"};

/// The message of the std::invalid_argument `f` throws ("" if it throws none).
template <class F>
std::string refusal(F&& f) {
  try {
    f();
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

TEST(LogTelemetry, SelectsColumnsByNameGlobAndDegreeView) {
  const TelemetrySelection s = select_telemetry({"angle_deg", "*_loadcell_N", "t_s", "agonist_loadcell_N"}, kTelemetryColumns);
  // The glob's matches in the log's order; a name chosen twice streams once.
  EXPECT_EQ(s.names, (std::vector<std::string>{"angle_deg", "agonist_loadcell_N", "antagonist_loadcell_N", "t_s"}));
  const std::vector<double> row = {0.5, 0.25, -1.0, 100.0, 200.0, 0.0};
  std::vector<double> values(s.names.size());
  pick_telemetry(s, row, {}, values);
  EXPECT_DOUBLE_EQ(values[0], 0.25 * 180.0 / std::numbers::pi);  // 14.32 deg
  EXPECT_EQ(values[1], 100.0);
  EXPECT_EQ(values[2], 200.0);
  EXPECT_EQ(values[3], 0.5);
  // The harness's extras come after the row.
  const TelemetrySelection e = select_telemetry({"rtt_us", "velocity_degps"}, kTelemetryColumns, {"rtt_us", "lifecycle_state"});
  const double extras[] = {87.5, 2.0};
  std::vector<double> two(2);
  pick_telemetry(e, row, extras, two);
  EXPECT_EQ(two[0], 87.5);
  EXPECT_DOUBLE_EQ(two[1], -180.0 / std::numbers::pi);
}

TEST(LogTelemetry, RefusesAnUnknownNameNamingTheClosestColumn) {
  EXPECT_THAT(refusal([] { select_telemetry({"agonist_loadcel_N"}, kTelemetryColumns); }), HasSubstr("did you mean 'agonist_loadcell_N'"));
  EXPECT_THAT(refusal([] { select_telemetry({"angle_dg"}, kTelemetryColumns); }), HasSubstr("did you mean 'angle_deg'"));
  EXPECT_THAT(refusal([] { select_telemetry({"*_pressure_MPa"}, kTelemetryColumns); }), HasSubstr("matches no column"));
  // The harness's own signals exist on the board only.
  EXPECT_THAT(refusal([] { select_telemetry({"rtt_us"}, kTelemetryColumns); }), HasSubstr("'rtt_us' is not a column of the log"));
  EXPECT_EQ(refusal([] { select_telemetry({"rtt_us"}, kTelemetryColumns, {"rtt_us"}); }), "");
  // The same check before a run, and the destination's: loopback unless allowed.
  TelemetryOptions o;
  o.destination = io::parse_udp_endpoint("udp://192.0.2.7:9870");
  o.signals = {"angle_rad"};
  EXPECT_THAT(refusal([&] { check_telemetry(o, kTelemetryColumns); }), HasSubstr("not a loopback address"));
  o.allow_remote = true;
  EXPECT_EQ(refusal([&] { check_telemetry(o, kTelemetryColumns); }), "");
  o.signals = {"angle"};
  EXPECT_THAT(refusal([&] { check_telemetry(o, kTelemetryColumns); }), HasSubstr("not a column of the log"));
}

// With nothing chosen the one-DOF rig streams what it streamed before signals could be chosen:
// six signals of its joint and the harness's two, under the same names.
TEST(LogTelemetry, DefaultIsEachJointsAngleLoadCellsPressureCommandsAndMotorTorque) {
  EXPECT_EQ(default_telemetry_signals(experiments::e1_log_columns(), RealtimeHarness::telemetry_extras()),
            (std::vector<std::string>{"angle_deg", "agonist_loadcell_N", "antagonist_loadcell_N", "agonist_pressure_cmd_MPa",
                                      "antagonist_pressure_cmd_MPa", "tau_motor_cmd_Nm", "rtt_us", "lifecycle_state"}));
  // An arm's log: per joint prefix; a simulator-truth column of the same field is not a joint.
  const std::vector<std::string> arm = {"t_s", "r_sfe_angle_rad", "r_sfe_plant_angle_rad", "r_sfe_agonist_loadcell_N",
                                        "r_sfe_plant_agonist_force_N", "r_efe_angle_rad", "r_efe_agonist_loadcell_N", "r_efe_tau_motor_cmd_Nm"};
  EXPECT_EQ(default_telemetry_signals(arm), (std::vector<std::string>{"r_sfe_angle_deg", "r_sfe_agonist_loadcell_N", "r_efe_angle_deg",
                                                                      "r_efe_agonist_loadcell_N", "r_efe_tau_motor_cmd_Nm"}));
  EXPECT_EQ(select_telemetry({}, arm).names, default_telemetry_signals(arm));
}

TEST(LogTelemetry, ReadsTheScenarioKeyStrictly) {
  auto read = [](const std::string& yaml) {
    config::Map root = config::Document::load_string(yaml, "s.yaml").root();
    TelemetryOptions o = read_telemetry(root);
    root.finish();
    return o;
  };
  const TelemetryOptions o = read("telemetry: {signals: [angle_deg, '*_loadcell_N'], rate_Hz: 50, destination: udp://127.0.0.1:9871}\n");
  EXPECT_EQ(o.signals, (std::vector<std::string>{"angle_deg", "*_loadcell_N"}));
  EXPECT_EQ(o.rate_Hz, 50.0);
  ASSERT_TRUE(o.destination);
  EXPECT_EQ(o.destination->to_string(), "127.0.0.1:9871");
  config::Map without = config::Document::load_string("seed: 1\n", "s.yaml").root();
  EXPECT_FALSE(read_telemetry(without).destination);
  auto refused = [&](const std::string& yaml) {
    try {
      read(yaml);
    } catch (const config::Error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_THAT(refused("telemetry: {signal: [angle_deg]}\n"), HasSubstr("unknown key; did you mean 'signals'?"));
  EXPECT_THAT(refused("telemetry: {destination: udp://192.0.2.7:9870}\n"), HasSubstr("expected a loopback address"));
  EXPECT_THAT(refused("telemetry: {signals: []}\n"), HasSubstr("expected a list of 1 to"));
  EXPECT_THAT(refused("telemetry: {rate_Hz: 0}\n"), HasSubstr("telemetry.rate_Hz"));
}

// A 1 kHz log of 1001 rows streamed at 100 Hz: 101 datagrams whose keys are exactly the chosen
// signals and whose values are those of the row at their timestamp; the log keeps every row.
TEST(LogTelemetry, TeeStreamsTheChosenColumnsOfEachRowOverUdp) {
  testing::TelemetryReceiver rx;
  CsvLog log(kTelemetryColumns, 1001);
  TelemetryOptions o;
  o.destination = io::parse_udp_endpoint("udp://127.0.0.1:" + std::to_string(rx.port()));
  o.signals = {"antagonist_loadcell_N", "angle_deg"};
  TelemetryTee tee(log, o, kTelemetryColumns);
  auto row_at = [](int k) { return std::vector<double>{k * 1e-3, 0.001 * k, 0.0, 3.0 * k, -0.5 * k, 0.0}; };
  for (int k = 0; k <= 1000; ++k) tee.push_row(row_at(k));
  ASSERT_NE(tee.telemetry(), nullptr);
  tee.telemetry()->close();
  EXPECT_EQ(log.rows(), 1001u);
  EXPECT_EQ(tee.telemetry()->telemetry().sent_datagrams(), 101u);
  for (int i = 0; i <= 100; ++i) {
    const testing::TelemetrySample s = testing::parse_telemetry(rx.receive(), "peha");
    ASSERT_EQ(s.values.size(), 2u) << "datagram " << i;
    EXPECT_EQ(s.values[0].first, "antagonist_loadcell_N");
    EXPECT_EQ(s.values[1].first, "angle_deg");
    const int k = static_cast<int>(std::lround(s.timestamp * 1e3));
    EXPECT_EQ(k, 10 * i);
    EXPECT_EQ(s.values[0].second, log.at(static_cast<std::size_t>(k), 4));
    EXPECT_NEAR(s.values[1].second, log.at(static_cast<std::size_t>(k), 1) * 180.0 / std::numbers::pi, 1e-8 * (1 + std::abs(s.values[1].second)));
  }
  EXPECT_TRUE(rx.nothing_more(50));
}

TEST(LogTelemetry, TeeWithoutADestinationOnlyLogs) {
  CsvLog log(kTelemetryColumns, 2);
  TelemetryTee tee(log, {}, kTelemetryColumns);
  EXPECT_EQ(tee.telemetry(), nullptr);
  tee.push_row(std::vector<double>{0.0, 1.0, 2.0, 3.0, 4.0, 5.0});
  EXPECT_EQ(log.rows(), 1u);
  EXPECT_EQ(log.at(0, 3), 3.0);
}

// The tee's loop side (pick + publish) allocates nothing once set up.
TEST(LogTelemetry, TeeAllocatesNothingPerRow) {
  CsvLog log(kTelemetryColumns, 300);
  TelemetryOptions o;
  o.destination = io::parse_udp_endpoint("udp://127.0.0.1:9");  // nobody listens: sendto still succeeds
  o.signals = {"*"};
  TelemetryTee tee(log, o, kTelemetryColumns);
  std::vector<double> row(kTelemetryColumns.size());
  tee.push_row(row);
  ASSERT_TRUE(tee.telemetry()->telemetry().flush());  // the sender thread in its steady state
  const std::size_t allocations = testing::allocations_during([&] {
    for (int k = 1; k < 300; ++k) {
      row[0] = k * 1e-3;
      row[1] = 0.01 * k;
      tee.push_row(row);
    }
  });
  EXPECT_EQ(allocations, 0u);
  tee.telemetry()->close();
  EXPECT_EQ(tee.telemetry()->telemetry().published_samples(), 30u);  // t = 0, 0.01, ..., 0.29 s
}

}  // namespace
}  // namespace peha::runtime
