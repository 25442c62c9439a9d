/// Loop-side costs of the runtime infrastructure, per call, in ns (the console's Time column): the
/// lock-free queue, one CSV row handed to the writer, one telemetry publish, one timing sample.
/// The budget they share is the 1 ms control period.

#include "peha/runtime/async_log.hpp"
#include "peha/runtime/realtime.hpp"
#include "peha/runtime/spsc_ring.hpp"
#include "peha/runtime/telemetry.hpp"
#include "peha/runtime/timing_stats.hpp"

#include <fmt/format.h>

#include <benchmark/benchmark.h>

#include <unistd.h>

#include <array>
#include <cstdint>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

namespace peha::bench {
namespace {

// One push and one pop on the same thread: the uncontended cost of a hand-over. Arg: doubles per slot.
template <std::size_t N>
void BM_SpscRingPushPop(benchmark::State& state) {
  runtime::SpscRing<std::array<double, N>> ring(1024);
  std::array<double, N> in{}, out{};
  for (auto _ : state) {
    in[0] += 1.0;
    ring.try_push(in);
    ring.try_pop(out);
    benchmark::DoNotOptimize(out);
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK_TEMPLATE(BM_SpscRingPushPop, 1);
BENCHMARK_TEMPLATE(BM_SpscRingPushPop, 64);

std::filesystem::path bench_dir() {
  const auto dir = std::filesystem::temp_directory_path() / fmt::format("peha_runtime_bench_{}", getpid());
  std::filesystem::create_directories(dir);
  return dir;
}

// The writer formats ~1 row/us and the sender needs a few us per datagram, far slower than these
// loops push: the queued benchmarks run exactly one queue's worth of calls, so every call queues
// (none is dropped) and nothing outside the call is timed.
constexpr std::size_t kQueuedCalls = 1 << 14;

// One E1-width row (25 columns) into the writer's queue.
void BM_AsyncCsvLogPush(benchmark::State& state) {
  std::vector<std::string> columns = {"t_s"};
  for (int c = 1; c < 25; ++c) columns.push_back(fmt::format("c{}_N", c));
  const std::filesystem::path dir = bench_dir();
  runtime::AsyncCsvLog log(dir / "bench.csv", columns, {"benchmark"}, kQueuedCalls, 5000);
  std::vector<double> row(columns.size(), 0.125);
  for (auto _ : state) {
    row[0] += 1e-3;
    benchmark::DoNotOptimize(log.push(row));
  }
  state.SetItemsProcessed(state.iterations());
  if (log.dropped_rows() > 0) state.SkipWithError("rows dropped: the timing includes refused pushes");
  log.close();
  std::filesystem::remove_all(dir);
}
BENCHMARK(BM_AsyncCsvLogPush)->Iterations(kQueuedCalls);

// A 1 kHz loop publishing 32 signals at 100 Hz: the average per call (9 of 10 calls only check
// the time; the 10th copies the sample into the queue).
void BM_TelemetryPublish1kHzLoop(benchmark::State& state) {
  std::vector<std::string> names;
  for (int i = 0; i < 32; ++i) names.push_back(fmt::format("signal_{}", i));
  runtime::Telemetry tm("127.0.0.1", 9, 100.0, "bench", names, kQueuedCalls);  // port 9: discard
  std::vector<double> values(names.size(), 0.5);
  double t = 0;
  for (auto _ : state) {
    t += 1e-3;
    tm.publish(t, values);
  }
  state.SetItemsProcessed(state.iterations());
  if (tm.dropped_samples() > 0) state.SkipWithError("samples dropped: the timing includes refused publishes");
}
BENCHMARK(BM_TelemetryPublish1kHzLoop)->Iterations(10 * kQueuedCalls);

// Every call kept (rate far above the call rate): the cost of a queued sample of 32 signals.
void BM_TelemetryPublishQueued(benchmark::State& state) {
  std::vector<std::string> names;
  for (int i = 0; i < 32; ++i) names.push_back(fmt::format("signal_{}", i));
  runtime::Telemetry tm("127.0.0.1", 9, 1e12, "bench", names, kQueuedCalls);
  std::vector<double> values(names.size(), 0.5);
  double t = 0;
  for (auto _ : state) {
    t += 1e-3;
    tm.publish(t, values);
  }
  state.SetItemsProcessed(state.iterations());
  if (tm.dropped_samples() > 0) state.SkipWithError("samples dropped: the timing includes refused publishes");
}
BENCHMARK(BM_TelemetryPublishQueued)->Iterations(kQueuedCalls);

void BM_HistogramAdd(benchmark::State& state) {
  runtime::Histogram h;
  std::mt19937_64 rng(1);
  std::lognormal_distribution<double> duration(std::log(200e-6), 0.5);  // compute times around 200 us
  std::array<double, 1024> samples{};
  for (double& s : samples) s = duration(rng);
  std::size_t k = 0;
  for (auto _ : state) h.add(samples[k++ & 1023]);
  benchmark::DoNotOptimize(h.count());
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_HistogramAdd);

void BM_PeriodicClockNow(benchmark::State& state) {
  for (auto _ : state) benchmark::DoNotOptimize(runtime::PeriodicClock::now_ns());
}
BENCHMARK(BM_PeriodicClockNow);

}  // namespace
}  // namespace peha::bench
