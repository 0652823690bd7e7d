// The outputs of `boresight noise`: noise.json, noise.yaml (the platform file's `noise` form) and
// report.md with a log-log spectrum per axis (include/boresight/noise/run.h).
#include <boresight/core/conventions.h>
#include <boresight/report/text.h>
#include <boresight/io/files.h>
#include <boresight/io/overlay_yaml.h>
#include <boresight/noise/run.h>
#include <boresight/report/svg_plot.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <cstdio>
#include <filesystem>
#include <sstream>

namespace boresight::noise {
namespace {

using Json = nlohmann::ordered_json;

Json num(double v) { return std::isfinite(v) ? Json(v) : Json(nullptr); }

Json termJson(const model::NoiseTerm& t) {
  Json j;
  j["kind"] = model::noiseKindName(t.kind);
  j["sigma"] = num(t.sigma);
  if (t.kind == model::NoiseKind::GaussMarkov) j["tau_s"] = num(t.tau_s);
  if (t.kind == model::NoiseKind::PowerLaw) {
    j["alpha"] = num(t.alpha);
    j["f_lo_hz"] = num(t.f_lo_hz);
    j["f_hi_hz"] = num(t.f_hi_hz);
    j["pl_terms"] = t.powerLawTermCount();
  }
  return j;
}

Json modelJson(const model::NoiseModel& m) {
  Json a = Json::array();
  for (const auto& t : m.terms) a.push_back(termJson(t));
  return a;
}

Json fitJson(const model::NoiseFit& f) {
  Json j;
  j["structure"] = model::noiseStructureName(f.structure);
  j["converged"] = f.converged;
  if (!f.message.empty()) j["message"] = f.message;
  j["m2ll"] = num(f.m2ll);
  j["bic"] = num(f.bic);
  j["aic"] = num(f.aic);
  j["model"] = modelJson(f.model);
  Json ps = Json::array();
  for (const auto& p : f.params) {
    Json q;
    q["name"] = p.name;
    q["value"] = num(p.value);
    q["sigma"] = num(p.sigma);
    q["determined"] = p.determined;
    if (!p.note.empty()) q["note"] = p.note;
    if (p.at_hz > 0) q["at_hz"] = num(p.at_hz);
    if (p.derived) q["derived"] = true;  // from the other parameters, outside their joint covariance
    ps.push_back(q);
  }
  j["params"] = ps;
  if (f.beta.size() > 0) j["mean"] = num(f.beta[0]);
  j["likelihood"] = model::noiseLikelihoodName(f.likelihood);
  j["evaluations"] = f.evaluations;
  if (f.likelihood == model::NoiseLikelihood::Whittle) j["whittle_samples"] = f.whittle_samples;
  return j;
}

bool writeText(const std::string& path, const std::string& text, std::string* error) {
  return io::writeFileAtomic(path, text, error);  // whole or not at all
}

using report::fmt;  // include/boresight/report/text.h

std::string fileOf(const AxisResult& a) {
  std::string s = a.sensor + "_" + a.axis + (a.series.rfind("block", 0) == 0 ? "_slow" : "");
  for (auto& c : s)
    if (c == ' ') c = '_';
  return "psd_" + s + ".svg";
}

/// The chosen model's parameters as text: "white.sigma 2.01 +- 0.01, gm.sigma ..."
std::string paramsText(const model::NoiseFit& f) {
  std::string o;
  for (const auto& p : f.params) {
    o += (o.empty() ? "" : ", ") + p.name + " " + fmt(p.value, "%.4g");
    if (p.determined) o += " +- " + fmt(p.sigma, "%.2g");
    else o += " (not determined)";
  }
  return o;
}

}  // namespace

bool writeNoiseJson(const std::string& path, const NoiseOutput& out, std::string* error) {
  Json j;
  j["platform"] = out.platform;
  j["span_s"] = out.span_s;
  j["epochs"] = out.epochs;
  j["epochs_with_every_head"] = out.full_epochs;
  j["accelerometer_samples"] = out.acc_samples;
  j["inputs"] = out.inputs;
  j["notes"] = out.notes;
  Json axes = Json::array();
  for (const auto& a : out.axes) {
    Json x;
    x["sensor"] = a.sensor;
    x["axis"] = a.axis;
    x["unit"] = a.unit;
    x["series"] = a.series;
    x["samples"] = a.samples;
    x["span_s"] = a.span_s;
    x["interval_s"] = a.interval_s;
    x["decimation"] = a.decimation;
    x["determinable_band_hz"] = {num(a.f_det_lo), num(a.f_det_hi)};
    x["configured"] = modelJson(a.configured);
    if (!a.contamination.empty()) x["contamination"] = modelJson(a.contamination);
    if (a.fitted()) {
      x["chosen"] = fitJson(a.selection.chosen());
      Json c = Json::array();
      for (const auto& f : a.selection.fits) c.push_back(fitJson(f));
      x["candidates"] = c;
      // natural log of the PSD (unit^2/Hz, without the other heads' part); null: not determined
      Json bs = Json::array();
      for (const BandPoint& q : bandSpectrum(a)) {
        Json o;
        o["f_hz"] = num(q.f_hz);
        o["chosen_log_psd"] = num(q.chosen_log_psd);
        o["chosen_se"] = num(q.chosen_se);
        o["averaged_log_psd"] = num(q.averaged_log_psd);
        o["averaged_se"] = num(q.averaged_se);
        bs.push_back(o);
      }
      x["band_spectrum"] = bs;
    } else {
      x["chosen"] = nullptr;
    }
    x["notes"] = a.notes;
    axes.push_back(x);
  }
  j["axes"] = axes;
  return writeText(path, j.dump(2) + "\n", error);
}

namespace {

/// The axis's model and parameters in model units: arcsec values back to rad (levels only; times,
/// frequencies and alpha as they are). Parameter names follow model::noiseTermName.
model::AxisNoise axisNoiseOf(const model::NoiseFit& f, double to_model) {
  model::AxisNoise a;
  a.model = f.model;
  for (auto& t : a.model.terms) t.sigma *= to_model;
  for (model::NoiseParam p : f.params) {
    if (p.at_hz > 0) continue;  // a spectral level at a frequency: not a field of the model's terms
    if (p.name.size() > 6 && p.name.compare(p.name.size() - 6, 6, ".sigma") == 0) {
      p.value *= to_model;
      p.sigma *= to_model;
    }
    if (!std::isfinite(p.sigma)) p.sigma = std::numeric_limits<double>::quiet_NaN();
    if (!p.determined && p.note.empty()) p.note = "not determined";
    a.params.push_back(p);
  }
  return a;
}

/// The accelerometer's slow series (block means of star minus accelerometer).
bool isSlow(const AxisResult& a) { return a.series.rfind("block", 0) == 0; }

}  // namespace

model::NoiseSection fittedNoiseSection(const NoiseOutput& out) {
  model::NoiseSection s;
  for (const auto& a : out.axes) {
    if (!a.fitted() || a.sensor.rfind("head ", 0) != 0) continue;
    const int id = std::atoi(a.sensor.c_str() + 5);
    auto it = std::find_if(s.heads.begin(), s.heads.end(), [&](const model::HeadNoise& h) { return h.id == id; });
    if (it == s.heads.end()) {
      s.heads.push_back({});
      s.heads.back().id = id;
      it = s.heads.end() - 1;
    }
    const int k = a.axis == "cross_x" ? 0 : a.axis == "cross_y" ? 1 : 2;
    it->axis[static_cast<std::size_t>(k)] = axisNoiseOf(a.selection.chosen(), 1.0 / kArcsecPerRad);
  }
  // The accelerometer: the white term of the difference series, then the coloured terms of the slow
  // series (its white part is the star sensors', not the accelerometer's).
  for (int k = 0; k < 3; ++k) {
    model::AxisNoise acc;
    for (const auto& a : out.axes) {
      if (a.sensor != "accelerometer" || a.axis != std::string(1, "xyz"[k]) || !a.fitted()) continue;
      const model::AxisNoise part = axisNoiseOf(a.selection.chosen(), 1.0);
      const bool slow = isSlow(a);
      for (const auto& t : part.model.terms)
        if (slow ? t.kind != model::NoiseKind::White : t.kind == model::NoiseKind::White) acc.model.terms.push_back(t);
      for (const auto& p : part.params)
        if (slow ? p.name.rfind("white", 0) != 0 : p.name.rfind("white", 0) == 0) acc.params.push_back(p);
    }
    if (acc.model.empty()) continue;
    if (!s.accelerometer) s.accelerometer = model::AccNoise{};
    s.accelerometer->axis[static_cast<std::size_t>(k)] = acc;
  }
  return s;
}

bool writeNoiseYaml(const std::string& path, const NoiseOutput& out, std::string* error) {
  std::string y =
      "# boresight noise: the noise model chosen per axis (BIC) from the data, in a platform file's `noise`\n"
      "# form (paste under `noise:`). Head axes in arcsec, accelerometer angular acceleration in rad/s^2\n"
      "# per A axis; `uncertainty` gives standard errors, `not_determined` what the span could not decide.\n"
      "noise:\n";
  y += io::noiseSectionYaml(fittedNoiseSection(out), 2, false);
  return writeText(path, y, error);
}

bool writeNoiseOverlay(const std::string& path, const NoiseOutput& out, const std::string& program, std::string* error) {
  model::Overlay o;
  o.written_by = program;
  o.platform = out.platform;
  o.note = "noise models estimated from " + std::to_string(static_cast<long long>(std::llround(out.span_s))) + " s of data";
  o.noise = fittedNoiseSection(out);
  for (auto& h : o.noise.heads) {
    h.valid.from = out.t0;
    h.valid.to = out.t1;
  }
  if (o.noise.accelerometer) {
    o.noise.accelerometer->valid.from = out.t0;
    o.noise.accelerometer->valid.to = out.t1;
  }
  const std::string v = model::validate(o);
  if (!v.empty()) {
    if (error) *error = path + ": the fitted overlay is not valid: " + v;
    return false;
  }
  return io::writeOverlay(path, o, error);
}

bool writeNoiseReport(const std::string& dir, const NoiseOutput& out, std::string* error) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) {
    if (error) *error = dir + ": cannot create the report directory: " + ec.message();
    return false;
  }
  std::ostringstream md;
  md << "# Noise as the data has it\n\n";
  md << "Platform `" << out.platform << "`, " << fmt(out.span_s / 3600.0, "%.2f") << " h of data, " << out.epochs
     << " head epochs (" << out.full_epochs << " with every head), " << out.acc_samples << " accelerometer samples.\n\n";
  md << "Inputs:\n\n";
  for (const auto& s : out.inputs) md << "- " << s << "\n";
  if (!out.model_in_use.empty()) {
    md << "\nConfigured model (compared with the data below):\n\n";
    for (const auto& s : out.model_in_use) md << "- " << s << "\n";
  }
  if (!out.notes.empty()) {
    md << "\nNotes:\n\n";
    for (const auto& s : out.notes) md << "- " << s << "\n";
  }
  md << "\n## Chosen models (BIC)\n\n";
  md << "| sensor | axis | series | samples | likelihood | chosen | parameters | configured |\n|---|---|---|---|---|---|---|---|\n";
  for (const auto& a : out.axes) {
    md << "| " << a.sensor << " | " << a.axis << " | " << (a.series.rfind("block", 0) == 0 ? "slow (blocks)" : "white/full")
       << " | " << a.samples << " | ";
    if (a.fitted()) {
      const auto& f = a.selection.chosen();
      md << model::noiseLikelihoodName(f.likelihood);
      if (f.likelihood == model::NoiseLikelihood::Whittle) md << " (" << f.whittle_samples << ")";
      md << " | " << f.model.describe(1.0, "") << " | " << paramsText(f) << " | " << a.configured.describe(1.0, "") << " |\n";
    } else {
      md << "- | not fitted | - | " << a.configured.describe(1.0, "") << " |\n";
    }
  }
  md << "\nUnits: heads in arcsec, the accelerometer in rad/s^2. Correlation times and corner frequencies are\n"
        "determined only between 20 / span and 1 / (20 interval) (Whittle: 20 / the longest gap-free run);\n"
        "outside, a parameter says \"not determined\". Likelihood: exact (state space, every sample) or\n"
        "whittle (the periodograms of the long gap-free runs; in brackets the samples they hold).\n";
  md << "\n## Spectra\n\nThe data's Welch spectrum against the chosen model (log-log), the configured model, for the\n"
        "heads what the other heads add (the contamination the fit carries), and across the determinable band\n"
        "the fitted candidates averaged with Akaike weights (points, +-2 standard errors that hold the choice\n"
        "between the candidates as well as each one's own; where they are much wider than the chosen model's\n"
        "own, the axis's notes say so).\n\n";
  for (const auto& a : out.axes) {
    if (a.spectrum.f_hz.empty()) continue;
    report::Plot p;
    p.title = a.sensor + " " + a.axis + (a.series.rfind("block", 0) == 0 ? " (slow part)" : "");
    p.xlabel = "frequency [Hz]";
    p.ylabel = "PSD [" + a.unit + "^2/Hz]";
    p.logx = p.logy = true;
    report::Series data;
    data.name = "data (Welch)";
    data.x = a.spectrum.f_hz;
    data.y = a.spectrum.psd;
    p.series.push_back(data);
    const double T = a.interval_s;
    auto curve = [&](const std::string& name, const model::NoiseModel& m, const model::NoiseModel* plus) {
      report::Series s;
      s.name = name;
      for (double f : a.spectrum.f_hz) {
        s.x.push_back(f);
        s.y.push_back(m.psdSampled(f, T) + (plus ? plus->psdSampled(f, T) : 0.0));
      }
      p.series.push_back(s);
    };
    if (a.fitted()) curve("chosen model + contamination", a.selection.chosen().model, &a.contamination);
    if (!a.contamination.empty()) curve("contamination (other heads)", a.contamination, nullptr);
    {
      // the candidates averaged with Akaike weights, +- 2 unconditional standard errors (the choice
      // between them included), plus the other heads' part as the chosen curve has it
      report::Series avg;
      avg.name = "candidates averaged (Akaike), +-2 se";
      avg.style = report::Series::Style::kPoints;
      for (const BandPoint& q : bandSpectrum(a)) {
        if (!(std::isfinite(q.averaged_log_psd) && std::isfinite(q.averaged_se))) continue;
        const double c = a.contamination.empty() ? 0.0 : a.contamination.psdSampled(q.f_hz, T);
        const double mid = std::exp(q.averaged_log_psd) + c;
        avg.x.push_back(q.f_hz);
        avg.y.push_back(mid);
        avg.yerr.push_back(std::exp(q.averaged_log_psd + 2 * q.averaged_se) + c - mid);
        avg.yerr_lo.push_back(mid - (std::exp(q.averaged_log_psd - 2 * q.averaged_se) + c));
      }
      if (!avg.x.empty()) p.series.push_back(avg);
    }
    if (!a.configured.empty() && !isSlow(a)) {
      // the accelerometer's difference series carries only its white part
      model::NoiseModel conf = a.configured;
      if (a.sensor == "accelerometer") conf = model::NoiseModel::white(std::sqrt(a.configured.whiteVariance()));
      curve("configured", conf, nullptr);
    }
    if (!report::writeSvgPlot(dir + "/" + fileOf(a), p, error)) return false;
    md << "![" << p.title << "](" << fileOf(a) << ")\n\n";
    for (const auto& n : a.notes) md << "- " << n << "\n";
    if (!a.notes.empty()) md << "\n";
  }
  return writeText(dir + "/report.md", md.str(), error);
}

}  // namespace boresight::noise
