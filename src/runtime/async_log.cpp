#include "peha/runtime/async_log.hpp"

#include "peha/config/csv_sidecar.hpp"
#include "peha/runtime/csv_log.hpp"

#include <fmt/compile.h>
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <bit>
#include <cerrno>
#include <cstring>
#include <stdexcept>

namespace peha::runtime {
namespace {

constexpr std::size_t kFileBufferBytes = 1 << 20;
constexpr std::size_t kPendingFaultRequests = 8;
constexpr auto kIdleFlushInterval = std::chrono::milliseconds(250);

void check_columns(const std::vector<std::string>& columns) {
  if (columns.empty() || columns.size() > AsyncCsvLog::kMaxColumns) {
    throw std::invalid_argument(fmt::format("AsyncCsvLog: expected 1..{} columns, got {}", AsyncCsvLog::kMaxColumns,
                                            columns.size()));
  }
  const std::string& t = columns.front();
  if (t.size() < 3 || t.compare(t.size() - 2, 2, "_s") != 0) {
    throw std::invalid_argument(
        fmt::format("AsyncCsvLog: the first column must be the time in seconds (e.g. 't_s'), got '{}'", t));
  }
  for (const std::string& c : columns) {
    if (c.empty() || c.find_first_of(",\n\r\"") != std::string::npos) {
      throw std::invalid_argument(fmt::format("AsyncCsvLog: column name '{}' is empty or holds , \" or a newline", c));
    }
  }
}

std::size_t format_row(const double* values, std::size_t n, char* out) noexcept {
  char* p = out;
  for (std::size_t c = 0; c < n; ++c) {
    if (c) *p++ = ',';
    p = format_log_value(p, c, values[c]);
  }
  *p++ = '\n';
  return static_cast<std::size_t>(p - out);
}

std::string header_text(const std::vector<std::string>& columns) { return fmt::format("{}\n", fmt::join(columns, ",")); }

std::size_t checked_window(std::size_t rows) {
  if (rows == 0) throw std::invalid_argument("AsyncCsvLog: fault_window_rows must be >= 1");
  return rows;
}

// Opens `path` for writing with `buffer` as its stdio buffer and writes the header; the sidecar
// (comments, columns; no row count until close) goes beside it at once, so a run that dies still
// leaves its log described.
std::FILE* open_with_header(const std::filesystem::path& path, const std::vector<std::string>& columns,
                            const std::vector<std::string>& comments, std::vector<char>& buffer) {
  config::remove_csv_sidecar(path);
  const std::string header = header_text(columns);
  std::FILE* f = std::fopen(path.c_str(), "w");
  if (!f) throw std::runtime_error(fmt::format("{}: cannot write log: {}", path.string(), std::strerror(errno)));
  std::setvbuf(f, buffer.data(), _IOFBF, buffer.size());
  if (std::fwrite(header.data(), 1, header.size(), f) != header.size()) {
    std::fclose(f);
    throw std::runtime_error(fmt::format("{}: write failed: {}", path.string(), std::strerror(errno)));
  }
  try {
    config::write_csv_sidecar(path, {columns, std::nullopt, comments, {}});
  } catch (...) {
    std::fclose(f);
    throw;
  }
  return f;
}

}  // namespace

// Everything the writer touches is built in the initialiser list, before the writer (last) starts.
AsyncCsvLog::AsyncCsvLog(std::filesystem::path path, std::vector<std::string> columns,
                         std::vector<std::string> comments, std::size_t capacity_rows, std::size_t fault_window_rows)
    : path_(std::move(path)),
      columns_((check_columns(columns), std::move(columns))),
      comments_(std::move(comments)),
      file_buffer_(kFileBufferBytes),
      file_(open_with_header(path_, columns_, comments_, file_buffer_)),
      ring_(std::bit_ceil(std::max<std::size_t>(capacity_rows, 1))),
      requests_(kPendingFaultRequests),
      window_(checked_window(fault_window_rows) * columns_.size()),
      window_rows_(fault_window_rows),
      line_(columns_.size() * (kMaxLogValueChars + 1) + 1),
      last_flush_(std::chrono::steady_clock::now()),
      writer_("peha-log", {[this] { return writer_step(); }, [this](bool flush) { writer_idle(flush); },
                           [this] { writer_finish(); }}) {}

AsyncCsvLog::~AsyncCsvLog() {
  try {
    close();
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
  }
}

bool AsyncCsvLog::push(std::span<const double> row) noexcept {
  if (row.size() != columns_.size()) {
    malformed_.store(malformed_.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
    return false;
  }
  // Only this thread writes the loop-side counters: a plain load + store, no locked instruction.
  const std::uint64_t seq = pushed_.load(std::memory_order_relaxed);
  pushed_.store(seq + 1, std::memory_order_relaxed);
  last_t_s_ = row[0];
  const bool queued = !closing_.load(std::memory_order_relaxed) && ring_.try_push_with([&](Row& slot) noexcept {
    slot.seq = seq;
    std::copy(row.begin(), row.end(), slot.values);
  });
  if (!queued) dropped_.store(dropped_.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
  return queued;
}

bool AsyncCsvLog::request_fault_dump(const char* reason) noexcept {
  const bool queued = requests_.try_push_with([&](FaultRequest& r) noexcept {
    r.row_end = pushed_.load(std::memory_order_relaxed);
    r.t_s = last_t_s_;
    const std::size_t n = reason ? strnlen(reason, kMaxReasonChars) : 0;
    if (n) std::memcpy(r.reason, reason, n);
    r.reason[n] = '\0';
  });
  if (!queued) dropped_requests_.store(dropped_requests_.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
  return queued;
}

void AsyncCsvLog::write_row(const double* values) noexcept {
  const std::size_t n = format_row(values, columns_.size(), line_.data());
  if (std::fwrite(line_.data(), 1, n, file_.get()) != n) {
    record_error(fmt::format("{}: write failed: {}", path_.string(), std::strerror(errno)));
  }
  std::copy(values, values + columns_.size(), window_.begin() + static_cast<std::ptrdiff_t>(window_next_ * columns_.size()));
  window_next_ = (window_next_ + 1) % window_rows_;
  window_filled_ = std::min(window_filled_ + 1, window_rows_);
  written_.store(written_.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
}

void AsyncCsvLog::write_fault_dump(const FaultRequest& request) noexcept {
  try {
    const std::filesystem::path dir = path_.parent_path();
    const std::string base = fmt::format("{}_fault_{:.3f}s", path_.stem().string(), request.t_s);
    std::filesystem::path dump = dir / (base + ".csv");
    for (int k = 2; std::filesystem::exists(dump); ++k) dump = dir / fmt::format("{}_{}.csv", base, k);

    std::vector<std::string> comments = {
        fmt::format("fault dump of {}: the last {} rows before the request", path_.filename().string(), window_filled_),
        fmt::format("reason: {}", request.reason),
        fmt::format("requested after {} rows (t = {:.6f} s); window {} rows; rows dropped by a full queue are missing",
                    request.row_end, request.t_s, window_rows_)};
    comments.insert(comments.end(), comments_.begin(), comments_.end());
    std::FILE* out = std::fopen(dump.c_str(), "w");
    if (!out) throw std::runtime_error(fmt::format("{}: cannot write fault dump: {}", dump.string(), std::strerror(errno)));
    const std::string header = header_text(columns_);
    bool ok = std::fwrite(header.data(), 1, header.size(), out) == header.size();
    const std::size_t first = (window_next_ + window_rows_ - window_filled_) % window_rows_;
    for (std::size_t k = 0; k < window_filled_; ++k) {
      const double* values = window_.data() + ((first + k) % window_rows_) * columns_.size();
      const std::size_t n = format_row(values, columns_.size(), line_.data());
      ok = ok && std::fwrite(line_.data(), 1, n, out) == n;
    }
    ok = std::fclose(out) == 0 && ok;
    if (!ok) throw std::runtime_error(fmt::format("{}: fault dump write failed", dump.string()));
    config::write_csv_sidecar(dump, {columns_, window_filled_, comments, {}});
    std::fflush(file_.get());  // the main log up to the fault is on disk too
    spdlog::warn("fault dump written: {} ({} rows; reason: {})", dump.string(), window_filled_, request.reason);
    std::lock_guard lock(mutex_);
    dumps_.push_back(dump);
  } catch (const std::exception& e) {
    record_error(e.what());
  }
}

void AsyncCsvLog::record_error(std::string message) noexcept {
  std::lock_guard lock(mutex_);
  if (!error_.empty()) return;  // the first error says what went wrong; the rest follow from it
  spdlog::error("AsyncCsvLog: {}", message);
  error_ = std::move(message);
}

bool AsyncCsvLog::writer_step() noexcept {
  // The request is popped before the next row, so every row pushed before it is either still in
  // the ring or written: it is served before the first row pushed after it, never later.
  if (!have_request_) have_request_ = requests_.try_pop(held_request_);
  if (!have_row_) have_row_ = ring_.try_pop(held_row_);
  if (have_request_ && (!have_row_ || held_row_.seq >= held_request_.row_end)) {
    write_fault_dump(held_request_);
    have_request_ = false;
    return true;
  }
  if (!have_row_) return false;
  write_row(held_row_.values);
  have_row_ = false;
  return true;
}

void AsyncCsvLog::writer_idle(bool flush) noexcept {
  const auto now = std::chrono::steady_clock::now();
  if (!flush && now - last_flush_ < kIdleFlushInterval) return;
  if (std::fflush(file_.get()) != 0) record_error(fmt::format("{}: write failed: {}", path_.string(), std::strerror(errno)));
  last_flush_ = now;
}

void AsyncCsvLog::writer_finish() noexcept {
  const bool flushed = std::fflush(file_.get()) == 0;
  const bool closed = std::fclose(file_.release()) == 0;
  if (!flushed || !closed) record_error(fmt::format("{}: final write failed: {}", path_.string(), std::strerror(errno)));
}

bool AsyncCsvLog::flush(std::chrono::milliseconds timeout) { return writer_.flush(timeout); }

void AsyncCsvLog::set_writer_paused_for_test(bool paused) { writer_.set_paused(paused); }

std::vector<std::filesystem::path> AsyncCsvLog::fault_dumps() const {
  std::lock_guard lock(mutex_);
  return dumps_;
}

void AsyncCsvLog::close() {
  closing_.store(true, std::memory_order_relaxed);
  writer_.stop();
  std::lock_guard lock(mutex_);
  if (!sidecar_final_) {
    sidecar_final_ = true;
    // The row count says the writer finished: a sidecar without one belongs to a run that died.
    try {
      config::write_csv_sidecar(path_, {columns_, written_.load(std::memory_order_relaxed), comments_, {}});
    } catch (const std::exception& e) {
      if (error_.empty()) error_ = e.what();
    }
  }
  if (error_.empty() || error_thrown_) return;
  error_thrown_ = true;
  throw std::runtime_error(error_);
}

}  // namespace peha::runtime
