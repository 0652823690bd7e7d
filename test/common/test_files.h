// Small helpers the tests share: whole files as text, a fresh temporary directory, and a run of the
// `boresight` program (when the test defines BORESIGHT_CLI, the program's path) with its output.
#pragma once

#include <gtest/gtest.h>

#include <cstdio>
#include <string>
#include <sys/wait.h>
#include <unistd.h>

namespace testutil {

/// The whole file (binary-safe); empty when it cannot be read.
inline std::string slurp(const std::string& path) {
  std::string s;
  if (std::FILE* f = std::fopen(path.c_str(), "rb")) {
    char b[65536];
    std::size_t n;
    while ((n = std::fread(b, 1, sizeof b, f)) > 0) s.append(b, n);
    std::fclose(f);
  }
  return s;
}

/// Writes BYTES to PATH (binary-safe, replacing it); false when the file cannot be written whole.
inline bool writeFile(const std::string& path, const std::string& bytes) {
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) return false;
  const bool ok = std::fwrite(bytes.data(), 1, bytes.size(), f) == bytes.size();
  return std::fclose(f) == 0 && ok;
}

/// A new directory under the test's temporary directory, named PREFIX_XXXXXX.
inline std::string makeTempDir(const std::string& prefix) {
  std::string tmpl = ::testing::TempDir() + prefix + "_XXXXXX";
  const char* d = ::mkdtemp(tmpl.data());
  return d ? std::string(d) : ::testing::TempDir();
}

struct CliRun {
  int status = -1;   ///< exit status (-1: did not exit normally)
  std::string out;   ///< stdout and stderr together
};

/// Runs `PROGRAM ARGS 2>&1` through the shell.
inline CliRun runProgram(const std::string& program, const std::string& args) {
  const std::string cmd = program + " " + args + " 2>&1";
  CliRun r;
  FILE* p = ::popen(cmd.c_str(), "r");
  if (!p) return r;
  char buf[4096];
  std::size_t n;
  while ((n = std::fread(buf, 1, sizeof buf, p)) > 0) r.out.append(buf, n);
  const int st = ::pclose(p);
  r.status = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  return r;
}

}  // namespace testutil
