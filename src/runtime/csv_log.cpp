#include "peha/runtime/csv_log.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <fstream>
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

void CsvLog::write(const std::filesystem::path& path, const std::vector<std::string>& comments) const {
  std::ofstream out(path);
  if (!out) throw std::runtime_error(fmt::format("{}: cannot write log", path.string()));
  for (const auto& c : comments) out << "# " << c << '\n';
  out << fmt::format("{}\n", fmt::join(columns_, ","));
  std::string line;
  for (std::size_t r = 0; r < rows_; ++r) {
    line.clear();
    for (std::size_t c = 0; c < columns_.size(); ++c) {
      if (c) line += ',';
      line += fmt::format("{:.9g}", values_[r * columns_.size() + c]);
    }
    out << line << '\n';
  }
  if (!out) throw std::runtime_error(fmt::format("{}: write failed", path.string()));
}

}  // namespace peha::runtime
