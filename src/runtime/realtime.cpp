#include "peha/runtime/realtime.hpp"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <alloca.h>
#include <pthread.h>
#include <sched.h>
#include <sys/mman.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/utsname.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <mutex>
#include <stdexcept>

namespace peha::runtime {
namespace {

// Margin left untouched below the prefaulted part of the stack (guard page, signal frames).
constexpr std::size_t kStackMarginBytes = 64 * 1024;
constexpr std::size_t kPageBytes = 4096;

std::string errno_text(int err) {
  const char* name = strerrorname_np(err);
  return fmt::format("{}: {}", name ? name : "errno " + std::to_string(err), std::strerror(err));
}

std::string rlimit_text(rlim_t v) { return v == RLIM_INFINITY ? std::string("unlimited") : std::to_string(v); }

// "0-3,6" for the CPUs in `set`.
std::string cpu_list(const cpu_set_t& set) {
  std::string out;
  for (int c = 0; c < CPU_SETSIZE; ++c) {
    if (!CPU_ISSET(c, &set)) continue;
    int last = c;
    while (last + 1 < CPU_SETSIZE && CPU_ISSET(last + 1, &set)) ++last;
    if (!out.empty()) out += ',';
    out += last == c ? std::to_string(c) : fmt::format("{}-{}", c, last);
    c = last;
  }
  return out.empty() ? "none" : out;
}

// CPUs pinned by configure_realtime_thread, kept off-limits for the helper threads.
std::mutex g_pinned_mutex;
cpu_set_t g_pinned_cpus;  // zero-initialised (static storage)

bool kernel_is_preempt_rt(std::string& version) {
  utsname u{};
  if (uname(&u) == 0) version = u.version;
  if (version.find("PREEMPT_RT") != std::string::npos) return true;
  std::ifstream flag("/sys/kernel/realtime");
  int value = 0;
  return flag >> value && value == 1;
}

// Touches `bytes` of fresh stack below the caller's frame, one write per page, so those pages are
// mapped (and, after mlockall, locked) before the loop needs them.
[[gnu::noinline]] void touch_stack(std::size_t bytes) noexcept {
  auto* p = static_cast<volatile unsigned char*>(alloca(bytes));
  for (std::size_t i = 0; i < bytes; i += kPageBytes) p[i] = 0;
  p[bytes - 1] = 0;
}

void request_fifo(const RealtimeOptions& o, RealtimeReport& r) {
  sched_param sp{};
  sp.sched_priority = o.fifo_priority;
  int err = pthread_setschedparam(pthread_self(), SCHED_FIFO, &sp);
  if (err == 0) {
    r.fifo = true;
    r.priority = o.fifo_priority;
    return;
  }
  rlimit rl{};
  getrlimit(RLIMIT_RTPRIO, &rl);
  if (err == EPERM && rl.rlim_cur != RLIM_INFINITY && rl.rlim_cur > 0 &&
      rl.rlim_cur < static_cast<rlim_t>(o.fifo_priority)) {
    // The limit allows a lower priority: take it rather than none, and say so.
    sp.sched_priority = static_cast<int>(rl.rlim_cur);
    if (pthread_setschedparam(pthread_self(), SCHED_FIFO, &sp) == 0) {
      r.fifo = true;
      r.priority = sp.sched_priority;
      r.warnings.push_back(fmt::format(
          "SCHED_FIFO priority {} refused ({}); running at priority {} instead, the RLIMIT_RTPRIO "
          "limit. Raise it with 'rtprio {}' in /etc/security/limits.conf (log in again) or run as root.",
          o.fifo_priority, errno_text(err), r.priority, o.fifo_priority));
      return;
    }
  }
  if (err == EPERM) {
    r.warnings.push_back(fmt::format(
        "SCHED_FIFO priority {} refused ({}; RLIMIT_RTPRIO is {}): run as root, or grant CAP_SYS_NICE "
        "(setcap cap_sys_nice+ep <binary>), or add '<user> - rtprio 99' to /etc/security/limits.conf "
        "and log in again; in a container add --cap-add=SYS_NICE --ulimit rtprio=99. The loop runs "
        "SCHED_OTHER: timing will be best-effort.",
        o.fifo_priority, errno_text(err), rlimit_text(rl.rlim_cur)));
  } else {
    r.warnings.push_back(fmt::format("SCHED_FIFO priority {} refused ({}). The loop runs SCHED_OTHER: "
                                     "timing will be best-effort.",
                                     o.fifo_priority, errno_text(err)));
  }
}

// Locked memory of this process in KiB, from /proc/self/status (VmLck), or -1 if unreadable.
long locked_kib() {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind("VmLck:", 0) == 0) return std::atol(line.c_str() + 6);
  }
  return -1;
}

void request_memory_lock(RealtimeReport& r) {
  if (mlockall(MCL_CURRENT | MCL_FUTURE) == 0) {
    // Believe the kernel's accounting rather than the return value: sanitizer runtimes intercept
    // mlockall and return success without locking anything.
    if (locked_kib() != 0) {
      r.memory_locked = true;
      return;
    }
    r.warnings.push_back(
        "mlockall(MCL_CURRENT|MCL_FUTURE) returned success but the kernel reports no locked memory "
        "(VmLck: 0 kB; a sanitizer build intercepts mlockall). Page faults may stall the loop.");
    return;
  }
  const int err = errno;
  rlimit rl{};
  getrlimit(RLIMIT_MEMLOCK, &rl);
  const std::string limit = rl.rlim_cur == RLIM_INFINITY ? "unlimited" : fmt::format("{} KiB", rl.rlim_cur / 1024);
  r.warnings.push_back(fmt::format(
      "mlockall(MCL_CURRENT|MCL_FUTURE) refused ({}; RLIMIT_MEMLOCK is {}): run as root, or grant "
      "CAP_IPC_LOCK, or add '<user> - memlock unlimited' to /etc/security/limits.conf and log in "
      "again; in a container add --cap-add=IPC_LOCK --ulimit memlock=-1. Page faults may stall the loop.",
      errno_text(err), limit));
}

void request_pinning(const RealtimeOptions& o, RealtimeReport& r) {
  cpu_set_t set;
  CPU_ZERO(&set);
  CPU_SET(o.cpu, &set);
  const int err = pthread_setaffinity_np(pthread_self(), sizeof(set), &set);
  if (err == 0) {
    r.pinned = true;
    r.cpu = o.cpu;
    std::lock_guard lock(g_pinned_mutex);
    CPU_SET(o.cpu, &g_pinned_cpus);
    return;
  }
  cpu_set_t allowed;
  CPU_ZERO(&allowed);
  const std::string allowed_text =
      pthread_getaffinity_np(pthread_self(), sizeof(allowed), &allowed) == 0 ? cpu_list(allowed) : "unknown";
  r.warnings.push_back(fmt::format(
      "pinning to CPU {} refused ({}); this thread may use CPUs {} ({} online). Choose one of them, "
      "ideally one kept free of other work (isolcpus=/nohz_full= on the kernel command line). The "
      "loop will migrate between CPUs.",
      o.cpu, errno_text(err), allowed_text, sysconf(_SC_NPROCESSORS_ONLN)));
}

void prefault_stack(const RealtimeOptions& o, RealtimeReport& r) {
  std::size_t bytes = o.prefault_stack_bytes;
  pthread_attr_t attr;
  if (pthread_getattr_np(pthread_self(), &attr) == 0) {
    void* low = nullptr;
    std::size_t size = 0;
    pthread_attr_getstack(&attr, &low, &size);
    pthread_attr_destroy(&attr);
    const char here = 0;
    const auto used_top = reinterpret_cast<std::uintptr_t>(&here);
    const auto bottom = reinterpret_cast<std::uintptr_t>(low);
    const std::size_t free_bytes = used_top > bottom + kStackMarginBytes ? used_top - bottom - kStackMarginBytes : 0;
    if (bytes > free_bytes) {
      r.warnings.push_back(fmt::format(
          "stack prefault of {} KiB asked, but only {} KiB of this thread's stack are free; prefaulted "
          "{} KiB. Create the loop thread with a larger stack (pthread_attr_setstacksize).",
          bytes / 1024, free_bytes / 1024, free_bytes / 1024));
      bytes = free_bytes;
    }
  }
  if (bytes == 0) return;
  touch_stack(bytes);
  r.stack_prefaulted_bytes = bytes;
}

void log_report(const RealtimeReport& r) {
  if (r.warnings.empty()) {
    spdlog::info("{}", r.summary());
    return;
  }
  const std::string rule(100, '!');
  spdlog::warn("{}", rule);
  spdlog::warn("!!! REAL-TIME: {} warning(s), loop timing is NOT guaranteed", r.warnings.size());
  for (const std::string& w : r.warnings) spdlog::warn("!!! - {}", w);
  spdlog::warn("!!! {}", r.summary());
  spdlog::warn("{}", rule);
}

}  // namespace

std::string RealtimeReport::summary() const {
  return fmt::format(
      "real-time: SCHED_FIFO {} | memory locked: {} | pinned: {} | stack prefaulted: {} KiB | "
      "PREEMPT_RT kernel: {} | {} warning(s)",
      fifo ? fmt::format("priority {}", priority) : std::string("no (SCHED_OTHER)"), memory_locked ? "yes" : "no",
      pinned ? fmt::format("CPU {}", cpu) : std::string("no"), stack_prefaulted_bytes / 1024,
      preempt_rt_kernel ? "yes" : "no", warnings.size());
}

RealtimeReport configure_realtime_thread(const RealtimeOptions& options) {
  const int lo = sched_get_priority_min(SCHED_FIFO);
  const int hi = sched_get_priority_max(SCHED_FIFO);
  if (options.fifo_priority != 0 && (options.fifo_priority < lo || options.fifo_priority > hi)) {
    throw std::invalid_argument(fmt::format("RealtimeOptions.fifo_priority: expected 0 (off) or {}..{}, got {}",
                                            lo, hi, options.fifo_priority));
  }
  if (options.cpu < -1 || options.cpu >= CPU_SETSIZE) {
    throw std::invalid_argument(
        fmt::format("RealtimeOptions.cpu: expected -1 (don't pin) or 0..{}, got {}", CPU_SETSIZE - 1, options.cpu));
  }

  RealtimeReport r;
  std::string kernel_version;
  r.preempt_rt_kernel = kernel_is_preempt_rt(kernel_version);
  if (options.fifo_priority != 0) {
    request_fifo(options, r);
    if (!r.preempt_rt_kernel) {
      r.warnings.push_back(fmt::format(
          "the kernel is not PREEMPT_RT ('{}'): SCHED_FIFO helps, but wake-up latency is not bounded. "
          "Run the exoskeleton on a PREEMPT_RT kernel (Debian: linux-image-rt-amd64).",
          kernel_version));
    }
  }
  if (options.lock_memory) request_memory_lock(r);
  if (options.cpu >= 0) request_pinning(options, r);
  if (options.prefault_stack_bytes > 0) prefault_stack(options, r);
  if (options.timer_slack_ns > 0) prctl(PR_SET_TIMERSLACK, options.timer_slack_ns, 0, 0, 0);
  log_report(r);
  return r;
}

void make_thread_non_realtime() noexcept {
  sched_param sp{};
  sp.sched_priority = 0;
  pthread_setschedparam(pthread_self(), SCHED_OTHER, &sp);
  cpu_set_t set;
  CPU_ZERO(&set);
  {
    std::lock_guard lock(g_pinned_mutex);
    for (int c = 0; c < CPU_SETSIZE; ++c) {
      if (!CPU_ISSET(c, &g_pinned_cpus)) CPU_SET(c, &set);
    }
  }
  // The kernel intersects the mask with the CPUs the process may use; fall back to all of them if
  // that leaves none (every allowed CPU is pinned by a loop).
  if (pthread_setaffinity_np(pthread_self(), sizeof(set), &set) != 0) {
    for (int c = 0; c < CPU_SETSIZE; ++c) CPU_SET(c, &set);
    pthread_setaffinity_np(pthread_self(), sizeof(set), &set);
  }
}

ThreadCounters thread_counters() noexcept {
  rusage u{};
  if (getrusage(RUSAGE_THREAD, &u) != 0) return {};
  return {static_cast<std::uint64_t>(u.ru_minflt), static_cast<std::uint64_t>(u.ru_majflt), static_cast<std::uint64_t>(u.ru_nivcsw)};
}

PeriodicClock::PeriodicClock(double period_s) : period_ns_(std::llround(period_s * 1e9)) {
  if (!(period_s > 0) || !std::isfinite(period_s) || period_ns_ < 1) {
    throw std::invalid_argument(fmt::format("PeriodicClock: period_s must be > 0 and finite, got {}", period_s));
  }
}

std::int64_t PeriodicClock::now_ns() noexcept {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

void PeriodicClock::start() noexcept {
  t0_ns_ = now_ns();
  deadline_ns_ = t0_ns_;
  cycles_ = missed_ = overruns_ = last_skipped_ = max_skipped_ = 0;
  last_call_ns_ = t0_ns_;
}

double PeriodicClock::wait_next() noexcept {
  std::int64_t next = deadline_ns_ + period_ns_;
  const std::int64_t now = now_ns();
  last_call_ns_ = now;
  last_skipped_ = 0;
  if (now > next) {
    // Overran: skip every deadline already passed (counted), wake at the first one still ahead.
    ++overruns_;
    const std::int64_t skipped = (now - next) / period_ns_ + 1;
    missed_ += static_cast<std::uint64_t>(skipped);
    last_skipped_ = static_cast<std::uint64_t>(skipped);
    max_skipped_ = std::max(max_skipped_, last_skipped_);
    next += skipped * period_ns_;
  }
  const std::int64_t sleep_until = next - spin_ns_;
  timespec ts{};
  ts.tv_sec = static_cast<time_t>(sleep_until / 1'000'000'000);
  ts.tv_nsec = static_cast<long>(sleep_until % 1'000'000'000);
  while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
  }
  if (spin_ns_ > 0) {
    while (now_ns() < next) {
    }
  }
  deadline_ns_ = next;
  ++cycles_;
  return static_cast<double>(now_ns() - next) * 1e-9;
}

}  // namespace peha::runtime
