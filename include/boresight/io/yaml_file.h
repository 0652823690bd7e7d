// Loading the YAML files of boresight (platform, node, scenario, truth, ground measurement): bounded
// (io/files.h: a directory, a missing file or one above its size limit is refused with the reason),
// parsed, and checked for duplicated keys (yaml-cpp keeps both and the first one wins silently; here
// the second is an error with its line). Header-only: include it where yaml-cpp is linked.
#pragma once

#include <boresight/io/files.h>

#include <yaml-cpp/yaml.h>

#include <set>
#include <string>

namespace boresight::io {

/// 1-based line of a node, 0 when it has none.
inline int yamlLine(const YAML::Node& n) {
  return n && n.IsDefined() && n.Mark().line >= 0 ? n.Mark().line + 1 : 0;
}

/// "PATH:LINE: " (or "PATH: " without a line).
inline std::string yamlPlace(const std::string& path, int line) {
  return line > 0 ? path + ":" + std::to_string(line) + ": " : path + ": ";
}

/// False with *error "PATH:LINE: key 'a.b': given twice in this mapping (first at line N)" for the first
/// key that appears twice in one mapping, anywhere in the tree (the wording of yamlcheck::checkKeys,
/// which finds the same in the mappings it checks).
inline bool checkDuplicateKeys(const YAML::Node& n, const std::string& path, std::string* error,
                               const std::string& prefix = {}) {
  if (n.IsMap()) {
    std::set<std::string> seen;
    std::vector<std::pair<std::string, int>> first;
    for (const auto& kv : n) {
      const std::string k = kv.first.IsScalar() ? kv.first.Scalar() : std::string("(complex key)");
      const std::string full = prefix.empty() ? k : prefix + "." + k;
      if (!seen.insert(k).second) {
        int at = 0;
        for (const auto& f : first)
          if (f.first == k) at = f.second;
        if (error)
          *error = yamlPlace(path, yamlLine(kv.first)) + "key '" + full +
                   "': given twice in this mapping (first at line " + std::to_string(at) + "); remove one of them";
        return false;
      }
      first.emplace_back(k, yamlLine(kv.first));
      if (!checkDuplicateKeys(kv.second, path, error, full)) return false;
    }
  } else if (n.IsSequence()) {
    for (std::size_t i = 0; i < n.size(); ++i)
      if (!checkDuplicateKeys(n[i], path, error, prefix + "[" + std::to_string(i) + "]")) return false;
  }
  return true;
}

/// Parses YAML text (from `path`, for messages) and refuses duplicated keys. False with *error
/// ("PATH:LINE:COL: reason" for a syntax error).
inline bool parseYaml(const std::string& text, const std::string& path, YAML::Node& root, std::string* error) {
  try {
    root = YAML::Load(text);
  } catch (const YAML::ParserException& e) {
    if (error)
      *error = path + ":" + std::to_string(e.mark.line + 1) + ":" + std::to_string(e.mark.column + 1) + ": " + e.msg;
    return false;
  } catch (const YAML::Exception& e) {
    if (error) *error = path + ": " + e.what();
    return false;
  }
  return checkDuplicateKeys(root, path, error);
}

/// readBounded (at most max_bytes) then parseYaml. `what` names the file in messages
/// ("configuration file").
inline bool loadYamlFile(const std::string& path, YAML::Node& root, std::string* error, const char* what,
                         std::uint64_t max_bytes = kMaxConfigBytes) {
  std::string text;
  if (!readBounded(path, max_bytes, what, text, error)) return false;
  return parseYaml(text, path, root, error);
}

}  // namespace boresight::io
