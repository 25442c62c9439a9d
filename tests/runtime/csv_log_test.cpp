// The CSV log format read back: CsvLog::write, then read_csv_log_columns (peha faults --link and the
// end-to-end tests read the real-time logs with it).
#include "peha/runtime/csv_log.hpp"

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

  std::ofstream(path) << "# c\nt_s,angle_rad\n0,1\n0.001,oops\n";
  EXPECT_THROW(read_csv_log_columns(path, {"angle_rad"}), std::runtime_error);
  std::filesystem::remove(path);
  EXPECT_THROW(read_csv_log_columns(path, {"t_s"}), std::runtime_error);
}

}  // namespace
}  // namespace peha::runtime
