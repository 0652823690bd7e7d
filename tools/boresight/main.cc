// boresight: one command-line program with subcommands.
#include "commands.h"

#include <cstdio>
#include <cstring>
#include <exception>
#include <new>

#include "../process_memory.h"

namespace {

struct Command {
  const char* name;
  const char* summary;
  int (*run)(int argc, char** argv);
};

// One line per subcommand; a subcommand that is not built yet is simply absent.
const Command kCommands[] = {
    {"inspect", "summarise Level-1 files: products, records, times, rejected lines, inter-boresight angles",
     boresight::cli::runInspect},
    {"convert", "Level-1 files to an LCM log ordered by sensor time, and back (--to-level1 DIR)",
     boresight::cli::runConvert},
#ifdef BORESIGHT_HAVE_PROCESS
    {"process", "run the real-time core over Level-1 files or an LCM log and write a CSV", boresight::cli::runProcess},
#endif
    {"plot", "line plots of CSV columns (e.g. process output) as SVG", boresight::cli::runPlot},
#ifdef BORESIGHT_HAVE_SIMULATE
    {"simulate", "simulate real-format telemetry with known truth and injected effects", boresight::cli::runSimulate},
#endif
#ifdef BORESIGHT_HAVE_CALIBRATE
    {"calibrate", "method A: each head's mounting-error angles with sigma, Cramer-Rao bound, observability",
     boresight::cli::runCalibrate},
#endif
#ifdef BORESIGHT_HAVE_BOUND
    {"bound", "method A's raw-data Cramer-Rao bound for a simulated span: what the raw measurements determine",
     boresight::cli::runBound},
#endif
#ifdef BORESIGHT_HAVE_AUDIT
    {"audit", "model audit: what the model gets wrong in measured data, the named cause, the gain of extending it",
     boresight::cli::runAudit},
#endif
#ifdef BORESIGHT_HAVE_NOISE
    {"noise", "the noise of every head and accelerometer axis from the data: a fitted model per axis",
     boresight::cli::runNoise},
#endif
#ifdef BORESIGHT_HAVE_GROUND
    {"ground", "star sensor to IMU mounting from a ground measurement (method C)", boresight::cli::runGround},
    {"simulate-ground", "simulate a method C ground measurement with its truth", boresight::cli::runSimulateGround},
#endif
};

void usage(std::FILE* out) {
  std::fprintf(out,
               "boresight - star sensor mounting calibration toolset\n\n"
               "usage: boresight COMMAND [options]   (boresight COMMAND --help for details)\n\ncommands:\n");
  for (const auto& c : kCommands) std::fprintf(out, "  %-10s %s\n", c.name, c.summary);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || !std::strcmp(argv[1], "--help") || !std::strcmp(argv[1], "-h") || !std::strcmp(argv[1], "help")) {
    usage(argc < 2 ? stderr : stdout);
    return argc < 2 ? 2 : 0;
  }
  if (!std::strcmp(argv[1], "--version")) {
    std::printf("boresight %s\n", BORESIGHT_VERSION);
    return 0;
  }
  boresight::tools::returnLargeBuffersToTheSystem();
  for (const auto& c : kCommands)
    if (!std::strcmp(argv[1], c.name)) {
      // Bad input never aborts: whatever a command lets escape ends it with exit status 1 and the reason.
      try {
        return c.run(argc - 1, argv + 1);
      } catch (const std::bad_alloc&) {
        std::fprintf(stderr, "boresight %s: out of memory (an input far larger than expected?)\n", c.name);
      } catch (const std::exception& e) {
        std::fprintf(stderr, "boresight %s: %s\n", c.name, e.what());
      } catch (...) {
        std::fprintf(stderr, "boresight %s: failed with an unknown exception\n", c.name);
      }
      return 1;
    }
  std::fprintf(stderr, "boresight: unknown command '%s'\n\n", argv[1]);
  usage(stderr);
  return 2;
}
