// Small helpers the tests share: whole files as text, a fresh temporary directory, and a run of the
// `boresight` program (when the test defines BORESIGHT_CLI, the program's path) with its output.
#pragma once

#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <system_error>
#include <vector>
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

/// The directories makeTempDir made; removed with everything in them when the test program exits
/// normally (set BORESIGHT_KEEP_TEST_FILES to keep them for a look after a failure).
class TempDirs {
 public:
  static TempDirs& instance() {
    static TempDirs dirs;
    return dirs;
  }
  void add(const std::string& dir) { dirs_.push_back(dir); }
  ~TempDirs() {
    if (std::getenv("BORESIGHT_KEEP_TEST_FILES")) return;
    for (const auto& d : dirs_) {
      std::error_code ec;
      std::filesystem::remove_all(d, ec);
    }
  }

 private:
  std::vector<std::string> dirs_;
};

/// A new directory under the test's temporary directory, named PREFIX_XXXXXX, its own even when
/// ctest runs this program's tests as parallel processes; removed at exit (see TempDirs).
inline std::string makeTempDir(const std::string& prefix) {
  std::string tmpl = ::testing::TempDir() + prefix + "_XXXXXX";
  const char* d = ::mkdtemp(tmpl.data());
  if (!d) return ::testing::TempDir();
  TempDirs::instance().add(d);
  return std::string(d);
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
