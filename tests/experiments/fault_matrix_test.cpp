// The fault matrix (peha faults, docs/safety.md) on a small subset: the nominal row, a stuck load
// cell and a NaN from the controller while holding. The rows report what the monitor did, measured
// from the log: the flag, the cycles to it, and the plant's figures after the fault.
#include "peha/experiments/faults/fault_matrix.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <unistd.h>

namespace peha::experiments {
namespace {

TEST(FaultMatrix, HoldingRowsNameTheFlagTheCyclesAndThePlantsFigures) {
  const E1Scenario s = read_e1(config::Document::load_file(PEHA_SOURCE_DIR "/configs/e1_one_dof.yaml"));
  FaultMatrixOptions o;
  o.kinds = {sim::FaultKind::kLoadcellStuck, sim::FaultKind::kControllerNan};
  o.moments = {"holding"};
  o.after_fault_s = 2.0;
  const std::vector<FaultRow> rows = run_fault_matrix(s, o);
  ASSERT_EQ(rows.size(), 3u);
  const FaultRow& nominal = rows[0];
  EXPECT_EQ(nominal.fault, "none");
  EXPECT_FALSE(nominal.detected) << nominal.flag;  // no false alarm while holding (6 s)
  EXPECT_TRUE(nominal.log_complete);
  const FaultRow& stuck = rows[1];
  EXPECT_EQ(stuck.fault, "loadcell_stuck");
  EXPECT_TRUE(stuck.detected);
  EXPECT_EQ(stuck.flag, "loadcell_stuck");
  EXPECT_GE(stuck.detection_cycles, 0.0);
  EXPECT_LE(stuck.detection_cycles, 5.0);
  EXPECT_FALSE(stuck.passed);  // a faulted run never passes
  EXPECT_LE(stuck.peak_force_N, 2000.0);
  const FaultRow& nan = rows[2];
  EXPECT_EQ(nan.flag, "nonfinite_command");
  EXPECT_LE(nan.detection_cycles, 1.0);
  EXPECT_EQ(nan.limits_exceeded, 0);
  EXPECT_TRUE(nan.log_complete);

  const std::filesystem::path dir = std::filesystem::temp_directory_path() / ("peha_fault_matrix_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  write_fault_matrix(dir, rows, "e1_one_dof.yaml");
  std::ifstream md(dir / "faults.md");
  std::stringstream text;
  text << md.rdbuf();
  EXPECT_NE(text.str().find("| loadcell_stuck | joint.agonist | holding | loadcell_stuck |"), std::string::npos) << text.str();
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace peha::experiments
