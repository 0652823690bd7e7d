// Command-line parsing shared by the subcommands: CLI11 (Debian libcli11-dev), one convention for all.
//   CLI::App app{"what it does", "boresight NAME"};  ... add options ...
//   if (int rc = parseCommandLine(app, argc, argv); rc >= 0) return rc;
// Exit statuses: 0 after --help, 2 for a usage error (unknown option, missing or malformed value),
// printed as "boresight NAME: reason" and a pointer to --help on stderr.
#pragma once

#include <CLI/CLI.hpp>

#include <cstdio>
#include <string>

namespace boresight::cli {

/// -1: parsed, go on; otherwise the exit status to return.
inline int parseCommandLine(CLI::App& app, int argc, char** argv) {
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

}  // namespace boresight::cli
