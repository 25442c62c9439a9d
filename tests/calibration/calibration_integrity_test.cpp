// A calibration file carries the SHA-256 of each of its sections' values (the data section holding
// the data CSV's SHA-256): any edit, a cut, a missing or changed data file, or a file from before
// the hash is refused when it is read (docs/calibration.md#integrity).
#include "peha/calibration/calibrate.hpp"
#include "peha/calibration/calibration_file.hpp"
#include "peha/calibration/dataset.hpp"
#include "peha/config/reader.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <unistd.h>

namespace peha::calibration {
namespace {

using ::testing::HasSubstr;
namespace fs = std::filesystem;

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

/// A calibration fitted to a small recorded CSV (a triangle in pressure over a sweep in
/// contraction), written with its SPGP: the file `peha calibrate` writes, in a few seconds.
class CalibrationIntegrity : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = fs::temp_directory_path() / ("peha_cal_integrity_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
    {
      std::ofstream csv(dir_ / "agonist.csv");
      csv << "t_s,pressure_MPa,contraction,force_N\n";
      for (int i = 0; i < 1200; ++i) {
        const double t = i / 50.0, phase = std::fmod(t, 6.0) / 6.0;
        const double p = 0.1 + 0.3 * (phase < 0.5 ? 2 * phase : 2 - 2 * phase);
        const double eps = 0.05 + 0.05 * (0.5 + 0.5 * std::sin(t / 3.0));
        const double f = p * 1e6 * (0.0100 - 0.048 * eps + 0.054 * eps * eps) * (1.0 + 0.02 * std::sin(7.0 * t));
        csv << t << ',' << p << ',' << eps << ',' << f << '\n';
      }
    }
    CalibrateOptions o;
    o.muscle = "agonist";
    o.fit.restarts = 4;
    o.spgp.num_pseudo = 10;
    o.spgp.max_iterations = 30;
    write_calibration(dir_ / "agonist.yaml", calibrate(read_dataset(dir_ / "agonist.csv"), o).calibration);
    text_ = new std::string(slurp(dir_ / "agonist.yaml"));
  }
  static void TearDownTestSuite() {
    fs::remove_all(dir_);
    delete text_;
  }
  void SetUp() override { std::ofstream(dir_ / "agonist.yaml", std::ios::binary) << *text_; }

  /// What reading the file says: "" when it is accepted.
  static std::string refusal() {
    try {
      read_calibration(dir_ / "agonist.yaml");
    } catch (const CalibrationRejected& e) {
      return e.what();
    } catch (const config::Error& e) {
      return e.what();
    }
    return "";
  }
  /// Rewrites the file from its parsed YAML after `edit` (as a user with an editor or a script would).
  template <class Edit>
  static void edit_yaml(Edit edit) {
    YAML::Node root = YAML::Load(*text_);
    edit(root);
    YAML::Emitter out;
    out.SetDoublePrecision(17);
    out << root;
    std::ofstream(dir_ / "agonist.yaml", std::ios::binary) << out.c_str() << '\n';
  }

  static inline fs::path dir_;
  static inline std::string* text_ = nullptr;
};

TEST_F(CalibrationIntegrity, AcceptsTheFileAsWrittenAndReformatted) {
  EXPECT_EQ(refusal(), "");
  // The hash is of the values, not their spelling: re-emitted (other layout, no comments), accepted.
  edit_yaml([](YAML::Node&) {});
  EXPECT_NE(slurp(dir_ / "agonist.yaml"), *text_);
  EXPECT_EQ(refusal(), "");
}

// Each kind of parameter the controller uses, edited by a factor the checks of the model alone let
// through (the tester's gains x 0.6 drove the link to 51.4 deg), is refused, naming the section.
TEST_F(CalibrationIntegrity, RefusesAnEditOfEachParameterKind) {
  struct Case {
    const char* section;
    const char* key;
    int index;      // -1: a scalar; else the list item
    double factor;  // new value = old x factor + offset
    double offset;
  };
  for (const Case& c : {Case{"tendon_spring", "a_N_per_MPa", -1, 0.6, 0}, Case{"tendon_spring", "c_N_per_MPa", -1, 0.6, 0},
                        Case{"tendon_spring", "k_N", -1, 2.0, 0}, Case{"tendon_spring", "eps0", -1, 1.0, 0.001},
                        Case{"input_ranges", "residual_Pa", 1, 2.0, 0}, Case{"input_ranges", "force_N", 1, 1.5, 0},
                        Case{"data", "loadcell_zero_N", -1, 1.0, 40.0}, Case{"spgp", "alpha", 0, 3.0, 0},
                        Case{"spgp", "output_scale", -1, 175.0, 0}, Case{"spgp", "log_b", 0, 1.1, 0}}) {
    SetUp();
    edit_yaml([&](YAML::Node& root) {
      // Assigning to a yaml-cpp node handle sets the node's value: index from the root each time.
      if (c.index < 0) {
        root[c.section][c.key] = root[c.section][c.key].as<double>() * c.factor + c.offset;
      } else {
        root[c.section][c.key][c.index] = root[c.section][c.key][c.index].as<double>() * c.factor + c.offset;
      }
    });
    EXPECT_THAT(refusal(), HasSubstr(std::string("section '") + c.section + ":' differs from what `peha calibrate` wrote"))
        << c.section << "." << c.key;
  }
  // The muscle's name is a parameter too (a relabelled file).
  edit_yaml([](YAML::Node& root) { root["muscle"] = "antagonist"; });
  EXPECT_THAT(refusal(), HasSubstr("section 'muscle:' differs"));
}

TEST_F(CalibrationIntegrity, RefusesAnEditedHashToo) {
  // Edit a parameter and put its section's new hash in: the hash over the sections no longer holds.
  edit_yaml([](YAML::Node& root) { root["tendon_spring"]["k_N"] = 5000.0; });
  const std::string why = refusal();
  const std::string found = why.substr(why.find("its hash is ") + 12, 64);
  edit_yaml([&](YAML::Node& root) {
    root["tendon_spring"]["k_N"] = 5000.0;
    root["integrity"]["sections"]["tendon_spring"] = found;
  });
  EXPECT_THAT(refusal(), HasSubstr("the integrity section was edited"));
}

// A file cut before `spgp:` ran "with SPGP" without one.
TEST_F(CalibrationIntegrity, RefusesAFileCutBeforeItsSpgp) {
  const std::size_t spgp = text_->find("\nspgp:");
  ASSERT_NE(spgp, std::string::npos);
  std::ofstream(dir_ / "agonist.yaml", std::ios::binary) << text_->substr(0, spgp + 1);
  EXPECT_THAT(refusal(), HasSubstr("section 'spgp:' is missing although the file announces it"));
}

TEST_F(CalibrationIntegrity, RefusesATruncatedFileWherever) {
  for (const double at : {0.2, 0.5, 0.8, 0.95, 0.999}) {
    std::ofstream(dir_ / "agonist.yaml", std::ios::binary) << text_->substr(0, static_cast<std::size_t>(at * text_->size()));
    EXPECT_NE(refusal(), "") << "cut at " << at;
  }
}

TEST_F(CalibrationIntegrity, RefusesAMissingOrChangedDataCsv) {
  const std::string data = slurp(dir_ / "agonist.csv");
  fs::rename(dir_ / "agonist.csv", dir_ / "moved.csv");
  EXPECT_THAT(refusal(), HasSubstr("agonist.csv is missing"));
  fs::rename(dir_ / "moved.csv", dir_ / "agonist.csv");
  std::ofstream(dir_ / "agonist.csv", std::ios::app) << "24,0.1,0.05,500\n";
  EXPECT_THAT(refusal(), HasSubstr("the data changed after calibrating"));
  std::ofstream(dir_ / "agonist.csv", std::ios::binary) << data;
  EXPECT_EQ(refusal(), "");
}

TEST_F(CalibrationIntegrity, RefusesAFileFromBeforeTheHashWithTheWayOut) {
  edit_yaml([](YAML::Node& root) { root.remove("integrity"); });
  EXPECT_THAT(refusal(), HasSubstr("re-run `peha calibrate`"));
}

}  // namespace
}  // namespace peha::calibration
