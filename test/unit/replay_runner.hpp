// Runs cut_replay (or any command) as a user would, for the CLI tests.
#pragma once

#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <string>

namespace tissue_cut::test {

struct Outcome {
  int status;          ///< exit status, -1 when the command did not exit normally
  std::string output;  ///< stdout and stderr
};

inline Outcome run(const std::string& command) {
  Outcome r{-1, ""};
  FILE* pipe = popen((command + " 2>&1").c_str(), "r");
  if (!pipe) return r;
  std::array<char, 4096> buf;
  while (fgets(buf.data(), buf.size(), pipe)) r.output += buf.data();
  const int raw = pclose(pipe);
  r.status = WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
  return r;
}

/// cut_replay with `args`.
inline Outcome replay(const std::string& args) {
  return run(std::string(TISSUE_CUT_REPLAY) + " " + args);
}

}  // namespace tissue_cut::test
