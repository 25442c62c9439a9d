#pragma once
// A child process for end-to-end tests (e.g. `peha mfb-emulator`): started with fork/exec, its
// stdout readable line by line, stopped with a signal, its exit status and output collected.

#include <string>
#include <vector>
#include <sys/types.h>

namespace peha::testing {

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

}  // namespace peha::testing
