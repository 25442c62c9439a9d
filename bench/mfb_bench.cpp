// The hardware path measured end to end on loopback: `peha mfb-emulator` in its own process, the
// host's E1 loop at 1 kHz for 60 s (absolute deadlines; SCHED_FIFO, mlockall when permitted;
// host and emulator pinned to the same CPU, see LoopSetup) over real UDP. Reports the round trip (command sent -> the board's reply received, host clock)
// median/p99/p99.9/max, the deadline-miss rate, the control step's compute time (read -> controller
// -> limits -> hooks, without the send) and the link's counters. One iteration: it is a soak, not
// a micro-benchmark; the figures are the counters.
//
// BM_TimerFloor1kHz60s, run just before it, is the machine's floor: the same absolute-deadline
// 1 kHz PeriodicClock, the same real-time set-up (RealtimeRunOptions' defaults: SCHED_FIFO 80,
// mlockall, prefaulted stack), the same deadline rule, but no UDP, no emulator and no controller (a
// cyclictest-like bare timer loop). Its figures are how late the thread wakes (wake_*_us) and the
// misses; whatever the loop misses beyond them is peha's (or its emulator's).
//
// Both report the misses' structure: `overruns` (cycles that ended past the next deadline),
// `max_burst` (most deadlines one overrun skipped: a 20 ms stall is one overrun of ~20 misses),
// `burst_miss_pct` (the share of the misses inside overruns of more than one deadline) and
// `late_wake_overruns` (overruns whose cycle had woken >= one period late: the thread did not run
// at all, so the kernel or the hypervisor), and `on_time_miss_pct`, the deadlines missed by the
// others, the cycles that woke on time (the loop's own share, over all cycles).
// out/bench/<name>/timing_overruns.csv lists them.
//
// BM_TimerFloor1kHz60s and BM_MfbLoopback1kHz60s run in `make bench`. PEHA_RT_STUDY=1 also
// registers the 60 s variants the loop's set-up was chosen with (other core busy; host and emulator
// unpinned, as before, or pinned to different CPUs instead of the same one; the emulator's priority;
// a final spin before the deadline), each beside its floor. The soaks, 10 minutes each, once with the machine
// otherwise idle and once with a busy thread spinning on the other core (arithmetic and memory
// traffic: what a build or a plot does to the loop), are registered only when PEHA_SOAK=1
// (`make soak`).
#include "peha/experiments/e1_gravity/e1_realtime.hpp"

#include "peha/runtime/child_process.hpp"
#include "peha/runtime/realtime.hpp"
#include "peha/runtime/timing_stats.hpp"

#include <benchmark/benchmark.h>

#include <algorithm>
#include <atomic>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <unistd.h>

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

/// The CPU the host's loop and the emulator share in `make bench`: the second one (the first takes
/// most interrupts and housekeeping), or the only one.
int loop_cpu() { return sysconf(_SC_NPROCESSORS_ONLN) > 1 ? 1 : 0; }

/// How the loop (and its floor) is set up: the defaults are `make bench`'s. Host and emulator are
/// pinned to the same CPU: each round trip is then a hand-over between two threads on one CPU. Left
/// to the scheduler they run on different CPUs, and every command and every reply has to wake the
/// other CPU out of its idle halt (on a virtual machine an exit to the hypervisor and back): RTT
/// p99.9 and the misses of the loop were that (docs/performance.md, "UDP loop").
struct LoopSetup {
  bool busy = false;            ///< a busy thread on the other core
  int host_cpu = loop_cpu();    ///< pin the host's loop (RealtimeOptions::cpu; -1 = don't pin)
  int emulator_cpu = loop_cpu();  ///< pin the emulator's loop (mfb-emulator --cpu; -1 = don't pin)
  int emulator_priority = 70;   ///< mfb-emulator --rt-priority
  std::int64_t spin_ns = 0;     ///< RealtimeOptions::wake_spin_ns
};

void miss_counters(benchmark::State& state, const runtime::LoopTiming& t, double period_s) {
  state.counters["cycles"] = static_cast<double>(t.cycles);
  state.counters["wake_median_us"] = t.wake.percentile(50) * 1e6;
  state.counters["wake_p999_us"] = t.wake.percentile(99.9) * 1e6;
  state.counters["wake_max_us"] = t.wake.max() * 1e6;
  state.counters["period_p999_us"] = t.period.percentile(99.9) * 1e6;
  state.counters["miss_rate_pct"] = 100.0 * static_cast<double>(t.deadline_misses) / static_cast<double>(t.cycles + t.deadline_misses);
  state.counters["overruns"] = static_cast<double>(t.overruns);
  state.counters["max_burst"] = static_cast<double>(t.max_burst);
  std::uint64_t in_bursts = 0, late_wake = 0, on_time_misses = 0;
  for (const runtime::OverrunEvent& e : t.overrun_events) {
    if (e.skipped > 1) in_bursts += e.skipped;
    if (e.wake_late_s >= period_s) {
      ++late_wake;
    } else {
      on_time_misses += e.skipped;
    }
  }
  // The deadlines missed by cycles that woke on time (less than a period late), over all cycles: the
  // loop's own share. Those that began with a late wake-up are the kind the bare timer loop shows.
  state.counters["on_time_miss_pct"] =
      100.0 * static_cast<double>(on_time_misses) / static_cast<double>(t.cycles + t.deadline_misses);
  state.counters["burst_miss_pct"] = t.deadline_misses ? 100.0 * static_cast<double>(in_bursts) / static_cast<double>(t.deadline_misses) : 0.0;
  state.counters["late_wake_overruns"] = static_cast<double>(late_wake);
  state.counters["minor_faults"] = static_cast<double>(t.minor_faults);
  state.counters["involuntary_switches"] = static_cast<double>(t.involuntary_switches);
}

/// The bare timer loop: PeriodicClock at 1 kHz under the loop's real-time set-up, nothing else.
void timer_floor(benchmark::State& state, const std::string& name, double duration_s, const LoopSetup& setup) {
  constexpr double kPeriod_s = 1e-3;
  for (auto _ : state) {
    std::optional<BusyCore> hog;
    if (setup.busy) hog.emplace();
    runtime::RealtimeOptions rt = runtime::RealtimeRunOptions{}.realtime;  // exactly the harness's defaults
    rt.cpu = setup.host_cpu;
    rt.wake_spin_ns = setup.spin_ns;
    runtime::LoopTiming t;
    t.overrun_events.reserve(4096);
    runtime::PeriodicClock clock(kPeriod_s);
    clock.set_spin_ns(setup.spin_ns);
    const runtime::RealtimeReport report = runtime::configure_realtime_thread(rt);
    const runtime::ThreadCounters before = runtime::thread_counters();
    clock.start();
    const std::int64_t end_ns = clock.start_ns() + static_cast<std::int64_t>(duration_s * 1e9);
    std::int64_t cycle_start_ns = 0, last_wake_ns = 0;
    double wake_late_s = 0;
    for (;;) {
      const double late_s = clock.wait_next();
      const std::int64_t now = runtime::PeriodicClock::now_ns();
      if (clock.last_skipped() > 0 && cycle_start_ns != 0 && t.overrun_events.size() < t.overrun_events.capacity()) {
        t.overrun_events.push_back({static_cast<double>(cycle_start_ns - clock.start_ns()) * 1e-9, clock.last_skipped(), wake_late_s,
                                    static_cast<double>(clock.last_call_ns() - cycle_start_ns) * 1e-9, std::nan("")});
      }
      t.wake.add(late_s);
      wake_late_s = late_s;
      if (last_wake_ns) t.period.add(static_cast<double>(now - last_wake_ns) * 1e-9);
      last_wake_ns = cycle_start_ns = now;
      if (now >= end_ns) break;
    }
    const runtime::ThreadCounters after = runtime::thread_counters();
    runtime::make_thread_non_realtime();
    hog.reset();
    t.minor_faults = after.minor_faults - before.minor_faults;
    t.major_faults = after.major_faults - before.major_faults;
    t.involuntary_switches = after.involuntary_switches - before.involuntary_switches;
    t.cycles = clock.cycles();
    t.overruns = clock.overruns();
    t.deadline_misses = clock.missed_deadlines();
    t.max_burst = clock.max_skipped();
    const std::filesystem::path dir = std::filesystem::path("out") / "bench" / name;
    t.write_csv(dir);
    std::printf("\n%s\n%s%s\n", report.summary().c_str(), t.table().c_str(), t.burst_summary(kPeriod_s).c_str());
    miss_counters(state, t, kPeriod_s);
    state.counters["fifo"] = report.fifo ? 1 : 0;
    state.counters["other_core_busy"] = setup.busy ? 1 : 0;
  }
}

void mfb_loopback(benchmark::State& state, const std::string& name, double duration_s, const LoopSetup& setup) {
  const bool busy = setup.busy;
  experiments::E1Scenario s = experiments::read_e1(config::Document::load_file(PEHA_SOURCE_DIR "/configs/e1_one_dof.yaml"));
  s.duration_s = duration_s;
  for (auto _ : state) {
    std::optional<BusyCore> hog;
    if (busy) hog.emplace();
    runtime::ChildProcess emulator({PEHA_BINARY, "mfb-emulator", "--config", PEHA_SOURCE_DIR "/configs/e1_one_dof.yaml", "--port", "0", "--case",
                                    "payload_2.5kg", "--rt-priority", std::to_string(setup.emulator_priority), "--cpu",
                                    std::to_string(setup.emulator_cpu)});
    const int port = runtime::parse_listening_port(emulator.wait_for_line("listening on", 10.0));
    if (port == 0) {
      state.SkipWithError("mfb-emulator did not start");
      return;
    }
    experiments::HardwareRunOptions o;
    o.backend = hardware::BackendUri::parse("udp://127.0.0.1:" + std::to_string(port));
    o.quiet = true;
    o.realtime.cpu = setup.host_cpu;
    o.realtime.wake_spin_ns = setup.spin_ns;
    o.dir = std::filesystem::path("out") / "bench" / name;
    std::filesystem::create_directories(o.dir);
    const experiments::E1RealtimeResult r = experiments::run_e1_realtime(s, s.cases.front(), o);
    emulator.stop(SIGTERM);
    hog.reset();
    r.timing.write_csv(o.dir);
    std::printf("\n%s\n%s%s\n", r.realtime.summary().c_str(), r.timing.table().c_str(), r.timing.burst_summary(s.period_s).c_str());
    const auto& t = r.timing;
    miss_counters(state, t, s.period_s);
    state.counters["rtt_median_us"] = t.rtt.percentile(50) * 1e6;
    state.counters["rtt_p99_us"] = t.rtt.percentile(99) * 1e6;
    state.counters["rtt_p999_us"] = t.rtt.percentile(99.9) * 1e6;
    state.counters["rtt_max_us"] = t.rtt.max() * 1e6;
    state.counters["compute_median_us"] = t.compute.percentile(50) * 1e6;
    state.counters["compute_p999_us"] = t.compute.percentile(99.9) * 1e6;
    state.counters["no_sample_pct"] = 100.0 * static_cast<double>(r.link.replies_missing) / static_cast<double>(r.link.commands_sent);
    state.counters["late_pct"] = 100.0 * static_cast<double>(r.link.late_replies) / static_cast<double>(r.link.commands_sent);
    state.counters["fifo"] = r.realtime.fifo ? 1 : 0;
    state.counters["faults"] = static_cast<double>(r.faults);  // host watchdog / board trip / e-stop during the soak
    state.counters["other_core_busy"] = busy ? 1 : 0;
    for (const std::string& e : r.lifecycle) std::printf("  %s\n", e.c_str());
  }
}

void BM_TimerFloor1kHz60s(benchmark::State& state) { timer_floor(state, "BM_TimerFloor1kHz60s", 60.0, LoopSetup{}); }
BENCHMARK(BM_TimerFloor1kHz60s)->Iterations(1)->Unit(benchmark::kSecond)->UseRealTime();

void BM_MfbLoopback1kHz60s(benchmark::State& state) { mfb_loopback(state, "BM_MfbLoopback1kHz60s", 60.0, LoopSetup{}); }
BENCHMARK(BM_MfbLoopback1kHz60s)->Iterations(1)->Unit(benchmark::kSecond)->UseRealTime();

/// PEHA_RT_STUDY=1: each set-up the loop was measured in, floor then loop, 60 s each.
const bool kStudyRegistered = [] {
  const char* study = std::getenv("PEHA_RT_STUDY");
  if (study == nullptr || std::string(study) != "1") return false;
  const std::pair<const char*, LoopSetup> setups[] = {
      {"OtherCoreBusy", LoopSetup{.busy = true}},
      {"Unpinned", LoopSetup{.host_cpu = -1, .emulator_cpu = -1}},  // make bench's set-up before
      {"UnpinnedOtherCoreBusy", LoopSetup{.busy = true, .host_cpu = -1, .emulator_cpu = -1}},
      {"SeparateCpus", LoopSetup{.host_cpu = 1, .emulator_cpu = 0}},
      {"EmulatorPriority0", LoopSetup{.emulator_priority = 0}},
      {"Spin50us", LoopSetup{.spin_ns = 50'000}},
  };
  for (const auto& [name, setup] : setups) {
    const LoopSetup copy = setup;
    const std::string floor = std::string("BM_TimerFloor1kHz60s") + name, loop = std::string("BM_MfbLoopback1kHz60s") + name;
    benchmark::RegisterBenchmark(floor.c_str(), [copy, floor](benchmark::State& st) { timer_floor(st, floor, 60.0, copy); })
        ->Iterations(1)->Unit(benchmark::kSecond)->UseRealTime();
    benchmark::RegisterBenchmark(loop.c_str(), [copy, loop](benchmark::State& st) { mfb_loopback(st, loop, 60.0, copy); })
        ->Iterations(1)->Unit(benchmark::kSecond)->UseRealTime();
  }
  return true;
}();

/// The 10-minute soaks, only with PEHA_SOAK=1 (`make soak`).
const bool kSoakRegistered = [] {
  const char* soak = std::getenv("PEHA_SOAK");
  if (soak == nullptr || std::string(soak) != "1") return false;
  benchmark::RegisterBenchmark("BM_TimerFloorSoak1kHz600s", [](benchmark::State& st) { timer_floor(st, "BM_TimerFloorSoak1kHz600s", 600.0, LoopSetup{}); })
      ->Iterations(1)->Unit(benchmark::kSecond)->UseRealTime();
  benchmark::RegisterBenchmark("BM_MfbSoak1kHz600s", [](benchmark::State& st) { mfb_loopback(st, "BM_MfbSoak1kHz600s", 600.0, LoopSetup{}); })
      ->Iterations(1)->Unit(benchmark::kSecond)->UseRealTime();
  benchmark::RegisterBenchmark("BM_TimerFloorSoak1kHz600sOtherCoreBusy", [](benchmark::State& st) { timer_floor(st, "BM_TimerFloorSoak1kHz600sOtherCoreBusy", 600.0, LoopSetup{.busy = true}); })
      ->Iterations(1)->Unit(benchmark::kSecond)->UseRealTime();
  benchmark::RegisterBenchmark("BM_MfbSoak1kHz600sOtherCoreBusy", [](benchmark::State& st) { mfb_loopback(st, "BM_MfbSoak1kHz600sOtherCoreBusy", 600.0, LoopSetup{.busy = true}); })
      ->Iterations(1)->Unit(benchmark::kSecond)->UseRealTime();
  return true;
}();

}  // namespace
