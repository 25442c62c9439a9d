#include "peha/config/reader.hpp"

#include "peha/experiments/e1_gravity/e1_gravity.hpp"
#include "../support/replaced.hpp"

#include <gtest/gtest.h>
#include <gmock/gmock.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <unistd.h>
#include <string>

namespace peha::config {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;

std::string e1_text() {
  std::ifstream in(PEHA_SOURCE_DIR "/configs/e1_one_dof.yaml");
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

/// Replaces the first occurrence of `from` in the E1 config by `to` and parses it as if it were
/// configs/e1_one_dof.yaml (so relative paths resolve). Returns the error message ("" if none).
std::string e1_error_after(const std::string& from, const std::string& to) {
  const std::string text = testing::replaced(e1_text(), from, to);
  // One file per test: CTest runs tests in parallel, and relative paths must resolve from configs/.
  const std::string path = std::string(PEHA_SOURCE_DIR "/configs/mutated_") +
                           ::testing::UnitTest::GetInstance()->current_test_info()->name() + ".yaml";
  { std::ofstream(path) << text; }
  std::string message;
  try {
    experiments::read_e1(Document::load_file(path));
  } catch (const Error& e) {
    message = e.what();
  }
  std::remove(path.c_str());
  return message;
}

TEST(Config, ShippedE1ConfigLoads) { EXPECT_EQ(e1_error_after("seed: 1", "seed: 1"), ""); }

TEST(Config, RejectsUnknownKeyWithFileLineAndPath) {
  const std::string e = e1_error_after("    use_motor: true", "    use_motor: true\n    use_motr: false");
  EXPECT_THAT(e, HasSubstr("mutated_RejectsUnknownKeyWithFileLineAndPath.yaml:"));
  EXPECT_THAT(e, HasSubstr("controller.allocation.use_motr: unknown key; did you mean 'use_motor'?"));
}

// A key near none of the section's is listed with the keys the section knows (optional ones too).
TEST(Config, UnknownKeyFarFromEveryKnownOneListsTheSectionsKeys) {
  const std::string e = e1_error_after("  duration_s: 34.0", "  duration_s: 34.0\n  realtime: true");
  EXPECT_THAT(e, HasSubstr("run.realtime: unknown key; known keys here: control_period_s, drift_window_s, duration_s, initial_angle_deg"));
  EXPECT_THAT(e1_error_after("hold: true,", "hold: true, brekaway: up,"),
              HasSubstr("finger.pushes[0].brekaway: unknown key; did you mean 'breakaway'?"));
}

TEST(Config, RejectsMissingKey) {
  const std::string e = e1_error_after("  velocity_cutoff_Hz: 20.0\n", "");
  EXPECT_THAT(e, HasSubstr("controller.velocity_cutoff_Hz: missing required key"));
  EXPECT_THAT(e, Not(HasSubstr("did you mean")));
}

// A required key misspelled is reported missing with the spelling that was given (one edit, a swap).
TEST(Config, MisspelledRequiredKeySaysDidYouMean) {
  EXPECT_THAT(e1_error_after("  velocity_cutoff_Hz: 20.0", "  velocity_cutof_Hz: 20.0"),
              HasSubstr("controller.velocity_cutoff_Hz: missing required key (did you mean 'velocity_cutof_Hz', given here?)"));
  EXPECT_THAT(e1_error_after("  supply_pressure_MPa: 0.8", "  supply_pressrue_MPa: 0.8"),
              HasSubstr("limits.supply_pressure_MPa: missing required key (did you mean 'supply_pressrue_MPa', given here?)"));
}

TEST(Config, RejectsWrongType) {
  EXPECT_THAT(e1_error_after("duration_s: 34.0", "duration_s: long"),
              HasSubstr("run.duration_s: expected a number in [0.1, 3600] (decimal, e.g. 0.25 or 2.5e-3), found 'long'"));
  EXPECT_THAT(e1_error_after("use_motor: true", "use_motor: 1"),
              HasSubstr("controller.allocation.use_motor: expected true or false, found '1'"));
  EXPECT_THAT(e1_error_after("  pushes:\n", "  pushes: 3\n  unused:\n"), HasSubstr("finger.pushes: expected a list"));
}

// The 2000 N safety ceiling cannot be configured away.
TEST(Config, RejectsMuscleCeilingAboveWireLimit) {
  const std::string e = e1_error_after("max_force_N: 2000.0", "max_force_N: 2500.0");
  EXPECT_THAT(e, HasSubstr("controller.agonist.max_force_N: expected a number in [1, 2000], found 2500"));
  const std::string text = e1_text();
  const auto line = 1 + std::count(text.begin(), text.begin() + text.find("max_force_N: 2000.0"), '\n');
  EXPECT_THAT(e, HasSubstr(":" + std::to_string(line) + ":"));  // the line of the offending value
}

TEST(Config, RejectsOutOfRangeSupplyAndNegativeLag) {
  EXPECT_THAT(e1_error_after("supply_pressure_MPa: 0.8", "supply_pressure_MPa: 8"),
              HasSubstr("limits.supply_pressure_MPa: expected a number in [0.1, 1]"));
  EXPECT_THAT(e1_error_after("lag_s: 0.03", "lag_s: -0.03"), HasSubstr("plant.agonist.valve.lag_s"));
}

TEST(Config, RejectsTimestepThatDoesNotDivideThePeriod) {
  EXPECT_THAT(e1_error_after("timestep_s: 0.0005", "timestep_s: 0.0003"),
              HasSubstr("plant.timestep_s: must divide the control period"));
}

TEST(Config, RejectsOverlappingPushesAndUnknownExperiment) {
  EXPECT_THAT(e1_error_after("start_s: 6.0", "start_s: 1.0"), HasSubstr("pushes must not overlap"));
  EXPECT_THAT(e1_error_after("experiment: gravity_compensation_1dof", "experiment: e9"),
              HasSubstr("experiment: expected one of {gravity_compensation_1dof}, found 'e9'"));
}

TEST(Config, RejectsMissingModelFileAndBrokenYaml) {
  std::string message;
  try {
    Document::load_string("a: [1, 2", "broken.yaml");
  } catch (const Error& e) {
    message = e.what();
  }
  EXPECT_THAT(message, HasSubstr("broken.yaml:"));
  EXPECT_THAT(message, HasSubstr("not valid YAML"));
  EXPECT_THROW(Document::load_file("/nonexistent/peha.yaml"), Error);
}

TEST(Config, RejectsDuplicateKey) {
  Document doc = Document::load_string("gain: 2.5\ngain: 3.0\n", "dup.yaml");
  Map root = doc.root();
  root.number("gain", {0, 10});
  try {
    root.finish();
    FAIL() << "a repeated key must be rejected";
  } catch (const Error& e) {
    EXPECT_THAT(std::string(e.what()), HasSubstr("dup.yaml:2:1: gain: duplicate key"));
  }
}

TEST(Config, StrictReaderAcceptsOnlyWhatItReads) {
  Document doc = Document::load_string("gain: 2.5\nname: x\nlist: [1, 2, 3]\n", "t.yaml");
  Map root = doc.root();
  EXPECT_EQ(root.number("gain", {0, 10}), 2.5);
  EXPECT_EQ(root.numbers("list", {0, 5}, 1, 3).size(), 3u);
  EXPECT_THROW(root.finish(), Error);  // "name" was never read
  EXPECT_EQ(root.string("name"), "x");
  EXPECT_NO_THROW(root.finish());
  EXPECT_THROW(root.number("gain", {3, 10}), Error);
  EXPECT_THROW(root.integer("gain", 0, 10), Error);
}

// A list of names from a fixed set (E4's goniometer.joints): each must be one of the options and listed
// once; the error names the item, what was expected and what was found.
TEST(Config, ChoicesAreDistinctNamesFromTheOptions) {
  Document doc = Document::load_string("a: [R_EFE, L_EFE]\nb: [R_EFE, R_WR]\nc: [R_EFE, R_EFE]\nd: R_EFE\n", "t.yaml");
  Map root = doc.root();
  const std::vector<std::string> io = {"R_SFE", "R_EFE", "L_EFE"};
  EXPECT_EQ(root.choices("a", io, 1, 3), (std::vector<std::string>{"R_EFE", "L_EFE"}));
  auto error = [&](const char* key) {
    try {
      root.choices(key, io, 1, 3);
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_THAT(error("b"), HasSubstr("t.yaml:2:12: b[1]: expected one of {R_SFE, R_EFE, L_EFE}, found 'R_WR'"));
  EXPECT_THAT(error("c"), HasSubstr("c[1]: 'R_EFE' is listed twice"));
  EXPECT_THAT(error("d"), HasSubstr("d: expected a list of 1 to 3 of {R_SFE, R_EFE, L_EFE}, found 'R_EFE'"));
}

TEST(Config, NumbersAreDecimalOnly) {
  const auto read = [](const std::string& text) {
    Document doc = Document::load_string("x: " + text + "\n", "n.yaml");
    Map root = doc.root();
    return root.number("x", {-1e9, 1e9});
  };
  EXPECT_EQ(read("2.5"), 2.5);
  EXPECT_EQ(read("+2"), 2.0);
  EXPECT_EQ(read("-0.5e-3"), -0.5e-3);
  EXPECT_EQ(read(".5"), 0.5);
  EXPECT_EQ(read("5."), 5.0);
  EXPECT_EQ(read("1E3"), 1000.0);
  for (const char* bad : {"0x10", "0X1p4", "nan", ".nan", "inf", "-.inf", "1e400", "1_000", "1,5", "1e", "e3", ".",
                          "+", "2.5.1", "'2 '", "1 2", "0b101", "12abc"}) {
    EXPECT_THROW(read(bad), Error) << bad;
  }
  try {
    read("0x10");
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("n.yaml:1:4: x: expected a number in [-1000000000, 1000000000] (decimal"));
  }
  Document doc = Document::load_string("n: -1\nm: 0x10\n", "i.yaml");
  Map root = doc.root();
  EXPECT_THROW(root.integer("n", 0, 100), Error);  // no negative where the range is unsigned
  EXPECT_THROW(root.integer("m", 0, 100), Error);  // 0x10 is not 16
}

TEST(Config, RefusesDevicesAndHugeFilesBeforeReadingThem) {
  // /dev/zero used to be read until bad_alloc.
  try {
    Document::load_file("/dev/zero");
    ADD_FAILURE() << "/dev/zero was accepted";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("/dev/zero: not a regular file"));
  }
  const auto big = std::filesystem::temp_directory_path() / ("peha_big.yaml_" + std::to_string(::getpid()));
  std::filesystem::resize_file((std::ofstream(big), big), kMaxFileBytes + 1);
  try {
    Document::load_file(big);
    ADD_FAILURE() << "a file above the limit was accepted";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("larger than the 256 MiB a config file may have"));
  }
  std::filesystem::remove(big);
  EXPECT_THROW(Document::load_file("/nonexistent/peha.yaml"), Error);
}

}  // namespace
}  // namespace peha::config
