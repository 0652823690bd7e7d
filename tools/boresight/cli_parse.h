// Command-line parsing of the subcommands on CLI11: our own --help text (kept in each cmd_*.cc),
// usage errors as "boresight CMD: reason" and exit status 2, unknown options named.
#pragma once

#include <CLI/CLI.hpp>

#include <cstdio>
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

/// Parses argv (argv[0] is the command name). Returns -1 to go on, else the exit status to return
/// (0 after --help, 2 on a usage error, with the message and the usage on stderr).
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
    std::fprintf(stderr, "boresight %s: %s\n\n%s", cmd, e.what(), usage);
    return 2;
  }
  if (help) {
    std::fputs(usage, stdout);
    return 0;
  }
  if (!app.remaining().empty()) {
    const std::string x = app.remaining().front();
    std::fprintf(stderr, "boresight %s: %s%s\n\n%s", cmd, x.size() > 1 && x[0] == '-' ? "unknown option " : "unexpected argument ",
                 x.c_str(), usage);
    return 2;
  }
  return -1;
}

}  // namespace boresight::cli
