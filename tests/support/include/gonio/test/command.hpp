// A shell command run to its end in tests: what it printed on stdout and its exit status.
#pragma once

#include <sys/wait.h>

#include <cstdio>
#include <string>

namespace gonio::test {

struct CommandRun {
  int code = -1;  // the exit status; -1 when it did not exit (a signal) or could not start
  std::string out;
};

// Runs `cmd` through the shell (redirect stderr in `cmd` to keep it).
inline CommandRun run_command(const std::string& cmd) {
  CommandRun r;
  FILE* p = ::popen(cmd.c_str(), "r");
  if (!p) return r;
  char buf[4096];
  std::size_t n;
  while ((n = std::fread(buf, 1, sizeof buf, p)) > 0) r.out.append(buf, n);
  const int status = ::pclose(p);
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

}  // namespace gonio::test
