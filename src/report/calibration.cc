// The calibration result as JSON, YAML and report.md (include/boresight/report/calibration.h).
#include <boresight/io/files.h>
#include <boresight/core/rotation.h>
#include <boresight/report/calibration.h>
#include <boresight/report/svg_plot.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace boresight::report {
namespace {

using json = Json;

json num(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }
json num(const std::optional<double>& v) { return v && std::isfinite(*v) ? json(*v) : json(nullptr); }

template <typename A>
json arr(const A& a) {
  json j = json::array();
  for (const auto& v : a) j.push_back(num(v));
  return j;
}

void putEstimate(json& acc, const char* value_key, const char* sigma_key, const std::optional<calib::Estimate3>& e) {
  if (!e) return;
  acc[value_key] = arr(e->value);
  acc[sigma_key] = arr(e->sigma);
}

const char* modeName(calib::RelativeMode m) {
  return m == calib::RelativeMode::kHardConstraint ? "hard_constraint" : "prior";
}

// --- YAML ---------------------------------------------------------------------------------------

std::string yamlScalar(const json& j) {
  if (j.is_null()) return "null";
  if (j.is_boolean()) return j.get<bool>() ? "true" : "false";
  if (j.is_number_integer() || j.is_number_unsigned()) return j.dump();
  if (j.is_number_float()) {
    char b[40];
    std::snprintf(b, sizeof b, "%.10g", j.get<double>());
    return b;
  }
  // Strings: always double-quoted (JSON escaping is valid YAML double-quoted style).
  return j.dump();
}

bool isFlat(const json& j) {
  if (!j.is_array()) return false;
  for (const auto& v : j)
    if (v.is_structured() || v.is_string()) return false;
  return true;
}

/// A key as a plain scalar when it is an identifier (every key of the result), else double-quoted.
std::string yamlKey(const std::string& k) {
  bool plain = !k.empty() && !(k[0] >= '0' && k[0] <= '9');
  for (char c : k) plain = plain && (std::isalnum(static_cast<unsigned char>(c)) || c == '_');
  return plain && k != "null" && k != "true" && k != "false" ? k : json(k).dump();
}

void yamlNode(std::ostringstream& o, const json& j, int indent);

void yamlValueAfterKey(std::ostringstream& o, const json& v, int indent) {
  if (v.is_object() && !v.empty()) {
    o << "\n";
    yamlNode(o, v, indent + 2);
  } else if (v.is_array() && !v.empty() && !isFlat(v)) {
    o << "\n";
    yamlNode(o, v, indent + 2);
  } else if (v.is_array()) {
    o << " [";
    for (std::size_t i = 0; i < v.size(); ++i) o << (i ? ", " : "") << yamlScalar(v[i]);
    o << "]\n";
  } else if (v.is_object()) {
    o << " {}\n";
  } else {
    o << " " << yamlScalar(v) << "\n";
  }
}

void yamlNode(std::ostringstream& o, const json& j, int indent) {
  const std::string pad(std::size_t(indent), ' ');
  if (j.is_object()) {
    for (auto it = j.begin(); it != j.end(); ++it) {
      o << pad << yamlKey(it.key()) << ":";
      yamlValueAfterKey(o, it.value(), indent);
    }
  } else if (j.is_array()) {
    for (const auto& v : j) {
      if (v.is_object() && !v.empty()) {
        // "- " then the first key on the same line, the others indented under it.
        std::ostringstream sub;
        yamlNode(sub, v, indent + 2);
        std::string s = sub.str();
        o << pad << "- " << s.substr(std::size_t(indent) + 2);
      } else if (v.is_array() && !isFlat(v) && !v.empty()) {
        o << pad << "-\n";
        yamlNode(o, v, indent + 2);
      } else {
        o << pad << "-";
        yamlValueAfterKey(o, v, indent);
      }
    }
  } else {
    o << pad << yamlScalar(j) << "\n";
  }
}

std::string fmt(const char* f, double v) {
  if (!std::isfinite(v)) return "-";
  char b[64];
  std::snprintf(b, sizeof b, f, v);
  return b;
}

std::string fmtJ(const char* f, const json& v) { return v.is_number() ? fmt(f, v.get<double>()) : "-"; }

}  // namespace

json calibrationJson(const calib::SolveResult& r, const CalibrationContext& c) {
  json j;
  j["ok"] = r.ok;
  j["message"] = r.message;
  j["datum"] =
      "accelerometer frame A: B is the body frame as the configured C_B_A puts A into it (a common rotation of "
      "all heads relative to A is estimated; a rotation of A itself is not)";
  j["conventions"] = {
      {"error_angles_arcsec", "rotation vector r in the head frame, C_S_B(true) = Exp([r]x) C_S_B(nominal)"},
      {"time_offset_s", "positive: the accelerometer's tags are late relative to the star cameras' for the same "
                        "instant"},
      {"null", "not determined (sigma), infinite (crlb), or not estimated"}};
  json heads = json::array();
  for (const auto& h : r.heads)
    heads.push_back({{"id", h.id},
                     {"error_angles_arcsec", arr(h.error_angles_arcsec)},
                     {"sigma_arcsec", arr(h.sigma_arcsec)},
                     {"crlb_arcsec", arr(h.crlb_arcsec)},
                     {"observable", h.observable}});
  j["heads"] = heads;
  json dirs = json::array();
  for (const auto& d : r.unobservable_directions_B) dirs.push_back({num(d.x()), num(d.y()), num(d.z())});
  j["unobservable_directions_B"] = dirs;
  j["covariance_arcsec2"] = arr(r.covariance_arcsec2);
  json acc = json::object();
  putEstimate(acc, "bias_radps2", "bias_sigma_radps2", r.acc_bias_radps2);
  putEstimate(acc, "scale", "scale_sigma", r.acc_scale);
  putEstimate(acc, "nonorthogonality_arcsec", "nonorthogonality_sigma_arcsec", r.acc_nonorthogonality_arcsec);
  j["accelerometer"] = acc;
  j["time_offset_s"] = num(r.time_offset_s);
  j["time_offset_sigma_s"] = num(r.time_offset_sigma_s);
  j["thermal"] = c.thermal.is_null() ? json{{"status", "not computed"}} : c.thermal;
  j["residual_rms_radps2"] = num(r.residual_rms_radps2);
  j["epochs"] = r.epochs;
  j["span_s"] = num(r.span_s);
  j["excitation_eigenvalues_radps2_sq"] = arr(r.excitation_eigenvalues);
  j["options"] = {{"relative", modeName(c.options.relative)},
                  {"estimate_acc_bias", c.options.estimate_acc_bias},
                  {"estimate_acc_scale", c.options.estimate_acc_scale},
                  {"estimate_acc_nonorthogonality", c.options.estimate_acc_nonorthogonality},
                  {"estimate_time_offset", c.options.estimate_time_offset},
                  {"huber_sigma", c.options.huber_sigma},
                  {"whiten", c.options.whiten},
                  {"from_moments", c.options.from_moments},
                  {"unobservable_sigma_arcsec", c.options.unobservable_sigma_arcsec},
                  {"decimation_s", c.span_options.decimation_s},
                  {"calibration_crn_bandwidth_hz", num(c.span_options.crn_bandwidth_hz > 0 ? c.span_options.crn_bandwidth_hz : NAN)},
                  {"calibration_crn_length_s", num(c.span_options.crn_length_s > 0 ? c.span_options.crn_length_s : NAN)}};
  j["config"] = c.config;
  j["inputs"] = c.inputs;
  json ign = json::array();
  for (const auto& [f, p] : c.ignored) ign.push_back({{"file", f}, {"product", p}});
  j["ignored"] = ign;
  return j;
}

namespace {

json termsJson(const std::vector<calib::ThermalHarmonicTerm>& terms) {
  json a = json::array();
  for (const auto& t : terms)
    a.push_back({{"harmonic", t.harmonic},
                 {"cos_arcsec", num(t.cos_arcsec)},
                 {"sin_arcsec", num(t.sin_arcsec)},
                 {"sigma_cos_arcsec", num(t.sigma_cos_arcsec)},
                 {"sigma_sin_arcsec", num(t.sigma_sin_arcsec)}});
  return a;
}

}  // namespace

json thermalJson(const calib::ThermalFitResult& t) {
  json j;
  j["status"] = t.ok ? "fitted" : "not determined: " + t.error;
  j["datum"] = t.datum_note;
  j["u_source"] = t.u_from_earth_fixed ? "GNV1B (Earth-fixed) rotated by the Earth rotation angle (about 0.1 deg)"
                                       : "GNI1B (inertial)";
  j["harmonics"] = t.harmonics;
  j["span_s"] = num(t.span_s);
  j["revolutions"] = num(t.revolutions);
  j["beta"] = {{"modulation", t.beta_determined ? "fitted" : "not determined"},
               {"note", t.beta_note},
               {"min_deg", num(t.beta_min_deg)},
               {"max_deg", num(t.beta_max_deg)}};
  j["counts"] = {{"head_epochs", t.head_epochs},
                 {"head_epochs_rejected", t.head_epochs_rejected},
                 {"epochs_without_orbit", t.epochs_without_orbit},
                 {"orbit_records", t.orbit_records},
                 {"orbit_records_rejected", t.orbit_records_rejected}};
  json heads = json::array();
  for (const auto& h : t.heads) {
    json jh;
    jh["id"] = h.id;
    jh["datum_head"] = h.datum_id;
    jh["determined"] = h.determined;
    if (!h.determined) jh["reason"] = h.reason;
    jh["epochs"] = h.epochs;
    jh["chi2_per_dof"] = num(h.chi2_per_dof);
    if (h.determined) {
      json axes;
      const char* names[3] = {"x", "y", "z"};
      for (std::size_t a = 0; a < 3; ++a) {
        const calib::ThermalAxisFit& f = h.axis[a];
        axes[names[a]] = {{"constant_arcsec", num(f.constant_arcsec)},
                          {"sigma_constant_arcsec", num(f.sigma_constant_arcsec)},
                          {"harmonics", termsJson(f.terms)},
                          {"beta_modulation", h.beta_determined ? termsJson(f.beta_terms) : json("not determined")},
                          {"rms_before_arcsec", num(f.rms_before_arcsec)},
                          {"rms_after_arcsec", num(f.rms_after_arcsec)},
                          {"noise_rms_arcsec", num(f.noise_rms_arcsec)}};
      }
      jh["axes_of_datum_head_frame"] = axes;
    }
    heads.push_back(jh);
  }
  j["heads"] = heads;
  return j;
}

std::string toYaml(const json& j) {
  std::ostringstream o;
  yamlNode(o, j, 0);
  return o.str();
}

bool writeCalibrationReport(const std::string& dir, const calib::CalibrationSpan& span, const calib::SolveResult& r,
                            const json& result, std::string* error) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) {
    if (error) *error = dir + ": cannot create the report directory: " + ec.message();
    return false;
  }
  const char* ax = "xyz";
  // Residuals against time, per head and head axis.
  const calib::SpanResiduals res = calib::residuals(span, r.estimate);
  Plot pr;
  pr.title = "residuals under the estimates (head frames)";
  pr.xlabel = "t - t0 [s]";
  pr.ylabel = "residual [rad/s^2]";
  for (int s = 0; s < span.n_heads && s < calib::kMaxHeads; ++s)
    for (int a = 0; a < 3; ++a) {
      Series se;
      se.name = "head " + std::to_string(span.head_ids[std::size_t(s)]) + " " + ax[a];
      se.x = res.t_s;
      for (const auto& row : res.r_S) se.y.push_back(row[std::size_t(s)][a]);
      pr.series.push_back(std::move(se));
    }
  pr.width = 1100;
  // Excitation: the accelerometer's angular acceleration in B.
  Plot pe;
  pe.title = "excitation: accelerometer angular acceleration in B (CRN low-pass)";
  pe.xlabel = "t - t0 [s]";
  pe.ylabel = "[rad/s^2]";
  for (int a = 0; a < 3; ++a) {
    Series se;
    se.name = std::string("alpha_B ") + ax[a];
    se.x = res.t_s;
    for (const auto& ob : span.obs) se.y.push_back((span.C_B_A * ob.alpha_A)[a]);
    pe.series.push_back(std::move(se));
  }
  // Estimates with their sigma against the CRLB, per head axis.
  Plot pa;
  pa.title = "error angles: estimate +- sigma (left), +- CRLB (right)";
  pa.ylabel = "[arcsec]";
  pa.xlabel = "head axis";
  Series est, bound;
  est.name = "estimate +- sigma";
  bound.name = "estimate +- CRLB";
  est.style = bound.style = Series::Style::kPoints;
  est.dx = -0.12;
  bound.dx = 0.12;
  for (const auto& h : r.heads)
    for (int a = 0; a < 3; ++a) {
      const double x = double(pa.xcategories.size());
      pa.xcategories.push_back(std::to_string(h.id) + ax[a]);
      est.x.push_back(x);
      bound.x.push_back(x);
      est.y.push_back(h.error_angles_arcsec[std::size_t(a)]);
      bound.y.push_back(h.error_angles_arcsec[std::size_t(a)]);
      est.yerr.push_back(h.sigma_arcsec[std::size_t(a)] ? *h.sigma_arcsec[std::size_t(a)] : NAN);
      bound.yerr.push_back(h.crlb_arcsec[std::size_t(a)]);
    }
  pa.series = {est, bound};
  for (const auto& [name, plot] : {std::pair<const char*, const Plot*>{"residuals.svg", &pr},
                                   {"excitation.svg", &pe},
                                   {"estimates.svg", &pa}})
    if (!writeSvgPlot(dir + "/" + name, *plot, error)) return false;

  std::ostringstream md;
  md << "# Mounting calibration (method A)\n\n";
  if (!r.ok) md << "**Not calibrated:** " << r.message << "\n\n";
  md << "Span " << fmt("%.1f", r.span_s) << " s, " << r.epochs << " epochs in the solution, residual RMS "
     << fmt("%.3e", r.residual_rms_radps2) << " rad/s^2. Relative attitude as a "
     << (result["options"]["relative"] == "prior" ? "prior" : "hard constraint") << ".\n\n";
  md << "Datum: " << result["datum"].get<std::string>() << ". Error angles: "
     << result["conventions"]["error_angles_arcsec"].get<std::string>() << ".\n\n";
  md << "| head | axis | error angle [\"] | sigma [\"] | CRLB [\"] | sigma / CRLB | observable |\n"
        "|---|---|---|---|---|---|---|\n";
  for (const auto& h : r.heads)
    for (std::size_t a = 0; a < 3; ++a) {
      const double sg = h.sigma_arcsec[a] ? *h.sigma_arcsec[a] : NAN;
      md << "| " << h.id << " | " << ax[a] << " | " << fmt("%.2f", h.error_angles_arcsec[a]) << " | "
         << (h.sigma_arcsec[a] ? fmt("%.2f", sg) : "not determined") << " | " << fmt("%.2f", h.crlb_arcsec[a])
         << " | " << fmt("%.2f", sg / h.crlb_arcsec[a]) << " | " << (h.observable[a] ? "yes" : "**no**") << " |\n";
    }
  md << "\n";
  if (r.unobservable_directions_B.empty()) {
    md << "Every direction of the body frame is excited.\n\n";
  } else {
    md << "**Not observable** (no excitation about these body directions; shared by all heads):";
    for (const auto& d : r.unobservable_directions_B)
      md << " (" << fmt("%.3f", d.x()) << ", " << fmt("%.3f", d.y()) << ", " << fmt("%.3f", d.z()) << ")";
    md << "\n\n";
  }
  if (!r.excitation_eigenvalues.empty()) {
    md << "Excitation (eigenvalues of sum a a^T in B, rad^2/s^4):";
    for (double e : r.excitation_eigenvalues) md << " " << fmt("%.3e", e);
    md << "\n\n";
  }
  const json& acc = result["accelerometer"];
  if (!acc.empty()) {
    md << "| accelerometer | x | y | z | sigma x | sigma y | sigma z |\n|---|---|---|---|---|---|---|\n";
    for (const auto& [k, sk] : {std::pair<const char*, const char*>{"bias_radps2", "bias_sigma_radps2"},
                                {"scale", "scale_sigma"},
                                {"nonorthogonality_arcsec", "nonorthogonality_sigma_arcsec"}})
      if (acc.contains(k)) {
        md << "| " << k;
        for (int a = 0; a < 3; ++a) md << " | " << fmtJ("%.4g", acc[k][std::size_t(a)]);
        for (int a = 0; a < 3; ++a) md << " | " << fmtJ("%.2g", acc[sk][std::size_t(a)]);
        md << " |\n";
      }
    md << "\n";
  }
  if (r.time_offset_s)
    md << "Time offset (accelerometer tags late by): " << fmt("%.4f", *r.time_offset_s) << " s +- "
       << (r.time_offset_sigma_s ? fmt("%.4f", *r.time_offset_sigma_s) : "-") << " s.\n\n";
  md << "## Thermal (orbit-periodic deformation relative to the datum head)\n\n";
  const json& th = result["thermal"];
  md << (th.contains("status") ? th["status"].get<std::string>() : std::string("-")) << "\n\n";
  if (th.contains("heads")) {
    md << th["datum"].get<std::string>() << " Argument of latitude from " << th["u_source"].get<std::string>()
       << "; beta modulation " << th["beta"]["modulation"].get<std::string>() << " (" << th["beta"]["note"].get<std::string>()
       << ").\n\n";
    md << "| head | axis | harmonic | cos [\"] | sin [\"] | RMS before [\"] | RMS after [\"] |\n|---|---|---|---|---|---|---|\n";
    for (const auto& h : th["heads"]) {
      if (!h["determined"].get<bool>()) {
        md << "| " << h["id"] << " | - | - | not determined: " << h["reason"].get<std::string>() << " | | | |\n";
        continue;
      }
      for (const auto& [axn, f] : h["axes_of_datum_head_frame"].items())
        for (const auto& term : f["harmonics"])
          md << "| " << h["id"] << " | " << axn << " | " << term["harmonic"] << " | " << fmtJ("%.2f", term["cos_arcsec"])
             << " +- " << fmtJ("%.2f", term["sigma_cos_arcsec"]) << " | " << fmtJ("%.2f", term["sin_arcsec"]) << " +- "
             << fmtJ("%.2f", term["sigma_sin_arcsec"]) << " | " << fmtJ("%.2f", f["rms_before_arcsec"]) << " | "
             << fmtJ("%.2f", f["rms_after_arcsec"]) << " |\n";
    }
    md << "\n";
  }
  md << "## Plots\n\n"
        "![residuals](residuals.svg)\n\n"
        "Residuals per head axis under the estimate: alpha_S - Exp([r]x) C_S_B(nominal) C_B_A K^-1 "
        "(alpha_A + tau jerk_A - bias), K = I + scale + non-orthogonality (what was not estimated is zero).\n\n"
        "![excitation](excitation.svg)\n\n"
     << (span.obs.empty() ? "(No epochs were kept (constant-memory moments): the residual and excitation plots are "
                            "empty.)\n\n"
                          : "")
     << "![estimates](estimates.svg)\n\n"
        "Estimates with their reported sigma (left bar) and the Cramer-Rao bound (right bar); an axis "
        "without a bar is not determined.\n\n";
  md << "## Inputs\n\n";
  for (const auto& f : result["inputs"]) md << "- " << f.get<std::string>() << "\n";
  for (const auto& f : result["ignored"])
    md << "- " << f["file"].get<std::string>() << " (" << f["product"].get<std::string>() << ", ignored)\n";
  return io::writeFileAtomic(dir + "/report.md", md.str(), error);
}

}  // namespace boresight::report
