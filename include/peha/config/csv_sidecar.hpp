#pragma once
/// \file
/// The metadata of a CSV peha writes, in a sidecar `<csv>.meta.json` beside it, so that the CSV's
/// first line is its header and numpy.genfromtxt(names=True), pandas.read_csv and PlotJuggler open
/// it unmodified (docs/runtime.md#log-files). The sidecar is one JSON object:
///
///     {"format": "peha-log-1", "file": "e1_payload_2.5kg.csv", "rows": 34001,
///      "columns": [{"name": "t_s", "unit": "s"}, {"name": "finger_active", "unit": null}, ...],
///      "notes": ["case: payload_2.5kg (2.5 kg payload)", "config: configs/e1_one_dof.yaml", ...],
///      "loadcell_zero_N": 0.21}
///
/// `rows` is there once the writer knows how many it wrote; named numbers a reader needs (the
/// calibration recording's `loadcell_zero_N`) sit at the top level. JSON is YAML, so the sidecar is
/// read with config::Document and its file:line:column errors. Set-up and after-run code only.

#include "peha/config/reader.hpp"

#include <cstddef>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace peha::config {

/// The sidecar's "format": bumped when a field changes meaning.
inline constexpr std::string_view kCsvSidecarFormat = "peha-log-1";

/// What a sidecar says about its CSV.
struct CsvMeta {
  std::vector<std::string> columns;                    ///< the CSV's header, in order
  std::optional<std::size_t> rows;                     ///< data rows written, when known
  std::vector<std::string> notes;                      ///< free text: case, config path, seed, units notes
  std::vector<std::pair<std::string, double>> values;  ///< named numbers (NaN and inf written as null)
  std::vector<std::pair<std::string, std::string>> texts{};  ///< named strings (the recording's "muscle")
};

/// `<csv>.meta.json`: the whole file name plus a suffix, so `a.csv` and `a.txt` never share one.
std::filesystem::path csv_sidecar_path(const std::filesystem::path& csv);

/// The sidecar's text (what write_csv_sidecar writes). Throws std::invalid_argument if a value's or
/// text's name is empty or one of the fixed fields (format, file, rows, columns, notes), or given twice.
std::string csv_sidecar_json(const std::filesystem::path& csv, const CsvMeta& meta);

/// Writes `<csv>.meta.json` atomically (write_file_atomically: a reader sees the old sidecar or the
/// new one, never half). Throws std::runtime_error naming the file on failure.
void write_csv_sidecar(const std::filesystem::path& csv, const CsvMeta& meta);

/// Removes `<csv>.meta.json` if there is one. A writer calls it before it replaces the CSV, so a run
/// that stops between the two files leaves a CSV without a sidecar, never one with another's.
void remove_csv_sidecar(const std::filesystem::path& csv);

/// The sidecar of `csv` parsed, or nullopt when it has none (a CSV from before sidecars, or from
/// another program). Throws config::Error (file:line:column) if it is not JSON/YAML or its "format"
/// is not kCsvSidecarFormat.
std::optional<Document> read_csv_sidecar(const std::filesystem::path& csv);

/// `text` as a JSON string literal: quoted, with ", \ and control characters escaped (UTF-8 passes
/// through as it is).
std::string json_quoted(std::string_view text);

/// The unit of a column named with its unit as suffix ("angle_rad" -> "rad", "velocity_radps" ->
/// "rad/s", "tau_Nm" -> "N m"); empty when the name ends in no known unit ("finger_active").
std::string_view column_unit(std::string_view column);

}  // namespace peha::config
