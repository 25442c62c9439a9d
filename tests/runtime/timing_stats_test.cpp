#include "peha/runtime/timing_stats.hpp"

#include "peha/config/csv_sidecar.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <unistd.h>

namespace peha::runtime {
namespace {

std::filesystem::path fresh_timing_dir(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() / ("peha_timing_" + std::to_string(getpid()) + "_" + name);
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

// 100 000 samples spread evenly over 1..1000 us: each percentile lands inside the right bin, so it
// is within the stated resolution (one bin: 12.2 % at 20 bins per decade) of the exact value.
// Count, min, max and mean are exact.
TEST(Histogram, PercentilesOfAUniformSampleAreWithinOneBin) {
  Histogram h;
  constexpr int kN = 100000;
  for (int i = 0; i < kN; ++i) h.add(1e-6 + 999e-6 * i / (kN - 1));
  EXPECT_EQ(h.count(), static_cast<std::uint64_t>(kN));
  EXPECT_DOUBLE_EQ(h.min(), 1e-6);
  EXPECT_DOUBLE_EQ(h.max(), 1e-3);
  EXPECT_NEAR(h.mean(), 500.5e-6, 1e-12);
  const double resolution = std::pow(10.0, 1.0 / 20) - 1;
  for (double p : {10.0, 50.0, 90.0, 99.0, 99.9}) {
    const double exact = 1e-6 + 999e-6 * p / 100;
    EXPECT_NEAR(h.percentile(p), exact, resolution * exact) << "p" << p;
  }
  EXPECT_DOUBLE_EQ(h.percentile(0), 1e-6);
  EXPECT_DOUBLE_EQ(h.percentile(100), 1e-3);
}

// Far outside 1 us .. 1 s, values still count (under/overflow bins) and min/max stay exact, so
// the worst case of a run is never lost.
TEST(Histogram, KeepsOutOfRangeValuesInUnderAndOverflowBins) {
  Histogram h;
  h.add(5e-9);
  h.add(2e-4);
  h.add(3.0);
  h.add(std::nan(""));  // ignored
  EXPECT_EQ(h.count(), 3u);
  EXPECT_EQ(h.bin_count(0), 1u);
  EXPECT_EQ(h.bin_count(h.bin_count() - 1), 1u);
  EXPECT_DOUBLE_EQ(h.min(), 5e-9);
  EXPECT_DOUBLE_EQ(h.max(), 3.0);
  EXPECT_DOUBLE_EQ(h.percentile(100), 3.0);
  EXPECT_EQ(h.bin_count(), 602u);  // 6 decades x 100 bins + under- and overflow
  EXPECT_TRUE(std::isinf(h.upper_s(h.bin_count() - 1)));
}

TEST(Histogram, IsEmptyAfterClearAndReportsNaN) {
  Histogram h;
  h.add(1e-3);
  h.clear();
  EXPECT_EQ(h.count(), 0u);
  EXPECT_TRUE(std::isnan(h.percentile(50)));
  EXPECT_TRUE(std::isnan(h.mean()));
  EXPECT_THROW(Histogram(1e-3, 1e-6), std::invalid_argument);
}

// The bins are contiguous and the CSV's counts add up to the histogram's count.
TEST(Histogram, WritesEveryBinToCsv) {
  Histogram h;
  for (int i = 1; i <= 1000; ++i) h.add(i * 1e-5);
  for (std::size_t i = 0; i + 1 < h.bin_count(); ++i) EXPECT_DOUBLE_EQ(h.upper_s(i), h.lower_s(i + 1));
  const auto path = fresh_timing_dir("hist") / "h.csv";
  h.write_csv(path);
  std::ifstream in(path);
  std::string line;
  std::uint64_t total = 0;
  std::size_t rows = 0;
  bool header_seen = false;
  while (std::getline(in, line)) {
    if (!header_seen) {
      EXPECT_EQ(line, "lower_s,upper_s,count");
      header_seen = true;
      continue;
    }
    total += std::stoull(line.substr(line.rfind(',') + 1));
    ++rows;
  }
  EXPECT_EQ(rows, h.bin_count());
  EXPECT_EQ(total, 1000u);
  // The figures the `#` lines held are numbers in the sidecar.
  const YAML::Node meta = YAML::LoadFile(config::csv_sidecar_path(path).string());
  EXPECT_EQ(meta["count"].as<int>(), 1000);
  EXPECT_EQ(meta["min_s"].as<double>(), h.min());  // shortest round-trip text: the same double
  EXPECT_EQ(meta["max_s"].as<double>(), h.max());
  EXPECT_EQ(meta["rows"].as<std::size_t>(), h.bin_count());
}

TEST(LoopTiming, TablesAndWritesTheLoopStatistics) {
  LoopTiming t;
  for (int i = 0; i < 1000; ++i) {
    t.period.add(1e-3 + (i % 10) * 1e-6);
    t.compute.add(200e-6);
  }
  t.cycles = 1000;
  t.overruns = 2;
  t.deadline_misses = 3;
  const std::string table = t.table();
  EXPECT_NE(table.find("period"), std::string::npos);
  EXPECT_NE(table.find("compute"), std::string::npos);
  EXPECT_NE(table.find("p99.9"), std::string::npos);
  EXPECT_NE(table.find("deadline misses 3 (miss rate 0.2991 %)"), std::string::npos) << table;  // 3 / 1003
  const auto dir = fresh_timing_dir("loop");
  t.write_csv(dir);
  for (const char* f : {"timing_summary.csv", "timing_period_hist.csv", "timing_compute_hist.csv", "timing_rtt_hist.csv"}) {
    EXPECT_TRUE(std::filesystem::exists(dir / f)) << f;
  }
  std::ifstream in(dir / "timing_summary.csv");
  std::stringstream text;
  text << in.rdbuf();
  EXPECT_EQ(text.str().rfind("name,count,min_s,mean_s,p50_s,p99_s,p99_9_s,max_s\nperiod,1000,", 0), 0u) << text.str();
  const YAML::Node meta = YAML::LoadFile(config::csv_sidecar_path(dir / "timing_summary.csv").string());
  EXPECT_EQ(meta["cycles"].as<int>(), 1000);
  EXPECT_EQ(meta["overruns"].as<int>(), 2);
  EXPECT_EQ(meta["deadline_misses"].as<int>(), 3);
  EXPECT_EQ(meta["lost_packets"].as<int>(), 0);
  EXPECT_EQ(YAML::LoadFile(config::csv_sidecar_path(dir / "timing_overruns.csv").string())["overruns"].as<int>(), 2);
}

}  // namespace
}  // namespace peha::runtime
