// Nothing lost, nothing clobbered: a run is written beside its final folder and put in place only
// when it ends; no output replaces a file the scenario reads or anything that is not a regular file;
// each case leaves the earlier files intact byte for byte.
#include "peha/app/cli_checks.hpp"
#include "peha/app/run_dir.hpp"

#include "../support/peha_cli.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <csignal>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

namespace peha::app {
namespace {

using ::testing::HasSubstr;
namespace fs = std::filesystem;

using Result = peha::testing::CliResult;

Result peha(const std::string& args) {
  // timeout: a refusal that does not come would otherwise hang on a FIFO or read /dev/zero forever.
  return peha::testing::run_peha(args, "timeout -s KILL 120 ");
}

std::string bytes(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

/// Every regular file under `dir`: relative name -> its size and content's hash (a short message
/// when they differ; equal hashes of equal sizes: equal bytes for this purpose).
std::map<std::string, std::string> snapshot(const fs::path& dir) {
  std::map<std::string, std::string> files;
  for (const auto& e : fs::recursive_directory_iterator(dir)) {
    if (!e.is_regular_file()) continue;
    const std::string b = bytes(e.path());
    files[fs::relative(e.path(), dir).string()] = std::to_string(b.size()) + " bytes, hash " + std::to_string(std::hash<std::string>{}(b));
  }
  return files;
}

class Outputs : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("peha_outputs_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  /// A copy of E1's scenario with its channel map, key and plant laws in `into` (the MuJoCo model
  /// read from the source tree through ../models): files a wrong output may hit without harm.
  fs::path e1_copy(const fs::path& into) {
    fs::create_directories(into);
    fs::copy_file(PEHA_SOURCE_DIR "/configs/e1_one_dof.yaml", into / "e1_one_dof.yaml");
    fs::copy(PEHA_SOURCE_DIR "/configs/mfb", into / "mfb", fs::copy_options::recursive);
    fs::copy(PEHA_SOURCE_DIR "/configs/plant", into / "plant", fs::copy_options::recursive);
    fs::permissions(into / "mfb" / "dev_link.key", fs::perms::owner_read | fs::perms::owner_write);
    if (!fs::exists(into.parent_path() / "models")) fs::create_directory_symlink(PEHA_SOURCE_DIR "/models", into.parent_path() / "models");
    return into / "e1_one_dof.yaml";
  }
  fs::path dir_;
};

// `record-calibration --out configs/mfb/dev_link.key` replaced the link's key.
TEST_F(Outputs, RecordCalibrationRefusesToReplaceAFileTheScenarioReads) {
  const fs::path config = e1_copy(dir_ / "configs");
  const auto before = snapshot(dir_ / "configs");
  for (const char* target : {"mfb/dev_link.key", "mfb/one_dof_rig.yaml", "plant/dmsp40.yaml", "e1_one_dof.yaml"}) {
    const Result r = peha("record-calibration --muscle agonist --config " + config.string() + " --out " + (dir_ / "configs" / target).string());
    EXPECT_EQ(r.code, 2) << target << ": " << r.output;
    EXPECT_THAT(r.output, HasSubstr("refusing to overwrite it")) << target;
  }
  EXPECT_EQ(snapshot(dir_ / "configs"), before);
}

// `--out` onto a FIFO or a device replaced it (or would block on it).
TEST_F(Outputs, OutputOntoAFifoOrADeviceIsRefused) {
  const fs::path config = e1_copy(dir_ / "configs");
  const fs::path fifo = dir_ / "pipe.csv";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  Result r = peha("record-calibration --muscle agonist --config " + config.string() + " --out " + fifo.string());
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_THAT(r.output, HasSubstr("is a pipe (FIFO): an output file replaces only a regular file"));
  EXPECT_TRUE(fs::is_fifo(fifo));
  r = peha("record-calibration --muscle agonist --config " + config.string() + " --out /dev/null");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_THAT(r.output, HasSubstr("/dev/null is a device"));
  r = peha("run --no-plot --config " + config.string() + " --out " + fifo.string() + " --name x");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_THAT(r.output, HasSubstr("is not a folder"));
  EXPECT_TRUE(fs::is_fifo(fifo));
}

// `run --config D/config.yaml --out . --name D` truncated its own config.
TEST_F(Outputs, RunRefusesARunFolderThatHoldsItsOwnConfig) {
  const fs::path config = e1_copy(dir_ / "D");
  const auto before = snapshot(dir_ / "D");
  const Result r = peha("run --no-plot --config " + config.string() + " --out " + dir_.string() + " --name D");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_THAT(r.output, HasSubstr("which this run reads: the finished run would replace it"));
  EXPECT_EQ(snapshot(dir_ / "D"), before);
}

// A killed re-run left a partial log beside the earlier run's summary; a failed one truncated the
// earlier log. The earlier run stays whole until a new one is complete.
TEST_F(Outputs, AKilledRunLeavesTheEarlierRunOfItsNameIntact) {
  const std::string e1 = PEHA_SOURCE_DIR "/configs/e1_one_dof.yaml";
  const std::string args = "run --no-plot --config " + e1 + " --case payload_2.5kg --out " + (dir_ / "out").string() + " --name e1";
  Result r = peha(args);
  ASSERT_EQ(r.code, 0) << r.output;
  const auto earlier = snapshot(dir_ / "out" / "e1");
  ASSERT_TRUE(earlier.count("summary.csv"));
  // The same run again, killed as soon as it writes (its partial folder appears): the state a
  // power cut or Ctrl-\\ leaves.
  const pid_t pid = ::fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    ::execl(PEHA_BINARY, PEHA_BINARY, "run", "--no-plot", "--config", e1.c_str(), "--case", "payload_2.5kg", "--out",
            (dir_ / "out").c_str(), "--name", "e1", static_cast<char*>(nullptr));
    ::_exit(127);
  }
  bool writing = false;
  for (int i = 0; i < 20000 && !writing; ++i) {
    for (const auto& e : fs::directory_iterator(dir_ / "out")) writing = writing || e.path().filename().string().rfind(".e1.partial-", 0) == 0;
    if (!writing) ::usleep(500);
  }
  ::kill(pid, SIGKILL);
  int status = 0;
  ::waitpid(pid, &status, 0);
  ASSERT_TRUE(writing) << "the run never opened its partial folder";
  EXPECT_TRUE(WIFSIGNALED(status)) << "the run ended before it was killed";
  EXPECT_EQ(snapshot(dir_ / "out" / "e1"), earlier);
  EXPECT_EQ(fs::read_symlink(dir_ / "out" / "latest"), "e1");
}

TEST_F(Outputs, ARunThatDoesNotCommitLeavesTheEarlierOneAndLatest) {
  const fs::path config = dir_ / "c.yaml";
  std::ofstream(config) << "a: 1\n";
  {
    RunDir first(config, dir_ / "out", "D");
    std::ofstream(first.create(1) / "log.csv") << "t_s\n0\n";
    first.commit();
  }
  const auto earlier = snapshot(dir_ / "out" / "D");
  fs::path partial;
  {
    RunDir second(config, dir_ / "out", "D");
    partial = second.create(2);
    std::ofstream(partial / "log.csv") << "t_s\n";  // a failed run's short log
  }  // no commit: the run stopped on an error
  EXPECT_EQ(snapshot(dir_ / "out" / "D"), earlier);
  EXPECT_EQ(fs::read_symlink(dir_ / "out" / "latest"), "D");
  EXPECT_TRUE(fs::exists(partial / "log.csv"));  // kept for the post-mortem
  {
    RunDir third(config, dir_ / "out", "D");
    std::ofstream(third.create(3) / "log.csv") << "t_s\n0\n1\n";
    third.commit();
    EXPECT_EQ(third.path(), dir_ / "out" / "D");
  }
  EXPECT_EQ(bytes(dir_ / "out" / "D" / "log.csv"), "t_s\n0\n1\n");  // a complete run replaces the earlier one
  EXPECT_THAT(bytes(dir_ / "out" / "D" / "config.yaml"), HasSubstr("# seed used: 3"));
}

TEST_F(Outputs, RunDirRefusesANameThatIsAFileOrDevice) {
  const fs::path config = dir_ / "c.yaml";
  std::ofstream(config) << "a: 1\n";
  fs::create_directories(dir_ / "out");
  std::ofstream(dir_ / "out" / "D") << "mine";
  ASSERT_EQ(::mkfifo((dir_ / "out" / "F").c_str(), 0600), 0);
  EXPECT_THROW(RunDir(config, dir_ / "out", "D"), UsageError);
  EXPECT_THROW(RunDir(config, dir_ / "out", "F"), UsageError);
  EXPECT_THROW(RunDir(config, "/dev/null", "x"), UsageError);
  EXPECT_EQ(bytes(dir_ / "out" / "D"), "mine");
}

// `--goniometer-csv /dev/zero` read without bound; a FIFO would block. Both refused at once.
TEST_F(Outputs, GoniometerCsvThatIsADeviceOrFifoIsRefusedAtOnce) {
  const fs::path fifo = dir_ / "g.csv";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  for (const std::string& in : {std::string("/dev/zero"), fifo.string()}) {
    const Result r = peha("run --no-plot --config " PEHA_SOURCE_DIR "/configs/right_arm.yaml --experiment goniometer --out " +
                          (dir_ / "out").string() + " --goniometer-csv " + in);
    EXPECT_EQ(r.code, 2) << in << ": " << r.output;
    EXPECT_THAT(r.output, HasSubstr("not a regular file")) << in;
  }
}

}  // namespace
}  // namespace peha::app
