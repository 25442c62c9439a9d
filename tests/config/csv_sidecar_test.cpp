// A CSV's sidecar <csv>.meta.json: JSON that a JSON/YAML parser reads back to the same notes,
// whatever characters they hold, units from the column names, and a reader that knows its own format.
#include "peha/config/csv_sidecar.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <limits>
#include <stdexcept>
#include <unistd.h>

namespace peha::config {
namespace {

using ::testing::HasSubstr;

std::filesystem::path temp_csv(const std::string& name) {
  return std::filesystem::temp_directory_path() / ("peha_sidecar_" + std::to_string(::getpid()) + "_" + name + ".csv");
}

TEST(CsvSidecar, JsonQuotedEscapesQuotesBackslashesAndControlCharacters) {
  EXPECT_EQ(json_quoted("plain"), "\"plain\"");
  EXPECT_EQ(json_quoted("a\"b\\c"), "\"a\\\"b\\\\c\"");
  EXPECT_EQ(json_quoted("1\n2\r3\t4"), "\"1\\n2\\r3\\t4\"");
  EXPECT_EQ(json_quoted(std::string("\x01\x1f\x7f", 3)), "\"\\u0001\\u001f\\u007f\"");
  EXPECT_EQ(json_quoted("27.1 \xc2\xb0"), "\"27.1 \xc2\xb0\"");  // UTF-8 (a degree sign) as it is
}

TEST(CsvSidecar, UnitsComeFromTheColumnNamesSuffix) {
  EXPECT_EQ(column_unit("t_s"), "s");
  EXPECT_EQ(column_unit("agonist_pressure_MPa"), "MPa");
  EXPECT_EQ(column_unit("velocity_radps"), "rad/s");
  EXPECT_EQ(column_unit("tau_motor_cmd_Nm"), "N m");
  EXPECT_EQ(column_unit("wire_velocity_mps"), "m/s");
  EXPECT_EQ(column_unit("finger_active"), "");  // no unit: a flag
  EXPECT_EQ(column_unit("contraction"), "");
  EXPECT_EQ(column_unit("limit_flags"), "");
}

// Notes with every character JSON must escape come back byte for byte from a real parser
// (yaml-cpp, which reads JSON), with the fixed fields, the units and a named number.
TEST(CsvSidecar, ParsesBackToWhatWasWritten) {
  const std::filesystem::path csv = temp_csv("roundtrip");
  const std::vector<std::string> notes = {"case: payload_2.5kg (2.5 kg payload)", "config: out/we\"ird\\dir/e1.yaml",
                                          "two\nlines\tand a tab", std::string("bell \x07 and \xc2\xb0")};
  write_csv_sidecar(csv, {{"t_s", "angle_rad", "finger_active"}, 34001, notes, {{"loadcell_zero_N", -12.5}, {"empty_min_s", std::numeric_limits<double>::quiet_NaN()}}});
  const std::optional<Document> doc = read_csv_sidecar(csv);
  ASSERT_TRUE(doc);
  Map root = doc->root();
  EXPECT_EQ(root.string("file"), csv.filename().string());
  EXPECT_EQ(root.integer("rows", 0, 1000000), 34001);
  EXPECT_EQ(root.number("loadcell_zero_N", {-1000, 1000}), -12.5);
  std::vector<Map> columns = root.maps("columns", 3, 3);
  EXPECT_EQ(columns[0].string("name"), "t_s");
  EXPECT_EQ(columns[0].string("unit"), "s");
  EXPECT_EQ(columns[1].string("unit"), "rad");
  EXPECT_EQ(columns[2].string("name"), "finger_active");
  const YAML::Node raw = YAML::LoadFile(csv_sidecar_path(csv).string());
  EXPECT_TRUE(raw["columns"][2]["unit"].IsNull());
  EXPECT_TRUE(raw["empty_min_s"].IsNull());  // NaN is no JSON number
  ASSERT_EQ(raw["notes"].size(), notes.size());
  for (std::size_t i = 0; i < notes.size(); ++i) EXPECT_EQ(raw["notes"][i].as<std::string>(), notes[i]) << i;
  std::filesystem::remove(csv_sidecar_path(csv));
}

TEST(CsvSidecar, ReadingACsvWithoutOneGivesNothingAndAForeignOneIsAnError) {
  const std::filesystem::path csv = temp_csv("foreign");
  remove_csv_sidecar(csv);  // none there: no error
  EXPECT_FALSE(read_csv_sidecar(csv));
  std::ofstream(csv_sidecar_path(csv)) << "{\"format\": \"someone-else-2\"}\n";
  try {
    (void)read_csv_sidecar(csv);
    ADD_FAILURE() << "a foreign format was accepted";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr(csv_sidecar_path(csv).string() + ":1:"));
    EXPECT_THAT(e.what(), HasSubstr("expected 'peha-log-1'"));
    EXPECT_THAT(e.what(), HasSubstr("found 'someone-else-2'"));
  }
  std::ofstream(csv_sidecar_path(csv)) << "{\"format\": \"peha-log-1\", \"notes\": [\n";
  EXPECT_THROW((void)read_csv_sidecar(csv), Error);  // cut off
  remove_csv_sidecar(csv);
  EXPECT_FALSE(std::filesystem::exists(csv_sidecar_path(csv)));
}

TEST(CsvSidecar, RefusesValueNamesThatWouldShadowItsFields) {
  const std::filesystem::path csv = temp_csv("names");
  for (const char* name : {"format", "rows", "notes", ""}) {
    EXPECT_THROW((void)csv_sidecar_json(csv, {{}, {}, {}, {{name, 1.0}}}), std::invalid_argument) << name;
  }
  EXPECT_THROW((void)csv_sidecar_json(csv, {{}, {}, {}, {{"a", 1.0}, {"a", 2.0}}}), std::invalid_argument);
  EXPECT_NO_THROW((void)csv_sidecar_json(csv, {{}, {}, {}, {{"a", 1.0}, {"b", 2.0}}}));
}

}  // namespace
}  // namespace peha::config
