// audit.json and report.md on a hand-made AuditResult: the issue's keys, NaN as null, the files and
// plots written, and a clear error for a directory that cannot be written.
#include <boresight/audit/report.h>

#include "test_files.h"

#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <string>

using namespace boresight::audit;
using nlohmann::json;

namespace {

EffectTest effect(const std::string& name, const std::string& sensor, const std::string& family, double stat,
                  double thr, double p, bool named) {
  EffectTest e;
  e.name = name;
  e.sensor = sensor;
  e.family = family;
  e.statistic = stat;
  e.threshold = thr;
  e.p_value = p;
  e.dof = 3;
  e.detected = stat > thr;
  e.named = named;
  return e;
}

/// A result with something in every field, NaN in some numbers.
AuditResult handMade(bool with_truth) {
  AuditResult r;
  r.baseline.description = "configured heads and accelerometer, QSA1B mountings";
  r.baseline.span_s = 600;
  r.baseline.bin_s = 0.5;
  r.baseline.head_epochs = 1200;
  r.baseline.families = {"relative", "noise", "reference"};
  r.baseline.missing = {"angular_acceleration: span 16 s < CRN 70.7 s"};
  r.baseline.values["sigma_cross_arcsec"] = 6.0;
  r.baseline.values["not_known"] = kNaN;
  EffectTest mis = effect("relative_misalignment", "2", "relative", 85.0, 12.5, 1e-12, true);
  mis.params = {{"x_arcsec", "arcsec", 21.5, 0.8, with_truth ? 20.0 : kNaN},
                {"y_arcsec", "arcsec", -3.0, kNaN, kNaN}};
  EffectTest lat = effect("time_offset", "reference", "reference", 40.0, 12.5, 3e-8, true);
  lat.params = {{"offset_ms", "ms", 550.0, 40.0, kNaN}};
  EffectTest clean = effect("acc_scale", "acc", "angular_acceleration", 1.2, 12.5, kNaN, false);
  clean.note = "|ln(estimated / configured variance)| over its jackknife error";
  r.effects = {mis, lat, clean};
  r.tests = 3;
  r.named = {mis, lat};
  r.extended = {mis, lat};
  r.not_explained.push_back({"relative", "pair 1-2 axis y: residual line at 3 cycles/rev", 30.0, 12.5});
  r.ambiguous.push_back({{"time_offset[reference]", "relative_misalignment[reference]"},
                         "attitude rate changes (a manoeuvre) or a span long enough for the pitch rate to vary",
                         0.998});
  Gain g;
  g.family = "relative";
  g.unit = "arcsec";
  g.rms_before = 22.0;
  g.rms_after = 2.1;
  g.heldout_rms_before = 22.5;
  g.heldout_rms_after = 2.3;
  g.whiteness_before = 0.9;
  g.whiteness_after = 0.05;
  g.delta_bic = -812.0;
  Gain g2 = g;
  g2.family = "reference";
  g2.delta_bic = kNaN;
  g2.heldout_rms_after = kNaN;
  r.gain = g;
  r.gains = {g, g2};
  if (with_truth) r.truth.push_back({"relative_misalignment", "2", "x_arcsec", "arcsec", 20.0, 0.0, 21.5});
  Series s;
  s.family = "relative";
  s.label = "pair 1-2 x_B";
  s.unit = "arcsec";
  for (int i = 0; i < 50; ++i) {
    s.t_s.push_back(i * 0.5);
    s.before.push_back(20.0 + std::sin(i * 0.3));
    s.after.push_back(std::sin(i * 0.3));
  }
  s.before[10] = kNaN;  // a gap
  Series iba = s;
  iba.label = "iba 1-2";
  r.series = {s, iba};
  Spectrum sp;
  sp.family = "relative";
  sp.label = "pair 1-2 x_B";
  sp.unit = "cycles/rev";
  sp.freq = {0.5, 1, 2, 3, 4};
  sp.before = {8, 5, 1, 0.5, 0.2};
  sp.after = {0.6, 0.5, 0.4, 0.5, 0.2};
  sp.noise = {0.7, 0.5, 0.3, 0.3, 0.25};
  r.spectra = {sp};
  r.findings = {"the relative alignment of head 2 changed since QSA1B by 21.5\" about x"};
  return r;
}

}  // namespace

TEST(AuditJson, HasTheIssuesKeysAndNaNIsNull) {
  const std::string dir = testutil::makeTempDir("audit_json");
  std::string err;
  ASSERT_TRUE(writeAuditJson(handMade(true), dir + "/audit.json", &err)) << err;
  const json j = json::parse(testutil::slurp(dir + "/audit.json"));
  for (const char* k : {"baseline", "effects", "named_causes", "not_explained", "ambiguous", "extended", "gain", "gains",
                        "truth"})
    EXPECT_TRUE(j.contains(k)) << k;
  ASSERT_EQ(j["effects"].size(), 3u);
  for (const auto& e : j["effects"])
    for (const char* k : {"name", "sensor", "statistic", "threshold", "p_value", "detected", "params"})
      EXPECT_TRUE(e.contains(k)) << k << " in " << e.dump();
  const json& p = j["effects"][0]["params"];
  EXPECT_EQ(p["x_arcsec"]["unit"], "arcsec");
  EXPECT_DOUBLE_EQ(p["x_arcsec"]["value"].get<double>(), 21.5);
  EXPECT_DOUBLE_EQ(p["x_arcsec"]["truth"].get<double>(), 20.0);
  EXPECT_TRUE(p["y_arcsec"]["sigma"].is_null());          // NaN -> null
  EXPECT_FALSE(p["y_arcsec"].contains("truth"));          // no truth for it
  EXPECT_TRUE(j["effects"][2]["p_value"].is_null());      // NaN -> null
  EXPECT_FALSE(j["effects"][2]["detected"].get<bool>());
  EXPECT_TRUE(j["baseline"]["values"]["not_known"].is_null());
  ASSERT_EQ(j["named_causes"].size(), 2u);
  EXPECT_EQ(j["named_causes"][0]["name"], "relative_misalignment");
  EXPECT_EQ(j["named_causes"][0]["sensor"], "2");
  EXPECT_EQ(j["named_causes"][1]["params"]["offset_ms"]["unit"], "ms");
  ASSERT_EQ(j["ambiguous"].size(), 1u);
  EXPECT_EQ(j["ambiguous"][0]["causes"].size(), 2u);
  EXPECT_NE(j["ambiguous"][0]["separate_by"].get<std::string>().find("manoeuvre"), std::string::npos);
  EXPECT_EQ(j["not_explained"][0]["family"], "relative");
  EXPECT_EQ(j["extended"].size(), 2u);
  for (const char* k : {"family", "unit", "rms_before", "rms_after", "heldout_rms_before", "heldout_rms_after",
                        "delta_bic"}) {
    EXPECT_TRUE(j["gain"].contains(k)) << k;
    for (const auto& g : j["gains"]) EXPECT_TRUE(g.contains(k)) << k;
  }
  EXPECT_DOUBLE_EQ(j["gain"]["delta_bic"].get<double>(), -812.0);
  EXPECT_TRUE(j["gains"][1]["delta_bic"].is_null());
  EXPECT_TRUE(j["gains"][1]["heldout_rms_after"].is_null());
  EXPECT_EQ(j["truth"][0]["key"], "x_arcsec");
}

TEST(AuditJson, NoTruthKeyWithoutTruthAndAnEmptyResultIsValid) {
  const json j = json::parse(auditJsonText(handMade(false)));
  EXPECT_FALSE(j.contains("truth"));
  const json e = json::parse(auditJsonText(AuditResult{}));
  EXPECT_TRUE(e["effects"].empty());
  EXPECT_TRUE(e["gain"]["rms_before"].is_null());
  EXPECT_EQ(e["gain"]["family"], "");
}

TEST(AuditReport, WritesTheReportAndEveryPlot) {
  const std::string dir = testutil::makeTempDir("audit_report") + "/nested/out";  // created
  std::string err;
  ReportContext ctx;
  ctx.command = "boresight audit --config gracefo.yaml SCA1A.txt --out out";
  ctx.notes = {"outside reference: 16 SCA1B samples, GPS time tags mapped to receiver time through CLK1B"};
  const AuditResult r = handMade(true);
  ASSERT_TRUE(writeAuditReport(r, dir, &err, &ctx)) << err;
  const std::vector<std::string> plots = auditPlotFiles(r);
  for (const char* f : {"residuals_relative.svg", "iba.svg", "spectrum_relative.svg", "estimates_arcsec.svg",
                        "estimates_ms.svg"}) {
    EXPECT_NE(std::find(plots.begin(), plots.end(), f), plots.end()) << f;
    const std::string svg = testutil::slurp(dir + "/" + f);
    EXPECT_NE(svg.find("<svg"), std::string::npos) << f;
  }
  // The iba series is on its own plot, not among the residuals; before and after both drawn.
  const std::string res = testutil::slurp(dir + "/residuals_relative.svg");
  EXPECT_NE(res.find("pair 1-2 x_B before"), std::string::npos);
  EXPECT_NE(res.find("pair 1-2 x_B after"), std::string::npos);
  EXPECT_EQ(res.find("iba 1-2"), std::string::npos);
  EXPECT_NE(testutil::slurp(dir + "/iba.svg").find("iba 1-2 before"), std::string::npos);
  // The spectra: the fitted noise model beside the residuals, the orbit harmonics marked.
  const std::string spec = testutil::slurp(dir + "/spectrum_relative.svg");
  EXPECT_NE(spec.find("pair 1-2 x_B noise model"), std::string::npos);
  EXPECT_NE(spec.find("orbit harmonics"), std::string::npos);
  // Estimates with their error bars: a parameter without a sigma is not drawn.
  const std::string est = testutil::slurp(dir + "/estimates_arcsec.svg");
  EXPECT_NE(est.find("relative_misalignment[2] x_arcsec"), std::string::npos);
  EXPECT_EQ(est.find("relative_misalignment[2] y_arcsec"), std::string::npos);
  const std::string md = testutil::slurp(dir + "/report.md");
  for (const char* s : {"## What is wrong", "changed since QSA1B", "relative_misalignment", "| 85 | 12.5 |",
                        "What would separate them: attitude rate changes", "residual line at 3 cycles/rev",
                        "| relative (largest gain) | arcsec | 22 | 2.1 | 22.5 | 2.3 |", "## Against the truth",
                        "through CLK1B", "(residuals_relative.svg)", "(estimates_ms.svg)",
                        "angular_acceleration: span 16 s < CRN 70.7 s",
                        "(\\|ln(estimated / configured variance)\\| over"})  // a pipe in a cell is escaped
    EXPECT_NE(md.find(s), std::string::npos) << s << "\n" << md;
}

TEST(AuditReport, AnEmptyResultSaysSoAndWritesNoPlot) {
  const std::string dir = testutil::makeTempDir("audit_empty");
  std::string err;
  ASSERT_TRUE(writeAuditReport(AuditResult{}, dir, &err)) << err;
  const std::string md = testutil::slurp(dir + "/report.md");
  EXPECT_NE(md.find("No finding"), std::string::npos) << md;
  EXPECT_NE(md.find("No series to plot"), std::string::npos) << md;
  EXPECT_TRUE(auditPlotFiles(AuditResult{}).empty());
}

TEST(AuditReport, AnUnwritableDirectoryIsAClearError) {
  // A directory below a regular file cannot be created, whoever runs the test (root too).
  const std::string base = testutil::makeTempDir("audit_unwritable");
  ASSERT_TRUE(testutil::writeFile(base + "/file", "x"));
  std::string err;
  EXPECT_FALSE(writeAuditReport(handMade(false), base + "/file/report", &err));
  EXPECT_NE(err.find(base + "/file/report: cannot create the report directory"), std::string::npos) << err;
  err.clear();
  EXPECT_FALSE(writeAuditJson(handMade(false), base + "/file/audit.json", &err));
  EXPECT_NE(err.find(base + "/file/audit.json: cannot create"), std::string::npos) << err;
}
