#pragma once
/// \file
/// Ctrl-C (SIGINT) and SIGTERM during a run: the run's loops end at their next cycle and wind down
/// as at their end (outputs disabled, logs flushed), instead of the process dying mid-cycle. A
/// second signal ends the process at once. `peha` then says so and exits with kInterruptedExitCode.

namespace peha::runtime {

/// The shell's convention for a process ended by SIGINT: 128 + 2.
inline constexpr int kInterruptedExitCode = 130;

/// While alive, SIGINT and SIGTERM set the flag interrupt_requested() reads (and print one line
/// to stderr); a second one ends the process with kInterruptedExitCode. Restores the previous
/// handlers when destroyed; nests (the innermost restores the outer one's).
class InterruptHandler {
 public:
  InterruptHandler();
  ~InterruptHandler();
  InterruptHandler(const InterruptHandler&) = delete;
  InterruptHandler& operator=(const InterruptHandler&) = delete;

 private:
  void (*previous_sigint_)(int) = nullptr;
  void (*previous_sigterm_)(int) = nullptr;
};

/// True once SIGINT or SIGTERM arrived under an InterruptHandler (stays true). Lock-free, noexcept:
/// the control loop reads it every cycle.
bool interrupt_requested() noexcept;

}  // namespace peha::runtime
