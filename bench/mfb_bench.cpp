// The hardware path measured end to end on loopback: `peha mfb-emulator` in its own process, the
// host's E1 loop at 1 kHz for 60 s (absolute deadlines; SCHED_FIFO, mlockall when permitted) over
// real UDP. Reports the round trip (command sent -> the board's reply received, host clock)
// median/p99/p99.9/max, the deadline-miss rate, the control step's compute time (read -> controller
// -> limits -> hooks, without the send) and the link's counters. One iteration: it is a soak, not
// a micro-benchmark; the figures are the counters.
//
// BM_MfbLoopback1kHz60s runs in `make bench`. The soaks, 10 minutes each, once with the machine
// otherwise idle and once with a busy thread spinning on the other core (arithmetic and memory
// traffic: what a build or a plot does to the loop), are registered only when PEHA_SOAK=1
// (`make soak`).
#include "peha/experiments/e1_gravity/e1_realtime.hpp"

#include "peha/runtime/child_process.hpp"

#include <benchmark/benchmark.h>

#include <atomic>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <optional>
#include <string>
#include <thread>
#include <vector>

namespace {

using namespace peha;

/// Spins on another core until destroyed: floating-point work over a 4 MB buffer (larger than the
/// L2, so it also competes for the memory bus).
class BusyCore {
 public:
  BusyCore()
      : thread_([this] {
          std::vector<double> buffer(1 << 19, 1.0);
          double sum = 0.0;
          while (!stop_.load(std::memory_order_relaxed)) {
            for (double& v : buffer) {
              v = v * 1.0000001 + 1e-9;
              sum += v;
            }
          }
          sink_ = sum;
        }) {}
  ~BusyCore() {
    stop_.store(true);
    thread_.join();
  }

 private:
  std::atomic<bool> stop_{false};
  double sink_ = 0.0;
  std::thread thread_;
};

void mfb_loopback(benchmark::State& state, double duration_s, bool busy) {
  experiments::E1Scenario s = experiments::read_e1(config::Document::load_file(PEHA_SOURCE_DIR "/configs/e1_one_dof.yaml"));
  s.duration_s = duration_s;
  for (auto _ : state) {
    std::optional<BusyCore> hog;
    if (busy) hog.emplace();
    runtime::ChildProcess emulator({PEHA_BINARY, "mfb-emulator", "--config", PEHA_SOURCE_DIR "/configs/e1_one_dof.yaml", "--port", "0", "--case", "payload_2.5kg"});
    const int port = runtime::parse_listening_port(emulator.wait_for_line("listening on", 10.0));
    if (port == 0) {
      state.SkipWithError("mfb-emulator did not start");
      return;
    }
    runtime::RealtimeRunOptions o;
    o.board = io::parse_udp_endpoint("udp://127.0.0.1:" + std::to_string(port));
    o.quiet = true;
    o.dir = std::filesystem::path("out") / "bench" /
            ("mfb_loopback_" + std::to_string(static_cast<int>(duration_s)) + "s" + (busy ? "_busy" : ""));
    std::filesystem::create_directories(o.dir);
    const experiments::E1RealtimeResult r = experiments::run_e1_realtime(s, s.cases.front(), o);
    emulator.stop(SIGTERM);
    hog.reset();
    r.timing.write_csv(o.dir);
    std::printf("\n%s\n%s\n", r.realtime.summary().c_str(), r.timing.table().c_str());
    const auto& t = r.timing;
    state.counters["cycles"] = static_cast<double>(t.cycles);
    state.counters["rtt_median_us"] = t.rtt.percentile(50) * 1e6;
    state.counters["rtt_p99_us"] = t.rtt.percentile(99) * 1e6;
    state.counters["rtt_p999_us"] = t.rtt.percentile(99.9) * 1e6;
    state.counters["rtt_max_us"] = t.rtt.max() * 1e6;
    state.counters["compute_median_us"] = t.compute.percentile(50) * 1e6;
    state.counters["compute_p999_us"] = t.compute.percentile(99.9) * 1e6;
    state.counters["period_p999_us"] = t.period.percentile(99.9) * 1e6;
    state.counters["miss_rate_pct"] = 100.0 * static_cast<double>(t.deadline_misses) / static_cast<double>(t.cycles + t.deadline_misses);
    state.counters["no_sample_pct"] = 100.0 * static_cast<double>(r.link.replies_missing) / static_cast<double>(r.link.commands_sent);
    state.counters["late_pct"] = 100.0 * static_cast<double>(r.link.late_replies) / static_cast<double>(r.link.commands_sent);
    state.counters["fifo"] = r.realtime.fifo ? 1 : 0;
    state.counters["faults"] = static_cast<double>(r.faults);  // host watchdog / board trip / e-stop during the soak
    state.counters["other_core_busy"] = busy ? 1 : 0;
    for (const std::string& e : r.lifecycle) std::printf("  %s\n", e.c_str());
  }
}

void BM_MfbLoopback1kHz60s(benchmark::State& state) { mfb_loopback(state, 60.0, false); }
BENCHMARK(BM_MfbLoopback1kHz60s)->Iterations(1)->Unit(benchmark::kSecond)->UseRealTime();

/// The 10-minute soaks, only with PEHA_SOAK=1 (`make soak`).
const bool kSoakRegistered = [] {
  const char* soak = std::getenv("PEHA_SOAK");
  if (soak == nullptr || std::string(soak) != "1") return false;
  benchmark::RegisterBenchmark("BM_MfbSoak1kHz600s", [](benchmark::State& st) { mfb_loopback(st, 600.0, false); })
      ->Iterations(1)->Unit(benchmark::kSecond)->UseRealTime();
  benchmark::RegisterBenchmark("BM_MfbSoak1kHz600sOtherCoreBusy", [](benchmark::State& st) { mfb_loopback(st, 600.0, true); })
      ->Iterations(1)->Unit(benchmark::kSecond)->UseRealTime();
  return true;
}();

}  // namespace
