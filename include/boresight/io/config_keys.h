// Checking the keys of configuration files: a misspelt key is an error that names the nearest known
// key, never a silent fall-back to a default. Used by the platform loader (core_config.cc) and the
// scenario loader (sim/scenario.cc).
#pragma once

#include <algorithm>
#include <cstddef>
#include <string>
#include <vector>

namespace boresight::io {

/// Levenshtein distance (insertions, deletions, substitutions), case-sensitive.
inline std::size_t editDistance(const std::string& a, const std::string& b) {
  std::vector<std::size_t> prev(b.size() + 1), cur(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) prev[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    cur[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t sub = prev[j - 1] + (a[i - 1] == b[j - 1] ? 0 : 1);
      cur[j] = std::min({prev[j] + 1, cur[j - 1] + 1, sub});
    }
    std::swap(prev, cur);
  }
  return prev[b.size()];
}

/// The known key nearest to `key` (smallest edit distance; the first on ties), "" when none is
/// within a plausible typo distance (a third of the key's length, at least 2).
inline std::string nearestKey(const std::string& key, const std::vector<std::string>& known) {
  std::string best;
  std::size_t best_d = static_cast<std::size_t>(-1);
  for (const auto& k : known) {
    const std::size_t d = editDistance(key, k);
    if (d < best_d) {
      best_d = d;
      best = k;
    }
  }
  const std::size_t limit = std::max<std::size_t>(2, key.size() / 3);
  return best_d <= limit ? best : std::string();
}

/// "unknown key; did you mean 'x'?" or "unknown key (known here: a, b, c)".
inline std::string unknownKeyMessage(const std::string& key, const std::vector<std::string>& known) {
  const std::string near = nearestKey(key, known);
  if (!near.empty()) return "unknown key; did you mean '" + near + "'?";
  std::string list;
  for (const auto& k : known) list += (list.empty() ? "" : ", ") + k;
  return "unknown key (known here: " + list + ")";
}

}  // namespace boresight::io
