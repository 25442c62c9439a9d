#include "peha/runtime/child_process.hpp"

#include <chrono>
#include <csignal>
#include <cstdlib>
#include <poll.h>
#include <stdexcept>
#include <sys/wait.h>
#include <unistd.h>

namespace peha::runtime {

ChildProcess::ChildProcess(const std::vector<std::string>& argv) {
  int fds[2];
  if (::pipe(fds) != 0) throw std::runtime_error("pipe failed");
  pid_ = ::fork();
  if (pid_ < 0) throw std::runtime_error("fork failed");
  if (pid_ == 0) {
    ::dup2(fds[1], STDOUT_FILENO);
    ::dup2(fds[1], STDERR_FILENO);
    ::close(fds[0]);
    ::close(fds[1]);
    std::vector<char*> args;
    for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    ::execv(args[0], args.data());
    std::_Exit(127);
  }
  ::close(fds[1]);
  fd_ = fds[0];
}

ChildProcess::~ChildProcess() {
  if (!exited_ && pid_ > 0) {
    ::kill(pid_, SIGKILL);
    ::waitpid(pid_, &status_, 0);
  }
  if (fd_ >= 0) ::close(fd_);
}

void ChildProcess::pump(double timeout_s) {
  pollfd p{fd_, POLLIN, 0};
  if (::poll(&p, 1, static_cast<int>(timeout_s * 1000)) > 0) {
    char buf[4096];
    const ssize_t n = ::read(fd_, buf, sizeof buf);
    if (n > 0) output_.append(buf, static_cast<std::size_t>(n));
  }
}

std::string ChildProcess::wait_for_line(const std::string& needle, double timeout_s) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (std::chrono::steady_clock::now() < end) {
    const auto at = output_.find(needle);
    if (at != std::string::npos) {
      const auto b = output_.rfind('\n', at);
      const auto e = output_.find('\n', at);
      if (e != std::string::npos) return output_.substr(b == std::string::npos ? 0 : b + 1, e - (b == std::string::npos ? 0 : b + 1));
    }
    pump(0.05);
  }
  return "";
}

int ChildProcess::wait(double timeout_s) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (!exited_ && std::chrono::steady_clock::now() < end) {
    pump(0.02);
    if (::waitpid(pid_, &status_, WNOHANG) == pid_) exited_ = true;
  }
  if (!exited_) return -1;
  for (int i = 0; i < 50; ++i) pump(0.0);  // the rest of the output
  return WIFEXITED(status_) ? WEXITSTATUS(status_) : 128 + WTERMSIG(status_);
}

void ChildProcess::signal(int signal) const noexcept {
  if (!exited_ && pid_ > 0) ::kill(pid_, signal);
}

int ChildProcess::stop(int signal, double timeout_s) {
  if (!exited_) ::kill(pid_, signal);
  return wait(timeout_s);
}

const std::string& ChildProcess::output() {
  pump(0.0);
  return output_;
}

int parse_listening_port(const std::string& line) {
  const auto at = line.find("udp://");
  if (at == std::string::npos) return 0;
  const auto colon = line.find(':', at + 6);
  return colon == std::string::npos ? 0 : std::atoi(line.c_str() + colon + 1);
}

}  // namespace peha::runtime
