#pragma once
/// \file
/// A per-cycle CSV log held in memory during a run: rows are reserved up front, so appending in the
/// control loop does not allocate; `write` puts it on disk afterwards (time first, units in names).

#include <filesystem>
#include <span>
#include <string>
#include <vector>

namespace peha::runtime {

/// Where a loop's per-cycle rows go: the in-memory CsvLog (simulation runs) or the real-time
/// AsyncCsvLog (a writer thread). `push_row` is called from the control loop: noexcept, no allocation.
class RowSink {
 public:
  virtual ~RowSink() = default;
  /// One row, values in column order. A full sink drops the row (and counts it, if it can).
  virtual void push_row(std::span<const double> row) noexcept = 0;
};

class CsvLog final : public RowSink {
 public:
  /// `columns`: names with units, e.g. "t_s", "angle_rad". Reserves `expected_rows` rows.
  CsvLog(std::vector<std::string> columns, std::size_t expected_rows);
  std::size_t column_count() const { return columns_.size(); }
  /// Starts a row; call `set` for its values. Returns false (and drops the row) once full.
  bool begin_row() noexcept;
  void set(std::size_t column, double value) noexcept { values_[row_offset_ + column] = value; }
  /// begin_row + set of every column (extra values are ignored, missing ones left 0).
  void push_row(std::span<const double> row) noexcept override;
  std::size_t rows() const { return rows_; }
  /// Forgets every row (the capacity stays): the log can record the next run.
  void clear() noexcept { rows_ = 0; row_offset_ = 0; }
  double at(std::size_t row, std::size_t column) const { return values_[row * columns_.size() + column]; }
  std::size_t column(const std::string& name) const;  ///< index by name; throws if absent
  /// Writes the header, as the first line, and all rows; then `comments` (case, config, seed, units
  /// notes), the columns with their units and the row count to the sidecar `<path>.meta.json`
  /// (config/csv_sidecar.hpp), so the CSV opens unmodified in numpy, pandas and PlotJuggler. Throws
  /// on I/O failure.
  void write(const std::filesystem::path& path, const std::vector<std::string>& comments) const;

 private:
  std::vector<std::string> columns_;
  std::vector<double> values_;
  std::size_t capacity_rows_;
  std::size_t rows_ = 0;
  std::size_t row_offset_ = 0;
};

/// Longest text format_log_value writes (a double's shortest round-trip form is at most 24 characters).
inline constexpr std::size_t kMaxLogValueChars = 32;
/// Writes one value of a log row at `out` (at most kMaxLogValueChars) and returns the end: the first
/// column, the time stamp, in its shortest form that reads back to the same double (a replay feeds
/// the controller exactly the time it saw: a simulator's 0.8999999999999563 s is not 0.9 s at a
/// schedule's edge); every other column in 9 significant digits. noexcept, no allocation.
char* format_log_value(char* out, std::size_t column, double value) noexcept;

/// Reads the columns `names` of a log in this format (the column names, rows; CsvLog::write,
/// AsyncCsvLog; `# ` lines before the header, as logs had before the sidecar, are skipped), one
/// vector per name in that order; a name the file lacks gives an empty vector. Throws
/// std::runtime_error on a file it cannot open, one without a header or a cell that is not a number.
std::vector<std::vector<double>> read_csv_log_columns(const std::filesystem::path& path, const std::vector<std::string>& names);

}  // namespace peha::runtime
