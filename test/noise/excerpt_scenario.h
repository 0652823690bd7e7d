// The GRACE-FO scenario with the heads' white levels of the real C excerpt (config/preset_realistic.yaml's
// head_overrides) and the coloured effects a test names, simulated into a fresh directory, and
// `boresight noise` on its Level-1 files. Shared by the noise tests and benches that hide a coloured
// head error and ask the command to find it. Needs BORESIGHT_CLI and BORESIGHT_SOURCE_DIR.
#pragma once

#include <boresight/noise/run.h>

#include "test_files.h"

#include <gtest/gtest.h>

#include <string>

namespace testutil {

/// The excerpt's white levels per head: cross-boresight and about the boresight, arcsec.
constexpr double kExcerptCross[3] = {2.29, 1.69, 2.32}, kExcerptAbout[3] = {21.1, 30.8, 29.9};

/// Simulates `duration_s` of the scenario with `add_effects` (YAML lines of the list, each starting
/// "  - ") at `seed` into a fresh directory named after `tag`, then runs `boresight noise` on it with the
/// GRACE-FO platform file and `options`; fails the test (and returns false) when either step fails.
inline bool simulateExcerptScenarioAndFitNoise(const std::string& tag, const std::string& add_effects, int seed, int duration_s,
                                               const boresight::noise::NoiseOptions& options,
                                               boresight::noise::NoiseOutput& out) {
  const std::string d = makeTempDir(tag);
  std::string yaml = std::string("base: ") + BORESIGHT_SOURCE_DIR + "/config/sim_gracefo.yaml\nhead_overrides:\n";
  for (int h = 0; h < 3; ++h)
    yaml += "  - {id: " + std::to_string(h + 1) + ", noise_cross_arcsec: " + std::to_string(kExcerptCross[h]) +
            ", noise_about_arcsec: " + std::to_string(kExcerptAbout[h]) + "}\n";
  yaml += "add_effects:\n" + add_effects;
  if (!writeFile(d + "/scenario.yaml", yaml)) {
    ADD_FAILURE() << "cannot write " << d << "/scenario.yaml";
    return false;
  }
  const CliRun s = runProgram(BORESIGHT_CLI, "simulate --scenario " + d + "/scenario.yaml --seed " + std::to_string(seed) +
                                                 " --duration " + std::to_string(duration_s) + " --out " + d + " --quiet --no-lcm");
  if (s.status != 0) {
    ADD_FAILURE() << "simulate: " << s.out;
    return false;
  }
  boresight::noise::NoiseRequest req;
  req.config = std::string(BORESIGHT_SOURCE_DIR) + "/config/gracefo.yaml";
  req.inputs = {d + "/SCA1A_2023-06-01_C_04.txt", d + "/ACC1A_2023-06-01_C_04.txt", d + "/QSA1B_2023-06-01_C_04.txt"};
  req.options = options;
  std::string err;
  if (!boresight::noise::runNoise(req, out, &err)) {
    ADD_FAILURE() << "noise: " << err;
    return false;
  }
  return true;
}

}  // namespace testutil
