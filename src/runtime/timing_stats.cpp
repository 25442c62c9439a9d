#include "peha/runtime/timing_stats.hpp"
#include "peha/io/backend.hpp"

#include "peha/config/csv_sidecar.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <stdexcept>

namespace peha::runtime {
namespace {

using io::kNaN;
constexpr double kInf = std::numeric_limits<double>::infinity();

std::ofstream open_for_writing(const std::filesystem::path& path) {
  config::remove_csv_sidecar(path);
  std::ofstream out(path);
  if (!out) throw std::runtime_error(fmt::format("{}: cannot write timing statistics", path.string()));
  return out;
}

void check_written(std::ofstream& out, const std::filesystem::path& path) {
  out.close();
  if (!out) throw std::runtime_error(fmt::format("{}: write failed", path.string()));
}

double as_double(std::uint64_t n) { return static_cast<double>(n); }

}  // namespace

Histogram::Histogram(double lo_s, double hi_s, int bins_per_decade)
    : lo_s_(lo_s), hi_s_(hi_s), bins_per_decade_(bins_per_decade) {
  if (!(lo_s > 0) || !(hi_s > lo_s) || !std::isfinite(hi_s) || bins_per_decade < 1) {
    throw std::invalid_argument(fmt::format(
        "Histogram: expected 0 < lo_s < hi_s (finite) and bins_per_decade >= 1, got {}, {}, {}", lo_s, hi_s,
        bins_per_decade));
  }
  log_bins_ = static_cast<std::size_t>(std::ceil(std::log10(hi_s / lo_s) * bins_per_decade_ - 1e-9));
  counts_.assign(log_bins_ + 2, 0);
}

void Histogram::add(double seconds) noexcept {
  if (std::isnan(seconds)) return;
  std::size_t bin;
  if (seconds < lo_s_) {
    bin = 0;
  } else if (seconds >= hi_s_) {
    bin = log_bins_ + 1;
  } else {
    const double position = std::log10(seconds / lo_s_) * bins_per_decade_;
    bin = 1 + std::min(static_cast<std::size_t>(position), log_bins_ - 1);
  }
  ++counts_[bin];
  if (count_ == 0) {
    min_ = max_ = seconds;
  } else {
    min_ = std::min(min_, seconds);
    max_ = std::max(max_, seconds);
  }
  ++count_;
  sum_ += seconds;
}

void Histogram::clear() noexcept {
  std::fill(counts_.begin(), counts_.end(), 0);
  count_ = 0;
  sum_ = min_ = max_ = 0;
}

double Histogram::min() const noexcept { return count_ ? min_ : kNaN; }
double Histogram::max() const noexcept { return count_ ? max_ : kNaN; }
double Histogram::mean() const noexcept { return count_ ? sum_ / static_cast<double>(count_) : kNaN; }

double Histogram::lower_s(std::size_t i) const noexcept {
  if (i == 0) return 0.0;
  return lo_s_ * std::pow(10.0, static_cast<double>(i - 1) / bins_per_decade_);
}

double Histogram::upper_s(std::size_t i) const noexcept {
  if (i == counts_.size() - 1) return kInf;
  if (i == counts_.size() - 2) return hi_s_;  // the last log bin may be narrower than the others
  return lo_s_ * std::pow(10.0, static_cast<double>(i) / bins_per_decade_);
}

double Histogram::percentile(double p) const noexcept {
  if (count_ == 0 || std::isnan(p)) return kNaN;
  const double rank = std::clamp(p, 0.0, 100.0) / 100.0 * static_cast<double>(count_);
  double below = 0;  // samples in the bins before i
  std::size_t i = 0;
  for (; i + 1 < counts_.size(); ++i) {
    if (counts_[i] > 0 && below + static_cast<double>(counts_[i]) >= rank) break;
    below += static_cast<double>(counts_[i]);
  }
  const double fraction = counts_[i] ? std::clamp((rank - below) / static_cast<double>(counts_[i]), 0.0, 1.0) : 1.0;
  // The data's own extremes bound the bin: exact answers at p = 0 and p = 100.
  const double a = std::max(lower_s(i), min_);
  const double b = std::min(upper_s(i), max_);
  double value;
  if (i == 0 || i == counts_.size() - 1 || a <= 0) {
    value = a + fraction * (b - a);
  } else {
    value = a * std::pow(b / a, fraction);
  }
  return std::clamp(value, min_, max_);
}

void Histogram::write_csv(const std::filesystem::path& path) const {
  std::ofstream out = open_for_writing(path);
  out << "lower_s,upper_s,count\n";
  for (std::size_t i = 0; i < counts_.size(); ++i) {
    out << fmt::format("{:.9g},{:.9g},{}\n", lower_s(i), upper_s(i), counts_[i]);
  }
  check_written(out, path);
  config::write_csv_sidecar(path, {{"lower_s", "upper_s", "count"},
                                   counts_.size(),
                                   {"one row per bin [lower_s, upper_s): underflow first, overflow last"},
                                   {{"count", as_double(count_)}, {"min_s", min()}, {"mean_s", mean()}, {"max_s", max()}}});
}

std::string LoopTiming::table() const {
  const auto us = [](double s) { return std::isnan(s) ? std::string("-") : fmt::format("{:.1f}", s * 1e6); };
  std::string out = fmt::format("{:<10} {:>10} {:>10} {:>10} {:>10} {:>10} {:>10}\n", "[us]", "count", "median",
                                "p99", "p99.9", "max", "mean");
  const std::pair<const char*, const Histogram*> rows[] = {{"period", &period}, {"wake", &wake}, {"compute", &compute}, {"rtt", &rtt}};
  for (const auto& [name, h] : rows) {
    if (h == &wake && wake.count() == 0) continue;
    out += fmt::format("{:<10} {:>10} {:>10} {:>10} {:>10} {:>10} {:>10}\n", name, h->count(), us(h->percentile(50)),
                       us(h->percentile(99)), us(h->percentile(99.9)), us(h->max()), us(h->mean()));
  }
  const double deadlines = static_cast<double>(cycles + deadline_misses);
  out += fmt::format("cycles {}, overruns {}, deadline misses {} (miss rate {:.4f} %), lost packets {}\n", cycles,
                     overruns, deadline_misses, deadlines > 0 ? 100.0 * static_cast<double>(deadline_misses) / deadlines : 0.0,
                     lost_packets);
  return out;
}

void LoopTiming::write_csv(const std::filesystem::path& dir) const {
  std::filesystem::create_directories(dir);
  const std::filesystem::path summary = dir / "timing_summary.csv";
  std::ofstream out = open_for_writing(summary);
  const std::vector<std::string> columns = {"name", "count", "min_s", "mean_s", "p50_s", "p99_s", "p99_9_s", "max_s"};
  out << fmt::format("{}\n", fmt::join(columns, ","));
  const std::pair<const char*, const Histogram*> rows[] = {{"period", &period}, {"wake", &wake}, {"compute", &compute}, {"rtt", &rtt}};
  for (const auto& [name, h] : rows) {
    out << fmt::format("{},{},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g}\n", name, h->count(), h->min(), h->mean(),
                       h->percentile(50), h->percentile(99), h->percentile(99.9), h->max());
    h->write_csv(dir / fmt::format("timing_{}_hist.csv", name));
  }
  check_written(out, summary);
  config::write_csv_sidecar(summary, {columns,
                                      std::size(rows),
                                      {"one row per histogram (timing_<name>_hist.csv); the loop's counters are the values"},
                                      {{"cycles", as_double(cycles)},
                                       {"overruns", as_double(overruns)},
                                       {"deadline_misses", as_double(deadline_misses)},
                                       {"lost_packets", as_double(lost_packets)}}});
  const std::filesystem::path events = dir / "timing_overruns.csv";
  std::ofstream ev = open_for_writing(events);
  const std::vector<std::string> event_columns = {"t_s", "skipped", "wake_late_s", "work_s", "rtt_s"};
  ev << fmt::format("{}\n", fmt::join(event_columns, ","));
  for (const OverrunEvent& e : overrun_events) {
    ev << fmt::format("{:.6f},{},{:.9g},{:.9g},{:.9g}\n", e.t_s, e.skipped, e.wake_late_s, e.work_s, e.rtt_s);
  }
  check_written(ev, events);
  config::write_csv_sidecar(events, {event_columns,
                                     overrun_events.size(),
                                     {"one row per overrun listed (the capacity reserved before the loop); overruns counts them all, "
                                      "max_burst is the most deadlines one of them skipped"},
                                     {{"overruns", as_double(overruns)}, {"max_burst", as_double(max_burst)}}});
}

std::string LoopTiming::burst_summary(double period_s) const {
  std::uint64_t multi = 0, late_wake = 0, in_multi = 0;
  for (const OverrunEvent& e : overrun_events) {
    if (e.skipped > 1) ++multi, in_multi += e.skipped;
    if (e.wake_late_s >= period_s) ++late_wake;
  }
  return fmt::format("overruns {} (listed {}): max burst {} deadlines; {} overruns skipped > 1 deadline ({} of the {} misses); "
                     "{} began with a wake-up >= 1 period late, {} with long work; loop thread: {} minor / {} major page faults, "
                     "{} involuntary context switches",
                     overruns, overrun_events.size(), max_burst, multi, in_multi, deadline_misses, late_wake,
                     overrun_events.size() - late_wake, minor_faults, major_faults, involuntary_switches);
}

}  // namespace peha::runtime
