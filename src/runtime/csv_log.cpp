#include "peha/runtime/csv_log.hpp"

#include "peha/config/csv_sidecar.hpp"
#include "peha/config/input_file.hpp"

#include <fmt/compile.h>
#include <fmt/format.h>

#include <algorithm>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace peha::runtime {

CsvLog::CsvLog(std::vector<std::string> columns, std::size_t expected_rows)
    : columns_(std::move(columns)), values_(columns_.size() * expected_rows, 0.0), capacity_rows_(expected_rows) {}

bool CsvLog::begin_row() noexcept {
  if (rows_ >= capacity_rows_) return false;
  row_offset_ = rows_ * columns_.size();
  ++rows_;
  return true;
}

void CsvLog::push_row(std::span<const double> row) noexcept {
  if (!begin_row()) return;
  const std::size_t n = std::min(row.size(), columns_.size());
  for (std::size_t i = 0; i < n; ++i) values_[row_offset_ + i] = row[i];
}

std::size_t CsvLog::column(const std::string& name) const {
  for (std::size_t i = 0; i < columns_.size(); ++i) {
    if (columns_[i] == name) return i;
  }
  throw std::out_of_range(fmt::format("log has no column '{}'", name));
}

char* format_log_value(char* out, std::size_t column, double value) noexcept {
  return column == 0 ? fmt::format_to(out, FMT_COMPILE("{}"), value) : fmt::format_to(out, FMT_COMPILE("{:.9g}"), value);
}

void CsvLog::write(const std::filesystem::path& path, const std::vector<std::string>& comments) const {
  config::remove_csv_sidecar(path);
  std::ofstream out(path);
  if (!out) throw std::runtime_error(fmt::format("{}: cannot write log", path.string()));
  out << fmt::format("{}\n", fmt::join(columns_, ","));
  std::string line;
  for (std::size_t r = 0; r < rows_; ++r) {
    line.clear();
    for (std::size_t c = 0; c < columns_.size(); ++c) {
      if (c) line += ',';
      char text[kMaxLogValueChars];
      line.append(text, format_log_value(text, c, values_[r * columns_.size() + c]));
    }
    out << line << '\n';
  }
  out.close();
  if (!out) throw std::runtime_error(fmt::format("{}: write failed", path.string()));
  config::write_csv_sidecar(path, {columns_, rows_, comments, {}});
}

std::vector<std::vector<double>> read_csv_log_columns(const std::filesystem::path& path, const std::vector<std::string>& names) {
  std::istringstream in(config::read_input_file(path, config::InputKind::kLog));
  std::string line;
  std::size_t line_no = 0;
  bool have_header = false;
  // Logs written before the sidecar began with `# ` lines: skipped, so old logs replay too.
  while (std::getline(in, line)) {
    ++line_no;
    if (line.rfind('#', 0) != 0) {
      have_header = true;
      break;
    }
  }
  if (!have_header) throw std::runtime_error(fmt::format("{}: no header row (expected the column names, e.g. t_s,...)", path.string()));
  std::vector<std::string> header;
  {
    std::stringstream ss(line);
    std::string cell;
    while (std::getline(ss, cell, ',')) header.push_back(cell);
  }
  std::vector<std::ptrdiff_t> index;
  for (const std::string& n : names) {
    const auto it = std::find(header.begin(), header.end(), n);
    index.push_back(it == header.end() ? -1 : it - header.begin());
  }
  std::vector<std::vector<double>> out(names.size());
  while (std::getline(in, line)) {
    ++line_no;
    std::stringstream ss(line);
    std::string cell;
    for (std::ptrdiff_t i = 0; std::getline(ss, cell, ','); ++i) {
      for (std::size_t c = 0; c < names.size(); ++c) {
        if (index[c] != i) continue;
        char* end = nullptr;
        const double v = std::strtod(cell.c_str(), &end);
        if (end == cell.c_str()) throw std::runtime_error(fmt::format("{}:{}: column {}: expected a number, found '{}'", path.string(), line_no, names[c], cell));
        out[c].push_back(v);
      }
    }
  }
  return out;
}

}  // namespace peha::runtime
