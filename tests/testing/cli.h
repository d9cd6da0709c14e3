#pragma once
// Shared test helper: runs the `tether` program (TETHER_CLI) with arguments and returns its
// exit code and everything it printed (stdout and stderr together).
#include <sys/wait.h>

#include <cstdio>
#include <string>

namespace tether {
namespace testing {

struct CliRun {
  int code;
  std::string output;  // stdout and stderr together
};

/// `env`: shell variable assignments put before the program (e.g. "LD_LIBRARY_PATH=/tmp/x").
inline CliRun Tether(const std::string& args, const std::string& env = "") {
  const std::string cmd = (env.empty() ? "" : env + " ") + std::string(TETHER_CLI) + " " + args + " 2>&1";
  FILE* p = popen(cmd.c_str(), "r");
  std::string out;
  char buf[4096];
  std::size_t n;
  while ((n = fread(buf, 1, sizeof(buf), p)) > 0) out.append(buf, n);
  const int status = pclose(p);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, out};
}

}  // namespace testing
}  // namespace tether
