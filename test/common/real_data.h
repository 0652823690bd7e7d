// Locating the real GRACE / GRACE-FO samples (../shared/data/real next to the project).
// Tests that need them call BORESIGHT_REQUIRE_REAL_DATA(), which skips with a clear message when the
// folder is absent. BORESIGHT_REAL_DATA in the environment overrides the location.
#pragma once

#include <gtest/gtest.h>

#include <cstdlib>
#include <string>
#include <sys/stat.h>

namespace boresight::test {

inline std::string realDataDir() {
  if (const char* e = std::getenv("BORESIGHT_REAL_DATA")) return e;
  return BORESIGHT_REAL_DATA_DIR;
}
inline bool realDataPresent() {
  struct stat st {};
  return ::stat(realDataDir().c_str(), &st) == 0 && S_ISDIR(st.st_mode);
}
inline std::string realFile(const std::string& rel) { return realDataDir() + "/" + rel; }

}  // namespace boresight::test

#define BORESIGHT_REQUIRE_REAL_DATA()                                                                  \
  do {                                                                                                 \
    if (!::boresight::test::realDataPresent())                                                         \
      GTEST_SKIP() << "real telemetry folder not found at " << ::boresight::test::realDataDir()        \
                   << " (set BORESIGHT_REAL_DATA to its location); skipping this real-data test";     \
  } while (0)
