// The one hardware door: --backend's forms, the door's refusals, and the replay backend (a recorded
// log fed back into the controller that wrote it gives its commands back).
#include "peha/hardware/door.hpp"

#include "peha/api/exoskeleton.hpp"
#include "peha/experiments/arm_identification/arm_identification.hpp"
#include "peha/experiments/e1_gravity/e1_gravity.hpp"
#include "peha/experiments/e3_postures/postures.hpp"
#include "peha/experiments/e4_goniometer/goniometer.hpp"
#include "peha/runtime/csv_log.hpp"
#include "../support/shipped_scenarios.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <unistd.h>

namespace peha::hardware {
namespace {

using ::testing::HasSubstr;

std::string refusal(const std::string& text) {
  try {
    (void)BackendUri::parse(text);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

TEST(BackendUri, ParsesEveryFormAndNamesTheFormsItRefuses) {
  EXPECT_EQ(BackendUri::parse("").kind, BackendKind::kSim);
  EXPECT_EQ(BackendUri::parse("sim:").kind, BackendKind::kSim);
  const BackendUri one = BackendUri::parse("udp://10.0.0.2:50000");
  ASSERT_EQ(one.kind, BackendKind::kBoards);
  ASSERT_EQ(one.boards.size(), 1u);
  EXPECT_EQ(one.boards[0].to_string(), "10.0.0.2:50000");
  EXPECT_FALSE(one.in_process());
  const BackendUri two = BackendUri::parse("udp://10.0.0.2:50000,udp://10.0.0.3:50001");
  ASSERT_EQ(two.boards.size(), 2u);
  EXPECT_EQ(two.boards[1].port, 50001);
  const BackendUri replay = BackendUri::parse("replay:out/run/e1_payload_2.5kg.csv");
  EXPECT_EQ(replay.kind, BackendKind::kReplay);
  EXPECT_EQ(replay.replay_log, std::filesystem::path("out/run/e1_payload_2.5kg.csv"));
  EXPECT_TRUE(replay.in_process());
  EXPECT_THAT(refusal("ethercat://eth0"), HasSubstr("expected one of sim:, udp://A.B.C.D:PORT"));
  EXPECT_THAT(refusal("replay:"), HasSubstr("names no log"));
  EXPECT_THAT(refusal("udp://localhost:9"), HasSubstr("not a numeric IPv4 address"));
}

TEST(HardwareDoor, RefusesWhatTheRunCannotTake) {
  HardwareRequest request;
  request.joint_names = {"joint"};
  // udp:// without the scenario's mfb: section, sim: without a simulated plant.
  EXPECT_THROW((void)open_backend(BackendUri::parse("udp://127.0.0.1:9"), request), std::invalid_argument);
  EXPECT_THROW((void)open_backend(BackendUri::parse("sim:"), request), std::invalid_argument);
}

/// A log with the replay's columns: `rows` cycles of 1 ms.
std::filesystem::path write_log(const std::string& name, const std::vector<std::string>& columns, std::size_t rows) {
  const std::filesystem::path path = std::filesystem::temp_directory_path() / ("peha_replay_" + name + "_" + std::to_string(::getpid()) + ".csv");
  runtime::CsvLog log(columns, rows);
  for (std::size_t r = 0; r < rows; ++r) {
    std::vector<double> row(columns.size(), 0.0);
    for (std::size_t c = 0; c < columns.size(); ++c) row[c] = c == 0 ? 1e-3 * static_cast<double>(r) : 0.1 * static_cast<double>(c) + static_cast<double>(r);
    log.push_row(row);
  }
  log.write(path, {"test log"});
  return path;
}

TEST(ReplayBackend, GivesTheLogsSensorsRowByRowAndKeepsTheCommandsBesideTheRecorded) {
  const std::vector<std::string> columns = {"t_s", "angle_rad", "agonist_loadcell_N", "antagonist_loadcell_N", "agonist_pressure_MPa",
                                            "antagonist_pressure_MPa", "agonist_pressure_cmd_MPa", "antagonist_pressure_cmd_MPa", "tau_motor_cmd_Nm",
                                            "motor_torque_monitor_Nm"};
  const std::filesystem::path path = write_log("rows", columns, 3);
  ReplayBackend replay(path, {"joint"}, {}, 1e-3);
  EXPECT_EQ(replay.rows(), 3u);
  replay.activate();
  io::SensorState s;
  io::Command c;
  c.joint_count = 1;
  for (int r = 0; r < 3; ++r) {
    ASSERT_TRUE(replay.read(s));
    EXPECT_DOUBLE_EQ(s.time_s, 1e-3 * r);
    EXPECT_EQ(s.sequence, static_cast<std::uint64_t>(r + 1));
    EXPECT_DOUBLE_EQ(s.joints[0].angle_rad, 0.1 + r);
    EXPECT_DOUBLE_EQ(s.joints[0].agonist_pressure_Pa, (0.4 + r) * 1e6);  // MPa in the log, Pa inside
    EXPECT_TRUE(std::isnan(s.joints[0].supply_pressure_Pa));             // not in the log: not measured
    EXPECT_DOUBLE_EQ(s.joints[0].motor_torque_Nm, 0.9 + r);               // the driver's monitor, an optional sensor
    c.joints[0] = {(0.6 + r) * 1e6, (0.7 + r) * 1e6 + 0.002e6, 0.8 + r};   // the antagonist 2 kPa off the recorded
    replay.write(c);
  }
  EXPECT_FALSE(replay.read(s));  // every row given
  EXPECT_EQ(replay.replayed(), 3u);
  const ReplayBackend::Difference d = replay.max_difference();
  EXPECT_NEAR(d.pressure_MPa, 0.002, 1e-9);
  EXPECT_NEAR(d.motor_Nm, 0.0, 1e-9);
  const std::filesystem::path out = path.string() + ".commands.csv";
  replay.write_commands(out, {});
  const auto cols = runtime::read_csv_log_columns(out, {"recorded_antagonist_pressure_cmd_MPa", "replayed_antagonist_pressure_cmd_MPa"});
  ASSERT_EQ(cols[0].size(), 3u);
  EXPECT_NEAR(cols[1][2] - cols[0][2], 0.002, 1e-9);
  std::filesystem::remove(path);
  std::filesystem::remove(out);
}

TEST(ReplayBackend, RefusesALogWithoutTheSensorsOrAtAnotherRate) {
  const std::filesystem::path no_pressure = write_log("no_pressure", {"t_s", "angle_rad", "agonist_loadcell_N", "antagonist_loadcell_N"}, 3);
  try {
    ReplayBackend replay(no_pressure, {"joint"}, {}, 1e-3);
    FAIL() << "a log without pressures was replayed";
  } catch (const std::runtime_error& e) {
    EXPECT_THAT(e.what(), HasSubstr("lacks the sensor column(s) agonist_pressure_MPa, antagonist_pressure_MPa"));
  }
  const std::filesystem::path fast =
      write_log("fast", {"t_s", "angle_rad", "agonist_loadcell_N", "antagonist_loadcell_N", "agonist_pressure_MPa", "antagonist_pressure_MPa"}, 3);
  try {
    ReplayBackend replay(fast, {"joint"}, {}, 2e-3);  // the log's 1 ms rows into a 2 ms loop
    FAIL() << "a log at another rate was replayed";
  } catch (const std::runtime_error& e) {
    EXPECT_THAT(e.what(), HasSubstr("control period is 0.002 s"));
  }
  std::filesystem::remove(no_pressure);
  std::filesystem::remove(fast);
}

// The regression use: E1 in process on the simulated rig, its log replayed into the same controller
// through the door. The controller sees what it saw (the log's sensor columns) and commands what it
// commanded; what is left is the log's 9 significant digits and the rig's redundant encoder, which
// the log does not record.
TEST(ReplayBackend, AnE1LogReplayedIntoItsControllerGivesItsCommandsBack) {
  experiments::E1Scenario s = peha::test_support::shipped_e1();
  s.duration_s = 6.0;
  const experiments::E1Case& c = s.cases.front();
  runtime::CsvLog log(experiments::e1_log_columns(), 6002);
  const Hardware rig = open_backend(BackendUri::parse("sim:"), experiments::e1_hardware(s, c));
  (void)experiments::run_e1_on(s, c, *rig.backend, nullptr, &log);
  const std::filesystem::path path = std::filesystem::temp_directory_path() / ("peha_replay_e1_" + std::to_string(::getpid()) + ".csv");
  log.write(path, {});
  const Hardware replay = open_backend(BackendUri::parse("replay:" + path.string()), experiments::e1_hardware(s, c));
  ASSERT_NE(replay.replay, nullptr);
  (void)experiments::run_e1_on(s, c, *replay.backend, nullptr, nullptr);
  EXPECT_EQ(replay.replay->replayed(), replay.replay->rows());
  const ReplayBackend::Difference d = replay.replay->max_difference();
  RecordProperty("max_pressure_difference_MPa", std::to_string(d.pressure_MPa));
  RecordProperty("max_motor_difference_Nm", std::to_string(d.motor_Nm));
  EXPECT_LT(d.pressure_MPa, 1e-4);  // 0.1 kPa of commands of 0.1-0.4 MPa
  EXPECT_LT(d.motor_Nm, 1e-3);
  std::filesystem::remove(path);
}

// Every per-cycle log of an arm records, for each joint under the prefix the run gives the door, every
// sensor a replay reads and every command it compares, each once: E3 (on the simulated arm and the
// board), E4, the gravity identification and a user's controller, on one arm and on the upper body.
// A sensor added to the replay fails here until every arm log writes it.
TEST(ReplayBackend, EveryArmLogRecordsWhatAReplayReads) {
  for (const char* config : {PEHA_SOURCE_DIR "/configs/right_arm.yaml", PEHA_SOURCE_DIR "/configs/upper_body.yaml"}) {
    const experiments::ArmScenario s = experiments::read_arm_scenario(config::Document::load_file(config));
    const std::vector<std::string> arm_prefixes = experiments::postures_hardware(s).log_prefixes;
    const struct {
      const char* log;
      std::vector<std::string> columns, prefixes;
    } logs[] = {{"E3", experiments::arm_log_columns(s), arm_prefixes},
                {"E4", experiments::goniometer_log_columns(s), experiments::goniometer_hardware(s, s.plant).log_prefixes},
                {"identification", experiments::identification_log_columns(s), arm_prefixes},
                {"user controller", api::user_log_columns(s), arm_prefixes}};
    for (const auto& l : logs) {
      ASSERT_EQ(l.prefixes.size(), s.plant.actuated.size());
      for (const std::string& p : l.prefixes) {
        for (const char* c : kSensorColumns) EXPECT_EQ(std::count(l.columns.begin(), l.columns.end(), p + c), 1) << config << " " << l.log << ": " << p + c;
        for (const char* c : kCommandColumns) EXPECT_EQ(std::count(l.columns.begin(), l.columns.end(), p + c), 1) << config << " " << l.log << ": " << p + c;
      }
    }
  }
}

}  // namespace
}  // namespace peha::hardware
