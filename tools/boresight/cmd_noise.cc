// boresight noise --config FILE INPUT... --out DIR: the noise of every head axis and accelerometer axis
// from the data, a model fitted per axis. Option parsing and printing only: noise::runNoise() replays
// the inputs and fits, noise::writeNoise* write the results.
#include <boresight/io/files.h>
#include <boresight/report/text.h>
#include <boresight/noise/run.h>

#include "cli_common.h"
#include "commands.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

namespace boresight::cli {
// This file's own names, in a namespace of their own: the program builds as unity sources (several
// cmd_*.cc in one translation unit, tools/CMakeLists.txt), where anonymous namespaces would merge.
namespace cmd_noise {
namespace {

const char* kUsage =
    "usage: boresight noise --config FILE INPUT... --out DIR [--overlay FILE] [--models LIST]\n"
    "                       [--max-samples N] [--acc-block S] [--likelihood L] [--every-structure]\n"
    "                       [--lookahead S] [--strict] [--quiet]\n"
    "\n"
    "Noise as the data has it: for every head axis (cross-boresight x, y and about the boresight, head\n"
    "axes) and every accelerometer axis (A frame), a noise model fitted to the data by maximum\n"
    "likelihood and chosen among candidates by BIC, with uncertainties and what the span and the\n"
    "sampling can determine.\n"
    "\n"
    "Heads: each head against the fused attitude of the other heads, in its own axes, at epochs where\n"
    "every configured head is present: the attitude cancels; what the other heads add is known from\n"
    "their fusion weights and is carried in the fit as a fixed part: its white part from the white\n"
    "levels of all head axes fitted at once (from the differences of consecutive epochs; independent\n"
    "of the platform file's levels), its coloured part from the other heads' fits of the previous\n"
    "pass. Accelerometer: the white level from independent first differences of the raw\n"
    "samples (thruster pulses left out as outliers); the slow part from block means of accelerometer\n"
    "minus star-sensor angular acceleration (the same CRN on both) where the span allows.\n"
    "\n"
    "INPUT: Level-1 files recognised by content (SCA1A, ACC1A, QSA1B for the nominal mountings when\n"
    "the config says heads.mounting: qsa1b) or an LCM log. Other products are listed as ignored.\n"
    "\n"
    "  --config FILE        platform file (config/gracefo.yaml)\n"
    "  --out DIR            writes DIR/noise.json (every axis: candidates, chosen model, parameters with\n"
    "                       sigmas, the determinable band; band_spectrum: across the band the chosen\n"
    "                       model's log PSD and the fitted candidates' Akaike-weighted average, each with\n"
    "                       its standard error, the average's holding the choice between them),\n"
    "                       DIR/noise.yaml (the chosen models in the platform file's noise form),\n"
    "                       DIR/overlay.yaml (the same as a model overlay for --overlay of process,\n"
    "                       calibrate, audit) and DIR/report.md with a log-log spectrum per axis against\n"
    "                       the fitted and the configured model and the average with +-2 standard errors\n"
    "  --overlay FILE       a model overlay whose noise replaces the platform file's (the configured model\n"
    "                       the data are compared with, and the other heads' part at the first fit)\n"
    "  --models LIST        candidate structures, comma-separated, of white, white+gauss_markov,\n"
    "                       white+2gauss_markov, white+power_law (default: all four)\n"
    "  --every-structure    fit every candidate on every axis (by default a richer structure is not\n"
    "                       fitted where the simpler pair below it shows nothing for it to take up:\n"
    "                       two terms or a power law where one term does not beat white, a power law\n"
    "                       where two terms do not beat one); slower, for comparing the candidates\n"
    "  --max-samples N      samples kept per axis; longer series keep every 2nd, 4th, ... (default 65536)\n"
    "  --acc-block S        block of the star-minus-accelerometer series, s (default 100)\n"
    "  --likelihood L       exact (state space: every sample, any gaps; seconds per axis on a day),\n"
    "                       whittle (periodograms of the gap-free runs, taken as independent;\n"
    "                       milliseconds), auto (default: whittle when 95 % of the samples lie in runs\n"
    "                       of at least a quarter of the span, else exact)\n"
    "  --lookahead S        out-of-order tolerance of the inputs, seconds (default 2)\n"
    "  --strict             stop at the first malformed input line\n"
    "  --quiet              print the table only\n"
    "\n"
    "Exit status: 0 done (whatever a short span could determine); 1 bad input (file:line: reason) or\n"
    "an output that cannot be written; 2 usage error.\n";

int fail(const std::string& msg) {
  std::fprintf(stderr, "boresight noise: %s\n", msg.c_str());
  return 1;
}

using report::fmt;  // include/boresight/report/text.h

}  // namespace

int runNoise(int argc, char** argv) {
  CLI::App app{"boresight noise"};
  noise::NoiseRequest req;
  std::string out_dir, models;
  bool quiet = false;
  app.add_option("--config", req.config)->required();
  app.add_option("--out", out_dir)->required();
  app.add_option("--overlay", req.overlay);
  app.add_option("--models", models);
  app.add_option("--max-samples", req.options.max_samples)->check(CLI::Range(std::size_t{64}, std::size_t{1} << 24));
  app.add_option("--acc-block", req.options.acc_block_s)->check(finiteRange(2.0, 86400.0));
  app.add_option("--lookahead", req.lookahead_s)->check(finiteRange(0.0, 3600.0));
  std::string likelihood = "auto";
  app.add_option("--likelihood", likelihood)->check(CLI::IsMember({"exact", "whittle", "auto"}));
  app.add_flag("--every-structure", req.options.every_structure);
  app.add_flag("--strict", req.strict);
  app.add_flag("--quiet", quiet);
  app.add_option("inputs", req.inputs)->required();
  if (int st = parseCommandLine(app, argc, argv, "noise", kUsage); st >= 0) return st;
  if (!models.empty()) {
    req.options.structures.clear();
    std::stringstream ss(models);
    for (std::string m; std::getline(ss, m, ',');) {
      bool found = false;
      for (auto s : {model::NoiseStructure::White, model::NoiseStructure::WhiteGaussMarkov,
                     model::NoiseStructure::WhiteTwoGaussMarkov, model::NoiseStructure::WhitePowerLaw})
        if (m == model::noiseStructureName(s)) {
          req.options.structures.push_back(s);
          found = true;
        }
      if (!found) {
        std::fprintf(stderr, "boresight noise: --models: unknown structure '%s' (white, white+gauss_markov, "
                             "white+2gauss_markov, white+power_law)\n", m.c_str());
        return 2;
      }
    }
  }
  req.options.likelihood = likelihood == "exact" ? model::NoiseLikelihood::Exact
                           : likelihood == "whittle" ? model::NoiseLikelihood::Whittle
                                                     : model::NoiseLikelihood::Auto;
  const std::string json = out_dir + "/noise.json", yaml = out_dir + "/noise.yaml", ovl = out_dir + "/overlay.yaml";
  // Outputs never destroy inputs; the output folder first, removed again when the run fails (OutputDir).
  std::string err;
  {
    std::vector<std::string> ins = req.inputs;
    ins.push_back(req.config);
    if (!req.overlay.empty()) ins.push_back(req.overlay);
    if (!io::checkOutputs(ins, {{"--out", out_dir, true}}, &err)) return fail(err);
    // ... nor the files it writes into the folder (an input kept there under one of their names).
    if (!io::checkOutputs(ins, {{"--out", json}, {"--out", yaml}, {"--out", ovl}, {"--out", out_dir + "/report.md"}}, &err))
      return fail(err);
  }
  io::OutputDir dir;
  if (!dir.open(out_dir, &err)) return fail(err);
  if (!quiet) req.progress = [](const std::string& s) { std::fprintf(stderr, "%s\n", s.c_str()); };

  noise::NoiseOutput out;
  if (!noise::runNoise(req, out, &err)) return fail(err);
  // Every record used or rejected, per source; under --quiet still the sources with rejected records
  // (quiet, but never silent about bad input).
  for (std::size_t i = 0; i < out.sources.size(); ++i) {
    const bool rejected_line = out.sources[i].rfind("    rejected ", 0) == 0;
    const std::size_t used = out.sources[i].find(" used");
    const bool has_rejects = used != std::string::npos && used + 5 < out.sources[i].size();  // ", K REASON" follows
    if (!quiet || rejected_line || has_rejects) std::printf("%s\n", out.sources[i].c_str());
  }
  if (!quiet) {
    for (const auto& s : out.inputs) std::printf("%s\n", s.c_str());
    const auto& c = out.counters;
    std::printf("inputs: %llu read = %llu used + %llu rejected; span %.1f s, %llu head epochs (%llu with every head), "
                "%llu accelerometer samples\n",
                static_cast<unsigned long long>(c.read), static_cast<unsigned long long>(c.used()),
                static_cast<unsigned long long>(c.rejectedTotal()), out.span_s, static_cast<unsigned long long>(out.epochs),
                static_cast<unsigned long long>(out.full_epochs), static_cast<unsigned long long>(out.acc_samples));
  }
  if (!quiet)
    for (const auto& s : out.model_in_use) std::printf("configured: %s\n", s.c_str());
  for (const auto& s : out.notes) std::printf("note: %s\n", s.c_str());
  std::printf("\n%-14s %-8s %-6s %8s  %-22s %s\n", "sensor", "axis", "part", "samples", "chosen (BIC)", "parameters [unit]");
  for (const auto& a : out.axes) {
    const bool slow = a.series.rfind("block", 0) == 0;
    std::printf("%-14s %-8s %-6s %8zu  ", a.sensor.c_str(), a.axis.c_str(), slow ? "slow" : "white", a.samples);
    if (!a.fitted()) {
      std::printf("%-22s %s\n", "not fitted", a.notes.empty() ? "" : a.notes.front().c_str());
      continue;
    }
    const auto& f = a.selection.chosen();
    std::string p;
    for (const auto& q : f.params) {
      p += (p.empty() ? "" : ", ") + q.name + " " + fmt(q.value, "%.4g");
      p += q.determined ? " +- " + fmt(q.sigma, "%.2g") : std::string(" (not determined)");
    }
    std::printf("%-22s %s [%s]\n", model::noiseStructureName(f.structure), p.c_str(), a.unit.c_str());
  }
  if (!noise::writeNoiseJson(json, out, &err) || !noise::writeNoiseYaml(yaml, out, &err) ||
      !noise::writeNoiseOverlay(ovl, out, std::string("boresight noise ") + BORESIGHT_VERSION, &err) ||
      !noise::writeNoiseReport(out_dir, out, &err))
    return fail(err);
  dir.keep();
  std::printf("-> %s/report.md, %s, %s, %s\n", out_dir.c_str(), json.c_str(), yaml.c_str(), ovl.c_str());
  return 0;
}

}  // namespace cmd_noise

int runNoise(int argc, char** argv) { return cmd_noise::runNoise(argc, argv); }

}  // namespace boresight::cli
