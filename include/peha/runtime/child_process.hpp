#pragma once
/// \file
/// A child process (e.g. `peha mfb-emulator` for `peha faults --link`, the end-to-end tests and the
/// link benchmark): started with fork/exec, its stdout and stderr readable line by line, signalled,
/// its exit status and output collected. Not for the control loop (it allocates and blocks).

#include <string>
#include <vector>
#include <sys/types.h>

namespace peha::runtime {

class ChildProcess {
 public:
  /// Starts `argv[0]` with `argv`; stdout and stderr go to a pipe.
  explicit ChildProcess(const std::vector<std::string>& argv);
  ~ChildProcess();  ///< SIGKILL if still running
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;

  /// Reads output until a line containing `needle` (returned) or `timeout_s`; "" on timeout/EOF.
  std::string wait_for_line(const std::string& needle, double timeout_s);
  /// Sends `signal` and waits up to `timeout_s` for the exit; returns the exit status (-1: still running).
  int stop(int signal, double timeout_s = 5.0);
  /// Waits for the exit (up to timeout_s) without signalling; exit status or -1.
  int wait(double timeout_s);
  /// Everything the child wrote so far (after wait/stop: all of it).
  const std::string& output();
  pid_t pid() const { return pid_; }
  /// Sends `signal` without waiting (e.g. SIGSTOP / SIGCONT to stall and resume it).
  void signal(int signal) const noexcept;

 private:
  void pump(double timeout_s);
  pid_t pid_ = -1;
  int fd_ = -1;
  int status_ = -1;
  bool exited_ = false;
  std::string output_;
};

/// The port in "listening on udp://A.B.C.D:PORT" (0 if absent).
int parse_listening_port(const std::string& line);

}  // namespace peha::runtime
