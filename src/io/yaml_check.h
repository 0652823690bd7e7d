// Checked reading of YAML configuration nodes, shared by the platform file (core_config.cc) and the
// model overlay (overlay_yaml.cc): every error names the key and the line ("FILE:LINE: key 'k':
// reason" once the caller adds the file), a misspelt key names the nearest known one, a key given twice
// in one mapping is an error (yaml-cpp keeps both and returns the first), and numbers must be finite.
// Private to src/io.
#pragma once

#include <boresight/core/conventions.h>
#include <boresight/io/config_keys.h>
#include <boresight/io/time_format.h>

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <locale>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace boresight::io::yamlcheck {

struct Error : std::runtime_error {
  Error(const std::string& what, int line_) : std::runtime_error(what), line(line_) {}
  int line = 0;  ///< 1-based line of the offending node, 0 when unknown
};

inline int lineOf(const YAML::Node& n) { return n && n.IsDefined() && n.Mark().line >= 0 ? n.Mark().line + 1 : 0; }

/// The error names the key; `at` (when defined) gives the line.
[[noreturn]] inline void fail(const std::string& key, const std::string& why, const YAML::Node& at = YAML::Node()) {
  throw Error("key '" + key + "': " + why, lineOf(at));
}

/// "FILE:LINE: what" (or "FILE: what" without a line) for an Error caught by the caller.
inline std::string located(const std::string& file, const Error& e) {
  return file + ":" + (e.line > 0 ? std::to_string(e.line) + ":" : std::string()) + " " + e.what();
}

inline std::string join(const std::string& prefix, const std::string& k) { return prefix.empty() ? k : prefix + "." + k; }

/// Every key of the mapping n must be one of `known` (a misspelt key names the nearest known one) and
/// appear once.
inline void checkKeys(const YAML::Node& n, const std::string& prefix, const std::vector<std::string>& known) {
  if (!n || !n.IsMap()) return;
  std::set<std::string> seen;
  for (const auto& kv : n) {
    const std::string k = kv.first.Scalar();
    if (!seen.insert(k).second) fail(join(prefix, k), "given twice in this mapping", kv.first);
    if (std::find(known.begin(), known.end(), k) == known.end()) fail(join(prefix, k), unknownKeyMessage(k, known), kv.first);
  }
}

/// A finite number. ".nan", ".inf" and numbers beyond a double's range are refused.
inline double number(const YAML::Node& n, const std::string& key) {
  if (!n || n.IsNull()) fail(key, "missing (a number)", n);
  if (!n.IsScalar()) fail(key, "expected a number", n);
  const std::string& s = n.Scalar();
  char* end = nullptr;
  const double v = std::strtod(s.c_str(), &end);
  const bool whole = end && end != s.c_str() && *end == '\0';
  std::string low;
  for (char c : s) low += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  static const std::set<std::string> special = {".nan", "nan", ".inf", "+.inf", "-.inf", "inf", "+inf", "-inf",
                                                "infinity", "+infinity", "-infinity"};
  if (special.count(low) || (whole && !std::isfinite(v)))
    fail(key, "not a finite number ('" + s + "')", n);
  if (!whole) {
    try {  // YAML forms strtod does not take (e.g. "+.5" is fine for both; hex, octal)
      const double y = n.as<double>();
      if (!std::isfinite(y)) fail(key, "not a finite number ('" + s + "')", n);
      return y;
    } catch (const YAML::Exception&) {
      fail(key, "expected a number, not '" + s + "'", n);
    }
  }
  return v;
}

inline std::string rangeText(double lo, double hi) {
  std::ostringstream o;
  o.imbue(std::locale::classic());
  o << "[" << lo << ", " << hi << "]";
  return o.str();
}

/// A finite number in [lo, hi].
inline double numberIn(const YAML::Node& n, const std::string& key, double lo, double hi) {
  const double v = number(n, key);
  if (v < lo || v > hi) {
    std::ostringstream o;
    o.imbue(std::locale::classic());
    o << "value " << v << " outside " << rangeText(lo, hi);
    fail(key, o.str(), n);
  }
  return v;
}

/// An integer in [lo, hi].
inline long long integerIn(const YAML::Node& n, const std::string& key, long long lo, long long hi) {
  const double v = number(n, key);
  if (v != std::floor(v)) fail(key, "expected an integer", n);
  if (v < static_cast<double>(lo) || v > static_cast<double>(hi))
    fail(key, "value " + std::to_string(static_cast<long long>(v)) + " outside [" + std::to_string(lo) + ", " + std::to_string(hi) + "]", n);
  return static_cast<long long>(v);
}

/// A non-empty string scalar.
inline std::string text(const YAML::Node& n, const std::string& key) {
  if (!n || n.IsNull()) fail(key, "missing", n);
  if (!n.IsScalar() || n.Scalar().empty()) fail(key, "expected a non-empty text", n);
  return n.Scalar();
}

/// [x, y, z] of finite numbers in [lo, hi], times scale.
inline Vec3 vec3(const YAML::Node& n, const std::string& key, double lo, double hi, double scale = 1.0) {
  if (!n || n.IsNull()) fail(key, "missing ([x, y, z])", n);
  if (!n.IsSequence() || n.size() != 3) fail(key, "expected [x, y, z]", n);
  Vec3 v;
  for (std::size_t i = 0; i < 3; ++i) v[static_cast<int>(i)] = numberIn(n[i], key + "[" + std::to_string(i) + "]", lo, hi) * scale;
  return v;
}

/// [sx, sy, sz] of 1-sigmas >= 0 (at most hi), times scale; null is "not determined" (NaN).
inline Vec3 sigma3(const YAML::Node& n, const std::string& key, double hi, double scale = 1.0) {
  if (!n || n.IsNull()) fail(key, "missing ([sx, sy, sz]; null where not determined)", n);
  if (!n.IsSequence() || n.size() != 3) fail(key, "expected [sx, sy, sz] (null where not determined)", n);
  Vec3 v;
  for (std::size_t i = 0; i < 3; ++i)
    v[static_cast<int>(i)] = n[i].IsNull() ? std::numeric_limits<double>::quiet_NaN()
                                           : numberIn(n[i], key + "[" + std::to_string(i) + "]", 0, hi) * scale;
  return v;
}

/// A GPS calendar time "YYYY-MM-DD HH:MM:SS[.ffffff]" (or with T, or a date), years 1980-2100.
inline TimeUs gpsTime(const YAML::Node& n, const std::string& key) {
  const std::string s = text(n, key);
  TimeUs t = 0;
  if (!parseGpsCalendar(s, t)) fail(key, "expected a GPS calendar time \"YYYY-MM-DD HH:MM:SS[.ffffff]\", not '" + s + "'", n);
  const int year = civilFromTime(t).year;
  if (year < 1980 || year > 2100) fail(key, "year " + std::to_string(year) + " outside 1980-2100", n);
  return t;
}

}  // namespace boresight::io::yamlcheck
