// Tests for the calibration CSV reader/writer (docs/calibration.md, include/peha/calibration/dataset.hpp).
// Every error case checks that the message names the file, the line (and column where one applies)
// and the reason, because the message is all a person fixing the file gets.

#include "peha/calibration/dataset.hpp"

#include <yaml-cpp/yaml.h>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

namespace peha::calibration {
namespace {

namespace fs = std::filesystem;
using ::testing::AllOf;
using ::testing::HasSubstr;

class DatasetTest : public ::testing::Test {
 protected:
  void SetUp() override {
    static std::atomic<int> counter{0};
    const auto stamp = std::chrono::steady_clock::now().time_since_epoch().count();
    dir_ = fs::temp_directory_path() /
           ("peha_dataset_test_" + std::to_string(stamp) + "_" + std::to_string(counter++));
    fs::create_directories(dir_);
  }
  void TearDown() override {
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }

  fs::path write_file(const std::string& name, const std::string& content) const {
    const fs::path p = dir_ / name;
    std::ofstream out(p, std::ios::binary);
    out << content;
    return p;
  }

  /// Two comment lines, the header on line 3, then `rows` on lines 4, 5, ...
  fs::path write_csv(const std::string& name, const std::string& header, const std::vector<std::string>& rows) const {
    std::string s = "# test data\n# second comment\n" + header + "\n";
    for (const auto& r : rows) s += r + "\n";
    return write_file(name, s);
  }

  /// n plausible rows of pressure_MPa,contraction,force_N: pressure 0..0.6 MPa, force 0..~300 N.
  static std::vector<std::string> good_rows(int n = 60) {
    std::vector<std::string> rows;
    for (int i = 0; i < n; ++i) {
      const double p = 0.6 * i / (n - 1);
      const double eps = 0.02 + 0.1 * i / (n - 1);
      const double f = 500.0 * p - 200.0 * eps + 4.0;
      char buf[128];
      std::snprintf(buf, sizeof buf, "%.6g,%.6g,%.6g", p, eps, f);
      rows.emplace_back(buf);
    }
    return rows;
  }

  /// The DataError message of reading `p`, or a test failure if it reads fine.
  static std::string error_of(const fs::path& p, const DatasetRules& rules = {}) {
    try {
      (void)read_dataset(p, rules);
    } catch (const DataError& e) {
      return e.what();
    }
    ADD_FAILURE() << "read_dataset(" << p << ") did not throw DataError";
    return {};
  }

  /// "file:line" as the messages write it.
  static std::string at(const fs::path& p, int line) { return p.string() + ":" + std::to_string(line); }

  fs::path dir_;
};

// ---- good input --------------------------------------------------------------------------------

TEST_F(DatasetTest, ReadsGoodFileWithCommentsAndOptionalColumnsConvertingMPaToPa) {
  auto rows = good_rows(60);
  std::vector<std::string> with_optional;
  for (std::size_t i = 0; i < rows.size(); ++i) {
    // Optional columns first and in another order: the reader goes by name, not position.
    with_optional.push_back(std::to_string(0.004 * static_cast<double>(i)) + ",0.25,-0.01," + rows[i]);
    if (i == 10) with_optional.push_back("# a comment between data rows");
    if (i == 20) with_optional.push_back("");
  }
  with_optional[0] = "0,0.25,-0.01,0.125,0.02,4";  // exact values to check
  const auto p = write_csv("good.csv", "t_s,angle_rad,wire_velocity_mps,pressure_MPa,contraction,force_N", with_optional);

  const Dataset d = read_dataset(p);
  ASSERT_EQ(d.size(), 60u);
  EXPECT_DOUBLE_EQ(d.pressure_Pa[0], 125000.0);
  EXPECT_DOUBLE_EQ(d.contraction[0], 0.02);
  EXPECT_DOUBLE_EQ(d.force_N[0], 4.0);
  EXPECT_DOUBLE_EQ(d.pressure_Pa[59], 0.6e6);
  ASSERT_EQ(d.t_s.size(), 60u);
  ASSERT_EQ(d.angle_rad.size(), 60u);
  ASSERT_EQ(d.wire_velocity_mps.size(), 60u);
  EXPECT_DOUBLE_EQ(d.t_s[59], 0.004 * 59);
  EXPECT_DOUBLE_EQ(d.angle_rad[30], 0.25);
  EXPECT_DOUBLE_EQ(d.wire_velocity_mps[30], -0.01);
  EXPECT_EQ(d.source, p.string());
  EXPECT_EQ(d.sha256, sha256_file(p));
  EXPECT_EQ(d.sha256.size(), 64u);
}

TEST_F(DatasetTest, RequiredColumnsOnlyLeaveOptionalColumnsEmpty) {
  const auto p = write_csv("required.csv", "pressure_MPa,contraction,force_N", good_rows());
  const Dataset d = read_dataset(p);
  EXPECT_EQ(d.size(), 60u);
  EXPECT_TRUE(d.t_s.empty());
  EXPECT_TRUE(d.angle_rad.empty());
  EXPECT_TRUE(d.wire_velocity_mps.empty());
}

TEST_F(DatasetTest, AcceptsCrlfLineEndingsSpacesAndSmallNegativeLoadCellNoise) {
  auto rows = good_rows();
  rows[5] = " 0.05 , 0.03 , -3.5 ";  // load-cell noise below zero is kept as is
  std::string s = "# windows file\r\npressure_MPa,contraction,force_N\r\n";
  for (const auto& r : rows) s += r + "\r\n";
  const auto p = write_file("crlf.csv", s);
  const Dataset d = read_dataset(p);
  ASSERT_EQ(d.size(), 60u);
  EXPECT_DOUBLE_EQ(d.force_N[5], -3.5);
  EXPECT_DOUBLE_EQ(d.pressure_Pa[5], 50000.0);
}

// ---- header errors -----------------------------------------------------------------------------

TEST_F(DatasetTest, UnknownColumnIsNamedAndAcceptedColumnsListed) {
  const auto p = write_csv("unknown.csv", "pressure_MPa,contraction,force_N,speed", good_rows());
  EXPECT_THAT(error_of(p), AllOf(HasSubstr(at(p, 3)), HasSubstr("'speed'"), HasSubstr("unknown column"),
                                 HasSubstr("Accepted columns: pressure_MPa, contraction, force_N, t_s"),
                                 HasSubstr("wire_velocity_mps")));
}

TEST_F(DatasetTest, ColumnInWrongCaseSuggestsTheRightName) {
  const auto p = write_csv("case.csv", "pressure_MPa,contraction,Force_N", good_rows());
  EXPECT_THAT(error_of(p), AllOf(HasSubstr(at(p, 3)), HasSubstr("'Force_N'"), HasSubstr("did you mean 'force_N'")));
}

TEST_F(DatasetTest, DuplicateColumnIsAnError) {
  const auto p = write_csv("dup.csv", "pressure_MPa,contraction,force_N,contraction", good_rows());
  EXPECT_THAT(error_of(p), AllOf(HasSubstr(at(p, 3)), HasSubstr("duplicate column 'contraction'"),
                                 HasSubstr("fields 2 and 4")));
}

TEST_F(DatasetTest, PressureHeaderInOtherUnitsSaysConvertToMPa) {
  for (const std::string unit : {"kPa", "Pa", "bar"}) {
    SCOPED_TRACE(unit);
    const auto p = write_csv("unit_" + unit + ".csv", "pressure_" + unit + ",contraction,force_N", good_rows());
    EXPECT_THAT(error_of(p), AllOf(HasSubstr(at(p, 3)), HasSubstr("'pressure_" + unit + "'"),
                                   HasSubstr("convert to MPa (pressure_MPa)")));
  }
}

TEST_F(DatasetTest, AngleInDegreesHeaderSaysConvertToRad) {
  const auto p = write_csv("deg.csv", "pressure_MPa,contraction,force_N,angle_deg", good_rows());
  EXPECT_THAT(error_of(p), AllOf(HasSubstr(at(p, 3)), HasSubstr("'angle_deg'"), HasSubstr("convert to rad (angle_rad)")));
}

TEST_F(DatasetTest, MissingRequiredColumnIsNamed) {
  const auto p = write_csv("missing.csv", "pressure_MPa,force_N", {"0.1,10", "0.2,20"});
  EXPECT_THAT(error_of(p), AllOf(HasSubstr(at(p, 3)), HasSubstr("missing required column(s) contraction")));
}

TEST_F(DatasetTest, DataWithoutHeaderRowSaysHeaderMissing) {
  std::string s = "# no header\n";
  for (const auto& r : good_rows()) s += r + "\n";
  const auto p = write_file("noheader.csv", s);
  EXPECT_THAT(error_of(p), AllOf(HasSubstr(at(p, 2)), HasSubstr("header row missing")));
}

TEST_F(DatasetTest, SemicolonSeparatedHeaderSaysUseComma) {
  const auto p = write_csv("semicolon.csv", "pressure_MPa;contraction;force_N", {"0.1;0.02;10"});
  EXPECT_THAT(error_of(p), AllOf(HasSubstr(at(p, 3)), HasSubstr("separator must be ','")));
}

TEST_F(DatasetTest, EmptyOrCommentOnlyFileHasNoHeader) {
  const auto p = write_file("comments.csv", "# only\n\n# comments\n");
  EXPECT_THAT(error_of(p), AllOf(HasSubstr(p.string()), HasSubstr("no header row")));
}

TEST_F(DatasetTest, HeaderWithoutRowsIsAnError) {
  const auto p = write_csv("norows.csv", "pressure_MPa,contraction,force_N", {});
  EXPECT_THAT(error_of(p), AllOf(HasSubstr(p.string()), HasSubstr("no data rows after the header on line 3")));
}

TEST_F(DatasetTest, MissingFileSaysCannotOpen) {
  const auto p = dir_ / "does_not_exist.csv";
  EXPECT_THAT(error_of(p), AllOf(HasSubstr(p.string()), HasSubstr("cannot open")));
  EXPECT_THROW((void)sha256_file(p), DataError);
}

// ---- row errors --------------------------------------------------------------------------------

TEST_F(DatasetTest, RowWithWrongFieldCountNamesLineAndCounts) {
  auto rows = good_rows();
  rows[7] = "0.1,0.02,10,5";  // line 4 + 7 = 11
  const auto p = write_csv("fields.csv", "pressure_MPa,contraction,force_N", rows);
  EXPECT_THAT(error_of(p), AllOf(HasSubstr(at(p, 11) + ": expected 3 fields"), HasSubstr("found 4")));
}

TEST_F(DatasetTest, NonNumericFieldNamesLineColumnAndText) {
  auto rows = good_rows();
  rows[2] = "0.1,0.02,abc";  // line 6
  const auto p = write_csv("nan_text.csv", "pressure_MPa,contraction,force_N", rows);
  EXPECT_THAT(error_of(p), HasSubstr(at(p, 6) + ": column 'force_N': not a number 'abc'"));
}

TEST_F(DatasetTest, TrailingGarbageAfterNumberIsNotANumber) {
  auto rows = good_rows();
  rows[0] = "0.1MPa,0.02,10";  // line 4
  const auto p = write_csv("garbage.csv", "pressure_MPa,contraction,force_N", rows);
  EXPECT_THAT(error_of(p), HasSubstr(at(p, 4) + ": column 'pressure_MPa': not a number '0.1MPa'"));
}

TEST_F(DatasetTest, NanAndInfAreRejectedAsNotFinite) {
  for (const std::string bad : {"nan", "inf", "-inf", "NaN"}) {
    SCOPED_TRACE(bad);
    auto rows = good_rows();
    rows[3] = "0.1," + bad + ",10";  // line 7
    const auto p = write_csv("nonfinite.csv", "pressure_MPa,contraction,force_N", rows);
    EXPECT_THAT(error_of(p), HasSubstr(at(p, 7) + ": column 'contraction': not finite '" + bad + "'"));
  }
}

TEST_F(DatasetTest, EmptyFieldIsAnError) {
  auto rows = good_rows();
  rows[1] = "0.1,,10";  // line 5
  const auto p = write_csv("empty_field.csv", "pressure_MPa,contraction,force_N", rows);
  EXPECT_THAT(error_of(p), HasSubstr(at(p, 5) + ": column 'contraction': empty field"));
}

// ---- plausibility ------------------------------------------------------------------------------

TEST_F(DatasetTest, PressureInKPaUnderMPaHeaderLooksLikeKPa) {
  auto rows = good_rows();
  rows[10] = "620,0.02,10";  // line 14: first offender
  rows[20] = "300,0.02,10";
  const auto p = write_csv("kpa.csv", "pressure_MPa,contraction,force_N", rows);
  EXPECT_THAT(error_of(p), AllOf(HasSubstr(at(p, 14) + ": column 'pressure_MPa': value 620"),
                                 HasSubstr("looks like kPa (max 620)"), HasSubstr("convert to MPa")));
}

TEST_F(DatasetTest, PressureInPaUnderMPaHeaderLooksLikePa) {
  auto rows = good_rows();
  rows[0] = "0.5,0.02,10";
  rows[1] = "620000,0.02,10";  // line 5
  const auto p = write_csv("pa.csv", "pressure_MPa,contraction,force_N", rows);
  EXPECT_THAT(error_of(p), AllOf(HasSubstr(at(p, 5) + ": column 'pressure_MPa': value 620000"),
                                 HasSubstr("looks like Pa (max 620000)")));
}

TEST_F(DatasetTest, PressureBelowNoiseIsAnError) {
  auto rows = good_rows();
  rows[1] = "-0.01,0.02,10";  // noise: fine
  rows[4] = "-0.3,0.02,10";   // line 8
  const auto p = write_csv("negp.csv", "pressure_MPa,contraction,force_N", rows);
  EXPECT_THAT(error_of(p), AllOf(HasSubstr(at(p, 8) + ": column 'pressure_MPa': value -0.3"), HasSubstr("below -0.02 MPa")));
}

TEST_F(DatasetTest, ContractionInPercentLooksLikePercent) {
  auto rows = good_rows();
  rows[9] = "0.1,12.5,10";  // line 13
  const auto p = write_csv("percent.csv", "pressure_MPa,contraction,force_N", rows);
  EXPECT_THAT(error_of(p), AllOf(HasSubstr(at(p, 13) + ": column 'contraction': value 12.5"),
                                 HasSubstr("looks like percent")));
}

TEST_F(DatasetTest, ForceFarBelowZeroIsAnError) {
  auto rows = good_rows();
  rows[6] = "0.1,0.02,-120";  // line 10
  const auto p = write_csv("negf.csv", "pressure_MPa,contraction,force_N", rows);
  EXPECT_THAT(error_of(p), AllOf(HasSubstr(at(p, 10) + ": column 'force_N': value -120"), HasSubstr("below -50 N")));
}

// Each of these read with exit 0 before: one 1e300 N force, a file cut inside its last number,
// a device that never ends, and a file far larger than any calibration.
TEST_F(DatasetTest, ImpossibleForceIsAnError) {
  auto rows = good_rows();
  rows[7] = "0.3,0.05,1e300";  // line 11
  const auto p = write_csv("bigf.csv", "pressure_MPa,contraction,force_N", rows);
  EXPECT_THAT(error_of(p), AllOf(HasSubstr(at(p, 11) + ": column 'force_N': value 1e+300"), HasSubstr("above 18060 N"),
                                 HasSubstr("Festo's largest, DMSP-40")));
}

// The cap is the muscle's: Festo's DMSP-40 map holds 9331 N (0.62 MPa, stretched 5 %), read with the
// default rules (any muscle); the same row is refused against a ceiling given for a smaller muscle.
TEST_F(DatasetTest, ForceCapIsTheMusclesCeiling) {
  auto rows = good_rows();
  rows[7] = "0.62,-0.05,9331";  // line 11
  const auto p = write_csv("dmsp40.csv", "pressure_MPa,contraction,force_N", rows);
  EXPECT_EQ(read_dataset(p).force_N[7], 9331.0);
  DatasetRules dmsp10;
  dmsp10.max_force_N = 1040.0;
  dmsp10.max_force_reason = "the DMSP-10 law's ceiling";
  EXPECT_THAT(error_of(p, dmsp10), AllOf(HasSubstr(at(p, 11) + ": column 'force_N': value 9331 is above 1040 N"),
                                         HasSubstr("(the DMSP-10 law's ceiling)")));
}

TEST_F(DatasetTest, FileCutInsideItsLastNumberIsAnError) {
  std::string text = "pressure_MPa,contraction,force_N\n";
  for (const auto& r : good_rows()) text += r + "\n";
  text += "0.31,0.07,15";  // the last row was "0.31,0.07,152.4": the copy stopped
  const auto p = write_file("cut.csv", text);
  EXPECT_THAT(error_of(p), AllOf(HasSubstr(at(p, 62) + ": the last line has no line end"), HasSubstr("cut off")));
}

TEST_F(DatasetTest, DevicesAndHugeFilesAreRefusedBeforeReading) {
  EXPECT_THAT(error_of("/dev/zero"), HasSubstr("/dev/zero: not a regular file"));
  const auto p = dir_ / "huge.csv";
  { std::ofstream(p) << "pressure_MPa,contraction,force_N\n"; }
  fs::resize_file(p, (std::uintmax_t{512} << 20) + 1);  // sparse: no disk used
  EXPECT_THAT(error_of(p), HasSubstr("MiB is larger than the 512 MiB a calibration CSV may have"));
}

TEST_F(DatasetTest, AngleInDegreesUnderRadHeaderLooksLikeDegrees) {
  auto rows = good_rows();
  for (auto& r : rows) r += ",0.5";
  rows[3] = "0.1,0.02,10,45";  // line 7
  const auto p = write_csv("angle.csv", "pressure_MPa,contraction,force_N,angle_rad", rows);
  EXPECT_THAT(error_of(p), AllOf(HasSubstr(at(p, 7) + ": column 'angle_rad': value 45"), HasSubstr("looks like degrees")));
}

TEST_F(DatasetTest, TimeThatDoesNotIncreaseIsAnError) {
  auto rows = good_rows();
  for (std::size_t i = 0; i < rows.size(); ++i) rows[i] = std::to_string(0.004 * static_cast<double>(i)) + "," + rows[i];
  rows[12] = "0.044," + good_rows()[12];  // line 16: 0.044 == previous (11 * 0.004)
  const auto p = write_csv("time.csv", "t_s,pressure_MPa,contraction,force_N", rows);
  EXPECT_THAT(error_of(p), AllOf(HasSubstr(at(p, 16) + ": column 't_s': value 0.044"), HasSubstr("(line 15)"),
                                 HasSubstr("strictly increasing")));
}

TEST_F(DatasetTest, TooFewRowsSaysTooFewPoints) {
  const auto p = write_csv("few.csv", "pressure_MPa,contraction,force_N", good_rows(10));
  EXPECT_THAT(error_of(p), AllOf(HasSubstr(p.string()), HasSubstr("too few points (10 < 50)")));
  DatasetRules lenient;
  lenient.min_rows = 10;
  EXPECT_EQ(read_dataset(p, lenient).size(), 10u);
}

TEST_F(DatasetTest, ConstantPressureSaysNoExcitation) {
  std::vector<std::string> rows;
  for (int i = 0; i < 60; ++i) rows.push_back((i % 2 ? "0.31," : "0.30,") + std::to_string(0.01 * i) + "," + std::to_string(10 * i));
  const auto p = write_csv("flatp.csv", "pressure_MPa,contraction,force_N", rows);
  EXPECT_THAT(error_of(p), AllOf(HasSubstr(p.string()), HasSubstr("column 'pressure_MPa'"),
                                 HasSubstr("no excitation: pressure spans only 0.01 MPa")));
}

TEST_F(DatasetTest, ConstantForceSaysNoExcitation) {
  std::vector<std::string> rows;
  for (int i = 0; i < 60; ++i) rows.push_back(std::to_string(0.01 * i) + ",0.05," + (i % 2 ? "101" : "100"));
  const auto p = write_csv("flatf.csv", "pressure_MPa,contraction,force_N", rows);
  EXPECT_THAT(error_of(p), AllOf(HasSubstr(p.string()), HasSubstr("no excitation: force spans only 1 N")));
}

// ---- sha256 ------------------------------------------------------------------------------------

TEST_F(DatasetTest, Sha256OfKnownContentsMatchesKnownDigests) {
  EXPECT_EQ(sha256_file(write_file("abc.txt", "abc")),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  EXPECT_EQ(sha256_file(write_file("empty.txt", "")),
            "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
  // One million 'a' (FIPS 180-2 test vector): spans several read chunks.
  EXPECT_EQ(sha256_file(write_file("million.txt", std::string(1000000, 'a'))),
            "cdc76e5c9914fb9281a1c7e284d73e67f1809a48a497200e046d39ccc7112cd0");
}

// ---- write / round trip ------------------------------------------------------------------------

TEST_F(DatasetTest, WriteThenReadRoundTripsExactly) {
  Dataset d;
  for (int i = 0; i < 80; ++i) {
    d.pressure_Pa.push_back(1234.5678 + 7654.321 * i);
    d.contraction.push_back(-0.01 + 0.00123456789 * i);
    d.force_N.push_back(3.14159265358979 * i - 2.0);
    d.t_s.push_back(0.004 * i);
    d.wire_velocity_mps.push_back(0.001 * (i % 7) - 0.003);
  }
  d.loadcell_zero_N = 40.125;
  const auto a = dir_ / "a.csv";
  write_dataset(a, d, {"written by dataset_test", "two\nlines"});
  const Dataset r1 = read_dataset(a);
  ASSERT_EQ(r1.size(), d.size());
  EXPECT_EQ(r1.loadcell_zero_N, 40.125);
  EXPECT_TRUE(r1.angle_rad.empty());
  for (std::size_t i = 0; i < d.size(); ++i) {
    EXPECT_NEAR(r1.pressure_Pa[i], d.pressure_Pa[i], 1e-8 * d.pressure_Pa[i]);
    EXPECT_NEAR(r1.contraction[i], d.contraction[i], 1e-9);
    EXPECT_NEAR(r1.force_N[i], d.force_N[i], 1e-6);
  }
  // Data as read from a file (<= 9 significant digits) round-trips bit for bit.
  const auto b = dir_ / "b.csv";
  write_dataset(b, r1, {});
  const Dataset r2 = read_dataset(b);
  EXPECT_EQ(r2.pressure_Pa, r1.pressure_Pa);
  EXPECT_EQ(r2.contraction, r1.contraction);
  EXPECT_EQ(r2.force_N, r1.force_N);
  EXPECT_EQ(r2.t_s, r1.t_s);
  EXPECT_EQ(r2.wire_velocity_mps, r1.wire_velocity_mps);
  EXPECT_TRUE(r2.angle_rad.empty());
  EXPECT_EQ(r2.sha256, sha256_file(b));

  // The header is the first line; the comments and the zero are in the sidecar.
  std::ifstream in(a);
  std::string header;
  std::getline(in, header);
  EXPECT_EQ(header, "pressure_MPa,contraction,force_N,t_s,wire_velocity_mps");
  EXPECT_FALSE(fs::exists(dir_ / "a.csv.tmp"));
  const YAML::Node meta = YAML::LoadFile((dir_ / "a.csv.meta.json").string());
  EXPECT_EQ(meta["loadcell_zero_N"].as<double>(), 40.125);
  EXPECT_EQ(meta["rows"].as<int>(), 80);
  ASSERT_EQ(meta["notes"].size(), 3u);
  EXPECT_EQ(meta["notes"][0].as<std::string>(), "written by dataset_test");
  EXPECT_EQ(meta["notes"][1].as<std::string>(), "two\nlines");
  EXPECT_EQ(meta["columns"][0]["unit"].as<std::string>(), "MPa");
  // Without its sidecar the same CSV reads with zero 0: the zero came from there.
  fs::remove(dir_ / "a.csv.meta.json");
  EXPECT_EQ(read_dataset(a).loadcell_zero_N, 0.0);
}

// A recording written again over an older one: the old sidecar's zero never stays beside the new CSV.
// The recording names its muscle in the sidecar; a file that names none reads as "".
TEST_F(DatasetTest, TheMuscleRecordedRoundTripsThroughTheSidecar) {
  Dataset d = read_dataset(write_csv("m.csv", "pressure_MPa,contraction,force_N", good_rows()));
  EXPECT_EQ(d.muscle, "");
  d.muscle = "antagonist";
  const auto p = dir_ / "named.csv";
  write_dataset(p, d, {});
  EXPECT_EQ(recorded_muscle(p), "antagonist");
  EXPECT_EQ(read_dataset(p).muscle, "antagonist");
}

TEST_F(DatasetTest, RewritingReplacesTheSidecar) {
  Dataset d;
  for (int i = 0; i < 60; ++i) {
    d.pressure_Pa.push_back(1e5 + 5e3 * i);
    d.contraction.push_back(0.05);
    d.force_N.push_back(10.0 + 5.0 * i);
  }
  const auto p = dir_ / "agonist.csv";
  d.loadcell_zero_N = 7.5;
  write_dataset(p, d, {"first"});
  d.loadcell_zero_N = -3.25;
  write_dataset(p, d, {"second"});
  EXPECT_EQ(read_dataset(p).loadcell_zero_N, -3.25);
  EXPECT_EQ(YAML::LoadFile((dir_ / "agonist.csv.meta.json").string())["notes"][0].as<std::string>(), "second");
}

// The recording's load-cell zero travels in one comment line; a bad or repeated one is refused
// with its line, an ordinary comment that mentions it is not read.
TEST_F(DatasetTest, LoadcellZeroCommentIsReadStrictly) {
  std::string rows = "pressure_MPa,contraction,force_N\n";
  for (int i = 0; i < 60; ++i) rows += std::to_string(0.1 + 0.005 * i) + ",0.05," + std::to_string(10.0 + 5.0 * i) + "\n";
  EXPECT_EQ(read_dataset(write_file("none.csv", rows)).loadcell_zero_N, 0.0);
  EXPECT_EQ(read_dataset(write_file("zero.csv", "# loadcell_zero_N: -12.5\n" + rows)).loadcell_zero_N, -12.5);
  EXPECT_EQ(read_dataset(write_file("mention.csv", "# see loadcell_zero_N: none here\n" + rows)).loadcell_zero_N, 0.0);
  for (const char* bad : {"# loadcell_zero_N: 40 N\n", "# loadcell_zero_N: nan\n", "# loadcell_zero_N: 5000\n",
                          "# loadcell_zero_N:\n"}) {
    try {
      (void)read_dataset(write_file("bad.csv", std::string(bad) + rows));
      ADD_FAILURE() << "accepted " << bad;
    } catch (const DataError& e) {
      EXPECT_THAT(e.what(), HasSubstr("bad.csv:1: loadcell_zero_N: expected a number of newtons"));
    }
  }
  try {
    (void)read_dataset(write_file("twice.csv", "# loadcell_zero_N: 1\n# loadcell_zero_N: 2\n" + rows));
    ADD_FAILURE() << "accepted twice";
  } catch (const DataError& e) {
    EXPECT_THAT(e.what(), HasSubstr("twice.csv:2: loadcell_zero_N given twice (first on line 1)"));
  }
}

// Today's recordings carry the zero in the sidecar <csv>.meta.json: read from there, refused with
// the sidecar's line and column when out of range, and refused when an old '#' line gives it too.
TEST_F(DatasetTest, LoadcellZeroFromTheSidecar) {
  std::string rows = "pressure_MPa,contraction,force_N\n";
  for (int i = 0; i < 60; ++i) rows += std::to_string(0.1 + 0.005 * i) + ",0.05," + std::to_string(10.0 + 5.0 * i) + "\n";
  const auto sidecar = [&](const std::string& csv, const std::string& zero) {
    write_file(csv + ".meta.json", "{\n  \"format\": \"peha-log-1\",\n  \"notes\": [],\n  \"loadcell_zero_N\": " + zero + "\n}\n");
  };
  sidecar("side.csv", "-12.5");
  EXPECT_EQ(read_dataset(write_file("side.csv", rows)).loadcell_zero_N, -12.5);
  write_file("nozero.csv.meta.json", "{\"format\": \"peha-log-1\", \"notes\": [\"festo map\"]}\n");
  EXPECT_EQ(read_dataset(write_file("nozero.csv", rows)).loadcell_zero_N, 0.0);
  sidecar("far.csv", "5000");
  try {
    (void)read_dataset(write_file("far.csv", rows));
    ADD_FAILURE() << "accepted a zero of 5000 N";
  } catch (const DataError& e) {
    EXPECT_THAT(e.what(), HasSubstr("far.csv.meta.json:4:22: loadcell_zero_N: expected a number in [-1000, 1000], found 5000"));
  }
  sidecar("both.csv", "1");
  try {
    (void)read_dataset(write_file("both.csv", "# loadcell_zero_N: 1\n" + rows));
    ADD_FAILURE() << "accepted the zero in two places";
  } catch (const DataError& e) {
    EXPECT_THAT(e.what(), HasSubstr("both.csv:1: loadcell_zero_N given twice: in this '#' line and in "));
    EXPECT_THAT(e.what(), HasSubstr("both.csv.meta.json"));
  }
  write_file("foreign.csv.meta.json", "{\"format\": \"other\"}\n");
  EXPECT_THROW((void)read_dataset(write_file("foreign.csv", rows)), DataError);
}

TEST_F(DatasetTest, WriteRejectsRaggedOrNonFiniteColumns) {
  Dataset d;
  d.pressure_Pa = {1e5, 2e5};
  d.contraction = {0.1, 0.2};
  d.force_N = {10.0};
  EXPECT_THROW(write_dataset(dir_ / "ragged.csv", d, {}), DataError);
  d.force_N = {10.0, std::numeric_limits<double>::quiet_NaN()};
  try {
    write_dataset(dir_ / "nan.csv", d, {});
    ADD_FAILURE() << "no DataError";
  } catch (const DataError& e) {
    EXPECT_THAT(std::string(e.what()), AllOf(HasSubstr("force_N"), HasSubstr("row 2"), HasSubstr("not finite")));
  }
  EXPECT_FALSE(fs::exists(dir_ / "nan.csv"));
}

}  // namespace
}  // namespace peha::calibration
