#pragma once
/// \file
/// The per-cycle CSV log of a real-time run: the loop hands each row to a lock-free ring
/// (`push`, never blocks, never allocates) and a non-real-time writer thread turns the rows into
/// CSV on disk with buffered I/O, so a slow disk can never stall the loop. The file has the format
/// of `CsvLog::write` (csv_log.hpp): the column names first, then one line per row, values as
/// `{:.9g}`, time first; the comments go to the sidecar `<path>.meta.json` (config/csv_sidecar.hpp),
/// written when the log opens and again, with the row count, when it closes.
///
/// Fault window. The writer also keeps the last `fault_window_rows` rows it wrote in a preallocated
/// ring (writer side: `push` stays a single copy into the queue, and the window needs no locking).
/// `request_fault_dump` (from the loop, noexcept, no allocation) only queues a small request that
/// records how many rows had been pushed; the writer serves it after writing exactly those rows and
/// before any row pushed later, so the dump holds the last N rows before the request, in order.
/// Rows dropped by a full queue (counted in `dropped_rows`) are missing from both files.
///
/// Threads: `push` and `request_fault_dump` from one producer thread (the loop); everything else
/// from the thread that owns the log.

#include "peha/runtime/drain_thread.hpp"
#include "peha/runtime/spsc_ring.hpp"

#include <atomic>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <vector>

namespace peha::runtime {

class AsyncCsvLog {
 public:
  /// Width of a row slot: the upper body's E3 on the board logs 172 columns (8 io joints of 21, every
  /// sensor a replay reads among them); 4096 slots of 192 doubles are 6.3 MB.
  static constexpr std::size_t kMaxColumns = 192;
  static constexpr std::size_t kMaxReasonChars = 127;  ///< longer fault reasons are truncated

  /// Opens `path` (throws std::runtime_error if it cannot), writes the column names, `comments` to
  /// the sidecar `<path>.meta.json`, and starts the writer thread. `columns`: names with units, 1..kMaxColumns, the
  /// first being the time in seconds (its name ends in "_s", e.g. "t_s"); throws
  /// std::invalid_argument otherwise. `capacity_rows` (rounded up to a power of two) is the queue
  /// between loop and writer: at 1 kHz, 4096 rows ride out a 4 s disk stall. `fault_window_rows`
  /// (>= 1) is the length of a fault dump: 5000 rows = the last 5 s at 1 kHz.
  AsyncCsvLog(std::filesystem::path path, std::vector<std::string> columns, std::vector<std::string> comments,
              std::size_t capacity_rows = 4096, std::size_t fault_window_rows = 5000);
  /// Closes (see `close`); an I/O error found then is logged with spdlog::error, not thrown.
  ~AsyncCsvLog();
  AsyncCsvLog(const AsyncCsvLog&) = delete;
  AsyncCsvLog& operator=(const AsyncCsvLog&) = delete;

  /// Loop thread. Queues one row (`row.size()` must equal the column count; `row[0]` is the time).
  /// Never blocks: returns false and counts the row in `dropped_rows` if the queue is full or the
  /// log is closed, or in `malformed_rows` if its width is wrong.
  bool push(std::span<const double> row) noexcept;

  /// Loop thread. Asks the writer to write the last `fault_window_rows` rows pushed so far to
  /// `<dir>/<stem>_fault_<t>s.csv` next to the log (t = time of the last row pushed, 3 decimals;
  /// `_2`, `_3`... appended if taken), with `reason` (copied, truncated to kMaxReasonChars) in the
  /// notes of its sidecar. Returns false if too many requests are pending (8; counted in dropped_fault_requests).
  bool request_fault_dump(const char* reason) noexcept;

  /// Waits until everything pushed and requested before the call is on disk (fflush, no fsync).
  /// Returns false on timeout (e.g. while the writer is paused).
  bool flush(std::chrono::milliseconds timeout = std::chrono::seconds(10));

  /// Writes everything still queued (rows and fault dumps), flushes, closes the file, joins the
  /// writer and rewrites the sidecar with the rows written. Idempotent. Throws std::runtime_error
  /// if any write failed during the run.
  void close();

  const std::filesystem::path& path() const noexcept { return path_; }
  std::size_t column_count() const noexcept { return columns_.size(); }
  std::size_t capacity_rows() const noexcept { return ring_.capacity(); }
  std::uint64_t pushed_rows() const noexcept { return pushed_.load(std::memory_order_relaxed); }   ///< well-formed push calls
  std::uint64_t dropped_rows() const noexcept { return dropped_.load(std::memory_order_relaxed); } ///< of those, queue full
  std::uint64_t malformed_rows() const noexcept { return malformed_.load(std::memory_order_relaxed); }
  std::uint64_t written_rows() const noexcept { return written_.load(std::memory_order_relaxed); } ///< = pushed - dropped once flushed
  std::uint64_t dropped_fault_requests() const noexcept { return dropped_requests_.load(std::memory_order_relaxed); }
  /// Fault dumps written so far, oldest first.
  std::vector<std::filesystem::path> fault_dumps() const;

  /// Test hook (simulates a stalled disk): while paused the writer drains nothing. Returns once the
  /// writer has acknowledged the pause. `close` and the destructor resume it.
  void set_writer_paused_for_test(bool paused);

 private:
  struct Row {
    std::uint64_t seq;  ///< index among well-formed pushes (dropped rows leave gaps)
    double values[kMaxColumns];
  };
  struct FaultRequest {
    std::uint64_t row_end;  ///< rows pushed before the request: the dump ends just before this seq
    double t_s;             ///< time of the last of them
    char reason[kMaxReasonChars + 1];
  };

  bool writer_step() noexcept;
  void writer_idle(bool flush) noexcept;
  void writer_finish() noexcept;
  void write_row(const double* values) noexcept;
  void write_fault_dump(const FaultRequest& request) noexcept;
  void record_error(std::string message) noexcept;

  std::filesystem::path path_;
  std::vector<std::string> columns_;
  std::vector<std::string> comments_;
  struct FileCloser {
    void operator()(std::FILE* f) const noexcept { std::fclose(f); }
  };
  std::vector<char> file_buffer_;  ///< stdio buffer of file_
  std::unique_ptr<std::FILE, FileCloser> file_;

  SpscRing<Row> ring_;
  SpscRing<FaultRequest> requests_;

  // Loop side (written only by the producer; atomics so other threads may read them).
  std::atomic<std::uint64_t> pushed_{0}, dropped_{0}, malformed_{0}, dropped_requests_{0};
  std::atomic<bool> closing_{false};
  double last_t_s_ = 0;

  // Writer side.
  Row held_row_{};                     ///< popped, not yet written (a fault dump goes first)
  FaultRequest held_request_{};
  bool have_row_ = false, have_request_ = false;
  std::vector<double> window_;         ///< fault window: window_rows_ x column_count, circular
  std::size_t window_rows_;
  std::size_t window_next_ = 0;        ///< slot of the next row
  std::size_t window_filled_ = 0;
  std::vector<char> line_;             ///< one formatted row
  std::chrono::steady_clock::time_point last_flush_{};
  std::atomic<std::uint64_t> written_{0};

  mutable std::mutex mutex_;
  std::vector<std::filesystem::path> dumps_;  ///< guarded by mutex_
  std::string error_;                         ///< first I/O error, guarded by mutex_
  bool error_thrown_ = false;                 ///< close() threw it already; guarded by mutex_
  bool sidecar_final_ = false;                ///< close() wrote the sidecar with the row count; guarded by mutex_
  DrainThread writer_;                        ///< last: started after, stopped before, everything above
};

}  // namespace peha::runtime
