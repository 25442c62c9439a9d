#pragma once
/// \file
/// The non-real-time side of a loop helper (CSV writer, telemetry sender): a thread that repeatedly
/// runs `step` — one unit of work taken from lock-free queues fed by the loop — and, when there is
/// none, polls again after a short sleep. The loop never wakes it (no syscall, no lock on the loop
/// side); the owner can wait for everything queued so far (`flush`) and stop it after a final
/// drain (`stop`). The thread drops itself to SCHED_OTHER off the loop's CPU on start
/// (`make_thread_non_realtime`).

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <mutex>
#include <string>
#include <thread>

namespace peha::runtime {

class DrainThread {
 public:
  struct Hooks {
    std::function<bool()> step;            ///< does one unit of work; returns false if there was none
    std::function<void(bool flush)> idle;  ///< step found nothing; `flush`: a flush() waits for this call (optional)
    std::function<void()> finish;          ///< on the thread, after the final drain (optional)
  };

  /// Starts the thread, named `name` (<= 15 characters, shown by top -H). Poll interval 2 ms.
  DrainThread(std::string name, Hooks hooks);
  ~DrainThread();  ///< stop()
  DrainThread(const DrainThread&) = delete;
  DrainThread& operator=(const DrainThread&) = delete;

  /// Waits until `step` has found nothing to do, and `idle(true)` has returned, after this call
  /// began: everything queued before it is processed. False on timeout (or while paused).
  bool flush(std::chrono::milliseconds timeout);
  /// Processes everything still queued, calls `finish` and joins. Idempotent.
  void stop();
  /// Test hook: while paused the thread does nothing. Returns once the pause is in effect.
  void set_paused(bool paused);

 private:
  void run() noexcept;

  std::string name_;
  Hooks hooks_;
  std::mutex mutex_;
  std::condition_variable cv_;
  std::atomic<bool> stop_{false};
  std::atomic<bool> paused_{false};
  std::atomic<std::uint64_t> flush_requested_{0};
  std::uint64_t flush_done_ = 0;     ///< guarded by mutex_
  bool pause_acknowledged_ = false;  ///< guarded by mutex_
  bool done_ = false;                ///< the thread has finished; guarded by mutex_
  bool stopped_ = false;             ///< stop() was called; guarded by mutex_
  std::thread thread_;               ///< last: starts after every member above exists
};

}  // namespace peha::runtime
