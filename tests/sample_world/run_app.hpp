// Runs csm_flythrough (CSM_FLYTHROUGH_EXE) as a child process, capturing its exit code and
// everything it printed: the tests drive the app end to end, as a person would.
#pragma once

#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <string>

struct ProcessResult {
  int exitCode = -1;
  std::string output;
};

inline ProcessResult runApp(const std::string& args) {
  ProcessResult r;
  const std::string cmd = std::string(CSM_FLYTHROUGH_EXE) + " " + args + " 2>&1";
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) return r;
  std::array<char, 4096> buf{};
  while (fgets(buf.data(), buf.size(), p)) r.output += buf.data();
  const int status = pclose(p);
  r.exitCode = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}
