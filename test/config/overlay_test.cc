// The model overlay (model/overlay.h, io/overlay_yaml.h): a fully populated overlay round-trips
// (write, read, equal); the reader refuses an unknown version, unknown and misspelt keys (naming the
// nearest), keys given twice, NaN/Inf and out-of-range values, each as FILE:LINE: key 'k': reason; the
// noise section has one form for overlays and platform files; the noise table layers an overlay over a
// platform file and derives the core's sigmas.
#include <boresight/core/rotation.h>
#include <boresight/io/core_config.h>
#include <boresight/model/sensors.h>
#include <boresight/io/overlay_apply.h>
#include <boresight/io/overlay_yaml.h>
#include <boresight/io/time_format.h>
#include <boresight/model/overlay.h>

#include "test_files.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <string>

namespace boresight {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
const std::string kConfigDir = std::string(BORESIGHT_SOURCE_DIR) + "/config";

TimeUs gps(const char* s) {
  TimeUs t = 0;
  EXPECT_TRUE(io::parseGpsCalendar(s, t)) << s;
  return t;
}

model::Uncertain3 u3(double a, double b, double c, double sa, double sb, double sc, double scale) {
  model::Uncertain3 u;
  u.value = Vec3(a, b, c) * scale;
  u.sigma = Vec3(sa, sb, sc) * scale;
  return u;
}

model::NoiseParam param(const std::string& name, double value, double sigma, bool determined = true,
                        const std::string& note = "") {
  model::NoiseParam p;
  p.name = name;
  p.value = value;
  p.sigma = sigma;
  p.log_scale = name.find("alpha") == std::string::npos;
  p.log_sigma = std::isnan(sigma) ? kNaN : (p.log_scale ? sigma / value : 0.0);
  p.determined = determined;
  p.note = note;
  return p;
}

/// Every part, every kind of noise term, uncertainties and undetermined parameters, open and closed
/// validity spans, sigmas not determined.
model::Overlay fullOverlay() {
  model::Overlay o;
  o.written_by = "overlay_test (by hand)";
  o.platform = "GRACE-FO";
  o.note = "every part: \"quoted\" text, a backslash \\ and a colon: here";
  model::MountingEntry m;
  m.head = 1;
  m.q_Si_B = Quat(-0.1843610150, 0.6881349921, 0.6762283734, 0.1876071319).normalized();
  m.datum = model::MountingDatum::Accelerometer;
  m.epoch = gps("2023-06-01 00:07:10.5");
  m.sigma_rad = Vec3(12.25, 13.5, kNaN) * kRadPerArcsec;
  m.valid.from = gps("2023-06-01 00:00:00");
  m.valid.to = gps("2023-06-02 00:00:00.000001");
  o.mountings.push_back(m);
  m.head = 2;
  m.q_Si_B = Quat(0.2495963317, -0.0402839151, 0.8505722893, 0.4610918109).normalized();
  m.datum = model::MountingDatum::StarCameras;
  m.sigma_rad = Vec3(1, 2, 3) * kRadPerArcsec;
  m.valid = model::Validity{};  // open
  m.valid.from = gps("2023-06-01");
  o.mountings.push_back(m);
  m.head = 3;
  m.datum = model::MountingDatum::Ground;
  m.valid = model::Validity{};
  o.mountings.push_back(m);

  model::HeadNoise d;
  model::AxisNoise white;
  white.model = model::NoiseModel::white(2.1 * kRadPerArcsec);
  white.params.push_back(param("white.sigma", 2.1 * kRadPerArcsec, 0.05 * kRadPerArcsec));
  d.axis[0] = white;
  model::AxisNoise coloured;
  coloured.model.add(model::NoiseTerm::white(1.9 * kRadPerArcsec))
      .add(model::NoiseTerm::gaussMarkov(0.5 * kRadPerArcsec, 600))
      .add(model::NoiseTerm::gaussMarkov(0.25 * kRadPerArcsec, 5400))
      .add(model::NoiseTerm::powerLaw(1.0 * kRadPerArcsec, 1.2, 1e-4, 1e-2));
  coloured.params = {param("white.sigma", 1.9 * kRadPerArcsec, 0.01 * kRadPerArcsec),
                     param("gm1.sigma", 0.5 * kRadPerArcsec, 0.1 * kRadPerArcsec),
                     param("gm1.tau_s", 600, 120),
                     param("gm2.tau_s", 5400, kNaN, false, "slower than a fifth of the span"),
                     param("pl.alpha", 1.2, 0.3),
                     param("pl.f_lo_hz", 1e-4, 2e-5, false, "near 20/T")};
  d.axis[1] = coloured;
  d.axis[2] = model::AxisNoise{model::NoiseModel::white(25 * kRadPerArcsec), {}};
  d.axis[3] = model::AxisNoise{model::NoiseModel::white(5 * kRadPerArcsec), {}};
  d.valid.to = gps("2024-01-01 00:00:00");
  o.noise.head_defaults = d;
  model::HeadNoise h3;
  h3.id = 3;
  h3.axis[2] = model::AxisNoise{model::NoiseModel::white(31 * kRadPerArcsec), {}};
  h3.valid.from = gps("2023-06-01 00:00:00");
  h3.valid.to = gps("2023-06-01 12:00:00");
  o.noise.heads.push_back(h3);
  model::HeadNoise h2;
  h2.id = 2;
  h2.axis[0] = model::AxisNoise{model::NoiseModel::white(1.7 * kRadPerArcsec), {}};
  o.noise.heads.push_back(h2);
  model::AccNoise acc;
  acc.axis[0] = model::AxisNoise{model::NoiseModel::white(1.5e-7).add(model::NoiseTerm::gaussMarkov(2e-8, 2000)),
                                 {param("gm1.sigma", 2e-8, 4e-9)}};
  acc.axis[2] = model::AxisNoise{model::NoiseModel::white(5e-8), {}};
  o.noise.accelerometer = acc;

  model::ThermalTerms th;
  th.datum_head = 1;
  th.beta_ref_rad = 23.5 * kRadPerDeg;
  th.valid.from = gps("2023-06-01 00:00:00");
  model::ThermalHeadEntry te;
  te.head = 2;
  te.constant_rad = u3(41.5, -3.25, 7, 0.5, 0.5, 4, kRadPerArcsec);
  model::ThermalHarmonicEntry x;
  x.harmonic = 1;
  x.cos_rad = u3(8, 0.1, -2, 0.2, 0.2, 1.5, kRadPerArcsec);
  x.sin_rad = u3(-1, 0.3, 0.7, 0.2, 0.2, kNaN, kRadPerArcsec);
  te.harmonics.push_back(x);
  x.harmonic = 3;
  te.harmonics.push_back(x);
  x.harmonic = 1;
  te.beta_harmonics.push_back(x);
  th.heads.push_back(te);
  te.head = 3;
  te.beta_harmonics.clear();
  th.heads.push_back(te);
  o.thermal = th;

  model::AccelerometerTerms at;
  at.bias_rad_s2 = u3(1.31e-5, 1.19e-4, -7.81e-4, 1e-8, 2e-8, 3e-8, 1.0);
  at.scale = u3(0.002, -0.001, 0.0005, 5e-5, 5e-5, kNaN, 1.0);
  at.misalignment_rad = u3(750, 150, -650, 7, 7, 8, kRadPerArcsec);
  at.nonorthogonality_rad = u3(10, -20, 30, 1, 2, 3, kRadPerArcsec);
  at.valid.from = gps("2023-06-01 00:00:00");
  at.valid.to = gps("2023-06-01 00:14:20");
  o.accelerometer = at;

  model::TimeOffsetEntry t;
  t.sensor = "accelerometer";
  t.relative_to = "heads";
  t.offset_s = 0.01503;
  t.sigma_s = 0.00017;
  o.time_offsets.push_back(t);
  t.sensor = "head2";
  t.relative_to = "gps";
  t.offset_s = -0.546;
  t.sigma_s = kNaN;
  t.valid.to = gps("2023-06-01 00:00:16");
  o.time_offsets.push_back(t);
  model::PublishedFrame f;
  f.q_B_Bpub = Quat(0.9999999, 0.0002, -0.0003, 0.0001).normalized();
  f.epoch = gps("2023-06-01 03:20:00");
  f.calibration = 4;
  o.published_frame = f;
  model::DataEventRates ev;
  ev.head_dropouts_per_day = 0.5;
  ev.head_dropouts_by_id = {{3, 12.25}, {1, 0}};
  ev.epoch_gaps_per_day = 2;
  ev.acc_gaps_per_day = 1.0 / 3;
  ev.epoch_gap_max_s = 90;  // the others: no limit (null in the file)
  o.data_events = ev;
  return o;
}

TEST(Overlay, FullyPopulatedOverlayRoundTrips) {
  const model::Overlay o = fullOverlay();
  ASSERT_EQ(model::validate(o), "");
  const std::string text = io::overlayYaml(o);
  EXPECT_EQ(text.find("boresight_overlay: 1\n"), text.find("boresight_overlay")) << "the version is the first key";
  EXPECT_NE(text.find("written_by: \"overlay_test (by hand)\""), std::string::npos) << text;
  model::Overlay back;
  std::string err;
  ASSERT_TRUE(io::parseOverlay(text, "full.yaml", back, &err)) << err << "\n" << text;
  const auto diff = model::compareOverlays(o, back);
  for (const auto& d : diff) ADD_FAILURE() << d;
  EXPECT_TRUE(diff.empty()) << text;
  // Exact where the file carries the struct's own numbers (no arcsec scaling): the accelerometer
  // terms, times, the time offsets.
  EXPECT_TRUE(back.accelerometer->bias_rad_s2 == o.accelerometer->bias_rad_s2);
  EXPECT_TRUE(back.time_offsets == o.time_offsets);
  EXPECT_TRUE(back.mountings[0].valid == o.mountings[0].valid);
  EXPECT_EQ(back.mountings[0].epoch, o.mountings[0].epoch);
  // The parts, and the file written and read through the file functions.
  EXPECT_EQ(back.parts(),
            (std::vector<std::string>{"mountings", "noise", "thermal", "accelerometer", "time_offsets", "published_frame", "data_events"}));
  EXPECT_EQ(back.data_events->headDropoutsPerDay(3), 12.25);
  EXPECT_EQ(back.data_events->epoch_gap_max_s, 90.0);
  EXPECT_TRUE(std::isnan(back.data_events->acc_gap_max_s));
  EXPECT_EQ(back.published_frame->epoch, o.published_frame->epoch);
  EXPECT_EQ(back.published_frame->calibration, 4);
  const std::string path = testutil::makeTempDir("overlay_rt") + "/o.yaml";
  ASSERT_TRUE(io::writeOverlay(path, o, &err)) << err;
  model::Overlay fromFile;
  ASSERT_TRUE(io::readOverlay(path, fromFile, &err)) << err;
  EXPECT_TRUE(model::compareOverlays(o, fromFile).empty());
}

TEST(Overlay, CompareFindsADifferenceInEveryPart) {
  // compareOverlays is what the round trip relies on: it must see a change anywhere.
  const model::Overlay o = fullOverlay();
  std::vector<std::function<void(model::Overlay&)>> changes = {
      [](model::Overlay& x) { x.mountings[1].q_Si_B = Quat(0, 1, 0, 0); },
      [](model::Overlay& x) { x.mountings[0].sigma_rad[2] = 1e-5; },
      [](model::Overlay& x) { x.mountings[0].valid.to.reset(); },
      [](model::Overlay& x) { x.noise.head_defaults->axis[1]->model.terms[1].tau_s = 601; },
      [](model::Overlay& x) { x.noise.head_defaults->axis[1]->params[3].note = "other"; },
      [](model::Overlay& x) { x.noise.heads[0].axis[2]->model.terms[0].sigma *= 1.001; },
      [](model::Overlay& x) { x.noise.accelerometer->axis[1] = model::AxisNoise{model::NoiseModel::white(1e-8), {}}; },
      [](model::Overlay& x) { x.thermal->heads[0].harmonics[1].harmonic = 2; },
      [](model::Overlay& x) { x.thermal->heads[1].constant_rad.sigma[0] = kNaN; },
      [](model::Overlay& x) { x.accelerometer->scale->value[2] = 0.0006; },
      [](model::Overlay& x) { x.time_offsets[1].relative_to = "heads"; },
      [](model::Overlay& x) { x.published_frame->q_B_Bpub = Quat::Identity(); },
      [](model::Overlay& x) { x.published_frame->calibration = 5; },
      [](model::Overlay& x) { x.published_frame.reset(); },
      [](model::Overlay& x) { x.data_events->head_dropouts_by_id[0].second = 12; },
      [](model::Overlay& x) { x.data_events->head_dropouts_by_id[1].first = 2; },
      [](model::Overlay& x) { x.data_events->head_dropouts_by_id.pop_back(); },
      [](model::Overlay& x) { x.data_events->epoch_gaps_per_day = 3; },
      [](model::Overlay& x) { x.data_events->acc_gaps_per_day = 0; },
      [](model::Overlay& x) { x.data_events->head_dropouts_per_day = 0; },
      [](model::Overlay& x) { x.data_events->epoch_gap_max_s = kNaN; },
      [](model::Overlay& x) { x.data_events->acc_gap_max_s = 60; },
      [](model::Overlay& x) { x.data_events.reset(); },
      [](model::Overlay& x) { x.written_by = "someone else"; },
  };
  for (std::size_t i = 0; i < changes.size(); ++i) {
    model::Overlay c = o;
    changes[i](c);
    EXPECT_FALSE(model::compareOverlays(o, c).empty()) << "change " << i << " not seen";
  }
}

// ---- refusals -------------------------------------------------------------------------------------

const char* kMinimal =
    "boresight_overlay: 1\n"
    "written_by: test\n"
    "mountings:\n"
    "  - head: 1\n"
    "    q_Si_B: [1, 0, 0, 0]\n"
    "    datum: accelerometer\n"
    "    epoch: \"2023-06-01 00:00:00\"\n"
    "    sigma_arcsec: [1, 2, null]\n"
    "noise:\n"
    "  heads:\n"
    "    - id: 2\n"
    "      about_boresight: [{kind: white, sigma_arcsec: 31}]\n"
    "  accelerometer:\n"
    "    x: [{kind: gauss_markov, sigma_rad_s2: 2.0e-8, tau_s: 2000}]\n";

std::string replaced(std::string s, const std::string& from, const std::string& to) {
  const auto p = s.find(from);
  EXPECT_NE(p, std::string::npos) << "test fixture: '" << from << "' not in the text";
  if (p != std::string::npos) s.replace(p, from.size(), to);
  return s;
}

/// Parses `text` and expects a refusal "bad.yaml:LINE: key 'KEY': ...WHY...".
void expectRefused(const std::string& text, int line, const std::string& key, const std::string& why) {
  model::Overlay o;
  std::string err;
  EXPECT_FALSE(io::parseOverlay(text, "bad.yaml", o, &err)) << key << "\n" << text;
  const std::string head = "bad.yaml:" + std::to_string(line) + ": key '" + key + "': ";
  EXPECT_EQ(err.rfind(head, 0), 0u) << "expected '" << head << "...', got: " << err;
  EXPECT_NE(err.find(why), std::string::npos) << "expected '" << why << "' in: " << err;
}

TEST(Overlay, MinimalOverlayReads) {
  model::Overlay o;
  std::string err;
  ASSERT_TRUE(io::parseOverlay(kMinimal, "min.yaml", o, &err)) << err;
  ASSERT_EQ(o.mountings.size(), 1u);
  EXPECT_TRUE(std::isnan(o.mountings[0].sigma_rad.z()));
  EXPECT_NEAR(o.mountings[0].sigma_rad.y() * kArcsecPerRad, 2.0, 1e-12);
  ASSERT_EQ(o.noise.heads.size(), 1u);
  EXPECT_NEAR(std::sqrt(o.noise.heads[0].axis[2]->model.variance()) * kArcsecPerRad, 31.0, 1e-12);
  EXPECT_EQ(o.noise.accelerometer->axis[0]->model.terms[0].tau_s, 2000.0);
}

TEST(Overlay, UnknownOrMissingVersionIsRefused) {
  expectRefused(replaced(kMinimal, "boresight_overlay: 1", "boresight_overlay: 2"), 1, "boresight_overlay",
                "unsupported version 2 (this program reads version 1)");
  expectRefused(replaced(kMinimal, "boresight_overlay: 1", "boresight_overlay: one"), 1, "boresight_overlay", "expected a number");
  // A file of another version may have other keys: the version is what is reported.
  expectRefused(replaced(replaced(kMinimal, "boresight_overlay: 1", "boresight_overlay: 3"), "mountings:", "mounts:"), 1,
                "boresight_overlay", "unsupported version 3");
  expectRefused(replaced(kMinimal, "boresight_overlay: 1\n", ""), 1, "boresight_overlay", "not a boresight model overlay");
}

TEST(Overlay, UnknownAndMisspeltKeysNameTheNearest) {
  expectRefused(replaced(kMinimal, "mountings:", "mountngs:"), 3, "mountngs", "unknown key; did you mean 'mountings'?");
  expectRefused(replaced(kMinimal, "    datum: accelerometer", "    datun: accelerometer"), 6, "mountings[0].datun",
                "did you mean 'datum'?");
  expectRefused(replaced(kMinimal, "      about_boresight:", "      about_boresite:"), 12, "noise.heads[0].about_boresite",
                "did you mean 'about_boresight'?");
  expectRefused(replaced(kMinimal, "kind: white, sigma_arcsec: 31", "kind: white, sigma_arcsex: 31"), 12,
                "noise.heads[0].about_boresight[0].sigma_arcsex", "did you mean 'sigma_arcsec'?");
  // a level in the other sensor's unit
  expectRefused(replaced(kMinimal, "kind: white, sigma_arcsec: 31", "kind: white, sigma_rad_s2: 31"), 12,
                "noise.heads[0].about_boresight[0].sigma_rad_s2", "did you mean 'sigma_arcsec'?");
  // a parameter of another kind of term
  expectRefused(replaced(kMinimal, "kind: white, sigma_arcsec: 31", "kind: white, sigma_arcsec: 31, tau_s: 60"), 12,
                "noise.heads[0].about_boresight[0].tau_s", "unknown key");
  expectRefused(replaced(kMinimal, "kind: gauss_markov", "kind: gauss_markow"), 14, "noise.accelerometer.x[0].kind",
                "unknown kind 'gauss_markow'; did you mean 'gauss_markov'?");
  expectRefused(replaced(kMinimal, "    datum: accelerometer", "    datum: acelerometer"), 6, "mountings[0].datum",
                "did you mean 'accelerometer'?");
  expectRefused(replaced(kMinimal, "tau_s: 2000}]", "tau_s: 2000, uncertainty: {tau: 100}}]"), 14,
                "noise.accelerometer.x[0].uncertainty.tau", "did you mean 'tau_s'?");
}

TEST(Overlay, KeysGivenTwiceAreRefused) {
  expectRefused(replaced(kMinimal, "written_by: test\n", "written_by: test\nwritten_by: again\n"), 3, "written_by",
                "given twice");
  expectRefused(replaced(kMinimal, "    datum: accelerometer\n", "    datum: accelerometer\n    datum: ground\n"), 7,
                "mountings[0].datum", "given twice");
  expectRefused(replaced(kMinimal, "{kind: white, sigma_arcsec: 31}", "{kind: white, sigma_arcsec: 31, sigma_arcsec: 3}"),
                12, "noise.heads[0].about_boresight[0].sigma_arcsec", "given twice");
  // the same head twice in a list
  expectRefused(replaced(kMinimal, "noise:\n", "  - {head: 1, q_Si_B: [1, 0, 0, 0], datum: ground, epoch: \"2023-06-01\", sigma_arcsec: [1, 1, 1]}\nnoise:\n"),
                9, "mountings[1].head", "given twice");
}

TEST(Overlay, NonFiniteAndOutOfRangeValuesAreRefused) {
  expectRefused(replaced(kMinimal, "sigma_arcsec: [1, 2, null]", "sigma_arcsec: [1, .nan, null]"), 8,
                "mountings[0].sigma_arcsec[1]", "not a finite number");
  expectRefused(replaced(kMinimal, "sigma_arcsec: 31", "sigma_arcsec: .inf"), 12, "noise.heads[0].about_boresight[0].sigma_arcsec",
                "not a finite number");
  expectRefused(replaced(kMinimal, "tau_s: 2000", "tau_s: 1e400"), 14, "noise.accelerometer.x[0].tau_s", "not a finite number");
  expectRefused(replaced(kMinimal, "sigma_arcsec: [1, 2, null]", "sigma_arcsec: [1, -2, null]"), 8, "mountings[0].sigma_arcsec[1]",
                "outside [0,");
  expectRefused(replaced(kMinimal, "q_Si_B: [1, 0, 0, 0]", "q_Si_B: [0.9, 0, 0, 0]"), 5, "mountings[0].q_Si_B", "not a unit quaternion");
  expectRefused(replaced(kMinimal, "sigma_arcsec: 31", "sigma_arcsec: 0"), 12, "noise.heads[0].about_boresight[0].sigma_arcsec",
                "must be > 0");
  expectRefused(replaced(kMinimal, "tau_s: 2000", "tau_s: -5"), 14, "noise.accelerometer.x[0].tau_s", "outside");
  expectRefused(replaced(kMinimal, "[{kind: white, sigma_arcsec: 31}]",
                         "[{kind: power_law, sigma_arcsec: 1, alpha: 2.5, f_lo_hz: 1e-4, f_hi_hz: 1e-2}]"),
                12, "noise.heads[0].about_boresight[0].alpha", "outside [0, 2]");
  expectRefused(replaced(kMinimal, "[{kind: white, sigma_arcsec: 31}]",
                         "[{kind: power_law, sigma_arcsec: 1, alpha: 1, f_lo_hz: 1e-2, f_hi_hz: 1e-4}]"),
                12, "noise.heads[0].about_boresight[0].f_hi_hz", "must be above f_lo_hz");
  expectRefused(replaced(kMinimal, "epoch: \"2023-06-01 00:00:00\"", "epoch: \"1970-01-01 00:00:00\""), 7, "mountings[0].epoch",
                "outside 1980-2100");
  expectRefused(replaced(kMinimal, "epoch: \"2023-06-01 00:00:00\"", "epoch: \"2023-13-01 00:00:00\""), 7, "mountings[0].epoch",
                "expected a GPS calendar time");
  expectRefused(replaced(kMinimal, "    sigma_arcsec: [1, 2, null]\n",
                         "    sigma_arcsec: [1, 2, null]\n    valid_from: \"2023-06-02\"\n    valid_to: \"2023-06-01\"\n"),
                10, "mountings[0].valid_to", "before valid_from");
  expectRefused(replaced(kMinimal, "about_boresight: [{kind: white, sigma_arcsec: 31}]", "about_boresight: []"), 12,
                "noise.heads[0].about_boresight", "empty");
  const std::string thermal =
      std::string(kMinimal) +
      "thermal:\n  datum_head: 1\n  heads:\n    - id: 2\n      constant_arcsec: [1, 2, 3]\n      constant_sigma_arcsec: [1, 1, 1]\n"
      "      harmonics:\n        - {harmonic: 0, cos_arcsec: [0, 0, 0], cos_sigma_arcsec: [1, 1, 1], sin_arcsec: [0, 0, 0], sin_sigma_arcsec: [1, 1, 1]}\n";
  expectRefused(thermal, 22, "thermal.heads[0].harmonics[0].harmonic", "outside [1, 100]");
  expectRefused(replaced(replaced(thermal, "    - id: 2\n      constant", "    - id: 1\n      constant"), "harmonic: 0", "harmonic: 1"), 18, "thermal.heads[0].id",
                "the datum head");
  const std::string acc = std::string(kMinimal) + "accelerometer:\n  scale: [0.7, 0, 0]\n  scale_sigma: [0, 0, 0]\n";
  expectRefused(acc, 16, "accelerometer.scale[0]", "outside [-0.5, 0.5]");
  expectRefused(replaced(acc, "  scale_sigma: [0, 0, 0]\n", ""), 16, "accelerometer.scale_sigma", "missing");
  const std::string off = std::string(kMinimal) + "time_offsets:\n  - {sensor: gyro, relative_to: heads, offset_s: 0.1, offset_sigma_s: 0.01}\n";
  expectRefused(off, 16, "time_offsets[0].sensor", "expected accelerometer, or head<id>");
  expectRefused(replaced(off, "sensor: gyro", "sensor: head2, extra: 1"), 16, "time_offsets[0].extra", "unknown key");
  const std::string ev = std::string(kMinimal) + "data_events:\n  epoch_gaps_per_day: 2\n  heads: [{id: 3, dropouts_per_day: 4}]\n";
  expectRefused(replaced(ev, "epoch_gaps_per_day: 2", "epoch_gaps_per_day: -2"), 16, "data_events.epoch_gaps_per_day", "outside [0,");
  expectRefused(replaced(ev, "epoch_gaps_per_day: 2", "epoch_gaps_per_day: .nan"), 16, "data_events.epoch_gaps_per_day", "not a finite number");
  expectRefused(replaced(ev, "{id: 3, dropouts_per_day: 4}", "{id: 3, dropouts_per_day: 4}, {id: 3, dropouts_per_day: 1}"), 17,
                "data_events.heads[1].id", "given twice");
  expectRefused(replaced(ev, "{id: 3, dropouts_per_day: 4}", "{id: 0, dropouts_per_day: 4}"), 17, "data_events.heads[0].id", "outside [1, 255]");
  expectRefused(replaced(ev, "epoch_gaps_per_day: 2", "epoch_gap_per_day: 2"), 16, "data_events.epoch_gap_per_day", "unknown key");
}

TEST(Overlay, EmptyOrSyntacticallyBrokenFilesAreRefused) {
  model::Overlay o;
  std::string err;
  EXPECT_FALSE(io::parseOverlay("boresight_overlay: 1\nwritten_by: x\n", "e.yaml", o, &err));
  EXPECT_NE(err.find("no content"), std::string::npos) << err;
  EXPECT_FALSE(io::parseOverlay("boresight_overlay: 1\nwritten_by: [x\n", "s.yaml", o, &err));
  EXPECT_EQ(err.rfind("s.yaml:", 0), 0u) << err;
  EXPECT_FALSE(io::readOverlay("/no/such/overlay.yaml", o, &err));
  EXPECT_NE(err.find("/no/such/overlay.yaml: cannot open"), std::string::npos) << err;
}

// ---- one noise form for overlays and platform files -------------------------------------------

TEST(Overlay, NoiseSectionHasOneFormInOverlayAndPlatformFile) {
  // The overlay's noise section written out drops into a platform file (without its validity spans)
  // and reads back as the same models.
  model::Overlay o = fullOverlay();
  o.noise.heads.erase(o.noise.heads.begin() + 1);  // head 2's override: kept below
  const std::string section = io::noiseSectionYaml(o.noise, 2, false);
  EXPECT_EQ(section.find("valid_"), std::string::npos) << section;
  const std::string dir = testutil::makeTempDir("overlay_noise");
  const std::string platform = dir + "/p.yaml";
  ASSERT_TRUE(testutil::writeFile(platform, "base: " + kConfigDir + "/gracefo.yaml\nnoise:\n" + section));
  io::PlatformConfig pc;
  std::string err;
  ASSERT_TRUE(io::loadPlatformConfig(platform, pc, &err)) << err << "\n" << section;
  model::Overlay same;
  same.noise = pc.noise;
  model::Overlay want;
  want.noise = o.noise;
  want.noise.head_defaults->valid = {};
  for (auto& h : want.noise.heads) h.valid = {};
  want.noise.accelerometer->valid = {};
  // the base's accelerometer y and z stay where the overlay's section has none
  want.noise.accelerometer->axis[1] = pc.noise.accelerometer->axis[1];
  for (const auto& d : model::compareOverlays(want, same)) ADD_FAILURE() << d;
  // Head 3's about_boresight from its own entry, the others from the defaults; sources named.
  const model::NoiseInUse& u = pc.noise_in_use;
  EXPECT_NEAR(pc.pipeline.heads.head[2].sigma_roll_rad * kArcsecPerRad, 31.0, 1e-12);
  EXPECT_NEAR(pc.pipeline.heads.head[1].sigma_roll_rad * kArcsecPerRad, 25.0, 1e-12);
  EXPECT_EQ(u.head[2][2].source, platform + " noise.heads[id 3]");
  EXPECT_EQ(u.head[1][2].source, platform + " noise.head_defaults");
  EXPECT_EQ(u.acc[1].source, kConfigDir + "/gracefo.yaml noise.accelerometer");
}

TEST(Overlay, NoiseTableDerivesTheCoreSigmasFromTheTotalVariance) {
  model::NoiseInUse u;
  u.reset({1, 2});
  model::NoiseSection platform;
  platform.head_defaults = model::HeadNoise{};
  for (int a = 0; a < model::kHeadAxes; ++a)
    platform.head_defaults->axis[static_cast<std::size_t>(a)] = model::AxisNoise{model::NoiseModel::white(6 * kRadPerArcsec), {}};
  platform.accelerometer = model::AccNoise{};
  for (int a = 0; a < 3; ++a)
    platform.accelerometer->axis[static_cast<std::size_t>(a)] =
        model::AxisNoise{model::NoiseModel::white(1e-7).add(model::NoiseTerm::gaussMarkov(1e-6, 100)), {}};
  u.layer(platform, "p.yaml");
  EXPECT_EQ(u.missing(), "");
  model::NoiseSection ov;
  model::HeadNoise h2;
  h2.id = 2;
  h2.axis[0] = model::AxisNoise{model::NoiseModel::white(3 * kRadPerArcsec).add(model::NoiseTerm::gaussMarkov(4 * kRadPerArcsec, 600)), {}};
  h2.axis[1] = model::AxisNoise{model::NoiseModel::white(1 * kRadPerArcsec), {}};
  ov.heads.push_back(h2);
  model::HeadNoise h9;
  h9.id = 9;
  ov.heads.push_back(h9);
  std::vector<std::string> unused;
  u.layer(ov, "overlay o.yaml", &unused);
  EXPECT_EQ(unused, std::vector<std::string>{"noise.heads[id 9]"});
  // head 2 cross: x has 3^2 + 4^2 = 25, y 1: RMS sqrt(13)
  EXPECT_NEAR(u.crossSigmaRad(1) * kArcsecPerRad, std::sqrt(13.0), 1e-12);
  EXPECT_NEAR(u.crossSigmaRad(0) * kArcsecPerRad, 6.0, 1e-12);
  EXPECT_EQ(u.head[1][0].source, "overlay o.yaml noise.heads[id 2]");
  EXPECT_EQ(u.head[1][2].source, "p.yaml noise.head_defaults");
  // the accelerometer's white part only
  EXPECT_NEAR(u.accWhiteSigma(0), 1e-7, 1e-20);
  const auto lines = u.describe();
  ASSERT_EQ(lines.size(), 3u);
  EXPECT_EQ(lines[1], "head 2: cross_x white 3\" + GM(4\", tau 600 s), cross_y white 1\" (overlay o.yaml noise.heads[id 2]); "
                      "about_boresight white 6\", star_direction white 6\" (p.yaml noise.head_defaults)");
  EXPECT_NE(lines[0].find("(p.yaml noise.head_defaults)"), std::string::npos) << lines[0];
  u.reset({1});
  EXPECT_EQ(u.missing(), "head 1 cross_x");
}

TEST(Overlay, ApplyingItNamesWhatWasNotApplied) {
  io::PlatformConfig pc;
  std::string err;
  ASSERT_TRUE(io::loadPlatformConfig(kConfigDir + "/gracefo.yaml", pc, &err)) << err;
  model::Overlay o = fullOverlay();
  o.mountings[2].head = 7;  // not configured
  io::OverlayUse use;
  ASSERT_TRUE(io::applyOverlay(o, "o.yaml", "test", {}, pc, use, &err)) << err;
  // noise: head 3 about from its entry, head 2 cross_x from its entry, the rest from the defaults
  EXPECT_NEAR(pc.pipeline.heads.head[2].sigma_roll_rad * kArcsecPerRad, 31.0, 1e-12);
  EXPECT_NEAR(pc.pipeline.heads.head[0].sigma_roll_rad * kArcsecPerRad, 25.0, 1e-12);
  EXPECT_EQ(pc.noise_in_use.head[1][0].source, "overlay o.yaml noise.heads[id 2]");
  // mountings: heads 1 and 2 from the overlay, 3 still to come from QSA1B
  EXPECT_TRUE(pc.pipeline.heads.head[0].q_Si_B.coeffs() == o.mountings[0].q_Si_B.coeffs());
  EXPECT_EQ(pc.mounting_source[0].rfind("overlay o.yaml (datum accelerometer", 0), 0u) << pc.mounting_source[0];
  EXPECT_TRUE(pc.mounting_source[2].empty());
  EXPECT_TRUE(pc.mounting_from_qsa1b);
  std::string not_applied;
  for (const auto& n : use.not_applied) not_applied += n + "\n";
  for (const char* part : {"mountings of head 7: no such head", "thermal: test does not apply", "accelerometer: test does not apply",
                           "data_events: test does not test data events",
                           "time_offsets: test does not apply time offsets (accelerometer against heads)",
                           "time_offsets: test does not apply time offsets (head2 against gps)"})
    EXPECT_NE(not_applied.find(part), std::string::npos) << part << " not in\n" << not_applied;
  EXPECT_EQ(pc.events.epoch_gaps_per_day, 0.0);  // not applied: the platform file's
  // a program that tests data events takes the overlay's rates whole; a head the platform lacks is refused
  {
    io::PlatformConfig pe;
    ASSERT_TRUE(io::loadPlatformConfig(kConfigDir + "/gracefo.yaml", pe, &err)) << err;
    io::OverlayUses ev_uses;
    ev_uses.data_events = true;
    const model::Overlay full = fullOverlay();
    ASSERT_TRUE(io::applyOverlay(full, "o.yaml", "test", ev_uses, pe, use, &err)) << err;
    EXPECT_TRUE(pe.events == *full.data_events);
    EXPECT_EQ(pe.events.headDropoutsPerDay(3), 12.25);
    EXPECT_EQ(pe.events.headDropoutsPerDay(2), 0.5);
    model::Overlay bad = full;
    bad.data_events->head_dropouts_by_id[0].first = 9;
    EXPECT_FALSE(io::applyOverlay(bad, "o.yaml", "test", ev_uses, pe, use, &err));
    EXPECT_NE(err.find("o.yaml: data_events.heads: head 9 is not a head of the platform"), std::string::npos) << err;
  }
  // a program that does not use noise says so
  io::PlatformConfig pc2;
  ASSERT_TRUE(io::loadPlatformConfig(kConfigDir + "/gracefo.yaml", pc2, &err)) << err;
  io::OverlayUses mountings_only;
  mountings_only.noise = false;
  ASSERT_TRUE(io::applyOverlay(o, "o.yaml", "test", mountings_only, pc2, use, &err));
  EXPECT_NEAR(pc2.pipeline.heads.head[2].sigma_roll_rad * kArcsecPerRad, 25.0, 1e-12);
  EXPECT_EQ(use.not_applied.front(), "noise: test does not use noise models");
  // another platform's overlay is refused
  o.platform = "GRACE";
  EXPECT_FALSE(io::applyOverlay(o, "o.yaml", "test", {}, pc2, use, &err));
  EXPECT_NE(err.find("o.yaml: platform 'GRACE' is not the platform file's ('GRACE-FO'"), std::string::npos) << err;
  // validity: head 1's mounting holds for 2023-06-01 only
  o = fullOverlay();
  ASSERT_TRUE(io::applyOverlay(o, "o.yaml", "test", {}, pc, use, &err)) << err;
  EXPECT_TRUE(io::validityWarnings(use, gps("2023-06-01 01:00:00"), gps("2023-06-01 02:00:00")).empty());
  const auto w = io::validityWarnings(use, gps("2023-06-03 00:00:00"), gps("2023-06-03 01:00:00"));
  std::string all;
  for (const auto& x : w) all += x + "\n";
  EXPECT_NE(all.find("the mounting of head 1 valid 2023-06-01 00:00:00.000000 to 2023-06-02 00:00:00.000001"), std::string::npos) << all;
  EXPECT_NE(all.find("noise.heads[id 3]"), std::string::npos) << all;
  EXPECT_EQ(all.find("the mounting of head 2"), std::string::npos) << all;  // open-ended
}

// The accelerometer terms as the core's correction: the simulator's accelerometer (model::AccelModel:
// bias, scale, misalignment) measured and corrected gives back C_A_B a_B; with a non-orthogonality the
// solver's K (calib/solver.h). Applied only for a program that takes them (process, audit).
TEST(Overlay, AccelerometerTermsCorrectWhatTheSimulatorsAccelerometerMeasures) {
  model::AccelerometerTerms t;
  model::Uncertain3 b, sc, mis, n;
  b.value = Vec3(3e-6, -2e-6, 1e-6);
  sc.value = Vec3(0.05, -0.04, 0.03);
  mis.value = Vec3(300, -200, 100) * kRadPerArcsec;
  t.bias_rad_s2 = b;
  t.scale = sc;
  t.misalignment_rad = mis;
  core::AccCorrection c;
  std::string err;
  ASSERT_TRUE(io::accCorrectionFromOverlay(t, c, &err)) << err;
  EXPECT_TRUE(c.on);
  model::AccelConfig acfg;
  acfg.C_A_B = accToBodyDefault().transpose();
  model::AccEffects eff;
  eff.bias_rad_s2 = b.value;
  eff.scale = sc.value;
  eff.misalignment_rad = mis.value;
  const model::AccelModel acc(acfg, eff);
  for (const Vec3& a_B : {Vec3(1e-5, 2e-5, -3e-5), Vec3(-4e-5, 0, 1e-6), Vec3(0, 0, 0)}) {
    const Vec3 corrected = c.M * (acc.predict(a_B) - c.bias_A);
    EXPECT_LT((corrected - acfg.C_A_B * a_B).norm(), 1e-12 * std::max(1.0, 1e5 * a_B.norm())) << a_B.transpose();
  }
  // the solver's non-orthogonality: K = I + diag(s) + N(n), N = [0 n2 n1; n2 0 n0; n1 n0 0]
  n.value = Vec3(1e-3, -2e-3, 5e-4);
  t.nonorthogonality_rad = n;
  t.misalignment_rad.reset();
  ASSERT_TRUE(io::accCorrectionFromOverlay(t, c, &err)) << err;
  Mat3 K = Mat3::Identity();
  K.diagonal() += sc.value;
  K(0, 1) = K(1, 0) = n.value[2];
  K(0, 2) = K(2, 0) = n.value[1];
  K(1, 2) = K(2, 1) = n.value[0];
  const Vec3 a_A(2e-5, -1e-5, 3e-5);
  EXPECT_LT((c.M * (K * a_A + b.value - c.bias_A) - a_A).norm(), 1e-17);
  // a singular K is refused
  sc.value = Vec3(-1, 0, 0);
  t.scale = sc;
  t.nonorthogonality_rad.reset();
  EXPECT_FALSE(io::accCorrectionFromOverlay(t, c, &err));
  EXPECT_NE(err.find("singular"), std::string::npos) << err;
  // applied for a program that takes them, named as not applied otherwise
  io::PlatformConfig pc;
  ASSERT_TRUE(io::loadPlatformConfig(kConfigDir + "/gracefo.yaml", pc, &err)) << err;
  model::Overlay o;
  sc.value = Vec3(0.05, -0.04, 0.03);
  t.scale = sc;
  o.accelerometer = t;
  io::OverlayUse use;
  ASSERT_TRUE(io::applyOverlay(o, "o.yaml", "test", {}, pc, use, &err)) << err;
  EXPECT_FALSE(pc.pipeline.acc_correction.on);
  ASSERT_EQ(use.not_applied.size(), 1u);
  EXPECT_EQ(use.not_applied[0], "accelerometer: test does not apply accelerometer terms (bias, scale)");
  io::OverlayUses uses;
  uses.accelerometer = true;
  ASSERT_TRUE(io::applyOverlay(o, "o.yaml", "test", uses, pc, use, &err)) << err;
  EXPECT_TRUE(pc.pipeline.acc_correction.on);
  EXPECT_EQ(pc.pipeline.acc_correction.bias_A, b.value);
  ASSERT_EQ(use.applied.size(), 1u);
  EXPECT_EQ(use.applied[0].rfind("accelerometer: bias, scale", 0), 0u) << use.applied[0];
}

}  // namespace
}  // namespace boresight
