// `peha run` streams any logged signal, chosen on the command line or in the scenario: the plain
// simulated run (no backend) as a PlotJuggler UDP server receives it, over a real socket between
// two processes, checked against the log the run wrote.
#include "peha/runtime/csv_log.hpp"

#include "../support/edited_config.hpp"
#include "../support/peha_cli.hpp"
#include "../support/telemetry_receiver.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <map>
#include <numbers>
#include <string>
#include <vector>

namespace {

using ::testing::HasSubstr;
using peha::testing::TelemetryReceiver;

const std::string kE1 = std::string(PEHA_SOURCE_DIR) + "/configs/e1_one_dof.yaml";
constexpr double kPeriod_s = 1e-3;  // the scenario's control_period_s

/// The shipped E1 scenario's text with its model named by an absolute path (an edited copy lives elsewhere).
std::string e1_text(const peha::testing::EditedConfig& config) {
  std::string text = config.shipped();
  text.replace(text.find("../models/"), 10, std::string(PEHA_SOURCE_DIR) + "/models/");
  return text;
}

std::filesystem::path scratch(const std::string& tag) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / ("peha_telemetry_out_" + tag + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  return dir;
}

/// Every datagram has exactly `keys`, in order, and the values of the log's row at its timestamp:
/// column `columns[i]` of `log` for key i (times `scale[i]`: a degree view), within the 9
/// significant digits both print. Returns how many datagrams were checked.
std::size_t expect_rows_match(const std::vector<std::string>& datagrams, const std::filesystem::path& log, const std::vector<std::string>& keys,
                              const std::vector<std::string>& columns, const std::vector<double>& scale) {
  std::vector<std::string> wanted = {"t_s"};
  wanted.insert(wanted.end(), columns.begin(), columns.end());
  const std::vector<std::vector<double>> c = peha::runtime::read_csv_log_columns(log, wanted);
  std::map<long long, std::size_t> row_of_cycle;
  for (std::size_t i = 0; i < c[0].size(); ++i) row_of_cycle[std::llround(c[0][i] / kPeriod_s)] = i;
  std::size_t checked = 0;
  for (const std::string& d : datagrams) {
    const peha::testing::TelemetrySample s = peha::testing::parse_telemetry(d, "peha");
    std::vector<std::string> names;
    for (const auto& [name, value] : s.values) names.push_back(name);
    EXPECT_EQ(names, keys) << d;
    if (names != keys) continue;
    const auto row = row_of_cycle.find(std::llround(s.timestamp / kPeriod_s));
    EXPECT_NE(row, row_of_cycle.end()) << "no log row at " << s.timestamp << " s";
    if (row == row_of_cycle.end()) continue;
    for (std::size_t k = 0; k < keys.size(); ++k) {
      const double expected = c[k + 1][row->second] * scale[k];
      if (std::isnan(expected)) {
        EXPECT_TRUE(std::isnan(s.values[k].second)) << keys[k] << " in " << d;
      } else {
        EXPECT_NEAR(s.values[k].second, expected, 1e-7 * (1 + std::abs(expected))) << keys[k] << " in " << d;
      }
    }
    ++checked;
  }
  return checked;
}

// The command line's choice (repeatable and comma-separated, a degree view among them) streams from
// the in-process simulation: one sample per 10 ms of simulated time, the timestamp the simulated
// time, every value the log's.
TEST(TelemetryCli, InProcessRunStreamsTheSignalsChosenOnTheCommandLine) {
  const std::filesystem::path out = scratch("cli");
  TelemetryReceiver rx;
  rx.start_collecting();
  const peha::testing::CliResult r = peha::testing::run_peha(
      "run --no-plot --config " + kE1 + " --case payload_2.5kg --out " + out.string() + " --name r --telemetry udp://127.0.0.1:" +
      std::to_string(rx.port()) + " --telemetry-signal tau_motor_cmd_Nm,angle_deg --telemetry-signal agonist_pressure_MPa");
  const std::vector<std::string> datagrams = rx.stop();
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_THAT(r.output, HasSubstr("telemetry: 3 signal(s)"));
  const std::vector<double> t = peha::runtime::read_csv_log_columns(out / "r" / "e1_payload_2.5kg.csv", {"t_s"}).front();
  ASSERT_FALSE(t.empty());
  // 100 Hz of simulated time: t = 0, 0.01, ..., the last row's.
  const auto expected = static_cast<std::size_t>(std::floor((t.back() - t.front()) / 0.01 + 1e-6)) + 1;
  EXPECT_EQ(datagrams.size(), expected);
  const std::size_t checked = expect_rows_match(datagrams, out / "r" / "e1_payload_2.5kg.csv", {"tau_motor_cmd_Nm", "angle_deg", "agonist_pressure_MPa"},
                                                {"tau_motor_cmd_Nm", "angle_rad", "agonist_pressure_MPa"}, {1.0, 180.0 / std::numbers::pi, 1.0});
  EXPECT_EQ(checked, datagrams.size());
  std::filesystem::remove_all(out);
}

// The scenario's `telemetry:` section streams with no option at all (its glob chooses), and the
// command line's destination wins over the scenario's.
TEST(TelemetryCli, TheScenarioKeyChoosesTheSignalsAndTheDestination) {
  const std::filesystem::path out = scratch("scenario");
  TelemetryReceiver rx, unused;
  peha::testing::EditedConfig config("e1_one_dof.yaml", "telemetry_scenario");
  const std::filesystem::path yaml =
      config.write(e1_text(config) + "\ntelemetry: {signals: ['*_loadcell_N'], rate_Hz: 20, destination: udp://127.0.0.1:" + std::to_string(unused.port()) + "}\n");
  rx.start_collecting();
  const peha::testing::CliResult r = peha::testing::run_peha("run --no-plot --config " + yaml.string() + " --case payload_5.0kg --out " + out.string() +
                                                             " --name r --telemetry udp://127.0.0.1:" + std::to_string(rx.port()));
  const std::vector<std::string> datagrams = rx.stop();
  ASSERT_EQ(r.code, 0) << r.output;
  const std::filesystem::path log = out / "r" / "e1_payload_5.0kg.csv";
  const std::vector<double> t = peha::runtime::read_csv_log_columns(log, {"t_s"}).front();
  ASSERT_FALSE(t.empty());
  EXPECT_EQ(datagrams.size(), static_cast<std::size_t>(std::floor((t.back() - t.front()) / 0.05 + 1e-6)) + 1);  // 20 Hz
  EXPECT_EQ(expect_rows_match(datagrams, log, {"agonist_loadcell_N", "antagonist_loadcell_N"}, {"agonist_loadcell_N", "antagonist_loadcell_N"},
                              {1.0, 1.0}),
            datagrams.size());
  EXPECT_TRUE(unused.nothing_more(50));
  std::filesystem::remove_all(out);
}

// A name the log lacks is a set-up error naming the closest column: exit 2, nothing written; so
// are a misspelled scenario key and signals with nowhere to go.
TEST(TelemetryCli, AnUnknownSignalIsRefusedNamingTheClosestColumn) {
  const std::filesystem::path out = scratch("refused");
  const std::string run = "run --no-plot --config " + kE1 + " --out " + out.string() + " ";
  peha::testing::CliResult r = peha::testing::run_peha(run + "--telemetry udp://127.0.0.1:9 --telemetry-signal angle_dg");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_THAT(r.output, HasSubstr("telemetry signal 'angle_dg' is not a column of the log (did you mean 'angle_deg'?)"));
  r = peha::testing::run_peha(run + "--telemetry udp://127.0.0.1:9 --telemetry-signal 'plant_*_deg,rtt_us'");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_THAT(r.output, HasSubstr("'rtt_us' is not a column of the log"));  // the harness's: on the board only
  r = peha::testing::run_peha(run + "--telemetry-signal angle_deg");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_THAT(r.output, HasSubstr("--telemetry-signal needs a destination"));
  peha::testing::EditedConfig config("e1_one_dof.yaml", "telemetry_refused");
  const std::filesystem::path yaml = config.write(e1_text(config) + "\ntelemetry: {signal: [angle_deg]}\n");
  r = peha::testing::run_peha("run --no-plot --config " + yaml.string() + " --out " + out.string());
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_THAT(r.output, HasSubstr("telemetry.signal: unknown key; did you mean 'signals'?"));
  EXPECT_FALSE(std::filesystem::exists(out));
}

}  // namespace
