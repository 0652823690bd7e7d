// boresight bound --scenario FILE --seed N: the raw-data Cramer-Rao bound of method A for a simulated
// span (calib/raw_bound.h), computed from the simulation's truth in memory (no files are written).
#include <boresight/calib/raw_bound.h>
#include <boresight/calib/raw_bound_sim.h>
#include <boresight/core/conventions.h>
#include <boresight/core/rotation.h>
#include <boresight/io/files.h>
#include <boresight/report/text.h>
#include <boresight/sim/scenario.h>
#include <boresight/sim/simulator.h>

#include <nlohmann/json.hpp>

#include "cli_common.h"
#include "commands.h"

#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>

namespace boresight::cli {
// This file's own names, in a namespace of their own: the program builds as unity sources (several
// cmd_*.cc in one translation unit, tools/CMakeLists.txt), where anonymous namespaces would merge.
namespace cmd_bound {
namespace {

const char* kUsage =
    "usage: boresight bound --scenario FILE --seed N [--duration S] [--effect SPEC]... [--no-bias]\n"
    "                       [--scale] [--time-offset] [--harmonics K] [--json FILE] [--quiet]\n"
    "\n"
    "The raw-data Cramer-Rao bound of method A: how well the raw measurements of a span determine each\n"
    "head's mounting error, whatever the estimator. The span is simulated in memory from the scenario\n"
    "and seed (as `boresight simulate` would write it, same options); the bound is the Fisher\n"
    "information of the linearised raw model at the truth: every delivered head sample at its own rate\n"
    "with its noise model per head axis (white, coloured_noise, thermal_wander), the accelerometer's\n"
    "angular acceleration at its rate driving a free attitude trajectory (white, low-frequency,\n"
    "acc_coloured_noise, acc_bias_wander; no sample: free), blinding and gaps as holes. No filter, no\n"
    "decimation: a bound of the data, not of a pipeline. The field-of-view error, outliers and sign\n"
    "flips are not in it.\n"
    "\n"
    "Parameters: every head's constant mounting error (head axes e1, e2, b), the accelerometer bias\n"
    "(unless --no-bias) and, with the options, its scale, its time offset and orbit harmonics 1..K of\n"
    "heads 2..n's alignment. The accelerometer frame is the datum.\n"
    "\n"
    "  --scenario FILE   scenario YAML (config/sim_gracefo_calibration.yaml)\n"
    "  --seed N          random seed of the simulation\n"
    "  --duration S      seconds (default: the scenario's duration_s)\n"
    "  --effect SPEC     an effect added to the scenario, repeatable (boresight simulate --list-effects)\n"
    "  --no-bias         the accelerometer bias is known\n"
    "  --scale           the accelerometer scale per axis is a parameter\n"
    "  --time-offset     the accelerometer time offset is a parameter\n"
    "  --harmonics K     orbit harmonics 1..K of heads 2..n's alignment are parameters (0..8)\n"
    "  --json FILE       writes the bound: sigmas, principal directions, the information matrix\n"
    "  --quiet           the table only, no progress\n"
    "\n"
    "Output: per head axis the bound's sigma (arcsec) beside the injected constant error of the head in\n"
    "the accelerometer datum (its mounting error and relative misalignment, and the accelerometer's\n"
    "misalignment: what `boresight calibrate` estimates); the rotation common to all heads as principal body directions with their\n"
    "sigmas (inf: not determined, e.g. the rotation about the only excited axis); each head's\n"
    "alignment relative to head 1; the bias. Cost: O(n^2) per head sample and axis with n = 6 + the\n"
    "noise models' Gauss-Markov states (a power law counts three per decade).\n"
    "\n"
    "Exit status: 0 done; 1 a scenario that does not load or an output that cannot be written; 2 usage.\n";

int fail(const std::string& msg) {
  std::fprintf(stderr, "boresight bound: %s\n", msg.c_str());
  return 1;
}

double arcsec(double rad) { return rad / kRadPerArcsec; }

std::string sigmaText(double rad) { return std::isfinite(rad) ? report::fmt(arcsec(rad), "%.3g") : std::string("inf"); }

nlohmann::json finiteOrNull(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }

}  // namespace

int runBound(int argc, char** argv) {
  CLI::App app{"boresight bound"};
  std::string scenario, seed_s, json_path;
  std::vector<std::string> effects;
  double duration = 0;
  bool no_bias = false, quiet = false;
  calib::RawBoundOptions opt;
  app.add_option("--scenario", scenario)->required();
  app.add_option("--seed", seed_s)->required();
  app.add_option("--duration", duration)->check(finiteRange(1e-6, 366 * 86400.0));
  app.add_option("--effect", effects)->take_all()->expected(1)->allow_extra_args(false);
  app.add_flag("--no-bias", no_bias);
  app.add_flag("--scale", opt.scale);
  app.add_flag("--time-offset", opt.time_offset);
  app.add_option("--harmonics", opt.harmonics)->check(CLI::Range(0, 8));
  app.add_option("--json", json_path);
  app.add_flag("--quiet", quiet);
  if (int st = parseCommandLine(app, argc, argv, "bound", kUsage); st >= 0) return st;
  opt.bias = !no_bias;
  unsigned long long seed = 0;
  if (!parseSeed("bound", seed_s, seed)) return 2;
  std::string err;
  if (!json_path.empty() && !io::checkOutputs({scenario}, {{"--json", json_path}}, &err)) return fail(err);
  sim::Scenario sc;
  if (!sim::loadScenario(scenario, sc, &err) || !sim::addEffectArgs(sc, effects, &err)) return fail(err);
  sim::Simulator simulator;
  if (!simulator.init(sc, seed, duration, &err)) return fail(err);
  {
    Vec3 r_I, v_I;  // the harmonics' rate: the orbit's angular rate at the start
    simulator.orbit().posVel(toSeconds(sc.start), r_I, v_I);
    opt.orbit_rate_rad_s = r_I.cross(v_I).norm() / r_I.squaredNorm();
  }
  const calib::RawBoundConfig cfg = calib::rawBoundConfig(simulator.heads(), simulator.accel(), opt);
  if (const std::string e = cfg.validate(); !e.empty()) return fail(scenario + ": " + e);
  calib::RawBound bound(cfg);
  calib::RawBoundSimSink sink(bound, simulator);
  const auto t0 = std::chrono::steady_clock::now();
  ProgressBar bar(!quiet && ::isatty(::fileno(stderr)), "bounding");
  simulator.run(sink, [&](double f) { bar(f); });
  const calib::RawBoundResult r = bound.result();
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

  const auto& heads = simulator.heads();
  if (!quiet) {
    std::printf("raw-data bound: %s, seed %llu, %.0f s simulated; %zu states, %zu parameters; %.1f s wall\n",
                sc.file.c_str(), seed, simulator.duration(), bound.stateSize(), bound.parameterCount(), secs);
    for (std::size_t i = 0; i < heads.size(); ++i) {
      std::printf("  head %d: %llu samples; noise per axis (e1, e2, b):", heads[i].config().id,
                  static_cast<unsigned long long>(r.head_samples[i]));
      for (int j = 0; j < 3; ++j) std::printf(" %s%s", j ? "| " : "", cfg.heads[i].noise[static_cast<std::size_t>(j)].describe(1 / kRadPerArcsec, "\"").c_str());
      std::printf("\n");
    }
    std::printf("  accelerometer: %llu samples, %llu gaps; noise per axis (x, y, z):", static_cast<unsigned long long>(r.acc_samples),
                static_cast<unsigned long long>(r.acc_gaps));
    for (int a = 0; a < 3; ++a) std::printf(" %s%s", a ? "| " : "", cfg.acc_noise[static_cast<std::size_t>(a)].describe(1, " rad/s^2").c_str());
    std::printf("\n  parameters: mounting errors%s%s%s%s\n", opt.bias ? ", accelerometer bias" : "", opt.scale ? ", scale" : "",
                opt.time_offset ? ", time offset" : "",
                opt.harmonics > 0 ? (", orbit harmonics 1.." + std::to_string(opt.harmonics)).c_str() : "");
  }
  std::printf("\n%-6s %-5s %12s %14s %10s\n", "head", "axis", "sigma [\"]", "injected [\"]", "inj/sigma");
  static const char* kAxis[3] = {"e1", "e2", "b"};
  for (std::size_t i = 0; i < heads.size(); ++i) {
    const Vec3 inj = heads[i].toHeadAxes(calib::trueErrorInDatum(heads[i], simulator.accel()));
    for (int j = 0; j < 3; ++j) {
      const double s = r.head_sigma_rad[i](j);
      std::printf("%-6d %-5s %12s %14.2f %10s\n", heads[i].config().id, kAxis[j], sigmaText(s).c_str(), arcsec(inj(j)),
                  std::isfinite(s) ? report::fmt(std::abs(inj(j)) / s, "%.1f").c_str() : "-");
    }
  }
  std::printf("\ncommon rotation of all heads (body directions):\n");
  for (int k = 0; k < 3; ++k) {
    const Vec3 u = r.common_axes_B.col(k);
    std::printf("  (%+.3f, %+.3f, %+.3f)  sigma %s\"\n", u.x(), u.y(), u.z(), sigmaText(r.common_sigma_rad(k)).c_str());
  }
  if (heads.size() > 1) {
    std::printf("relative to head %d (head axes e1, e2, b):\n", heads[0].config().id);
    for (std::size_t i = 1; i < heads.size(); ++i)
      std::printf("  head %d: %s, %s, %s\"\n", heads[i].config().id, sigmaText(r.relative_sigma_rad[i](0)).c_str(),
                  sigmaText(r.relative_sigma_rad[i](1)).c_str(), sigmaText(r.relative_sigma_rad[i](2)).c_str());
  }
  if (opt.bias)
    std::printf("accelerometer bias sigma: %.3g, %.3g, %.3g rad/s^2\n", r.bias_sigma_rad_s2(0), r.bias_sigma_rad_s2(1),
                r.bias_sigma_rad_s2(2));

  if (!json_path.empty()) {
    nlohmann::json j;
    j["scenario"] = sc.file;
    j["seed"] = seed;
    j["duration_s"] = simulator.duration();
    j["options"] = {{"bias", opt.bias}, {"scale", opt.scale}, {"time_offset", opt.time_offset}, {"harmonics", opt.harmonics}};
    j["heads"] = nlohmann::json::array();
    for (std::size_t i = 0; i < heads.size(); ++i) {
      const Vec3 inj = heads[i].toHeadAxes(calib::trueErrorInDatum(heads[i], simulator.accel()));
      nlohmann::json h;
      h["id"] = heads[i].config().id;
      h["samples"] = r.head_samples[i];
      for (int a = 0; a < 3; ++a) {
        h["sigma_arcsec"].push_back(finiteOrNull(arcsec(r.head_sigma_rad[i](a))));
        h["injected_arcsec"].push_back(arcsec(inj(a)));
        h["relative_sigma_arcsec"].push_back(i ? finiteOrNull(arcsec(r.relative_sigma_rad[i](a))) : nlohmann::json(nullptr));
      }
      j["heads"].push_back(h);
    }
    for (int k = 0; k < 3; ++k) {
      const Vec3 u = r.common_axes_B.col(k);
      j["common"].push_back({{"direction_B", {u.x(), u.y(), u.z()}}, {"sigma_arcsec", finiteOrNull(arcsec(r.common_sigma_rad(k)))}});
    }
    if (opt.bias) j["acc_bias_sigma_rad_s2"] = {r.bias_sigma_rad_s2(0), r.bias_sigma_rad_s2(1), r.bias_sigma_rad_s2(2)};
    j["acc_samples"] = r.acc_samples;
    j["acc_gaps"] = r.acc_gaps;
    j["parameters"] = r.names;
    for (Eigen::Index a = 0; a < r.information.rows(); ++a) {
      std::vector<double> row(static_cast<std::size_t>(r.information.cols()));
      for (Eigen::Index b = 0; b < r.information.cols(); ++b) row[static_cast<std::size_t>(b)] = r.information(a, b);
      j["information_si"].push_back(row);
    }
    std::ofstream f(json_path);
    f << j.dump(1) << "\n";
    if (!f) return fail(json_path + ": cannot write");
    if (!quiet) std::printf("-> %s\n", json_path.c_str());
  }
  return 0;
}

}  // namespace cmd_bound

int runBound(int argc, char** argv) { return cmd_bound::runBound(argc, argv); }

}  // namespace boresight::cli
