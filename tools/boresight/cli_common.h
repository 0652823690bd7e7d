// Command-line parsing shared by the subcommands: CLI11 (Debian libcli11-dev), one convention for all.
//   CLI::App app{"what it does", "boresight NAME"};  ... add options ...
//   if (int rc = parseCommandLine(app, argc, argv); rc >= 0) return rc;             // CLI11's help
//   if (int rc = parseCommandLine(app, argc, argv, "process", kUsage); rc >= 0) ... // own help text
// (process, convert and inspect keep their own --help text: their column and format descriptions do
// not fit CLI11's generated help.) Exit statuses: 0 after --help, 2 for a usage error (unknown
// option, missing or malformed value, a value that looks like an option), printed as
// "boresight NAME: reason" and a pointer to --help on stderr.
#pragma once

#include <CLI/CLI.hpp>

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstdio>
#include <exception>
#include <string>

namespace boresight::cli {

/// A validator for options that take a value: a value that looks like an option ("--out") is an
/// error, so `--config --out x.csv` does not take "--out" as the configuration path.
inline CLI::Validator notAnOption() {
  return CLI::Validator(
      [](std::string& v) -> std::string {
        if (v.size() > 1 && v[0] == '-' && !(v[1] >= '0' && v[1] <= '9') && v[1] != '.')
          return "value '" + v + "' looks like an option (is the value missing?)";
        return {};
      },
      "VALUE", "not an option");
}

/// A number in [lo, hi]: unlike CLI::Range, NaN and infinities are refused ("nan" compares false with
/// both bounds and would pass a range check).
inline CLI::Validator finiteRange(double lo, double hi) {
  return CLI::Validator(
      [lo, hi](std::string& v) -> std::string {
        double x = 0;
        try {
          std::size_t used = 0;
          x = std::stod(v, &used);
          if (used != v.size()) return "'" + v + "' is not a number";
        } catch (const std::exception&) {
          return "'" + v + "' is not a number";
        }
        if (!std::isfinite(x)) return "'" + v + "' is not a finite number";
        if (x < lo || x > hi) {
          char b[160];
          std::snprintf(b, sizeof b, "%s is outside %g .. %g", v.c_str(), lo, hi);
          return b;
        }
        return {};
      },
      "[" + std::to_string(lo) + " - " + std::to_string(hi) + "]", "finite range");
}

/// Any finite number (NaN and infinities refused).
inline CLI::Validator finiteNumber() { return finiteRange(-1e308, 1e308); }

/// Parses argv (argv[0] is the command name). Returns -1 to go on, else the exit status to return
/// (0 after --help with `usage` on stdout, 2 on a usage error with the reason on stderr).
inline int parseCommandLine(CLI::App& app, int argc, char** argv, const char* cmd, const char* usage) {
  bool help = false;
  app.set_help_flag();
  app.add_flag("-h,--help", help, "this help");
  app.allow_extras();
  for (CLI::Option* o : app.get_options())
    if (o->get_expected_min() > 0 && o->get_name() != "--help") o->check(notAnOption());
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (help) {
      std::fputs(usage, stdout);
      return 0;
    }
    std::fprintf(stderr, "boresight %s: %s\n(boresight %s --help lists the options)\n", cmd, e.what(), cmd);
    return 2;
  }
  if (help) {
    std::fputs(usage, stdout);
    return 0;
  }
  if (!app.remaining().empty()) {
    const std::string x = app.remaining().front();
    std::fprintf(stderr, "boresight %s: %s%s\n(boresight %s --help lists the options)\n", cmd,
                 x.size() > 1 && x[0] == '-' ? "unknown option " : "unexpected argument ", x.c_str(), cmd);
    return 2;
  }
  return -1;
}


/// -1: parsed, go on; otherwise the exit status to return.
inline int parseCommandLine(CLI::App& app, int argc, char** argv) {
  for (CLI::Option* o : app.get_options())
    if (o->get_expected_min() > 0 && o->get_name() != "--help") o->check(notAnOption());
  try {
    app.parse(argc, argv);  // argv[0] is the subcommand's name
    return -1;
  } catch (const CLI::CallForHelp&) {
    std::fputs(app.help().c_str(), stdout);
    return 0;
  } catch (const CLI::ParseError& e) {
    std::fprintf(stderr, "%s: %s\n(%s --help lists the options)\n", app.get_name().c_str(), e.what(),
                 app.get_name().c_str());
    return 2;
  }
}

/// A --seed value: an unsigned decimal integer (no sign, nothing after it, in range). False, with the
/// reason printed as "boresight CMD: --seed: 'TEXT' is not an unsigned integer", otherwise.
inline bool parseSeed(const char* cmd, const std::string& text, unsigned long long& seed) {
  char* end = nullptr;
  errno = 0;
  seed = std::strtoull(text.c_str(), &end, 10);
  if (text.empty() || *end || errno || text[0] == '-' || text[0] == '+' || text[0] == ' ') {
    std::fprintf(stderr, "boresight %s: --seed: '%s' is not an unsigned integer\n", cmd, text.c_str());
    return false;
  }
  return true;
}

/// A progress bar on stderr ("  LABEL [####....]  42%"), redrawn only when it moves; off: silent.
class ProgressBar {
 public:
  ProgressBar(bool on, const char* label) : on_(on), label_(label) {}
  void operator()(double f) {
    if (!on_) return;
    const int width = 40, done = static_cast<int>(f * width + 0.5);
    if (done == last_ && f < 1.0) return;
    last_ = done;
    std::fprintf(stderr, "\r  %s [", label_);
    for (int i = 0; i < width; ++i) std::fputc(i < done ? '#' : '.', stderr);
    std::fprintf(stderr, "] %3d%%", static_cast<int>(f * 100 + 0.5));
    if (f >= 1.0) std::fputc('\n', stderr);
    std::fflush(stderr);
  }

 private:
  bool on_;
  const char* label_;
  int last_ = -1;
};

}  // namespace boresight::cli
