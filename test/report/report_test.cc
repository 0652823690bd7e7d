// The calibration result writers with a hand-filled SolveResult (no solver involved): JSON keys and
// nulls, the YAML copy read back, residuals of a span built from known angles, report.md and plots.
#include <boresight/core/rotation.h>
#include <boresight/report/calibration.h>
#include <boresight/report/svg_plot.h>

#include "test_files.h"

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <cstdlib>
#include <random>

namespace bc = boresight::calib;
namespace br = boresight::report;
using boresight::Mat3;
using boresight::Quat;
using boresight::Vec3;
using boresight::report::Json;

namespace {

bc::SolveResult handFilled() {
  bc::SolveResult r;
  r.ok = true;
  r.message = "converged";
  for (int id : {1, 2, 3}) {
    bc::HeadResult h;
    h.id = id;
    h.error_angles_arcsec = {10.0 * id, -5.0, 20.0};
    h.sigma_arcsec = {1.5, 2.0, std::nullopt};  // z not determined
    h.crlb_arcsec = {1.4, 1.9, INFINITY};
    h.observable = {true, true, false};
    r.heads.push_back(h);
  }
  r.unobservable_directions_B = {Vec3(0, 0, 1)};
  r.covariance_arcsec2.assign(81, 0.0);
  for (int i = 0; i < 9; ++i) r.covariance_arcsec2[std::size_t(i * 9 + i)] = 2.0 + i;
  r.covariance_arcsec2[8 * 9 + 8] = NAN;
  bc::Estimate3 b;
  b.value = {1e-7, -2e-7, 3e-7};
  b.sigma = {1e-9, 2e-9, std::nullopt};
  r.acc_bias_radps2 = b;
  r.time_offset_s = 0.25;
  r.time_offset_sigma_s = 0.01;
  r.residual_rms_radps2 = 3.2e-8;
  r.epochs = 1234;
  r.span_s = 12345.5;
  r.excitation_eigenvalues = {1e-20, 1e-12, 3e-12};
  return r;
}

}  // namespace

TEST(CalibrationJson, KeysOfTheIssueWithNullWhereNotDetermined) {
  br::CalibrationContext c;
  c.inputs = {"SCA1A.txt", "ACC1A.txt"};
  c.ignored = {{"GNV1B.txt", "GNV1B"}};
  c.options.estimate_time_offset = true;
  const auto j = br::calibrationJson(handFilled(), c);
  for (const char* k : {"heads", "unobservable_directions_B", "covariance_arcsec2", "accelerometer", "time_offset_s",
                        "time_offset_sigma_s", "thermal", "residual_rms_radps2", "epochs", "span_s", "datum"})
    EXPECT_TRUE(j.contains(k)) << k;
  ASSERT_EQ(j["heads"].size(), 3u);
  const auto& h = j["heads"][1];
  EXPECT_EQ(h["id"], 2);
  EXPECT_DOUBLE_EQ(h["error_angles_arcsec"][0].get<double>(), 20.0);
  EXPECT_DOUBLE_EQ(h["sigma_arcsec"][1].get<double>(), 2.0);
  EXPECT_TRUE(h["sigma_arcsec"][2].is_null());   // not determined: null, never a number
  EXPECT_TRUE(h["crlb_arcsec"][2].is_null());    // infinite bound
  EXPECT_EQ(h["observable"][2], false);
  EXPECT_EQ(j["covariance_arcsec2"].size(), 81u);
  EXPECT_TRUE(j["covariance_arcsec2"][80].is_null());
  EXPECT_DOUBLE_EQ(j["covariance_arcsec2"][10].get<double>(), 3.0);
  EXPECT_EQ(j["unobservable_directions_B"][0], Json({0.0, 0.0, 1.0}));
  // Only what was estimated.
  EXPECT_TRUE(j["accelerometer"].contains("bias_radps2"));
  EXPECT_TRUE(j["accelerometer"]["bias_sigma_radps2"][2].is_null());
  EXPECT_FALSE(j["accelerometer"].contains("scale"));
  EXPECT_DOUBLE_EQ(j["time_offset_s"].get<double>(), 0.25);
  EXPECT_EQ(j["epochs"], 1234);
  EXPECT_EQ(j["thermal"]["status"], "not computed");
  EXPECT_EQ(j["ignored"][0]["product"], "GNV1B");
  // No time offset estimated: null, not 0.
  bc::SolveResult r2 = handFilled();
  r2.time_offset_s.reset();
  r2.time_offset_sigma_s.reset();
  EXPECT_TRUE(br::calibrationJson(r2, c)["time_offset_s"].is_null());
  // The whole document is valid JSON (dump and parse back).
  EXPECT_EQ(Json::parse(j.dump()), j);
}

/// YAML value -> JSON value, for comparing the YAML copy with the JSON.
Json fromYaml(const YAML::Node& n) {
  if (n.IsMap()) {
    Json j = Json::object();
    for (const auto& kv : n) j[kv.first.as<std::string>()] = fromYaml(kv.second);
    return j;
  }
  if (n.IsSequence()) {
    Json j = Json::array();
    for (const auto& v : n) j.push_back(fromYaml(v));
    return j;
  }
  if (n.IsNull()) return nullptr;
  const std::string s = n.Scalar();
  if (n.Tag() == "!") return s;  // quoted: a string
  if (s == "true" || s == "false") return s == "true";
  return n.as<double>();
}

/// JSON numbers compared as doubles to 10 significant digits (the YAML precision).
void expectSame(const Json& a, const Json& b, const std::string& where) {
  if (a.is_number() && b.is_number()) {
    const double x = a.get<double>(), y = b.get<double>();
    EXPECT_NEAR(x, y, 1e-9 * std::max(std::abs(x), 1e-300)) << where;
    return;
  }
  ASSERT_EQ(a.type(), b.type()) << where << ": " << a.dump() << " vs " << b.dump();
  if (a.is_object()) {
    ASSERT_EQ(a.size(), b.size()) << where;
    for (auto it = a.begin(); it != a.end(); ++it) {
      ASSERT_TRUE(b.contains(it.key())) << where << "." << it.key();
      expectSame(it.value(), b[it.key()], where + "." + it.key());
    }
  } else if (a.is_array()) {
    ASSERT_EQ(a.size(), b.size()) << where;
    for (std::size_t i = 0; i < a.size(); ++i) expectSame(a[i], b[i], where + "[" + std::to_string(i) + "]");
  } else {
    EXPECT_EQ(a, b) << where;
  }
}

TEST(CalibrationYaml, TheYamlCopyReadsBackAsTheSameTree) {
  br::CalibrationContext c;
  c.inputs = {"a: b.txt", "quote\"d"};
  c.thermal = {{"datum_head", 1}, {"heads", Json::array({{{"id", 2}, {"x", {1.0, 2.0}}}})}};
  const auto j = br::calibrationJson(handFilled(), c);
  const std::string y = br::toYaml(j);
  YAML::Node n;
  ASSERT_NO_THROW(n = YAML::Load(y)) << y;
  expectSame(j, fromYaml(n), "");
}

TEST(CalibrationReport, ResidualsOfASpanBuiltFromTheEstimatesAreZeroAndShowAWrongAngle) {
  bc::CalibrationSpan span;
  span.n_heads = 2;
  span.head_ids = {};
  span.head_ids[0] = 1;
  span.head_ids[1] = 2;
  span.q_S_B_nominal[0] = Quat(Eigen::AngleAxisd(0.3, Vec3(1, 2, 3).normalized()));
  span.q_S_B_nominal[1] = Quat(Eigen::AngleAxisd(-1.2, Vec3(0, 1, 1).normalized()));
  span.C_B_A << 0, 0, 1, 1, 0, 0, 0, 1, 0;
  bc::SolveResult r = handFilled();
  r.heads.resize(2);
  const Vec3 bias(1e-7, -2e-7, 3e-7);
  for (int s = 0; s < 2; ++s) {
    const auto& e = r.heads[std::size_t(s)].error_angles_arcsec;
    r.estimate.r_S[std::size_t(s)] = Vec3(e[0], e[1], e[2]) * boresight::kRadPerArcsec;
  }
  r.estimate.acc_bias = bias;
  r.estimate.acc_scale = Vec3(1e-3, -2e-3, 5e-4);
  r.estimate.acc_nonorth = Vec3(1e-4, 2e-4, -3e-4);
  r.estimate.time_offset_s = 0.2;
  Mat3 K = Mat3::Identity();
  K.diagonal() += r.estimate.acc_scale;
  K(0, 1) = K(1, 0) = -3e-4;
  K(0, 2) = K(2, 0) = 2e-4;
  K(1, 2) = K(2, 1) = 1e-4;
  std::mt19937 rng(3);
  std::normal_distribution<double> g(0.0, 1e-6);
  for (int k = 0; k < 50; ++k) {
    bc::Observation ob;
    ob.t = 1000000 + k * 10000000LL;
    const Vec3 truth(g(rng), g(rng), g(rng));
    ob.jerk_A = Vec3(g(rng), g(rng), g(rng));
    ob.alpha_A = K * truth + bias - 0.2 * ob.jerk_A;  // tags late by 0.2 s
    for (int s = 0; s < 2; ++s) {
      const auto& e = r.heads[std::size_t(s)].error_angles_arcsec;
      const Vec3 rv = Vec3(e[0], e[1], e[2]) * boresight::kRadPerArcsec;
      ob.has_head[std::size_t(s)] = !(s == 1 && k == 7);  // a gap in head 2
      ob.alpha_S[std::size_t(s)] = boresight::core::so3Exp(rv) * span.q_S_B_nominal[std::size_t(s)].toRotationMatrix() *
                                   span.C_B_A * truth;
    }
    span.obs.push_back(ob);
  }
  auto res = bc::residuals(span, r.estimate);
  ASSERT_EQ(res.t_s.size(), 50u);
  EXPECT_DOUBLE_EQ(res.t_s.front(), 0.0);
  EXPECT_DOUBLE_EQ(res.t_s.back(), 490.0);
  for (std::size_t k = 0; k < 50; ++k)
    for (int s = 0; s < 2; ++s) {
      if (s == 1 && k == 7) {
        EXPECT_TRUE(std::isnan(res.r_S[k][1].x()));
        continue;
      }
      EXPECT_LT(res.r_S[k][std::size_t(s)].norm(), 1e-18) << k << " " << s;
    }
  // A head angle off by 100": residuals of about 100" times the excitation.
  bc::SolveResult wrong = r;
  wrong.estimate.r_S[0].x() += 100.0 * boresight::kRadPerArcsec;
  auto res2 = bc::residuals(span, wrong.estimate);
  double worst = 0;
  for (const auto& row : res2.r_S) worst = std::max(worst, row[0].norm());
  EXPECT_GT(worst, 1e-6 * 100 * boresight::kRadPerArcsec);

  const std::string dir = testutil::makeTempDir("calib_report") + "/out";
  br::CalibrationContext c;
  c.inputs = {"SCA1A.txt"};
  std::string err;
  ASSERT_TRUE(br::writeCalibrationReport(dir, span, r, br::calibrationJson(r, c), &err)) << err;
  const std::string md = testutil::slurp(dir + "/report.md");
  EXPECT_NE(md.find("| 1 | z | 20.00 | not determined | - |"), std::string::npos) << md;
  EXPECT_NE(md.find("**Not observable**"), std::string::npos);
  EXPECT_NE(md.find("(0.000, 0.000, 1.000)"), std::string::npos);
  for (const char* f : {"residuals.svg", "excitation.svg", "estimates.svg"}) {
    const std::string svg = testutil::slurp(dir + "/" + f);
    EXPECT_EQ(svg.rfind("<svg", 0), 0u) << f;
    EXPECT_NE(svg.find("</svg>"), std::string::npos) << f;
    EXPECT_NE(md.find(f), std::string::npos) << f;
  }
  // 2 heads x 3 axes with sigma bars where determined (4 of 6) and CRLB bars where finite (4 of 6).
  const std::string est = testutil::slurp(dir + "/estimates.svg");
  std::size_t bars = 0;
  for (std::size_t p = est.find("stroke-width='2'"); p != std::string::npos; p = est.find("stroke-width='2'", p + 1))
    ++bars;
  EXPECT_EQ(bars, 4u + 4u);
  // An unwritable directory: an error, no crash.
  EXPECT_FALSE(br::writeCalibrationReport("/proc/no/such", span, r, br::calibrationJson(r, c), &err));
  EXPECT_FALSE(err.empty());
}

TEST(SvgPlot, GapsBreakTheLineAndEmptyDataGivesAFrame) {
  br::Plot p;
  br::Series s;
  s.name = "a<b";
  s.x = {0, 1, 2, 3};
  s.y = {1, NAN, 2, 3};
  p.series.push_back(s);
  const std::string svg = br::svgPlot(p);
  EXPECT_NE(svg.find("a&lt;b"), std::string::npos);
  // Two pen-down moves: the gap starts a new segment.
  std::size_t moves = 0;
  for (std::size_t q = svg.find(" M"); q != std::string::npos; q = svg.find(" M", q + 1)) ++moves;
  EXPECT_EQ(moves, 2u);
  EXPECT_NE(br::svgPlot(br::Plot{}).find("</svg>"), std::string::npos);
}

TEST(SvgPlot, AnAsymmetricErrorBarReachesEachEnd) {
  // yerr above the point, yerr_lo below it: the bar's two halves in the ratio of the two lengths.
  br::Plot p;
  br::Series s;
  s.name = "points";
  s.style = br::Series::Style::kPoints;
  s.x = {1};
  s.y = {10};
  s.yerr = {10};
  s.yerr_lo = {5};
  p.series.push_back(s);
  const std::string svg = br::svgPlot(p);
  // the bar is the line drawn 2 wide; the point its circle
  const std::size_t bar = svg.rfind("<line", svg.find("stroke-width='2'")), dot = svg.find("<circle");
  ASSERT_TRUE(bar != std::string::npos && dot != std::string::npos);
  auto attr = [&](std::size_t at, const std::string& name) { return std::atof(svg.c_str() + svg.find(" " + name + "='", at) + name.size() + 3); };
  const double y1 = attr(bar, "y1"), y2 = attr(bar, "y2"), cy = attr(dot, "cy");
  // SVG y grows downwards: y1 (the lower end, value 5) below the point, y2 (value 20) above it
  EXPECT_GT(y1, cy);
  EXPECT_LT(y2, cy);
  EXPECT_NEAR((cy - y2) / (y1 - cy), 2.0, 1e-4);  // coordinates are printed to 6 digits
}

TEST(ThermalJson, PerNonDatumHeadAxisAndHarmonicWithBetaNotDeterminedOnShortSpans) {
  bc::ThermalFitResult t;
  t.ok = true;
  t.datum_note = "head 1 (slot 0) is the datum";
  t.harmonics = {1, 3};
  t.beta_note = "beta moved 0.1 deg";
  bc::ThermalHeadFit h;
  h.id = 2;
  h.datum_id = 1;
  h.determined = true;
  h.epochs = 1000;
  for (std::size_t a = 0; a < 3; ++a) {
    h.axis[a].terms = {{1, 4.0 + double(a), -3.0, 0.5, 0.6}, {3, 0.1, 0.2, 0.4, 0.4}};
    h.axis[a].rms_before_arcsec = 10;
    h.axis[a].rms_after_arcsec = 6;
  }
  bc::ThermalHeadFit h3;
  h3.id = 3;
  h3.datum_id = 1;
  h3.reason = "u covers 0.2 revolutions";
  t.heads = {h, h3};
  Json j = br::thermalJson(t);
  EXPECT_EQ(j["status"], "fitted");
  EXPECT_EQ(j["beta"]["modulation"], "not determined");
  const auto& y = j["heads"][0]["axes_of_datum_head_frame"]["y"];
  EXPECT_EQ(y["beta_modulation"], "not determined");
  EXPECT_EQ(y["harmonics"][0]["harmonic"], 1);
  EXPECT_DOUBLE_EQ(y["harmonics"][0]["cos_arcsec"].get<double>(), 5.0);
  EXPECT_DOUBLE_EQ(y["harmonics"][0]["sigma_sin_arcsec"].get<double>(), 0.6);
  EXPECT_EQ(y["harmonics"][1]["harmonic"], 3);
  EXPECT_DOUBLE_EQ(y["rms_after_arcsec"].get<double>(), 6.0);
  EXPECT_EQ(j["heads"][0]["datum_head"], 1);
  EXPECT_FALSE(j["heads"][1]["determined"].get<bool>());
  EXPECT_EQ(j["heads"][1]["reason"], "u covers 0.2 revolutions");
  EXPECT_FALSE(j["heads"][1].contains("axes_of_datum_head_frame"));
  // Weeks of data: the beta terms are written.
  t.beta_determined = true;
  t.heads[0].beta_determined = true;
  for (auto& ax : t.heads[0].axis) ax.beta_terms = {{1, 0.7, -0.2, 0.1, 0.1}, {3, 0.0, 0.0, 0.1, 0.1}};
  j = br::thermalJson(t);
  EXPECT_EQ(j["beta"]["modulation"], "fitted");
  EXPECT_DOUBLE_EQ(j["heads"][0]["axes_of_datum_head_frame"]["z"]["beta_modulation"][0]["cos_arcsec"].get<double>(), 0.7);
  // Not fitted at all: the reason in the status.
  t.ok = false;
  t.error = "no orbit records";
  EXPECT_EQ(br::thermalJson(t)["status"], "not determined: no orbit records");
}
