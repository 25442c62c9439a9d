#pragma once
/// The matrices' worker pool (peha robustness, peha false-alarms): independent jobs on a few threads.

#include <cstddef>
#include <functional>

namespace peha::experiments {

/// Runs `job(i)` once for every i in [0, count) on `threads` threads (this one included), each
/// thread taking the next index when it is done. The first exception a job throws stops the others
/// from taking more and is rethrown here once every thread has finished.
void run_job_pool(std::size_t count, int threads, const std::function<void(std::size_t)>& job);

}  // namespace peha::experiments
