// boresight simulate-ground: a simulated method C measurement file with its truth beside it.
#include "cli_common.h"
#include <boresight/io/files.h>
#include "commands.h"

#include <boresight/ground/simulate.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <string>

namespace boresight::cli {
// This file's own names, in a namespace of their own: the program builds as unity sources (several
// cmd_*.cc in one translation unit, tools/CMakeLists.txt), where anonymous namespaces would merge.
namespace cmd_simulate_ground {
namespace {

const char* kFooter =
    "Set-ups (--setup; the options after it change single values):\n"
    "  single     1 position, 1 prism face: the bias along the unreferenced horizontal axis is NOT separated\n"
    "  turned     3 positions turned 120 deg about the vertical, 1 face: NOT separated either\n"
    "  two-faces  1 position, prism faces +x and +y: separated\n"
    "  tilted     3 positions (level, tilted about lab x and lab y), 1 face: separated\n"
    "Writes FILE (the measurement format of `boresight ground`) and the truth beside it\n"
    "(FILE with .yaml replaced by .truth.yaml unless --truth is given).\n";

bool parseVec3(const std::string& s, Vec3& v) {
  std::stringstream ss(s);
  char c1 = 0, c2 = 0;
  double x = 0, y = 0, z = 0;
  if (!(ss >> x >> c1 >> y >> c2 >> z) || c1 != ',' || c2 != ',') return false;
  std::string rest;
  if (ss >> rest) return false;
  v = Vec3(x, y, z);
  return true;
}

}  // namespace

int runSimulateGround(int argc, char** argv) {
  CLI::App app{"Simulates a method C ground measurement (theodolites, prism, accelerometer, star sensor) with\n"
               "realistic noise and known truth.",
               "boresight simulate-ground"};
  ground::SimConfig cfg;
  std::string out, truth_path, setup = "single", bias_s;
  std::string seed_s;
  app.add_option("--seed", seed_s, "random seed (unsigned); the same seed gives identical files")
      ->type_name("N");
  app.add_option("--out", out, "measurement file to write (YAML)")->type_name("FILE");
  app.add_option("--truth", truth_path, "truth file (default: beside --out, .truth.yaml)")->type_name("FILE");
  app.add_option("--setup", setup, std::string("named set-up: ") + ground::setupNames() + " (default single)")
      ->type_name("NAME");
  app.add_option("--positions", cfg.positions, "number of positions")->check(finiteRange(1, 100))->type_name("N");
  app.add_option("--turn-deg", cfg.turn_deg, "position k turned by k*D about the vertical")->type_name("D")->check(finiteNumber());
  app.add_option("--tilt-deg", cfg.tilt_deg, "positions k >= 1 tilted by T about lab x (odd k) / lab y (even k)")
      ->type_name("T")->check(finiteNumber());
  app.add_option("--prism-faces", cfg.prism_faces, "1 (+x) or 2 (+x, +y)")->check(finiteRange(1, 2))->type_name("N");
  app.add_option("--targets", cfg.targets, "targets per position (default 40)")->check(finiteRange(4, 100000))->type_name("N");
  app.add_option("--accel-samples", cfg.accel_samples, "accelerometer samples per position (default 2000)")
      ->check(finiteRange(1, 10000000))
      ->type_name("N");
  app.add_option("--centroid-sigma-px", cfg.centroid_sigma_px, "centroid noise (default 0.05 px)")->type_name("PX")->check(finiteNumber());
  app.add_option("--theodolite-sigma-arcsec", cfg.theodolite_sigma_arcsec, "theodolite direction noise (default 1.5)")
      ->type_name("AS")->check(finiteNumber());
  app.add_option("--accel-noise-ug", cfg.accel_noise_ug, "accelerometer noise per sample (default 50 ug)")->type_name("UG")->check(finiteNumber());
  app.add_option("--bias-sigma-ug", cfg.accel_bias_sigma_ug, "bias drawn per axis with this sigma (default 100 ug)")
      ->type_name("UG")->check(finiteNumber());
  app.add_option("--bias-ug", bias_s, "fixed bias instead, IMU axes, e.g. 100,-100,100")->type_name("X,Y,Z");
  app.add_option("--mounting-sigma-arcsec", cfg.mounting_sigma_arcsec, "true mounting error per axis (default 300)")
      ->type_name("AS")->check(finiteNumber());
  app.add_option("--radial-k1", cfg.true_k1, "true radial distortion k1 (default 0)")->type_name("K1")->check(finiteNumber());
  double k1_prior = 0;
  app.add_option("--k1-prior-sigma", k1_prior, "write radial_k1_sigma: the refinement estimates k1 under this prior")
      ->type_name("S")->check(finiteNumber());
  app.footer(kFooter);
  if (const int rc = parseCommandLine(app, argc, argv); rc >= 0) return rc;
  if (!app.count("--seed") || out.empty()) {
    std::fprintf(stderr, "boresight simulate-ground: --seed and --out are required (--help lists the options)\n");
    return 2;
  }
  // the set-up first, then the single options that were given explicitly
  ground::SimConfig base = cfg;
  if (!ground::applySetup(setup, base)) {
    std::fprintf(stderr, "boresight simulate-ground: --setup: unknown set-up '%s' (%s)\n", setup.c_str(),
                 ground::setupNames());
    return 2;
  }
  if (app.count("--positions")) base.positions = cfg.positions;
  if (app.count("--turn-deg")) base.turn_deg = cfg.turn_deg;
  if (app.count("--tilt-deg")) base.tilt_deg = cfg.tilt_deg;
  if (app.count("--prism-faces")) base.prism_faces = cfg.prism_faces;
  cfg = base;
  {
    unsigned long long seed = 0;
    if (!parseSeed("simulate-ground", seed_s, seed)) return 2;
    cfg.seed = seed;
  }
  if (!bias_s.empty()) {
    if (!parseVec3(bias_s, cfg.bias_ug)) {
      std::fprintf(stderr, "boresight simulate-ground: --bias-ug: expected X,Y,Z in ug, got '%s'\n", bias_s.c_str());
      return 2;
    }
    cfg.fixed_bias = true;
  }
  if (k1_prior > 0) {
    cfg.camera.estimate_k1 = true;
    cfg.camera.k1_sigma = k1_prior;
  }
  if (truth_path.empty()) {
    const std::string ext = ".yaml";
    truth_path = (out.size() > ext.size() && out.compare(out.size() - ext.size(), ext.size(), ext) == 0
                      ? out.substr(0, out.size() - ext.size())
                      : out) +
                 ".truth.yaml";
  }
  ground::Measurement m;
  ground::SimTruth truth;
  std::string err;
  if (!io::checkOutputs({}, {{"--out", out}, {"--truth", truth_path}}, &err) ||
      !ground::simulateGround(cfg, m, truth, &err) || !ground::writeMeasurement(out, m, &err) ||
      !ground::writeTruth(truth_path, cfg, truth, &err)) {
    std::fprintf(stderr, "boresight simulate-ground: %s\n", err.c_str());
    return 1;
  }
  std::printf("wrote %s and %s (%d positions, %d prism faces, %d targets and %d accelerometer samples each)\n",
              out.c_str(), truth_path.c_str(), cfg.positions, cfg.prism_faces, cfg.targets, cfg.accel_samples);
  return 0;
}

}  // namespace cmd_simulate_ground

int runSimulateGround(int argc, char** argv) { return cmd_simulate_ground::runSimulateGround(argc, argv); }

}  // namespace boresight::cli
