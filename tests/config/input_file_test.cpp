// The one checked opener of input files: regular files within their kind's limit, nothing else.
#include "peha/config/input_file.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <chrono>
#include <fstream>
#include <sys/stat.h>
#include <unistd.h>

namespace peha::config {
namespace {

using ::testing::HasSubstr;
namespace fs = std::filesystem;

class InputFile : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("peha_input_file_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string error_of(const fs::path& p, InputKind kind) {
    try {
      read_input_file(p, kind);
    } catch (const InputFileError& e) {
      return e.what();
    }
    return "accepted";
  }
  fs::path dir_;
};

TEST_F(InputFile, ReadsARegularFileWhole) {
  const fs::path p = dir_ / "a.csv";
  std::ofstream(p, std::ios::binary) << "t_s,x\n0,1\n";
  EXPECT_EQ(read_input_file(p, InputKind::kCsv), "t_s,x\n0,1\n");
}

TEST_F(InputFile, RefusesADeviceAtOnce) {
  // /dev/zero used to be read without bound as a goniometer CSV.
  const auto t0 = std::chrono::steady_clock::now();
  EXPECT_THAT(error_of("/dev/zero", InputKind::kCsv), HasSubstr("/dev/zero: not a regular file (a device): a CSV file must be a regular file"));
  EXPECT_LT(std::chrono::steady_clock::now() - t0, std::chrono::seconds(1));
}

TEST_F(InputFile, RefusesAFifoWithoutWaitingForAWriter) {
  const fs::path p = dir_ / "fifo.yaml";
  ASSERT_EQ(::mkfifo(p.c_str(), 0600), 0);
  // An ifstream blocks here forever (no writer); the opener must answer at once.
  EXPECT_THAT(error_of(p, InputKind::kConfig), HasSubstr("not a regular file (a pipe (FIFO)): a config file must be"));
}

TEST_F(InputFile, RefusesAFolder) {
  EXPECT_THAT(error_of(dir_, InputKind::kLog), HasSubstr("not a regular file (a folder): a log must be"));
}

TEST_F(InputFile, RefusesAFileLargerThanItsKindAllows) {
  const fs::path p = dir_ / "big.csv";
  std::ofstream(p).close();
  fs::resize_file(p, max_input_bytes(InputKind::kCsv) + (std::size_t{1} << 20));  // sparse: no disk used
  EXPECT_THAT(error_of(p, InputKind::kCsv), HasSubstr("65 MiB is larger than the 64 MiB a CSV file may have"));
  const fs::path key = dir_ / "k.key";
  std::ofstream(key) << std::string(5000, '0');
  EXPECT_THAT(error_of(key, InputKind::kKey), HasSubstr("5000 bytes is larger than the 4096 bytes a key file may have"));
}

TEST_F(InputFile, NamesAMissingFile) {
  EXPECT_THAT(error_of(dir_ / "none.yaml", InputKind::kConfig), HasSubstr("none.yaml: cannot open the config file: no such file"));
}

}  // namespace
}  // namespace peha::config
