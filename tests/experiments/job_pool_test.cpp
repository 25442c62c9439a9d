#include "peha/experiments/common/job_pool.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <stdexcept>
#include <vector>

namespace peha::experiments {
namespace {

// Every job runs exactly once, whatever the number of threads (more threads than jobs included).
TEST(JobPool, RunsEveryJobOnceOnAnyNumberOfThreads) {
  for (int threads : {1, 2, 5}) {
    std::vector<std::atomic<int>> runs(4);
    run_job_pool(runs.size(), threads, [&](std::size_t i) { ++runs[i]; });
    for (const auto& r : runs) EXPECT_EQ(r.load(), 1) << threads << " threads";
  }
}

// A job's exception reaches the caller after every thread has stopped, and no job is taken after it.
TEST(JobPool, AJobsExceptionStopsTheOthersAndIsRethrown) {
  std::atomic<int> taken{0};
  EXPECT_THROW(run_job_pool(100, 1,
                            [&](std::size_t i) {
                              ++taken;
                              if (i == 3) throw std::runtime_error("job 3 failed");
                            }),
               std::runtime_error);
  EXPECT_EQ(taken.load(), 4);  // jobs 0..3 on one thread, none after the failure
}

}  // namespace
}  // namespace peha::experiments
