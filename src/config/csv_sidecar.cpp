#include "peha/config/csv_sidecar.hpp"

#include "peha/config/atomic_file.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>
#include <system_error>

namespace peha::config {
namespace {

// Column-name suffixes peha uses for units, and the unit each stands for.
constexpr std::array<std::pair<std::string_view, std::string_view>, 24> kUnits{{
    {"s", "s"},         {"ms", "ms"},           {"us", "us"},        {"ns", "ns"},          {"Hz", "Hz"},
    {"rad", "rad"},     {"deg", "deg"},         {"radps", "rad/s"},  {"degps", "deg/s"},    {"radps2", "rad/s^2"},
    {"degps2", "deg/s^2"}, {"m", "m"},          {"mm", "mm"},        {"mps", "m/s"},        {"N", "N"},
    {"Nm", "N m"},      {"Pa", "Pa"},           {"kPa", "kPa"},      {"MPa", "MPa"},        {"bar", "bar"},
    {"kg", "kg"},       {"pct", "%"},           {"1ps", "1/s"},      {"V", "V"},
}};

constexpr std::array<std::string_view, 5> kFixedFields = {"format", "file", "rows", "columns", "notes"};

std::string json_number(double v) { return std::isfinite(v) ? fmt::format("{}", v) : std::string("null"); }

}  // namespace

std::filesystem::path csv_sidecar_path(const std::filesystem::path& csv) {
  std::filesystem::path p = csv;
  p += ".meta.json";
  return p;
}

std::string json_quoted(std::string_view text) {
  std::string out;
  out.reserve(text.size() + 2);
  out += '"';
  for (const char ch : text) {
    switch (ch) {
      case '"': out += "\\\""; break;
      case '\\': out += "\\\\"; break;
      case '\n': out += "\\n"; break;
      case '\r': out += "\\r"; break;
      case '\t': out += "\\t"; break;
      default:
        // JSON forbids raw control characters in a string; bytes >= 0x80 (UTF-8) are allowed as they are.
        if (static_cast<unsigned char>(ch) < 0x20 || ch == '\x7f') {
          out += fmt::format("\\u{:04x}", static_cast<unsigned char>(ch));
        } else {
          out += ch;
        }
    }
  }
  out += '"';
  return out;
}

std::string_view column_unit(std::string_view column) {
  const std::size_t underscore = column.rfind('_');
  if (underscore == std::string_view::npos) return {};
  const std::string_view suffix = column.substr(underscore + 1);
  for (const auto& [name, unit] : kUnits) {
    if (name == suffix) return unit;
  }
  return {};
}

std::string csv_sidecar_json(const std::filesystem::path& csv, const CsvMeta& meta) {
  std::vector<std::string> names;
  for (const auto& v : meta.values) names.push_back(v.first);
  for (const auto& t : meta.texts) names.push_back(t.first);
  for (std::size_t i = 0; i < names.size(); ++i) {
    const std::string& key = names[i];
    const bool fixed = std::find(kFixedFields.begin(), kFixedFields.end(), key) != kFixedFields.end();
    const bool twice = std::find(names.begin(), names.begin() + static_cast<std::ptrdiff_t>(i), key) != names.begin() + static_cast<std::ptrdiff_t>(i);
    if (key.empty() || fixed || twice) {
      throw std::invalid_argument(fmt::format("{}: sidecar value name '{}' is empty, a fixed field or given twice",
                                              csv.string(), key));
    }
  }
  std::string out = fmt::format("{{\n  \"format\": {},\n  \"file\": {},\n", json_quoted(kCsvSidecarFormat),
                                json_quoted(csv.filename().string()));
  if (meta.rows) out += fmt::format("  \"rows\": {},\n", *meta.rows);
  out += "  \"columns\": [";
  for (std::size_t c = 0; c < meta.columns.size(); ++c) {
    const std::string_view unit = column_unit(meta.columns[c]);
    out += fmt::format("{}\n    {{\"name\": {}, \"unit\": {}}}", c ? "," : "", json_quoted(meta.columns[c]),
                       unit.empty() ? std::string("null") : json_quoted(unit));
  }
  out += meta.columns.empty() ? "],\n" : "\n  ],\n";
  out += "  \"notes\": [";
  for (std::size_t n = 0; n < meta.notes.size(); ++n) out += fmt::format("{}\n    {}", n ? "," : "", json_quoted(meta.notes[n]));
  out += meta.notes.empty() ? "]" : "\n  ]";
  for (const auto& [key, value] : meta.values) out += fmt::format(",\n  {}: {}", json_quoted(key), json_number(value));
  for (const auto& [key, text] : meta.texts) out += fmt::format(",\n  {}: {}", json_quoted(key), json_quoted(text));
  out += "\n}\n";
  return out;
}

void write_csv_sidecar(const std::filesystem::path& csv, const CsvMeta& meta) {
  const std::string text = csv_sidecar_json(csv, meta);
  write_file_atomically(csv_sidecar_path(csv), [&](std::ostream& out) { out << text; });
}

void remove_csv_sidecar(const std::filesystem::path& csv) {
  std::error_code ec;
  std::filesystem::remove(csv_sidecar_path(csv), ec);
  if (ec) throw std::runtime_error(fmt::format("{}: cannot remove the old sidecar: {}", csv_sidecar_path(csv).string(), ec.message()));
}

std::optional<Document> read_csv_sidecar(const std::filesystem::path& csv) {
  const std::filesystem::path path = csv_sidecar_path(csv);
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) return std::nullopt;
  Document doc = Document::load_file(path);
  Map root = doc.root();
  const std::string format = root.string("format");
  if (format != kCsvSidecarFormat) {
    root.fail("format", fmt::format("expected '{}' (the sidecar of a CSV peha wrote), found '{}'", kCsvSidecarFormat, format));
  }
  return doc;
}

}  // namespace peha::config
