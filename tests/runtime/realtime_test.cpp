#include "peha/runtime/realtime.hpp"

#include <gtest/gtest.h>
#include <spdlog/sinks/stdout_sinks.h>
#include <spdlog/spdlog.h>

#include <pthread.h>
#include <sched.h>
#include <sys/resource.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <stdexcept>
#include <string>
#include <thread>

namespace peha::runtime {
namespace {

bool any_warning_contains(const RealtimeReport& r, const std::string& text) {
  for (const std::string& w : r.warnings) {
    if (w.find(text) != std::string::npos) return true;
  }
  return false;
}

TEST(PeriodicClock, RejectsANonPositivePeriod) {
  EXPECT_THROW(PeriodicClock(0.0), std::invalid_argument);
  EXPECT_THROW(PeriodicClock(-1e-3), std::invalid_argument);
  EXPECT_THROW(PeriodicClock(std::nan("")), std::invalid_argument);
}

// 50 cycles of a 100 Hz clock cannot end before the 50th deadline, 0.50 s after start (0.49 s
// allowed for rounding); on a loaded machine cycles are skipped rather than shortened, so the
// deadline bookkeeping must match the cycles and skips exactly whatever the load.
TEST(PeriodicClock, SleepsToAbsoluteDeadlines) {
  PeriodicClock clock(0.01);
  clock.start();
  for (int k = 0; k < 50; ++k) {
    const double late_s = clock.wait_next();
    EXPECT_GE(late_s, 0.0);
    EXPECT_GE(PeriodicClock::now_ns() - clock.start_ns(), static_cast<std::int64_t>(clock.deadline_s() * 1e9) - 1);
  }
  const double elapsed_s = static_cast<double>(PeriodicClock::now_ns() - clock.start_ns()) * 1e-9;
  EXPECT_GE(elapsed_s, 0.49);
  EXPECT_LT(elapsed_s, 10.0);  // sanity only: generous for a loaded 2-core machine
  EXPECT_EQ(clock.cycles(), 50u);
  EXPECT_NEAR(clock.deadline_s(), static_cast<double>(clock.cycles() + clock.missed_deadlines()) * 0.01, 1e-9);
}

// A 35 ms stall in a 10 ms loop: the deadlines at 20, 30 and 40 ms have passed when wait_next is
// called, so it skips (and counts) them and sleeps to 50 ms, instead of returning at once three
// times to catch up. Under load the stall may be longer: then more are skipped, never fewer.
TEST(PeriodicClock, SkipsMissedDeadlinesInsteadOfBursting) {
  PeriodicClock clock(0.01);
  clock.start();
  clock.wait_next();  // cycle 1 at 10 ms
  const std::uint64_t missed_before = clock.missed_deadlines();
  std::this_thread::sleep_for(std::chrono::milliseconds(35));
  clock.wait_next();
  const std::uint64_t skipped = clock.missed_deadlines() - missed_before;
  EXPECT_GE(skipped, 3u);
  EXPECT_GE(clock.overruns(), 1u);
  EXPECT_EQ(clock.cycles(), 2u);
  // The stall is one burst: the call says how many deadlines it skipped, and the largest burst too.
  EXPECT_EQ(clock.last_skipped(), skipped);
  EXPECT_GE(clock.max_skipped(), skipped);
  EXPECT_NEAR(clock.deadline_s(), static_cast<double>(2 + clock.missed_deadlines()) * 0.01, 1e-9);
  // It woke at (not before) the first deadline still ahead of the stall's end.
  EXPECT_GE(PeriodicClock::now_ns() - clock.start_ns(), static_cast<std::int64_t>(clock.deadline_s() * 1e9) - 1);
  EXPECT_GE(clock.deadline_s(), 0.0449);
  // And the next cycle is a whole period later, not a catch-up cycle.
  const double before = clock.deadline_s();
  clock.wait_next();
  EXPECT_EQ(clock.last_skipped(), 0u);
  EXPECT_GE(clock.max_skipped(), skipped);
  EXPECT_GE(clock.deadline_s() - before, 0.01 - 1e-9);
  EXPECT_GE(PeriodicClock::now_ns() - clock.start_ns(), static_cast<std::int64_t>(clock.deadline_s() * 1e9) - 1);
}

// A final spin lands the wake-up on the deadline (within clock noise), never before it.
TEST(PeriodicClock, SpinsToTheDeadlineWhenAsked) {
  PeriodicClock clock(0.002);
  clock.set_spin_ns(200'000);
  clock.start();
  for (int i = 0; i < 5; ++i) {
    const double late_s = clock.wait_next();
    EXPECT_GE(late_s, 0.0);
    EXPECT_GE(PeriodicClock::now_ns(), clock.deadline_ns());
  }
  EXPECT_EQ(clock.cycles(), 5u);
}

TEST(ConfigureRealtime, RejectsInvalidOptions) {
  RealtimeOptions o;
  o.lock_memory = false;
  o.prefault_stack_bytes = 0;
  o.fifo_priority = 120;
  EXPECT_THROW(configure_realtime_thread(o), std::invalid_argument);
  o.fifo_priority = -3;
  EXPECT_THROW(configure_realtime_thread(o), std::invalid_argument);
  o.fifo_priority = 0;
  o.cpu = -2;
  EXPECT_THROW(configure_realtime_thread(o), std::invalid_argument);
}

TEST(ConfigureRealtime, AsksForNothingWhenEverythingIsOff) {
  RealtimeOptions o;
  o.fifo_priority = 0;
  o.cpu = -1;
  o.lock_memory = false;
  o.prefault_stack_bytes = 0;
  const RealtimeReport r = configure_realtime_thread(o);
  EXPECT_FALSE(r.fifo);
  EXPECT_FALSE(r.memory_locked);
  EXPECT_FALSE(r.pinned);
  EXPECT_TRUE(r.warnings.empty());
  EXPECT_NE(r.summary().find("0 warning(s)"), std::string::npos) << r.summary();
}

// On a fresh thread (the test process keeps its own scheduling): whatever the machine permits, the
// report matches what the kernel says the thread runs with, and each refusal has a warning.
TEST(ConfigureRealtime, ReportsWhatTheKernelReallyGranted) {
  std::thread t([] {
    RealtimeOptions o;
    o.fifo_priority = 10;  // low: never starves anything else on a shared machine
    o.cpu = 0;
    o.lock_memory = false;  // process-wide; tested in its own process below
    o.prefault_stack_bytes = 64 * 1024;
    const RealtimeReport r = configure_realtime_thread(o);
    int policy = -1;
    sched_param sp{};
    ASSERT_EQ(pthread_getschedparam(pthread_self(), &policy, &sp), 0);
    if (r.fifo) {
      EXPECT_EQ(policy, SCHED_FIFO);
      EXPECT_EQ(sp.sched_priority, r.priority);
    } else {
      EXPECT_EQ(policy, SCHED_OTHER);
      EXPECT_TRUE(any_warning_contains(r, "SCHED_FIFO")) << r.summary();
    }
    cpu_set_t set;
    ASSERT_EQ(pthread_getaffinity_np(pthread_self(), sizeof(set), &set), 0);
    if (r.pinned) {
      EXPECT_EQ(CPU_COUNT(&set), 1);
      EXPECT_TRUE(CPU_ISSET(0, &set));
      EXPECT_EQ(sched_getcpu(), 0);
    } else {
      EXPECT_TRUE(any_warning_contains(r, "CPU 0")) << r.summary();
    }
    EXPECT_EQ(r.stack_prefaulted_bytes, 64u * 1024u);
    EXPECT_EQ(r.preempt_rt_kernel, !any_warning_contains(r, "PREEMPT_RT"));
    // A helper thread created from here is dropped back to SCHED_OTHER, off the pinned CPU.
    std::thread helper([pinned = r.pinned] {
      make_thread_non_realtime();
      int helper_policy = -1;
      sched_param helper_sp{};
      pthread_getschedparam(pthread_self(), &helper_policy, &helper_sp);
      EXPECT_EQ(helper_policy, SCHED_OTHER);
      cpu_set_t helper_set;
      pthread_getaffinity_np(pthread_self(), sizeof(helper_set), &helper_set);
      if (pinned && sysconf(_SC_NPROCESSORS_ONLN) > 1) {
        EXPECT_FALSE(CPU_ISSET(0, &helper_set));
      }
    });
    helper.join();
  });
  t.join();
}

// Runs in a death-test child: drops every privilege, asks for everything, exits with a bit set
// for each request that was granted or refused without its warning.
[[noreturn]] void refuse_everything_in_child() {
  spdlog::set_default_logger(spdlog::stderr_logger_st("child"));  // so EXPECT_EXIT sees the banner
  if (geteuid() == 0 && setuid(65534) != 0) std::_Exit(10);
  const rlimit zero{0, 0};
  setrlimit(RLIMIT_RTPRIO, &zero);
  setrlimit(RLIMIT_MEMLOCK, &zero);
  RealtimeOptions o;
  o.fifo_priority = 80;
  o.cpu = CPU_SETSIZE - 1;  // no such CPU
  o.lock_memory = true;
  const RealtimeReport r = configure_realtime_thread(o);
  int code = 0;
  if (r.fifo || !any_warning_contains(r, "SCHED_FIFO priority 80 refused (EPERM")) code |= 1;
  if (r.memory_locked || !any_warning_contains(r, "mlockall")) code |= 2;
  if (r.pinned || !any_warning_contains(r, "pinning to CPU 1023 refused (EINVAL")) code |= 4;
  std::_Exit(code);
}

#if !defined(__SANITIZE_ADDRESS__) && !defined(__SANITIZE_THREAD__)
[[noreturn]] void lock_memory_in_child() {
  RealtimeOptions o;
  o.fifo_priority = 0;
  o.cpu = -1;
  const RealtimeReport r = configure_realtime_thread(o);
  std::ifstream status("/proc/self/status");
  std::string line;
  long locked_kB = 0;
  while (std::getline(status, line)) {
    if (line.rfind("VmLck:", 0) == 0) locked_kB = std::atol(line.c_str() + 6);
  }
  const bool consistent = r.memory_locked ? locked_kB > 0 : any_warning_contains(r, "mlockall");
  std::_Exit(consistent ? 0 : 1);
}
#endif

// Refusals, forced in a child process: without privileges (uid nobody when run as root) and with
// RLIMIT_RTPRIO = RLIMIT_MEMLOCK = 0 every request is refused, and configure_realtime_thread
// returns normally with one warning per refusal naming the errno, in a banner on the log.
TEST(ConfigureRealtimeDeathTest, WarnsAboutEveryRefusalAndNeverThrows) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  EXPECT_EXIT(refuse_everything_in_child(), ::testing::ExitedWithCode(0), "REAL-TIME: 4 warning\\(s\\), loop timing is NOT guaranteed");
}

// Memory locking in its own process (mlockall is process-wide): granted means the kernel counts
// locked pages (VmLck). Skipped under sanitizers, which intercept mlockall.
TEST(ConfigureRealtimeDeathTest, LocksMemoryWhenPermittedOrSaysWhyNot) {
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
  GTEST_SKIP() << "mlockall under a sanitizer";
#else
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  EXPECT_EXIT(lock_memory_in_child(), ::testing::ExitedWithCode(0), "");
#endif
}

}  // namespace
}  // namespace peha::runtime
