// Minimal, strict command-line parsing shared by the subcommands.
//   Args a(argc, argv, {"--json", "--out"}, {"--help", "--quiet"});
//   if (!a.ok()) { print a.error() and usage; return 2; }
// Options that take a value accept "--opt VALUE" and "--opt=VALUE". Repeated options keep every value.
#pragma once

#include <cstdio>
#include <initializer_list>
#include <string>
#include <utility>
#include <vector>

namespace boresight::cli {

class Args {
 public:
  Args(int argc, char** argv, std::initializer_list<const char*> with_value,
       std::initializer_list<const char*> flags) {
    for (const char* v : with_value) with_value_.emplace_back(v);
    for (const char* f : flags) flags_.emplace_back(f);
    for (int i = 1; i < argc; ++i) {
      std::string a = argv[i];
      if (a.size() > 1 && a[0] == '-' && !positional_only_) {
        if (a == "--") {
          positional_only_ = true;
          continue;
        }
        std::string name = a, value;
        bool inline_value = false;
        auto eq = a.find('=');
        if (eq != std::string::npos) {
          name = a.substr(0, eq);
          value = a.substr(eq + 1);
          inline_value = true;
        }
        if (contains(flags_, name) && !inline_value) {
          values_.emplace_back(name, "");
        } else if (contains(with_value_, name)) {
          if (!inline_value) {
            if (i + 1 >= argc) {
              error_ = "option " + name + " needs a value";
              continue;
            }
            value = argv[++i];
          }
          values_.emplace_back(name, value);
        } else {
          error_ = "unknown option " + a;
        }
      } else {
        positional_.push_back(a);
      }
    }
  }

  bool ok() const { return error_.empty(); }
  const std::string& error() const { return error_; }
  bool has(const std::string& name) const {
    for (const auto& kv : values_)
      if (kv.first == name) return true;
    return false;
  }
  /// Last value given for the option, or `def`.
  std::string get(const std::string& name, const std::string& def = "") const {
    std::string v = def;
    for (const auto& kv : values_)
      if (kv.first == name) v = kv.second;
    return v;
  }
  std::vector<std::string> all(const std::string& name) const {
    std::vector<std::string> v;
    for (const auto& kv : values_)
      if (kv.first == name) v.push_back(kv.second);
    return v;
  }
  const std::vector<std::string>& positional() const { return positional_; }
  bool help() const { return has("--help") || has("-h"); }

 private:
  static bool contains(const std::vector<std::string>& v, const std::string& s) {
    for (const auto& x : v)
      if (x == s) return true;
    return false;
  }
  std::vector<std::string> with_value_, flags_, positional_;
  std::vector<std::pair<std::string, std::string>> values_;
  std::string error_;
  bool positional_only_ = false;
};

}  // namespace boresight::cli
