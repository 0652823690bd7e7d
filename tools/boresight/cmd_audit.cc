// boresight audit --config FILE INPUT... --out DIR: the model audit (METHODS 4). Option parsing and
// printing only: audit::runAudit() replays the inputs into the audit's collector and analyses them,
// audit::writeAuditJson / writeAuditReport write the result.
#include <boresight/audit/extension.h>
#include <boresight/audit/report.h>
#include <boresight/io/overlay_yaml.h>
#include <boresight/report/text.h>
#include <boresight/io/files.h>
#include <boresight/audit/run.h>
#include <boresight/audit/simulated.h>
#include <boresight/io/time_format.h>
#include <boresight/report/svg_plot.h>
#include <boresight/sim/output.h>
#include <boresight/sim/overlay.h>
#include <boresight/sim/scenario.h>
#include <boresight/sim/simulator.h>
#include <boresight/stream/source.h>

#include "cli_common.h"
#include "commands.h"
#include "model_json.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

namespace boresight::cli {
// This file's own names, in a namespace of their own: the program builds as unity sources (several
// cmd_*.cc in one translation unit, tools/CMakeLists.txt), where anonymous namespaces would merge.
namespace cmd_audit {
namespace {

const char* kUsage =
    "usage: boresight audit --config FILE INPUT... --out DIR [--truth truth.yaml] [--false-alarm P]\n"
    "                       [--overlay FILE] [--holdout-blocks N] [--max-harmonic N] [--lookahead S] [--strict]\n"
    "                       [--write-model FILE] [--white-rows] [--quiet]\n"
    "\n"
    "The model audit: shows what the configured model gets wrong in measured data, names the cause from\n"
    "the effect catalogue (boresight simulate --list-effects), extends the model with it and measures\n"
    "the gain on data not used to fit.\n"
    "\n"
    "INPUT: Level-1 files, recognised by content: SCA1A (heads), ACC1A (accelerometer), QSA1B (the\n"
    "nominal mountings when the config says heads.mounting: qsa1b), GNI1B or GNV1B (orbit context:\n"
    "argument of latitude and beta angle, for the orbit-periodic tests), and optionally SCA1B as an\n"
    "outside reference with CLK1B (SCA1B's GPS tags are mapped to the receiver time of SCA1A through\n"
    "CLK1B; without it GPS time is taken as receiver time, and the output says so); or an LCM log\n"
    "(its ORBIT messages are the orbit context). Other products are listed as ignored.\n"
    "\n"
    "Residual families: relative (head pair residuals and inter-boresight angles against the\n"
    "configured mountings), noise (per head axis), angular_acceleration (star sensors minus\n"
    "accelerometer through the same CRN; needs a span longer than the CRN), reference (fused attitude\n"
    "against SCA1B), data (gaps and dropouts against the platform file's data_events rates and longest\n"
    "runs, outliers, sign flips). Every candidate effect is tested with\n"
    "a statistic against a threshold at a family-wise false-alarm rate over the whole catalogue; the\n"
    "causes the evidence supports are named, groups the data cannot separate are reported with what\n"
    "would separate them, and significant residuals nothing explains are reported as not explained.\n"
    "\n"
    "  --config FILE          platform file (config/gracefo.yaml; config/gracefo_ideal.yaml for data simulated\n"
    "                         with the ideal noise preset)\n"
    "  --overlay FILE         a model overlay (README \"The model overlay\"): its noise models replace the\n"
    "                         platform file's (the levels the noise tests compare with), its mountings the\n"
    "                         nominal ones, its thermal terms make the heads' mountings follow the argument\n"
    "                         of latitude (needs the orbit), its accelerometer terms correct every\n"
    "                         accelerometer sample; the parts the audit does not use are listed as not applied\n"
    "  --out DIR              writes DIR/report.md (findings, evidence, gain table, plots), DIR/audit.json\n"
    "                         (keys: baseline, effects[], named_causes[], not_explained[], ambiguous[],\n"
    "                         extended, gain, gains[], truth[] with --truth) and the SVG plots\n"
    "  --truth FILE           a simulator's truth.yaml: parameter errors before and after the extension\n"
    "  --write-model FILE     the extended model as a model overlay (README \"The model overlay\"; the --overlay's\n"
    "                         content extended): relative misalignments as mountings (datum: the heads\n"
    "                         together, the fused attitude unchanged), thermal harmonics (relative to the datum\n"
    "                         head), accelerometer bias / scale / misalignment, head noise levels and a\n"
    "                         Gauss-Markov part, time offsets; what it cannot carry (steps, drifts, ...) is\n"
    "                         listed. The audit then runs again on the same inputs with that overlay\n"
    "                         applied (the pipeline re-run) and reports, per family, the held-out RMS with\n"
    "                         the configured model against the extension applied, and what is still named\n"
    "                         (audit.json key extension, report.md section)\n"
    "  --simulate-model SCENARIO  with --write-model: closes the loop. The extended model is simulated\n"
    "                         (the scenario's orbit, attitude and stars; the overlay as its truth, sim/overlay.h;\n"
    "                         the data's span; files in DIR/model_simulation) and audited with the overlay\n"
    "                         applied, as the data were on the second pass: the held-out RMS and the residual\n"
    "                         spectra (in bands) of the data and of the simulation are compared, side by side\n"
    "                         in the report (audit.json key extension.simulation)\n"
    "  --simulate-seed N      seed of that simulation (default 1)\n"
    "  --false-alarm P        family-wise false-alarm probability over every test (default 0.01)\n"
    "  --holdout-blocks N     the span is cut into 2N blocks; every other block is held out to measure\n"
    "                         the gain (default 4); with an orbit context and three orbits or more,\n"
    "                         whole orbits are held out instead (every other one; first and last fitted)\n"
    "  --max-harmonic N       largest orbit harmonic tested, cycles per revolution (default 4);\n"
    "                         every order is a candidate of its own; the not-explained test looks\n"
    "                         for lines up to twice this order\n"
    "  --lookahead S          out-of-order tolerance of the inputs, seconds (default 2)\n"
    "  --strict               stop at the first malformed input line\n"
    "  --white-rows           the relative and reference families' tests without the noise colour in time\n"
    "                         (one lag-1 variance inflation per family, as before the colour was fitted;\n"
    "                         to compare: slow noise is then read as steps, drifts and harmonics)\n"
    "  --quiet                print the findings and the rejected inputs only (no progress, no input summary)\n"
    "\n"
    "Exit status: 0 audited (whatever was found); 1 bad input (file:line: reason) or an output that\n"
    "cannot be written; 2 usage error.\n";

int fail(const std::string& msg) {
  std::fprintf(stderr, "boresight audit: %s\n", msg.c_str());
  return 1;
}

using report::fmt;  // include/boresight/report/text.h

std::string paramsText(const audit::EffectTest& e) {
  std::string o;
  for (const auto& p : e.params) {
    o += (o.empty() ? "" : ", ") + p.key + " " + fmt(p.value, "%.4g");
    if (std::isfinite(p.sigma)) o += " +- " + fmt(p.sigma, "%.2g");
    if (!p.unit.empty() && p.key.find(p.unit) == std::string::npos) o += " " + p.unit;
  }
  return o;
}

void printResult(const audit::AuditResult& r) {
  std::printf("\nfindings:\n");
  if (r.findings.empty()) std::printf("  none: every test stayed below its threshold\n");
  for (const auto& f : r.findings) std::printf("  - %s\n", f.c_str());
  std::printf("\nnamed causes (%d tests, family-wise false-alarm rate):\n", r.tests);
  if (r.named.empty()) std::printf("  none\n");
  for (const auto& e : r.named)
    std::printf("  %-22s sensor %-9s %-20s statistic %9s > threshold %9s (p %s)  %s\n", e.name.c_str(),
                e.sensor.c_str(), e.family.c_str(), fmt(e.statistic).c_str(), fmt(e.threshold).c_str(),
                fmt(e.p_value, "%.2g").c_str(), paramsText(e).c_str());
  if (!r.ambiguous.empty()) {
    std::printf("\nthe data cannot tell apart:\n");
    for (const auto& a : r.ambiguous) {
      std::string c;
      for (const auto& x : a.causes) c += (c.empty() ? "" : " / ") + x;
      std::printf("  %s%s\n    would separate them: %s\n", c.c_str(),
                  std::isfinite(a.correlation) ? (" (signature correlation " + fmt(a.correlation, "%.3f") + ")").c_str()
                                               : "",
                  a.separate_by.c_str());
    }
  }
  if (!r.not_explained.empty()) {
    std::printf("\nnot explained:\n");
    for (const auto& n : r.not_explained)
      std::printf("  %s: %s (statistic %s, threshold %s)\n", n.family.c_str(), n.what.c_str(), fmt(n.statistic).c_str(),
                  fmt(n.threshold).c_str());
  }
  if (!r.gains.empty()) {
    std::printf("\ngain of the extended model (held out: data not used to fit; delta BIC < 0: better):\n");
    if (!r.baseline.holdout.empty()) std::printf("  held out: %s\n", r.baseline.holdout.c_str());
    std::printf("  %-22s %-10s %11s %11s %13s %13s %12s %11s\n", "family", "unit", "RMS before", "RMS after",
                "held-out bef.", "held-out aft.", "held-out dLL", "delta BIC");
    for (const auto& g : r.gains)
      std::printf("  %-22s %-10s %11s %11s %13s %13s %12s %11s%s\n", g.family.c_str(),
                  g.unit.substr(0, g.unit.find(" (")).c_str(),  // the explanation is in report.md
                  fmt(g.rms_before).c_str(), fmt(g.rms_after).c_str(), fmt(g.heldout_rms_before).c_str(),
                  fmt(g.heldout_rms_after).c_str(), fmt(g.heldout_loglik_gain, "%.4g").c_str(),
                  fmt(g.delta_bic, "%.4g").c_str(),
                  g.family == r.gain.family ? "  <- largest gain" : "");
  }
  if (!r.truth.empty()) {
    std::printf("\nagainst the truth:\n  %-22s %-7s %-14s %12s %12s %12s\n", "effect", "sensor", "parameter", "truth",
                "before", "after");
    for (const auto& t : r.truth)
      std::printf("  %-22s %-7s %-14s %12s %12s %12s\n", t.effect.c_str(), t.sensor.c_str(), t.key.c_str(),
                  fmt(t.truth, "%.4g").c_str(), fmt(t.before, "%.4g").c_str(), fmt(t.after, "%.4g").c_str());
  }
  for (const auto& m : r.baseline.missing) std::printf("not formed: %s\n", m.c_str());
}

/// --simulate-model: the extended model simulated over the data's span with the scenario's orbit,
/// attitude and stars, audited with the overlay applied, and compared with the data's second pass.
bool simulateModel(const std::string& scenario, unsigned long long seed, const std::string& model_file, const model::Overlay& model,
                   const audit::RunOutput& first, const audit::RunOutput& second, const audit::RunRequest& req,
                   const std::string& out_dir, bool quiet, nlohmann::ordered_json& jext, std::vector<std::string>& lines,
                   std::vector<std::pair<std::string, std::string>>& figures, std::string* error) {
  sim::Scenario sc;
  if (!sim::loadScenario(scenario, sc, error)) return false;
  const double duration = std::max(1.0, std::ceil(first.span_s));
  // The model is the platform file with the overlay, nothing else: the scenario gives the orbit, the
  // attitude, the stars, the heads' nominal mountings and rates; its effects and mounting errors (the
  // data's hidden truth, when the data were simulated from it) are not part of the model.
  const std::size_t n_effects = sc.effects.size();
  sc.effects.clear();
  sc.mounting_error_sigma_rad = 0;
  for (auto& h : sc.heads) h.mounting_error_rad = Vec3::Zero();
  model::Overlay full = model;
  {  // every head and accelerometer axis's noise as the second pass ran with it (platform, then overlay)
    const model::NoiseInUse& niu = second.platform.noise_in_use;
    full.noise = model::NoiseSection{};
    for (int s = 0; s < niu.n_heads; ++s) {
      model::HeadNoise hn;
      hn.id = niu.head_id[static_cast<std::size_t>(s)];
      for (int a = 0; a < model::kHeadAxes; ++a)
        if (niu.head[static_cast<std::size_t>(s)][static_cast<std::size_t>(a)].set)
          hn.axis[static_cast<std::size_t>(a)] = niu.head[static_cast<std::size_t>(s)][static_cast<std::size_t>(a)].noise;
      full.noise.heads.push_back(hn);
    }
    model::AccNoise an;
    for (int a = 0; a < 3; ++a)
      if (niu.acc[static_cast<std::size_t>(a)].set) an.axis[static_cast<std::size_t>(a)] = niu.acc[static_cast<std::size_t>(a)].noise;
    full.noise.accelerometer = an;
  }
  sim::ScenarioOverlayUse use;
  if (!sim::applyOverlay(full, model_file, duration, sc, use, error)) return false;
  // The data's availability is not part of the instrument model, but it shapes the residuals (the CRN
  // and the bins around a hole): the simulation leaves the same holes, at the same seconds since the
  // first head epoch, dropping the samples strictly between the two around each (the scenario's own
  // blinding geometry makes the blinded runs).
  std::vector<std::string> gap_args;
  int gaps_head = 0, gaps_all = 0, gaps_acc = 0;
  for (const audit::DataGap& g : second.result.gaps) {
    const double p = (g.end_s - g.start_s) / (g.samples + 1);  // the stream's sampling interval
    if (!(g.samples >= 1 && p > 0 && g.start_s + 0.5 * p < duration)) continue;
    gap_args.push_back("gaps:sensor=" + g.sensor + ",at_s=" + fmt(g.start_s + 0.5 * p, "%.6f") + ",duration_s=" +
                       fmt(g.end_s - g.start_s - p, "%.6f"));
    (g.sensor == "all" ? gaps_all : g.sensor == "acc" ? gaps_acc : gaps_head) += 1;
  }
  if (!sim::addEffectArgs(sc, gap_args, error)) return false;
  const std::string dir = out_dir + "/model_simulation";
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) {
    *error = dir + ": " + ec.message();
    return false;
  }
  sim::Simulator simulator;
  if (!simulator.init(sc, seed, duration, error)) return false;
  if (!quiet) std::fprintf(stderr, "audit: simulating the extended model (%s, seed %llu, %.0f s) into %s\n", scenario.c_str(), seed, duration, dir.c_str());
  std::vector<std::string> files;
  if (!sim::simulateIntoFolder(simulator, dir, false, {}, {}, files, error)) return false;
  audit::RunRequest r = req;
  r.inputs = files;
  r.overlay = model_file;
  r.truth.reset();
  r.progress = nullptr;
  audit::RunOutput out3;
  if (!audit::runAudit(r, out3, error)) {
    *error = "the audit of the simulation: " + *error;
    return false;
  }
  const audit::SimulatedCheck check = audit::compareWithSimulation(second.result, out3.result);
  lines.push_back("simulation of the extended model: " + scenario + " seed " + std::to_string(seed) + ", " + fmt(duration, "%.0f") +
                  " s from " + io::formatTime(sc.start) + " (the scenario's orbit and attitude), files in " + dir);
  if (std::llabs(sc.start - first.first_epoch) > 60'000'000)
    lines.push_back("simulation: the data start at " + io::formatTime(first.first_epoch) +
                    "; the simulation keeps the scenario's start (orbit phase and Sun geometry differ)");
  lines.push_back("simulation: the model is the platform file's noise and the overlay; the scenario's " + std::to_string(n_effects) +
                  " effect(s) and its mounting errors are not used");
  lines.push_back("simulation: the data's holes left in it too (" + std::to_string(gaps_head) + " of single heads, " +
                  std::to_string(gaps_all) + " of every head, " + std::to_string(gaps_acc) + " of the accelerometer)");
  int noise_items = 0;
  for (const auto& l : use.applied)
    if (l.rfind("noise:", 0) == 0) ++noise_items;
    else lines.push_back("simulation, applied: " + l);
  lines.push_back("simulation, applied: the noise of every head and accelerometer axis as the second pass ran with it (" +
                  std::to_string(noise_items) + " items: audit.json extension.simulation.applied)");
  for (const auto& l : use.replaced) lines.push_back("simulation, replaced in the scenario: " + l);
  for (const auto& l : use.notes) lines.push_back("simulation, note: " + l);
  for (const auto& l : use.not_applied) lines.push_back("simulation, not applied: " + l);
  for (const auto& l : check.lines()) lines.push_back(l);
  nlohmann::ordered_json js;
  js["scenario"] = scenario;
  js["seed"] = seed;
  js["folder"] = dir;
  js["applied"] = use.applied;
  js["replaced"] = use.replaced;
  js["not_applied"] = use.not_applied;
  js["notes"] = use.notes;
  js["data_gaps_replicated"] = {{"head", gaps_head}, {"all_heads", gaps_all}, {"accelerometer", gaps_acc}};
  for (const auto& f : check.families)
    js["families"].push_back({{"family", f.family}, {"unit", f.unit}, {"heldout_rms_data", f.heldout_rms_data},
                              {"heldout_rms_simulation", f.heldout_rms_sim}, {"ratio", f.ratio}, {"tolerance", f.tolerance}, {"kurtosis", f.kurtosis},
                              {"agrees", f.agrees}});
  for (const auto& b : check.bands)
    js["bands"].push_back({{"family", b.family}, {"component", b.label}, {"band", b.band}, {"lo", b.lo}, {"hi", b.hi}, {"k", b.k},
                           {"power_data", b.power_data}, {"power_simulation", b.power_sim}, {"ratio", b.ratio},
                           {"tolerance_ln", b.tolerance}, {"agrees", b.agrees}});
  js["named_data"] = check.named_data;
  js["named_simulation"] = check.named_sim;
  js["agrees"] = check.agrees();
  jext["simulation"] = js;
  for (const auto& [file, plot] : check.plots()) {
    if (!report::writeSvgPlot(out_dir + "/" + file, plot, error)) return false;
    figures.emplace_back(file, "Residual spectra with the extended model applied: the data and the simulation of the extended model (" +
                                   plot.title.substr(0, plot.title.find(' ')) + ")");
  }
  return true;
}

}  // namespace

int runAudit(int argc, char** argv) {
  CLI::App app{"boresight audit"};
  audit::RunRequest req;
  std::string out_dir;
  bool quiet = false;
  app.add_option("--config", req.config)->required();
  app.add_option("--out", out_dir)->required();
  std::string truth_file;
  app.add_option("--truth", truth_file);
  app.add_option("--overlay", req.overlay);
  std::string write_model;
  app.add_option("--write-model", write_model);
  std::string simulate_model, simulate_seed_s = "1";
  app.add_option("--simulate-model", simulate_model);
  app.add_option("--simulate-seed", simulate_seed_s);
  app.add_option("--false-alarm", req.options.false_alarm)->check(finiteRange(1e-12, 0.5));
  app.add_option("--holdout-blocks", req.options.holdout_blocks)->check(finiteRange(1, 1000));
  app.add_option("--max-harmonic", req.options.max_harmonic)->check(finiteRange(0, 20));
  app.add_option("--lookahead", req.lookahead_s)->check(finiteRange(0.0, 3600.0));
  app.add_flag("--strict", req.strict);
  bool white_rows = false;
  app.add_flag("--white-rows", white_rows);
  app.add_flag("--quiet", quiet);
  app.add_option("inputs", req.inputs)->required();
  if (int st = parseCommandLine(app, argc, argv, "audit", kUsage); st >= 0) return st;
  req.options.time_colour = !white_rows;
  if (!simulate_model.empty() && write_model.empty()) {
    std::fprintf(stderr, "boresight audit: --simulate-model needs --write-model (it simulates the model written)\n");
    return 2;
  }
  unsigned long long simulate_seed = 1;
  if (!parseSeed("audit", simulate_seed_s, simulate_seed)) return 2;

  // Outputs never destroy inputs; the output folder first (a run of hours must not end on an
  // unwritable folder), removed again when the run fails (OutputDir).
  std::string err;
  {
    std::vector<std::string> ins = req.inputs;
    ins.push_back(req.config);
    if (!truth_file.empty()) ins.push_back(truth_file);
    if (!req.overlay.empty()) ins.push_back(req.overlay);
    if (!simulate_model.empty()) ins.push_back(simulate_model);
    if (!io::checkOutputs(ins, {{"--out", out_dir, true}, {"--write-model", write_model}}, &err)) return fail(err);
  }
  io::OutputDir dir;
  if (!dir.open(out_dir, &err)) return fail(err);
  if (!quiet) req.progress = [](const std::string& s) { std::fprintf(stderr, "%s\n", s.c_str()); };

  if (!truth_file.empty()) {
    audit::Truth t;
    if (!audit::readTruthFile(truth_file, t, &err)) return fail(err);
    req.truth = std::move(t);
  }
  audit::RunOutput out;
  if (!audit::runAudit(req, out, &err)) return fail(err);

  if (!quiet) {
    for (const auto& s : out.inputs) std::printf("%s\n", s.c_str());
    for (const auto& s : out.notes) std::printf("%s\n", s.c_str());
    const auto& c = out.counters;
    std::printf("inputs: %llu read = %llu used (%llu head samples in %llu epochs, %llu accelerometer) + %llu rejected; "
                "span %.1f s\n",
                static_cast<unsigned long long>(c.read), static_cast<unsigned long long>(c.used()),
                static_cast<unsigned long long>(c.used_heads), static_cast<unsigned long long>(out.epochs),
                static_cast<unsigned long long>(c.used_accel), static_cast<unsigned long long>(c.rejectedTotal()),
                out.span_s);
  } else {
    // Quiet, but never silent about bad input: the rejected records with their place.
    for (const auto& s : out.notes)
      if (s.find(" rejected") != std::string::npos || s.find(" read, ") != std::string::npos) std::printf("%s\n", s.c_str());
    if (!out.reference_time_base.empty()) std::printf("outside reference SCA1B: %s\n", out.reference_time_base.c_str());
  }
  for (const auto& s : out.model_in_use) std::printf("%s\n", s.c_str());
  printResult(out.result);

  // --write-model: the extension as an overlay, applied on a second pass over the same inputs.
  nlohmann::ordered_json jext;
  std::vector<std::string> ext_lines;
  std::vector<std::pair<std::string, std::string>> figures;
  if (!write_model.empty()) {
    audit::ExtensionContext ec;
    ec.t0 = out.first_epoch;
    ec.t1 = out.last_epoch;
    ec.written_by = std::string("boresight audit ") + BORESIGHT_VERSION;
    ec.note = "the model audit's extended model over " + fmt(out.span_s, "%.1f") + " s of data (platform file " + req.config +
              (req.overlay.empty() ? std::string() : ", over the overlay " + req.overlay) + ")";
    const audit::Extension ext = audit::extensionOverlay(out.result, out.platform, out.overlay, ec);
    if (!io::writeOverlay(write_model, ext.overlay, &err)) return fail(err);
    ext_lines.push_back("overlay written: " + write_model);
    for (const auto& c : ext.carried) ext_lines.push_back("carried: " + c);
    for (const auto& c : ext.not_carried) ext_lines.push_back("not carried: " + c);
    if (!quiet) std::fprintf(stderr, "audit: second pass with %s applied\n", write_model.c_str());
    audit::RunRequest again = req;
    again.overlay = write_model;
    audit::RunOutput out2;
    if (!audit::runAudit(again, out2, &err)) return fail("the second pass with " + write_model + ": " + err);
    const audit::AppliedExtension applied = audit::compareApplied(out.result, out2.result);
    for (const auto& l : out2.model_in_use)
      if (l.find("applied: ") != std::string::npos || l.rfind("warning", 0) == 0) ext_lines.push_back("second pass, " + l.substr(l.find_first_not_of(' ')));
    for (const auto& l : applied.lines()) ext_lines.push_back(l);
    jext["model"] = write_model;
    jext["carried"] = ext.carried;
    jext["not_carried"] = ext.not_carried;
    for (const auto& f : applied.families)
      jext["families"].push_back({{"family", f.family},
                                  {"unit", f.unit},
                                  {"heldout_rms_configured", f.heldout_rms_configured},
                                  {"heldout_rms_applied", f.heldout_rms_applied},
                                  {"heldout_rms_fitted", f.heldout_rms_fitted}});
    jext["still_named"] = applied.still_named;
    jext["newly_named"] = applied.newly_named;
    jext["second_pass_model_in_use"] = out2.model_in_use;
    if (!simulate_model.empty()) {
      if (!simulateModel(simulate_model, simulate_seed, write_model, ext.overlay, out, out2, req, out_dir, quiet, jext, ext_lines,
                         figures, &err))
        return fail("--simulate-model: " + err);
    }
    std::printf("\nthe extended model, applied (--write-model):\n");
    for (const auto& l : ext_lines) std::printf("  %s\n", l.c_str());
  }

  audit::ReportContext ctx;
  ctx.extension = ext_lines;
  ctx.extension_figures = figures;
  ctx.command = "boresight audit --config " + req.config;
  if (!req.overlay.empty()) ctx.command += " --overlay " + req.overlay;
  for (const auto& f : req.inputs) ctx.command += " " + f;
  ctx.command += " --out " + out_dir;
  if (!truth_file.empty()) ctx.command += " --truth " + truth_file;
  if (!write_model.empty()) ctx.command += " --write-model " + write_model;
  if (!simulate_model.empty()) ctx.command += " --simulate-model " + simulate_model + " --simulate-seed " + simulate_seed_s;
  ctx.inputs = out.inputs;
  ctx.notes = out.notes;
  ctx.notes.insert(ctx.notes.end(), out.model_in_use.begin(), out.model_in_use.end());
  const std::string json = out_dir + "/audit.json";
  {  // the audit's keys, then the model it ran with
    nlohmann::ordered_json j = nlohmann::ordered_json::parse(audit::auditJsonText(out.result));
    j["model_in_use"] = modelInUseJson(out.platform, out.overlay);
    if (!jext.is_null()) j["extension"] = jext;
    if (!io::writeFileAtomic(json, j.dump(2) + "\n", &err)) return fail(err);
  }
  if (!audit::writeAuditReport(out.result, out_dir, &err, &ctx)) return fail(err);
  dir.keep();
  std::printf("-> %s/report.md, %s", out_dir.c_str(), json.c_str());
  if (!write_model.empty()) std::printf(", model overlay %s", write_model.c_str());
  for (const auto& f : audit::auditPlotFiles(out.result)) std::printf(", %s", f.c_str());
  std::printf("\n");
  return 0;
}

}  // namespace cmd_audit

int runAudit(int argc, char** argv) { return cmd_audit::runAudit(argc, argv); }

}  // namespace boresight::cli
