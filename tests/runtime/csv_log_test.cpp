// The CSV log format read back: CsvLog::write, then read_csv_log_columns (peha faults --link and the
// end-to-end tests read the real-time logs with it).
#include "peha/runtime/csv_log.hpp"

#include "peha/config/csv_sidecar.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <unistd.h>

namespace peha::runtime {
namespace {

TEST(CsvLog, ColumnsReadBackByNameInTheOrderAsked) {
  const std::filesystem::path path = std::filesystem::temp_directory_path() / ("peha_csv_log_" + std::to_string(::getpid()) + ".csv");
  CsvLog log({"t_s", "angle_rad", "force_N"}, 3);
  for (int k = 0; k < 3; ++k) {
    const double row[] = {1e-3 * k, 0.5 * k, 100.0 + k};
    log.push_row(row);
  }
  log.write(path, {"a comment line", "another"});
  const auto cols = read_csv_log_columns(path, {"force_N", "t_s", "missing"});
  ASSERT_EQ(cols.size(), 3u);
  EXPECT_EQ(cols[0], (std::vector<double>{100.0, 101.0, 102.0}));
  EXPECT_EQ(cols[1], (std::vector<double>{0.0, 1e-3, 2e-3}));
  EXPECT_TRUE(cols[2].empty());  // a column the log lacks

  // A log from before the sidecar: `# ` lines before the header are skipped.
  std::ofstream(path) << "# case: old\n# seed: 1\nt_s,angle_rad\n0,1\n0.001,2\n";
  EXPECT_EQ(read_csv_log_columns(path, {"angle_rad"})[0], (std::vector<double>{1.0, 2.0}));

  std::ofstream(path) << "t_s,angle_rad\n0,1\n0.001,oops\n";
  try {
    (void)read_csv_log_columns(path, {"angle_rad"});
    ADD_FAILURE() << "a cell that is no number was read";
  } catch (const std::runtime_error& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr(path.string() + ":3: column angle_rad: expected a number, found 'oops'"));
  }
  std::ofstream(path) << "# only comments\n";
  EXPECT_THROW(read_csv_log_columns(path, {"t_s"}), std::runtime_error);
  std::filesystem::remove(path);
  std::filesystem::remove(config::csv_sidecar_path(path));
  EXPECT_THROW(read_csv_log_columns(path, {"t_s"}), std::runtime_error);
}

// The log's first line is its header (numpy's genfromtxt(names=True) and pandas read it as the
// column names); what the comment lines said before is in the sidecar, with the row count. Writing
// again replaces the sidecar.
TEST(CsvLog, HeaderFirstAndTheCommentsInTheSidecar) {
  const std::filesystem::path path = std::filesystem::temp_directory_path() / ("peha_csv_log_header_" + std::to_string(::getpid()) + ".csv");
  CsvLog log({"t_s", "angle_rad"}, 4);
  const double row[] = {0.0, 0.25};
  log.push_row(row);
  log.push_row(row);
  log.write(path, {"case: payload_2.5kg", "config: a \"quoted\" path"});
  std::ifstream in(path);
  std::string first, second;
  std::getline(in, first);
  std::getline(in, second);
  EXPECT_EQ(first, "t_s,angle_rad");
  EXPECT_EQ(second, "0,0.25");
  std::optional<config::Document> meta = config::read_csv_sidecar(path);
  ASSERT_TRUE(meta);
  config::Map root = meta->root();
  EXPECT_EQ(root.integer("rows", 0, 10), 2);
  EXPECT_EQ(root.maps("columns", 2, 2)[1].string("unit"), "rad");
  const YAML::Node notes = YAML::LoadFile(config::csv_sidecar_path(path).string())["notes"];
  ASSERT_EQ(notes.size(), 2u);
  EXPECT_EQ(notes[1].as<std::string>(), "config: a \"quoted\" path");

  log.clear();
  log.write(path, {});
  meta = config::read_csv_sidecar(path);
  ASSERT_TRUE(meta);
  EXPECT_EQ(meta->root().integer("rows", 0, 10), 0);
  EXPECT_EQ(YAML::LoadFile(config::csv_sidecar_path(path).string())["notes"].size(), 0u);
  std::filesystem::remove(path);
  std::filesystem::remove(config::csv_sidecar_path(path));
}

}  // namespace
}  // namespace peha::runtime
