// Small text helpers shared by the reports and the command-line tools.
#pragma once

#include <cmath>
#include <cstdio>
#include <string>

namespace boresight::report {

/// A number in printf format f ("%.3g" by default), or "-" when it is not finite.
inline std::string fmt(double v, const char* f = "%.3g") {
  if (!std::isfinite(v)) return "-";
  char b[64];
  std::snprintf(b, sizeof b, f, v);
  return b;
}

}  // namespace boresight::report
