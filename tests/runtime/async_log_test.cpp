#include "peha/runtime/async_log.hpp"

#include "peha/config/csv_sidecar.hpp"
#include "peha/runtime/csv_log.hpp"

#include <gtest/gtest.h>

#include <unistd.h>

#include <array>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

namespace peha::runtime {
namespace {

std::filesystem::path fresh_dir(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() / ("peha_async_log_" + std::to_string(getpid()) + "_" + name);
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

std::string read_text(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

struct Csv {
  std::vector<std::string> comments;
  std::string header;
  std::vector<std::vector<double>> rows;
};

// The CSV (its first line the header) and the notes of its sidecar.
Csv read_csv(const std::filesystem::path& path) {
  Csv csv;
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) {
    if (csv.header.empty()) {
      csv.header = line;
    } else {
      std::vector<double> row;
      std::stringstream fields(line);
      std::string field;
      while (std::getline(fields, field, ',')) row.push_back(std::stod(field));
      csv.rows.push_back(row);
    }
  }
  const std::filesystem::path meta = config::csv_sidecar_path(path);
  if (std::filesystem::exists(meta)) {
    for (const YAML::Node& note : YAML::LoadFile(meta.string())["notes"]) csv.comments.push_back(note.as<std::string>());
  }
  return csv;
}

// The sidecar without its "file" field: two logs of the same rows and comments have the same one.
YAML::Node sidecar_without_file(const std::filesystem::path& csv) {
  YAML::Node meta = YAML::LoadFile(config::csv_sidecar_path(csv).string());
  meta.remove("file");
  return meta;
}

const std::vector<std::string> kColumns = {"t_s", "k", "force_N"};

// Row k of a test run: time k ms, the index itself, and a value that needs all 9 digits.
std::array<double, 3> row_k(int k) { return {k * 1e-3, static_cast<double>(k), std::sin(k) * 1e3 / 3.0}; }

// The files are byte for byte what CsvLog::write produces for the same rows, so every tool that
// reads the existing logs (tools/plot_run.py) reads these; so are their sidecars (but the file
// name), the row count written at close. While the log is open, its sidecar has no row count yet.
TEST(AsyncCsvLog, WritesTheSameFormatAsCsvLog) {
  const auto dir = fresh_dir("format");
  const std::vector<std::string> comments = {"scenario: unit test", "units: SI"};
  CsvLog reference(kColumns, 100);
  {
    AsyncCsvLog log(dir / "async.csv", kColumns, comments);
    const YAML::Node open_meta = YAML::LoadFile(config::csv_sidecar_path(dir / "async.csv").string());
    EXPECT_FALSE(open_meta["rows"]);
    EXPECT_EQ(open_meta["notes"].size(), 2u);
    for (int k = 0; k < 100; ++k) {
      auto r = row_k(k);
      r[2] = k == 7 ? -0.0 : k == 8 ? 1e-300 : k == 9 ? -123456789012.0 : r[2];
      ASSERT_TRUE(log.push(r));
      reference.begin_row();
      for (std::size_t c = 0; c < 3; ++c) reference.set(c, r[c]);
    }
  }
  reference.write(dir / "reference.csv", comments);
  EXPECT_EQ(read_text(dir / "async.csv"), read_text(dir / "reference.csv"));
  EXPECT_EQ(YAML::Dump(sidecar_without_file(dir / "async.csv")), YAML::Dump(sidecar_without_file(dir / "reference.csv")));
  EXPECT_EQ(sidecar_without_file(dir / "async.csv")["rows"].as<int>(), 100);
  EXPECT_EQ(read_text(dir / "async.csv").rfind("t_s,k,force_N\n", 0), 0u);
}

// 20 000 rows pushed in bursts of 1000 back to back (a 1 kHz loop's 20 s, pushed as fast as the
// CPU allows) into a queue that can hold them all: nothing is dropped, every row is written once,
// in order, whatever the writer's pace.
TEST(AsyncCsvLog, WritesEveryPushedRowInOrder) {
  const auto dir = fresh_dir("order");
  constexpr int kRows = 20000;
  AsyncCsvLog log(dir / "run.csv", kColumns, {}, 32768, 100);
  for (int k = 0; k < kRows; ++k) {
    ASSERT_TRUE(log.push(row_k(k)));
    if (k % 1000 == 999) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  ASSERT_TRUE(log.flush());
  EXPECT_EQ(log.written_rows(), static_cast<std::uint64_t>(kRows));
  log.close();
  EXPECT_EQ(log.pushed_rows(), static_cast<std::uint64_t>(kRows));
  EXPECT_EQ(log.dropped_rows(), 0u);
  const Csv csv = read_csv(dir / "run.csv");
  EXPECT_EQ(csv.header, "t_s,k,force_N");
  ASSERT_EQ(csv.rows.size(), static_cast<std::size_t>(kRows));
  for (int k = 0; k < kRows; ++k) ASSERT_EQ(csv.rows[k][1], k);
}

// The writer stalls (a slow disk): an 8-row queue takes exactly 8 rows, push refuses the other 92
// at once and counts them, and the file later holds the 8 accepted rows.
TEST(AsyncCsvLog, DropsAndCountsRowsWhileTheWriterStalls) {
  const auto dir = fresh_dir("drop");
  AsyncCsvLog log(dir / "run.csv", kColumns, {}, 8, 16);
  log.set_writer_paused_for_test(true);
  int accepted = 0;
  for (int k = 0; k < 100; ++k) accepted += log.push(row_k(k)) ? 1 : 0;
  EXPECT_EQ(accepted, 8);
  EXPECT_EQ(log.dropped_rows(), 92u);
  EXPECT_FALSE(log.flush(std::chrono::milliseconds(20)));  // nothing moves while stalled
  log.set_writer_paused_for_test(false);
  log.close();
  EXPECT_EQ(log.written_rows(), log.pushed_rows() - log.dropped_rows());
  const Csv csv = read_csv(dir / "run.csv");
  ASSERT_EQ(csv.rows.size(), 8u);
  for (int k = 0; k < 8; ++k) EXPECT_EQ(csv.rows[k][1], k);
}

void expect_dump_of_rows(const std::filesystem::path& path, int first_k, int last_k, const std::string& reason) {
  const Csv dump = read_csv(path);
  EXPECT_EQ(dump.header, "t_s,k,force_N");
  ASSERT_EQ(dump.rows.size(), static_cast<std::size_t>(last_k - first_k + 1)) << path;
  for (int k = first_k; k <= last_k; ++k) EXPECT_EQ(dump.rows[k - first_k][1], k);
  bool reason_found = false;
  for (const std::string& c : dump.comments) reason_found = reason_found || c == "reason: " + reason;
  EXPECT_TRUE(reason_found) << read_text(path);
  EXPECT_EQ(YAML::LoadFile(config::csv_sidecar_path(path).string())["rows"].as<int>(), last_k - first_k + 1);
}

// Fault requested after row 699: the dump holds rows 650..699 (the 50-row window), none of the
// 300 pushed afterwards, whether the writer drains as the rows come (running) or finds request
// and all rows queued at once (stalled).
TEST(AsyncCsvLog, FaultDumpHoldsExactlyTheLastRowsBeforeTheRequest) {
  for (const bool stalled : {false, true}) {
    SCOPED_TRACE(stalled ? "writer stalled" : "writer running");
    const auto dir = fresh_dir(stalled ? "fault_stalled" : "fault_running");
    AsyncCsvLog log(dir / "run.csv", kColumns, {"scenario: unit test"}, 2048, 50);
    if (stalled) log.set_writer_paused_for_test(true);
    for (int k = 0; k < 700; ++k) ASSERT_TRUE(log.push(row_k(k)));
    EXPECT_TRUE(log.request_fault_dump("agonist over pressure"));
    for (int k = 700; k < 1000; ++k) ASSERT_TRUE(log.push(row_k(k)));
    if (stalled) log.set_writer_paused_for_test(false);
    log.close();
    const auto dumps = log.fault_dumps();
    ASSERT_EQ(dumps.size(), 1u);
    EXPECT_EQ(dumps[0], dir / "run_fault_0.699s.csv");
    expect_dump_of_rows(dumps[0], 650, 699, "agonist over pressure");
    EXPECT_EQ(read_csv(dir / "run.csv").rows.size(), 1000u);  // the main log is complete
  }
}

// Early in a run the window is not full yet: the dump holds what there is. Two faults, two files.
TEST(AsyncCsvLog, WritesOneDumpPerRequest) {
  const auto dir = fresh_dir("two_faults");
  AsyncCsvLog log(dir / "run.csv", kColumns, {}, 2048, 50);
  for (int k = 0; k < 10; ++k) log.push(row_k(k));
  log.request_fault_dump("first");
  for (int k = 10; k < 200; ++k) log.push(row_k(k));
  log.request_fault_dump("second");
  log.close();
  const auto dumps = log.fault_dumps();
  ASSERT_EQ(dumps.size(), 2u);
  expect_dump_of_rows(dumps[0], 0, 9, "first");
  expect_dump_of_rows(dumps[1], 150, 199, "second");
}

TEST(AsyncCsvLog, RefusesRowsOfTheWrongWidth) {
  const auto dir = fresh_dir("width");
  AsyncCsvLog log(dir / "run.csv", kColumns, {});
  const double short_row[] = {0.0, 1.0};
  EXPECT_FALSE(log.push(short_row));
  EXPECT_TRUE(log.push(row_k(1)));
  log.close();
  EXPECT_EQ(log.malformed_rows(), 1u);
  EXPECT_EQ(log.pushed_rows(), 1u);
  EXPECT_EQ(read_csv(dir / "run.csv").rows.size(), 1u);
}

TEST(AsyncCsvLog, RejectsBadColumnsAndUnwritablePaths) {
  const auto dir = fresh_dir("bad");
  EXPECT_THROW(AsyncCsvLog(dir / "a.csv", {}, {}), std::invalid_argument);
  EXPECT_THROW(AsyncCsvLog(dir / "a.csv", {"angle_rad", "t_s"}, {}), std::invalid_argument);  // time first
  EXPECT_THROW(AsyncCsvLog(dir / "a.csv", {"t_s", "a,b"}, {}), std::invalid_argument);
  EXPECT_THROW(AsyncCsvLog(dir / "a.csv", std::vector<std::string>(AsyncCsvLog::kMaxColumns + 1, "t_s"), {}), std::invalid_argument);
  EXPECT_THROW(AsyncCsvLog(dir / "a.csv", kColumns, {}, 16, 0), std::invalid_argument);
  EXPECT_THROW(AsyncCsvLog(dir / "no_such_dir" / "a.csv", kColumns, {}), std::runtime_error);
}

}  // namespace
}  // namespace peha::runtime
