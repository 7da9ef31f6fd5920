// Running the `lensim` binary from a test: its exit status and everything it printed.
#pragma once

#include <sys/wait.h>

#include <cstdio>
#include <string>

namespace lensim::test {

struct CliResult {
  int status = -1;  ///< exit status, -1 if it did not exit normally
  std::string out;  ///< stdout and stderr together
};

/// Runs `lensim ARGS` (the binary the build made) through the shell.
inline CliResult runLensim(const std::string& args) {
  const std::string cmd = std::string(LENSIM_BINARY) + " " + args + " 2>&1";
  CliResult r;
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) return r;
  char buf[4096];
  size_t n;
  while ((n = fread(buf, 1, sizeof buf, p)) > 0) r.out.append(buf, n);
  const int st = pclose(p);
  r.status = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  return r;
}

}  // namespace lensim::test
