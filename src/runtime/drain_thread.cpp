#include "peha/runtime/drain_thread.hpp"

#include "peha/runtime/realtime.hpp"

#include <pthread.h>

namespace peha::runtime {
namespace {
// At 1 kHz a 2 ms poll leaves ~2 rows per wake-up in the queue: negligible CPU, low latency.
constexpr auto kPollInterval = std::chrono::milliseconds(2);
}  // namespace

DrainThread::DrainThread(std::string name, Hooks hooks)
    : name_(std::move(name)), hooks_(std::move(hooks)), thread_([this] { run(); }) {}

DrainThread::~DrainThread() { stop(); }

void DrainThread::run() noexcept {
  make_thread_non_realtime();
  pthread_setname_np(pthread_self(), name_.substr(0, 15).c_str());
  for (;;) {
    if (paused_.load(std::memory_order_acquire)) {
      std::unique_lock lock(mutex_);
      pause_acknowledged_ = true;
      cv_.notify_all();
      cv_.wait(lock, [&] { return !paused_.load() || stop_.load(); });
      pause_acknowledged_ = false;
      continue;
    }
    // Read before looking at the queues: if `step` then finds them empty, everything queued before
    // the stop or flush request has been processed.
    const bool stopping = stop_.load(std::memory_order_acquire);
    const std::uint64_t flush_target = flush_requested_.load(std::memory_order_acquire);
    if (hooks_.step()) continue;
    bool flushing;
    {
      std::lock_guard lock(mutex_);
      flushing = flush_target > flush_done_;
    }
    if (hooks_.idle) hooks_.idle(flushing);
    if (flushing) {
      std::lock_guard lock(mutex_);
      flush_done_ = flush_target;
      cv_.notify_all();
    }
    if (stopping) break;
    std::unique_lock lock(mutex_);
    cv_.wait_for(lock, kPollInterval,
                 [&] { return stop_.load() || paused_.load() || flush_requested_.load() > flush_done_; });
  }
  if (hooks_.finish) hooks_.finish();
  std::lock_guard lock(mutex_);
  done_ = true;
  cv_.notify_all();
}

bool DrainThread::flush(std::chrono::milliseconds timeout) {
  std::unique_lock lock(mutex_);
  if (done_) return true;
  const std::uint64_t target = flush_requested_.load() + 1;
  flush_requested_.store(target, std::memory_order_release);
  cv_.notify_all();
  return cv_.wait_for(lock, timeout, [&] { return flush_done_ >= target || done_; });
}

void DrainThread::set_paused(bool paused) {
  std::unique_lock lock(mutex_);
  if (done_ || stopped_) return;
  paused_.store(paused, std::memory_order_release);
  cv_.notify_all();
  if (paused) cv_.wait(lock, [&] { return pause_acknowledged_ || done_; });
}

void DrainThread::stop() {
  {
    std::lock_guard lock(mutex_);
    if (stopped_) return;
    stopped_ = true;
    paused_.store(false);
    stop_.store(true, std::memory_order_release);
    cv_.notify_all();
  }
  if (thread_.joinable()) thread_.join();
}

}  // namespace peha::runtime
