#include "peha/runtime/interrupt.hpp"

#include <atomic>
#include <csignal>
#include <unistd.h>

namespace peha::runtime {
namespace {

std::atomic<bool> g_interrupted{false};
static_assert(std::atomic<bool>::is_always_lock_free, "read and written in a signal handler");

extern "C" void on_interrupt(int) {
  if (g_interrupted.exchange(true)) _exit(kInterruptedExitCode);  // the second Ctrl-C: now
  // Only async-signal-safe calls here: write(2), not stdio.
  static constexpr char kMessage[] = "\ninterrupted (Ctrl-C): ending the run at its next cycle (Ctrl-C again: quit at once)\n";
  [[maybe_unused]] const ssize_t n = ::write(STDERR_FILENO, kMessage, sizeof kMessage - 1);
}

}  // namespace

InterruptHandler::InterruptHandler()
    : previous_sigint_(std::signal(SIGINT, on_interrupt)), previous_sigterm_(std::signal(SIGTERM, on_interrupt)) {}

InterruptHandler::~InterruptHandler() {
  std::signal(SIGINT, previous_sigint_);
  std::signal(SIGTERM, previous_sigterm_);
}

bool interrupt_requested() noexcept { return g_interrupted.load(std::memory_order_relaxed); }

}  // namespace peha::runtime
