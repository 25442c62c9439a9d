// The loop-side calls of the runtime allocate nothing (STYLE.md principle 3): a 1 kHz-like loop of
// wait_next + timing + lifecycle + log push + fault request + telemetry publish, 200 cycles, makes
// no heap allocation. The allocation counter is process-wide, so this also shows that the CSV
// writer and the telemetry sender, running meanwhile, do not allocate in their steady state (a
// fault dump's file name does, which is why the writer is paused around the fault request).
#include "peha/runtime/async_log.hpp"
#include "peha/runtime/lifecycle.hpp"
#include "peha/runtime/realtime.hpp"
#include "peha/runtime/spsc_ring.hpp"
#include "peha/runtime/telemetry.hpp"
#include "peha/runtime/timing_stats.hpp"

#include "../support/alloc_counter.hpp"

#include <gtest/gtest.h>

#include <unistd.h>

#include <array>
#include <filesystem>

namespace peha::runtime {
namespace {

TEST(RuntimeLoop, AllocatesNothing) {
  const auto dir = std::filesystem::temp_directory_path() / ("peha_no_alloc_" + std::to_string(getpid()));
  std::filesystem::create_directories(dir);
  AsyncCsvLog log(dir / "run.csv", {"t_s", "a", "b", "c"}, {"no allocation test"}, 1024, 100);
  // Nobody listens on this port: sendto still succeeds (unconnected UDP), nothing is received.
  Telemetry telemetry("127.0.0.1", 9, 100.0, "exo", {"a", "b", "c"});
  PeriodicClock clock(1e-3);
  LoopTiming timing;
  Lifecycle lifecycle;
  SpscRing<std::array<double, 4>> ring(64);
  // Let both helper threads reach their steady state (thread start-up allocates).
  ASSERT_TRUE(log.flush());
  ASSERT_TRUE(telemetry.flush());

  std::array<double, 4> row{};
  clock.start();
  std::int64_t last_wake_ns = clock.start_ns();
  const std::size_t allocations = testing::allocations_during([&] {
    lifecycle.apply(Transition::kConfigure, 0.0, "config");
    lifecycle.apply(Transition::kActivate, 0.0, "start");
    for (int k = 0; k < 200; ++k) {
      timing.overruns += clock.wait_next() > 1e-3 ? 1 : 0;
      const std::int64_t wake_ns = PeriodicClock::now_ns();
      timing.period.add(static_cast<double>(wake_ns - last_wake_ns) * 1e-9);
      last_wake_ns = wake_ns;
      row = {clock.deadline_s(), 1.0 * k, 2.0 * k, 3.0 * k};
      log.push(row);
      telemetry.publish(row[0], std::span<const double>(row).subspan(1));
      ring.try_push(row);
      ring.try_pop(row);
      timing.compute.add(static_cast<double>(PeriodicClock::now_ns() - wake_ns) * 1e-9);
    }
    lifecycle.apply(Transition::kFault, clock.deadline_s(), "test fault");
  });
  EXPECT_EQ(allocations, 0u);

  log.set_writer_paused_for_test(true);
  const std::size_t request_allocations =
      testing::allocations_during([&] { EXPECT_TRUE(log.request_fault_dump("test fault")); });
  EXPECT_EQ(request_allocations, 0u);
  log.set_writer_paused_for_test(false);
  log.close();
  telemetry.close();
  EXPECT_EQ(log.written_rows(), 200u);
  EXPECT_EQ(log.fault_dumps().size(), 1u);
  EXPECT_GE(telemetry.published_samples(), 15u);  // ~20 at 100 Hz over >= 0.2 s
  EXPECT_EQ(lifecycle.state(), LifecycleState::kFault);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace peha::runtime
