#pragma once
/// \file
/// Loop timing statistics without allocation in the loop: a histogram with fixed log-spaced bins
/// (preallocated), and the loop's set of them (period, compute time, round-trip time) plus counters.

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace peha::runtime {

/// Durations in seconds, binned on a log scale from `lo_s` to `hi_s` with `bins_per_decade` bins
/// per decade, plus an underflow bin [.., lo_s) and an overflow bin [hi_s, ..). Count, min, max and
/// mean are exact; percentiles are interpolated geometrically inside the bin that holds them, so
/// their resolution is one bin: a relative error below 10^(1/bins_per_decade) - 1 (2.3 % with the
/// default 100 bins per decade), usually far less. Percentiles are clamped to [min, max] and inside
/// the under/overflow bins interpolated linearly between min (max) and the range's end.
class Histogram {
 public:
  /// Defaults: 1 us .. 1 s, 100 bins per decade (602 bins, 4.8 KiB). Throws std::invalid_argument for
  /// 0 < lo_s < hi_s violated or bins_per_decade < 1.
  explicit Histogram(double lo_s = 1e-6, double hi_s = 1.0, int bins_per_decade = 100);

  /// Adds one duration. NaN is ignored; negative values count as underflow.
  void add(double seconds) noexcept;
  void clear() noexcept;

  std::uint64_t count() const noexcept { return count_; }
  double min() const noexcept;   ///< NaN when empty
  double max() const noexcept;   ///< NaN when empty
  double mean() const noexcept;  ///< NaN when empty
  /// `p` in percent, 0..100 (clamped). NaN when empty.
  double percentile(double p) const noexcept;

  /// Bins, underflow first and overflow last: [lower_s(i), upper_s(i)) holds bin_count(i) samples.
  std::size_t bin_count() const noexcept { return counts_.size(); }
  std::uint64_t bin_count(std::size_t i) const noexcept { return counts_[i]; }
  double lower_s(std::size_t i) const noexcept;  ///< 0 for the underflow bin
  double upper_s(std::size_t i) const noexcept;  ///< +inf for the overflow bin

  /// Writes `lower_s,upper_s,count`, one line per bin (all bins), the header first; count, min_s,
  /// mean_s and max_s go to the sidecar `<path>.meta.json`. Throws std::runtime_error on I/O failure.
  void write_csv(const std::filesystem::path& path) const;

 private:
  double lo_s_, hi_s_;
  double bins_per_decade_;
  std::size_t log_bins_;
  std::vector<std::uint64_t> counts_;  ///< underflow, log_bins_ bins, overflow
  std::uint64_t count_ = 0;
  double sum_ = 0, min_ = 0, max_ = 0;
};

/// Everything the loop measures about its own timing. The runner fills it each cycle:
/// `period` = time between successive wake-ups, `compute` = wake-up to end of the cycle's work,
/// `rtt` = command sent to matching sensor packet received (hardware backends only); the counters
/// come from PeriodicClock (overruns, missed deadlines) and the backend (lost packets).
/// One overrun of the loop: the cycle that woke `wake_late_s` after its deadline (at `t_s` since
/// the start) and ended `work_s` later, past the next deadline, so that `skipped` deadlines saw no
/// cycle; `rtt_s` is the round trip of the last sample received by then (NaN without one).
/// wake_late_s >= period: the thread itself did not run (kernel, hypervisor); else the cycle's work
/// (waiting for the board's reply, compute) pushed it over.
struct OverrunEvent {
  double t_s = 0;
  std::uint64_t skipped = 0;
  double wake_late_s = 0;
  double work_s = 0;
  double rtt_s = 0;
};

struct LoopTiming {
  Histogram period, compute, rtt;
  /// How late each wake-up came after its deadline (the timer's and the scheduler's latency).
  Histogram wake;
  /// The overruns in order, up to the capacity reserved before the loop (the loop never allocates:
  /// further ones are counted in `overruns` only).
  std::vector<OverrunEvent> overrun_events;
  std::uint64_t max_burst = 0;        ///< most deadlines one overrun skipped
  /// The loop thread's own counters over the loop, its first cycle to its last (getrusage(
  /// RUSAGE_THREAD) deltas): page faults (minor: no disk; major: read from disk) and involuntary
  /// context switches (preempted).
  std::uint64_t minor_faults = 0, major_faults = 0, involuntary_switches = 0;
  std::uint64_t cycles = 0;           ///< cycles run
  std::uint64_t overruns = 0;         ///< cycles whose work ran past the next deadline
  std::uint64_t deadline_misses = 0;  ///< deadlines skipped because of overruns
  std::uint64_t lost_packets = 0;     ///< sensor packets that never arrived

  /// Multi-line table: count, median, p99, p99.9, max, mean per histogram in us, then the counters
  /// and the miss rate (missed / (cycles + missed): the share of deadlines that saw no cycle).
  std::string table() const;
  /// One line on the misses' structure: overruns, how many deadlines the largest skipped, how many
  /// skipped more than one, and how many began with a late wake-up (>= one period) vs long work.
  std::string burst_summary(double period_s) const;
  /// Writes timing_summary.csv (one row per histogram; the counters in its sidecar
  /// timing_summary.csv.meta.json), timing_overruns.csv and timing_<name>_hist.csv for each
  /// histogram into `dir` (created if missing), each with its sidecar.
  void write_csv(const std::filesystem::path& dir) const;
};

}  // namespace peha::runtime
