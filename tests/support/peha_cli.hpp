#pragma once
// Runs the built `peha` command (PEHA_BINARY) with its output and error together: what a test of
// the command line reads.

#include <array>
#include <cstdio>
#include <string>

#include <sys/wait.h>

namespace peha::testing {

struct CliResult {
  int code;
  std::string output;
};

/// `peha <args>`, its exit code and its output; `wrapper` runs before it (e.g. a timeout).
inline CliResult run_peha(const std::string& args, const std::string& wrapper = "") {
  const std::string cmd = wrapper + std::string(PEHA_BINARY) + " " + args + " 2>&1";
  FILE* pipe = popen(cmd.c_str(), "r");
  std::string out;
  std::array<char, 4096> buf;
  while (fgets(buf.data(), buf.size(), pipe)) out += buf.data();
  const int status = pclose(pipe);
  return {WEXITSTATUS(status), out};
}

}  // namespace peha::testing
