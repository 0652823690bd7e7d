// Command-line parsing for the subcommands that keep their own --help text (process, convert,
// inspect: the column and format descriptions do not fit CLI11's generated help). Same convention as
// cli_common.h: 0 after --help, 2 with "boresight NAME: reason" on usage errors; in addition a value
// that looks like an option is an error and unknown options are named.
#pragma once

#include "cli_common.h"

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

}  // namespace boresight::cli
