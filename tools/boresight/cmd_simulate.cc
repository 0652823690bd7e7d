// boresight simulate: real-format GRACE-FO Level-1 telemetry with known truth and injected effects.
#include "cli_common.h"
#include <boresight/io/files.h>
#include "commands.h"

#include <boresight/model/effects.h>
#include <boresight/io/overlay_yaml.h>
#include <boresight/sim/output.h>
#include <boresight/sim/overlay.h>
#include <boresight/sim/scenario.h>
#include <boresight/sim/simulator.h>

#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <sys/stat.h>
#include <unistd.h>

namespace boresight::cli {
// This file's own names, in a namespace of their own: the program builds as unity sources (several
// cmd_*.cc in one translation unit, tools/CMakeLists.txt), where anonymous namespaces would merge.
namespace cmd_simulate {
namespace {

const char* kFooter =
    "Writes into DIR:\n"
    "  SCA1A_<date>_<sat>_<ver>.txt  all star-camera heads (blinded samples are absent)\n"
    "  ACC1A_..., GNV1B_...          accelerometer (10 Hz, frame A) and orbit (Earth-fixed, 1 Hz)\n"
    "  QSA1B_...                     the NOMINAL head alignment (the true one is in truth.yaml)\n"
    "  sim.lcmlog                    the node's input messages (NOMINAL_MOUNTINGS, STAR_HEAD, ACCEL,\n"
    "                                STAR_VECTORS, ORBIT)\n"
    "  truth.yaml                    seed, every injected effect, true mountings, run statistics\n"
    "\n"
    "--effect SPEC: NAME[:key=value,...], repeatable, e.g.\n"
    "  thermal_periodic:sensor=2,harmonic=1,x_arcsec=5\n"
    "  time_offset:sensor=acc,offset_ms=30\n"
    "`boresight simulate --list-effects` prints the catalogue.\n"
    "\n"
    "--overlay FILE: a model overlay (audit --write-model, calibrate --write-model) as the truth: its\n"
    "mountings, noise models, thermal, accelerometer terms and time offsets replace what the scenario\n"
    "says about the same items (include/boresight/sim/overlay.h); --effect specs come on top. Every item\n"
    "is printed as applied or not applied, with the reason.\n";

bool makeDirs(const std::string& dir, std::string* error) {
  std::string cur;
  for (std::size_t i = 0; i <= dir.size(); ++i) {
    if (i == dir.size() || dir[i] == '/') {
      if (!cur.empty() && ::mkdir(cur.c_str(), 0755) != 0 && errno != EEXIST) {
        if (error) *error = cur + ": " + std::strerror(errno);
        return false;
      }
    }
    if (i < dir.size()) cur += dir[i];
  }
  struct stat st {};
  if (::stat(dir.c_str(), &st) != 0 || !S_ISDIR(st.st_mode)) {
    if (error) *error = dir + ": not a directory";
    return false;
  }
  return true;
}

}  // namespace

int runSimulate(int argc, char** argv) {
  CLI::App app{"Simulates GRACE-FO-like telemetry (real Level-1 formats, an LCM log, truth.yaml) from a scenario\n"
               "(config/sim_gracefo.yaml) with named physical effects.",
               "boresight simulate"};
  std::string scenario, out, seed_s, overlay;
  std::vector<std::string> effects;
  double duration = 0;
  bool list_effects = false, no_lcm = false, quiet = false;
  app.add_option("--scenario", scenario, "scenario YAML (units and frames in its comments)")->type_name("FILE");
  app.add_option("--seed", seed_s, "random seed (unsigned); the same seed gives identical files")->type_name("N");
  app.add_option("--duration", duration, "simulated seconds (default: the scenario's duration_s)")
      ->check(finiteRange(1e-6, 366 * 86400.0))
      ->type_name("S");
  app.add_option("--out", out, "output folder (created)")->type_name("DIR");
  app.add_option("--effect", effects, "add an effect SPEC, repeatable (below)")->take_all()->expected(1)->allow_extra_args(false)->type_name("SPEC");
  app.add_option("--overlay", overlay, "a model overlay laid over the scenario as the truth (below)")->type_name("FILE");
  app.add_flag("--no-lcm", no_lcm, "do not write the LCM log");
  app.add_flag("--quiet", quiet, "no progress bar or summary");
  app.add_flag("--list-effects", list_effects, "print the effect catalogue and exit");
  app.footer(kFooter);
  if (const int rc = parseCommandLine(app, argc, argv); rc >= 0) return rc;
  if (list_effects) {
    std::printf("effects (NAME:key=value,...; angles in arcsec, times in s since the start):\n%s",
                model::effectCatalogueText().c_str());
    return 0;
  }
  if (scenario.empty() || out.empty() || seed_s.empty()) {
    std::fprintf(stderr, "boresight simulate: --scenario, --seed and --out are required (--help lists the options)\n");
    return 2;
  }
  unsigned long long seed = 0;
  if (!parseSeed("simulate", seed_s, seed)) return 2;
  std::string err;
  sim::Scenario sc;
  if (!sim::loadScenario(scenario, sc, &err)) {
    std::fprintf(stderr, "boresight simulate: %s\n", err.c_str());
    return 1;
  }
  if (!overlay.empty()) {
    model::Overlay ov;
    sim::ScenarioOverlayUse use;
    if (!io::readOverlay(overlay, ov, &err) || !sim::applyOverlay(ov, overlay, duration > 0 ? duration : sc.duration_s, sc, use, &err)) {
      std::fprintf(stderr, "boresight simulate: %s\n", err.c_str());
      return 1;
    }
    if (!quiet) {
      std::printf("overlay %s laid over the scenario:\n", overlay.c_str());
      for (const auto& s : use.applied) std::printf("  applied: %s\n", s.c_str());
      for (const auto& s : use.replaced) std::printf("  replaced: %s\n", s.c_str());
      for (const auto& s : use.notes) std::printf("  note: %s\n", s.c_str());
    }
    for (const auto& s : use.not_applied) std::fprintf(stderr, "boresight simulate: overlay %s: not applied: %s\n", overlay.c_str(), s.c_str());
  }
  if (!sim::addEffectArgs(sc, effects, &err)) {
    std::fprintf(stderr, "boresight simulate: %s\n", err.c_str());
    return 1;
  }
  sim::Simulator simulator;
  io::OutputDir out_dir;  // removed again when the run fails and it is empty
  if (!io::checkOutputs(overlay.empty() ? std::vector<std::string>{scenario} : std::vector<std::string>{scenario, overlay}, {{"--out", out, true}}, &err) || !out_dir.open(out, &err) ||
      !makeDirs(out, &err) || !simulator.init(sc, seed, duration, &err)) {
    std::fprintf(stderr, "boresight simulate: %s\n", err.c_str());
    return 1;
  }
  const bool lcm = sc.output.lcm_log && !no_lcm;
  std::vector<std::string> files;
  const auto t0 = std::chrono::steady_clock::now();
  ProgressBar bar(!quiet && ::isatty(::fileno(stderr)), "simulating");
  if (!sim::simulateIntoFolder(simulator, out, lcm, effects, [&](double f) { bar(f); }, files, &err)) {
    std::fprintf(stderr, "boresight simulate: %s\n", err.c_str());
    return 1;
  }
  out_dir.keep();
  if (!quiet) {
    const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const auto& st = simulator.stats();
    std::printf("simulated %.0f s from %s (seed %llu) in %.2f s wall\n", simulator.duration(), sc.file.c_str(), seed, secs);
    for (std::size_t i = 0; i < simulator.heads().size(); ++i)
      std::printf("  head %d: %llu samples, blinded sun/earth/moon %llu/%llu/%llu, missing %llu\n",
                  simulator.heads()[i].config().id, static_cast<unsigned long long>(st.head_samples[i]),
                  static_cast<unsigned long long>(st.head_blinded_sun[i]),
                  static_cast<unsigned long long>(st.head_blinded_earth[i]),
                  static_cast<unsigned long long>(st.head_blinded_moon[i]),
                  static_cast<unsigned long long>(st.head_missing[i]));
    std::printf("  accelerometer: %llu samples, missing %llu; thruster pulses %llu; max |alpha| %.3g rad/s^2\n",
                static_cast<unsigned long long>(st.acc_samples), static_cast<unsigned long long>(st.acc_missing),
                static_cast<unsigned long long>(st.thruster_pulses), st.max_abs_alpha);
    for (const auto& f : files) std::printf("  wrote %s\n", f.c_str());
    std::printf("  wrote %s/truth.yaml\n", out.c_str());
  }
  return 0;
}

}  // namespace cmd_simulate

int runSimulate(int argc, char** argv) { return cmd_simulate::runSimulate(argc, argv); }

}  // namespace boresight::cli
