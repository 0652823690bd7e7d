// audit.json and report.md with plots: see include/boresight/audit/report.h.
#include <boresight/audit/report.h>
#include <boresight/report/text.h>
#include <boresight/io/files.h>
#include <boresight/report/svg_plot.h>

#include <nlohmann/json.hpp>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

namespace boresight::audit {
namespace {

using Json = nlohmann::ordered_json;

Json num(double v) { return std::isfinite(v) ? Json(v) : Json(nullptr); }

Json paramsJson(const std::vector<ParamValue>& ps) {
  Json o = Json::object();
  for (const auto& p : ps) {
    Json v = {{"value", num(p.value)}, {"sigma", num(p.sigma)}, {"unit", p.unit}};
    if (std::isfinite(p.truth)) v["truth"] = p.truth;
    o[p.key] = std::move(v);
  }
  return o;
}

Json effectJson(const EffectTest& e) {
  return Json{{"name", e.name},         {"sensor", e.sensor},       {"family", e.family},
              {"statistic", num(e.statistic)}, {"threshold", num(e.threshold)}, {"p_value", num(e.p_value)},
              {"dof", e.dof},           {"detected", e.detected},   {"named", e.named},
              {"params", paramsJson(e.params)}, {"note", e.note}};
}

Json gainJson(const Gain& g) {
  return Json{{"family", g.family},
              {"unit", g.unit},
              {"rms_before", num(g.rms_before)},
              {"rms_after", num(g.rms_after)},
              {"heldout_rms_before", num(g.heldout_rms_before)},
              {"heldout_rms_after", num(g.heldout_rms_after)},
              {"whiteness_before", num(g.whiteness_before)},
              {"whiteness_after", num(g.whiteness_after)},
              {"heldout_loglik_gain", num(g.heldout_loglik_gain)},
              {"heldout_rows", num(g.heldout_rows)},
              {"delta_bic", num(g.delta_bic)}};
}

Json resultJson(const AuditResult& r) {
  Json j;
  const Baseline& b = r.baseline;
  Json values = Json::object();
  for (const auto& [k, v] : b.values) values[k] = num(v);
  j["baseline"] = {{"description", b.description},
                   {"span_s", num(b.span_s)},
                   {"bin_s", num(b.bin_s)},
                   {"head_epochs", b.head_epochs},
                   {"acc_samples", b.acc_samples},
                   {"acc_samples_outside_star_span", b.acc_samples_outside},
                   {"reference_samples", b.reference_samples},
                   {"orbit_samples", b.orbit_samples},
                   {"families", b.families},
                   {"missing", b.missing},
                   {"holdout", b.holdout},
                   {"values", values}};
  j["tests"] = r.tests;
  j["effects"] = Json::array();
  for (const auto& e : r.effects) j["effects"].push_back(effectJson(e));
  j["named_causes"] = Json::array();
  for (const auto& e : r.named) j["named_causes"].push_back(effectJson(e));
  j["not_explained"] = Json::array();
  for (const auto& n : r.not_explained)
    j["not_explained"].push_back(
        {{"family", n.family}, {"what", n.what}, {"statistic", num(n.statistic)}, {"threshold", num(n.threshold)}});
  j["ambiguous"] = Json::array();
  for (const auto& a : r.ambiguous)
    j["ambiguous"].push_back({{"causes", a.causes}, {"separate_by", a.separate_by}, {"correlation", num(a.correlation)}});
  j["extended"] = Json::array();
  for (const auto& e : r.extended) j["extended"].push_back(effectJson(e));
  j["gain"] = gainJson(r.gain);
  j["gains"] = Json::array();
  for (const auto& g : r.gains) j["gains"].push_back(gainJson(g));
  j["findings"] = r.findings;
  if (!r.truth.empty()) {
    j["truth"] = Json::array();
    for (const auto& t : r.truth)
      j["truth"].push_back({{"effect", t.effect},
                            {"sensor", t.sensor},
                            {"key", t.key},
                            {"unit", t.unit},
                            {"truth", num(t.truth)},
                            {"before", num(t.before)},
                            {"after", num(t.after)}});
  }
  return j;
}

bool writeText(const std::string& path, const std::string& text, std::string* error) {
  return io::writeFileAtomic(path, text, error);  // whole or not at all
}

/// A file-name part: lower-case letters, digits and '_' (runs of anything else become one '_').
std::string slug(const std::string& s) {
  std::string o;
  for (char c : s) {
    const bool keep = (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9');
    if (keep) o += c;
    else if (c >= 'A' && c <= 'Z') o += char(c - 'A' + 'a');
    else if (!o.empty() && o.back() != '_') o += '_';
  }
  while (!o.empty() && o.back() == '_') o.pop_back();
  return o.empty() ? "x" : o;
}

using report::fmt;  // include/boresight/report/text.h

bool isIba(const Series& s) { return s.family == "relative" && s.label.rfind("iba", 0) == 0; }

/// Families in the order they first appear.
template <class T>
std::vector<std::string> familiesOf(const std::vector<T>& v, bool (*skip)(const T&)) {
  std::vector<std::string> out;
  for (const auto& s : v) {
    if (skip && skip(s)) continue;
    bool seen = false;
    for (const auto& f : out) seen |= f == s.family;
    if (!seen) out.push_back(s.family);
  }
  return out;
}

const std::vector<EffectTest>& estimatesOf(const AuditResult& r) { return r.extended.empty() ? r.named : r.extended; }

/// A harmonic's cos/sin coefficients (what the model overlay takes): the plots show its amplitude and
/// phase instead.
bool coefficientOnly(const ParamValue& p) { return p.key.find("_cos_") != std::string::npos || p.key.find("_sin_") != std::string::npos; }

/// Units of the estimated parameters with a sigma (one estimates plot per unit), in order of appearance.
std::vector<std::string> estimateUnits(const AuditResult& r) {
  std::vector<std::string> units;
  for (const auto& e : estimatesOf(r))
    for (const auto& p : e.params) {
      if (!std::isfinite(p.value) || !std::isfinite(p.sigma) || coefficientOnly(p)) continue;
      bool seen = false;
      for (const auto& u : units) seen |= u == p.unit;
      if (!seen) units.push_back(p.unit);
    }
  return units;
}

struct NamedPlot {
  std::string file, caption;
  report::Plot plot;
};

std::vector<NamedPlot> plotsOf(const AuditResult& r) {
  std::vector<NamedPlot> out;
  bool (*not_iba)(const Series&) = [](const Series& s) { return isIba(s); };
  for (const auto& fam : familiesOf<Series>(r.series, not_iba)) {
    NamedPlot np;
    np.file = "residuals_" + slug(fam) + ".svg";
    np.caption = "Residuals of the " + fam + " family before and after the extension (bin means)";
    np.plot.title = fam + " residuals: before (baseline) and after (extended model)";
    np.plot.xlabel = "t - t0 [s]";
    np.plot.width = 1100;
    for (const auto& s : r.series) {
      if (s.family != fam || isIba(s)) continue;
      np.plot.ylabel = s.unit.empty() ? "residual" : "residual [" + s.unit + "]";
      np.plot.series.push_back({s.label + " before", s.t_s, s.before, {}, report::Series::Style::kLine, 0.0, {}});
      if (s.after.size() == s.t_s.size())
        np.plot.series.push_back({s.label + " after", s.t_s, s.after, {}, report::Series::Style::kLine, 0.0, {}});
    }
    out.push_back(std::move(np));
  }
  {
    NamedPlot np;
    np.file = "iba.svg";
    np.caption = "Inter-boresight angles against the configured mountings, before and after the extension";
    np.plot.title = "inter-boresight angle deviations";
    np.plot.xlabel = "t - t0 [s]";
    np.plot.width = 1100;
    for (const auto& s : r.series) {
      if (!isIba(s)) continue;
      np.plot.ylabel = s.unit.empty() ? "deviation" : "deviation [" + s.unit + "]";
      np.plot.series.push_back({s.label + " before", s.t_s, s.before, {}, report::Series::Style::kLine, 0.0, {}});
      if (s.after.size() == s.t_s.size())
        np.plot.series.push_back({s.label + " after", s.t_s, s.after, {}, report::Series::Style::kLine, 0.0, {}});
    }
    if (!np.plot.series.empty()) out.push_back(std::move(np));
  }
  for (const auto& fam : familiesOf<Spectrum>(r.spectra, nullptr)) {
    NamedPlot np;
    np.file = "spectrum_" + slug(fam) + ".svg";
    np.caption = "Amplitude spectra of the " + fam + " residuals before and after the extension (log-log), with the fitted "
                 "noise model's expected amplitude where the family fits one (approximate: the rows' median scale) and the "
                 "orbit harmonics marked";
    np.plot.title = fam + " residual spectra: before and after";
    np.plot.ylabel = "amplitude";
    np.plot.width = 1100;
    np.plot.logx = np.plot.logy = true;
    double ylo = 1e300, yhi = 0, fhi = 0;
    bool per_rev = false;
    for (const auto& s : r.spectra) {
      if (s.family != fam) continue;
      np.plot.xlabel = "frequency [" + s.unit + "]";
      for (const auto& se : r.series)
        if (se.family == s.family && se.label == s.label && !se.unit.empty()) np.plot.ylabel = "amplitude [" + se.unit + "]";
      np.plot.series.push_back({s.label + " before", s.freq, s.before, {}, report::Series::Style::kLine, 0.0, {}});
      if (s.after.size() == s.freq.size())
        np.plot.series.push_back({s.label + " after", s.freq, s.after, {}, report::Series::Style::kLine, 0.0, {}});
      if (s.noise.size() == s.freq.size())
        np.plot.series.push_back({s.label + " noise model", s.freq, s.noise, {}, report::Series::Style::kLine, 0.0, {}});
      for (const auto* v : {&s.before, &s.after, &s.noise})
        for (double y : *v)
          if (std::isfinite(y) && y > 0) ylo = std::min(ylo, y), yhi = std::max(yhi, y);
      for (double fq : s.freq) fhi = std::max(fhi, fq);
      per_rev |= s.unit == "cycles/rev";
    }
    if (per_rev && yhi > ylo) {
      std::vector<double> orders;
      for (int n = 1; n <= 10 && n <= fhi; ++n) orders.push_back(n);
      if (!orders.empty()) np.plot.series.push_back(report::verticalMarkers("orbit harmonics", orders, ylo, yhi));
    }
    out.push_back(std::move(np));
  }
  for (const auto& unit : estimateUnits(r)) {
    NamedPlot np;
    np.file = "estimates_" + slug(unit) + ".svg";
    np.caption = "Estimated parameters in " + unit + " with their 1-sigma (and the truth, when given)";
    np.plot.title = "estimates +- 1 sigma [" + unit + "]";
    np.plot.ylabel = "[" + unit + "]";
    np.plot.xlabel = "effect parameter";
    report::Series est, tru;
    est.name = "estimate +- sigma";
    tru.name = "truth";
    est.style = tru.style = report::Series::Style::kPoints;
    est.dx = -0.1;
    tru.dx = 0.1;
    bool any_truth = false;
    for (const auto& e : estimatesOf(r))
      for (const auto& p : e.params) {
        if (p.unit != unit || !std::isfinite(p.value) || !std::isfinite(p.sigma) || coefficientOnly(p)) continue;
        const double x = double(np.plot.xcategories.size());
        np.plot.xcategories.push_back(e.name + "[" + e.sensor + "] " + p.key);
        est.x.push_back(x);
        est.y.push_back(p.value);
        est.yerr.push_back(p.sigma);
        tru.x.push_back(x);
        tru.y.push_back(p.truth);
        any_truth |= std::isfinite(p.truth);
      }
    np.plot.series.push_back(std::move(est));
    if (any_truth) np.plot.series.push_back(std::move(tru));
    np.plot.width = std::max(600.0, 120.0 * double(np.plot.xcategories.size()));
    out.push_back(std::move(np));
  }
  return out;
}

std::string paramsText(const std::vector<ParamValue>& ps) {
  std::string o;
  for (const auto& p : ps) {
    if (!o.empty()) o += "; ";
    o += p.key + " = " + fmt(p.value, "%.4g");
    if (std::isfinite(p.sigma)) o += " +- " + fmt(p.sigma, "%.2g");
    if (!p.unit.empty()) o += " " + p.unit;
    if (std::isfinite(p.truth)) o += " (truth " + fmt(p.truth, "%.4g") + ")";
  }
  return o.empty() ? "-" : o;
}

std::string cell(const std::string& s) {  // a Markdown table cell: pipes escaped, no line breaks
  std::string o;
  for (char c : s) {
    if (c == '|') o += "\\|";
    else o += c == '\n' ? ' ' : c;
  }
  return o;
}

void effectTable(std::ostringstream& o, const std::vector<EffectTest>& v, bool verdict) {
  o << "| effect | sensor | family | statistic | threshold | p | " << (verdict ? "detected | named | " : "")
    << "parameters |\n|---|---|---|---|---|---|" << (verdict ? "---|---|" : "") << "---|\n";
  for (const auto& e : v) {
    o << "| " << cell(e.name) << " | " << cell(e.sensor) << " | " << cell(e.family) << " | " << fmt(e.statistic)
      << " | " << fmt(e.threshold) << " | " << fmt(e.p_value, "%.2g") << " | ";
    if (verdict) o << (e.detected ? "yes" : "no") << " | " << (e.named ? "yes" : "no") << " | ";
    o << cell(paramsText(e.params)) << (e.note.empty() ? "" : " (" + cell(e.note) + ")") << " |\n";
  }
}

std::string reportText(const AuditResult& r, const ReportContext* ctx, const std::vector<NamedPlot>& plots) {
  std::ostringstream o;
  const Baseline& b = r.baseline;
  o << "# Model audit\n\n";
  o << "What the configured model gets wrong in these data, the cause named from the effect catalogue, the "
       "model extended with it, and the gain on data not used to fit (METHODS 4).\n\n";
  if (ctx) {
    if (!ctx->command.empty()) o << "```\n" << ctx->command << "\n```\n\n";
    if (!ctx->inputs.empty()) {
      o << "Inputs:\n\n";
      for (const auto& s : ctx->inputs) o << "- " << s << "\n";
      o << "\n";
    }
    for (const auto& s : ctx->notes) o << "- " << s << "\n";
    if (!ctx->notes.empty()) o << "\n";
  }
  o << "## Baseline\n\n";
  if (!b.description.empty()) o << b.description << "\n\n";
  o << "Span " << fmt(b.span_s, "%.1f") << " s in bins of " << fmt(b.bin_s, "%.3g") << " s; " << b.head_epochs
    << " head epochs, " << b.acc_samples << " accelerometer samples"
    << (b.acc_samples_outside ? " (" + std::to_string(b.acc_samples_outside) + " outside the star data's span, not used)" : std::string())
    << ", " << b.reference_samples << " reference samples, "
    << b.orbit_samples << " orbit samples.\n\n";
  if (!b.families.empty()) {
    o << "Residual families with data:";
    for (const auto& f : b.families) o << " " << f;
    o << ".\n\n";
  }
  for (const auto& m : b.missing) o << "- not formed: " << m << "\n";
  if (!b.missing.empty()) o << "\n";
  if (!b.holdout.empty()) o << "Held out (not used to fit; the gain is measured on them): " << b.holdout << ".\n\n";
  if (!b.values.empty()) {
    o << "| model value | |\n|---|---|\n";
    for (const auto& [k, v] : b.values) o << "| " << cell(k) << " | " << fmt(v, "%.4g") << " |\n";
    o << "\n";
  }

  o << "## What is wrong\n\n";
  if (r.findings.empty()) o << "No finding: every test stayed below its threshold.\n\n";
  for (const auto& f : r.findings) o << "- " << f << "\n";
  if (!r.findings.empty()) o << "\n";

  o << "## Named causes and their evidence\n\n";
  if (r.named.empty()) {
    o << "None: no candidate passed its threshold (family-wise false-alarm rate over " << r.tests << " tests).\n\n";
  } else {
    o << "Forward selection over " << r.tests
      << " tests; the statistic of each named cause against its threshold at the family-wise false-alarm rate:\n\n";
    effectTable(o, r.named, false);
    o << "\n";
  }

  o << "## What the data cannot tell apart\n\n";
  if (r.ambiguous.empty()) o << "No ambiguity among the named causes.\n\n";
  for (const auto& a : r.ambiguous) {
    o << "- ";
    for (std::size_t i = 0; i < a.causes.size(); ++i) o << (i ? " / " : "") << a.causes[i];
    if (std::isfinite(a.correlation)) o << " (signature correlation " << fmt(a.correlation, "%.3f") << ")";
    o << ": explain the data equally. What would separate them: " << a.separate_by << "\n";
  }
  if (!r.ambiguous.empty()) o << "\n";

  o << "## Not explained\n\n";
  if (r.not_explained.empty()) o << "Nothing: no significant residual is left without a cause.\n\n";
  else {
    o << "| family | what | statistic | threshold |\n|---|---|---|---|\n";
    for (const auto& n : r.not_explained)
      o << "| " << cell(n.family) << " | " << cell(n.what) << " | " << fmt(n.statistic) << " | " << fmt(n.threshold)
        << " |\n";
    o << "\n";
  }

  o << "## The gain of the extended model\n\n";
  if (!r.extended.empty()) {
    o << "The extended model's effects, re-estimated together:\n\n";
    effectTable(o, r.extended, false);
    o << "\n";
  }
  if (r.gains.empty()) o << "No residual family to compare.\n\n";
  else {
    o << "RMS on the fitting data and on the held-out data (not used to fit), lag-1 autocorrelation of the "
         "held-out residuals (whiteness), the held-out log-likelihood gain (nats, conditional on the fitting "
         "data; the extended model's noise models count here) and the change of the information criterion on "
         "the held-out data (negative: the extended model is better).";
    if (!r.baseline.holdout.empty()) o << " Held out: " << r.baseline.holdout << ".";
    o << "\n\n";
    o << "| family | unit | RMS before | RMS after | held-out RMS before | held-out RMS after | whiteness before | "
         "whiteness after | held-out log-likelihood gain | delta BIC |\n|---|---|---|---|---|---|---|---|---|---|\n";
    for (const auto& g : r.gains)
      o << "| " << cell(g.family) << (g.family == r.gain.family ? " (largest gain)" : "") << " | " << cell(g.unit)
        << " | " << fmt(g.rms_before) << " | " << fmt(g.rms_after) << " | " << fmt(g.heldout_rms_before) << " | "
        << fmt(g.heldout_rms_after) << " | " << fmt(g.whiteness_before, "%.2f") << " | "
        << fmt(g.whiteness_after, "%.2f") << " | " << fmt(g.heldout_loglik_gain, "%.4g") << " | "
        << fmt(g.delta_bic, "%.4g") << " |\n";
    o << "\n";
  }

  if (ctx && !ctx->extension.empty()) {
    o << "## The extended model, applied\n\n";
    for (const auto& l : ctx->extension) o << "- " << l << "\n";
    o << "\n";
    for (const auto& [file, caption] : ctx->extension_figures) o << "![" << caption << "](" << file << ")\n\n*" << caption << "*\n\n";
  }

  if (!r.truth.empty()) {
    o << "## Against the truth\n\n| effect | sensor | parameter | unit | truth | before | after |\n"
         "|---|---|---|---|---|---|---|\n";
    for (const auto& t : r.truth)
      o << "| " << cell(t.effect) << " | " << cell(t.sensor) << " | " << cell(t.key) << " | " << cell(t.unit) << " | "
        << fmt(t.truth, "%.4g") << " | " << fmt(t.before, "%.4g") << " | " << fmt(t.after, "%.4g") << " |\n";
    o << "\n";
  }

  o << "## Every test\n\n";
  if (r.effects.empty()) o << "No candidate was tested.\n\n";
  else {
    effectTable(o, r.effects, true);
    o << "\n";
  }

  o << "## Plots\n\n";
  if (plots.empty()) o << "No series to plot.\n\n";
  for (const auto& p : plots) o << p.caption << ":\n\n![" << p.caption << "](" << p.file << ")\n\n";
  return o.str();
}

}  // namespace

std::string auditJsonText(const AuditResult& r) { return resultJson(r).dump(2) + "\n"; }

bool writeAuditJson(const AuditResult& r, const std::string& path, std::string* error) {
  return writeText(path, auditJsonText(r), error);
}

std::vector<std::string> auditPlotFiles(const AuditResult& r) {
  std::vector<std::string> out;
  for (const auto& p : plotsOf(r)) out.push_back(p.file);
  return out;
}

bool writeAuditReport(const AuditResult& r, const std::string& dir, std::string* error, const ReportContext* context) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) {
    if (error) *error = dir + ": cannot create the report directory: " + ec.message();
    return false;
  }
  const std::vector<NamedPlot> plots = plotsOf(r);
  for (const auto& p : plots)
    if (!report::writeSvgPlot(dir + "/" + p.file, p.plot, error)) return false;
  return writeText(dir + "/report.md", reportText(r, context, plots), error);
}

}  // namespace boresight::audit
