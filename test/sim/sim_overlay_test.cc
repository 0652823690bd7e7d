// sim::applyOverlay: a model overlay as the simulation's truth. Each item checked against what the
// simulator then does (the head models' rotations, the effect specs, the configured levels), not
// against the code's own arithmetic.
#include <boresight/model/rotation.h>
#include <boresight/model/sensors.h>
#include <boresight/sim/overlay.h>
#include <boresight/sim/scenario.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>

namespace {

using namespace boresight;

sim::Scenario scenario(const std::string& effects = "") {
  sim::Scenario sc;
  std::string err;
  std::string yaml = "base: " BORESIGHT_SOURCE_DIR "/config/sim_audit.yaml\n" + effects;
  EXPECT_TRUE(sim::parseScenario(yaml, "test.yaml", BORESIGHT_SOURCE_DIR "/config", sc, &err)) << err;
  return sc;
}

const model::HeadConfig& head(const sim::Scenario& sc, int id) {
  for (const auto& h : sc.heads)
    if (h.id == id) return h;
  ADD_FAILURE() << "no head " << id;
  return sc.heads.front();
}

int count(const sim::Scenario& sc, model::EffectKind k, const std::string& sensor) {
  return static_cast<int>(std::count_if(sc.effects.begin(), sc.effects.end(),
                                        [&](const model::EffectSpec& e) { return e.kind == k && e.sensor == sensor; }));
}

bool contains(const std::vector<std::string>& v, const std::string& s) {
  return std::any_of(v.begin(), v.end(), [&](const std::string& x) { return x.find(s) != std::string::npos; });
}

TEST(SimOverlay, AMountingBecomesTheHeadsTrueMountingAndReplacesTheScenariosMisalignment) {
  sim::Scenario sc = scenario(
      "mounting_error_sigma_arcsec: 20\n"
      "effects:\n  - {name: relative_misalignment, sensor: all, x_arcsec: 5}\n");
  const Quat q_nom = head(sc, 2).q_Si_B;
  model::Overlay ov;
  model::MountingEntry m;
  m.head = 2;
  m.q_Si_B = (model::quatExp(Vec3(30, -12, 4) * kRadPerArcsec) * q_nom).normalized();
  m.datum = model::MountingDatum::StarCameras;
  ov.mountings.push_back(m);
  sim::ScenarioOverlayUse use;
  std::string err;
  ASSERT_TRUE(sim::applyOverlay(ov, "o.yaml", 3600, sc, use, &err)) << err;
  EXPECT_EQ(sc.mounting_error_sigma_rad, 0.0);
  // The simulator's true constant mounting is the overlay's.
  const model::HeadModel hm(head(sc, 2), model::headEffectsFor(sc.effects, 2));
  EXPECT_LT(model::quatLog(hm.qSiBTrue() * m.q_Si_B.conjugate()).norm() * kArcsecPerRad, 1e-6);
  // The 'all' misalignment was split: heads 1 and 3 keep theirs, head 2 none.
  EXPECT_EQ(count(sc, model::EffectKind::RelativeMisalignment, "all"), 0);
  EXPECT_EQ(count(sc, model::EffectKind::RelativeMisalignment, "1"), 1);
  EXPECT_EQ(count(sc, model::EffectKind::RelativeMisalignment, "3"), 1);
  EXPECT_EQ(count(sc, model::EffectKind::RelativeMisalignment, "2"), 0);
  EXPECT_TRUE(contains(use.replaced, "random mounting error")) << ::testing::PrintToString(use.replaced);
  EXPECT_TRUE(contains(use.replaced, "relative_misalignment on head 2"));
  EXPECT_TRUE(contains(use.applied, "mountings: head 2 (star_cameras datum)"));
}

TEST(SimOverlay, ThermalTermsGiveTheOverlaysDeformationRelativeToTheDatumHead) {
  sim::Scenario sc = scenario("effects:\n  - {name: thermal_periodic, sensor: 3, harmonic: 1, x_arcsec: 9}\n");
  model::Overlay ov;
  model::ThermalTerms th;
  th.datum_head = 1;
  th.beta_ref_rad = 30 * kRadPerDeg;
  model::ThermalHeadEntry e;
  e.head = 2;
  e.constant_rad.value = Vec3(2, -1, 0.5) * kRadPerArcsec;
  model::ThermalHarmonicEntry h1, h2, b1;
  h1.harmonic = 1;
  h1.cos_rad.value = Vec3(3, -4, 1) * kRadPerArcsec;
  h1.sin_rad.value = Vec3(-2, 1.5, 0) * kRadPerArcsec;
  h2.harmonic = 2;
  h2.sin_rad.value = Vec3(0, 0, 6) * kRadPerArcsec;
  b1.harmonic = 1;
  b1.cos_rad.value = Vec3(5, 0, 0) * kRadPerArcsec;
  e.harmonics = {h1, h2};
  e.beta_harmonics = {b1};
  th.heads.push_back(e);
  ov.thermal = th;
  sim::ScenarioOverlayUse use;
  std::string err;
  ASSERT_TRUE(sim::applyOverlay(ov, "o.yaml", 3600, sc, use, &err)) << err;
  EXPECT_EQ(count(sc, model::EffectKind::ThermalPeriodic, "3"), 0);  // the scenario's term is replaced
  EXPECT_TRUE(contains(use.replaced, "thermal_periodic on head 3"));
  // What the simulator's head models do: C_Sd_Sk(t) = Exp(delta(t)) C0_dk with the overlay's delta.
  const model::HeadModel d(head(sc, 1), model::headEffectsFor(sc.effects, 1));
  const model::HeadModel k(head(sc, 2), model::headEffectsFor(sc.effects, 2));
  const Mat3 C0_dk = head(sc, 1).q_Si_B.toRotationMatrix() * head(sc, 2).q_Si_B.toRotationMatrix().transpose();
  for (double u : {0.0, 0.7, 2.1, 4.0}) {
    for (double beta : {30.0, 60.0}) {
      model::OrbitContext ctx;
      ctx.arg_lat_rad = u;
      ctx.beta_rad = beta * kRadPerDeg;
      const Mat3 C_dk = d.qSiB(ctx).toRotationMatrix() * k.qSiB(ctx).toRotationMatrix().transpose();
      const Vec3 got = model::quatLog(Quat(C_dk * C0_dk.transpose()));
      const double db = std::cos(beta * kRadPerDeg) - std::cos(30 * kRadPerDeg);
      const Vec3 want = e.constant_rad.value + h1.cos_rad.value * std::cos(u) + h1.sin_rad.value * std::sin(u) +
                        h2.sin_rad.value * std::sin(2 * u) + db * b1.cos_rad.value * std::cos(u);
      EXPECT_LT((got - want).norm() * kArcsecPerRad, 0.01) << "u " << u << " beta " << beta << ": " << got.transpose() * kArcsecPerRad
                                                           << " vs " << want.transpose() * kArcsecPerRad;
    }
  }
}

TEST(SimOverlay, NoiseModelsBecomeTheHeadsLevelsAndColouredTerms) {
  sim::Scenario sc = scenario(
      "effects:\n"
      "  - {name: cross_noise, sensor: all, cross_arcsec: 3}\n"
      "  - {name: coloured_noise, sensor: 2, cross_arcsec: 1, about_arcsec: 4, tau_s: 300}\n"
      "  - {name: fov_error, sensor: 2, arcsec: 1}\n");
  model::Overlay ov;
  model::HeadNoise hn;
  hn.id = 2;
  model::AxisNoise cx, cy, ab;
  cx.model.add(model::NoiseTerm::white(2.0 * kRadPerArcsec)).add(model::NoiseTerm::gaussMarkov(0.5 * kRadPerArcsec, 600));
  cy.model.add(model::NoiseTerm::white(2.0 * kRadPerArcsec)).add(model::NoiseTerm::gaussMarkov(0.5 * kRadPerArcsec, 600));
  ab.model.add(model::NoiseTerm::white(20.0 * kRadPerArcsec));
  hn.axis[0] = cx;
  hn.axis[1] = cy;
  hn.axis[2] = ab;
  ov.noise.heads.push_back(hn);
  model::AccNoise an;
  model::AxisNoise az;
  az.model.add(model::NoiseTerm::white(3e-9)).add(model::NoiseTerm::powerLaw(1e-9, 1.0, 1e-4, 1e-2));
  an.axis[2] = az;
  ov.noise.accelerometer = an;
  sim::ScenarioOverlayUse use;
  std::string err;
  ASSERT_TRUE(sim::applyOverlay(ov, "o.yaml", 3600, sc, use, &err)) << err;
  const model::HeadModel hm(head(sc, 2), model::headEffectsFor(sc.effects, 2));
  EXPECT_NEAR(hm.sigmaCross() * kArcsecPerRad, 2.0, 1e-9);  // the cross_noise spec on head 2 is gone
  EXPECT_NEAR(hm.sigmaAbout() * kArcsecPerRad, 20.0, 1e-9);
  const model::HeadModel h1(head(sc, 1), model::headEffectsFor(sc.effects, 1));
  EXPECT_NEAR(h1.sigmaCross() * kArcsecPerRad, 3.0, 1e-9);  // head 1 keeps the scenario's
  // Head 2's coloured noise: the overlay's Gauss-Markov term only (the scenario's cross and about
  // terms replaced); its fov_error too (the overlay's noise is the head's whole random error).
  int gm = 0;
  for (const auto& e : sc.effects)
    if (e.kind == model::EffectKind::ColouredNoise && e.sensor == "2") {
      ++gm;
      EXPECT_NEAR(e.get("cross_arcsec"), 0.5, 1e-9);
      EXPECT_EQ(e.get("about_arcsec"), 0.0);
      EXPECT_EQ(e.get("tau_s"), 600.0);
    }
  EXPECT_EQ(gm, 1);
  EXPECT_EQ(count(sc, model::EffectKind::FovError, "2"), 0);
  EXPECT_EQ(sc.acc.white_rad_s2.z(), 3e-9);
  EXPECT_EQ(sc.acc.lowfreq_rad_s2.z(), 0.0);
  int pl = 0;
  for (const auto& e : sc.effects)
    if (e.kind == model::EffectKind::AccColouredNoise) {
      ++pl;
      EXPECT_EQ(e.get("z"), 1e-9);
      EXPECT_EQ(e.get("x"), 0.0);
      EXPECT_EQ(e.get("f_lo_hz"), 1e-4);
    }
  EXPECT_EQ(pl, 1);
}

TEST(SimOverlay, DifferentCrossAxesAreSimulatedWithTheirRmsAndSaidSo) {
  sim::Scenario sc = scenario();
  model::Overlay ov;
  model::HeadNoise hn;
  hn.id = 1;
  model::AxisNoise cx, cy;
  cx.model.add(model::NoiseTerm::white(1.0 * kRadPerArcsec));
  cy.model.add(model::NoiseTerm::white(7.0 * kRadPerArcsec));
  hn.axis[0] = cx;
  hn.axis[1] = cy;
  ov.noise.heads.push_back(hn);
  sim::ScenarioOverlayUse use;
  std::string err;
  ASSERT_TRUE(sim::applyOverlay(ov, "o.yaml", 3600, sc, use, &err)) << err;
  EXPECT_NEAR(head(sc, 1).sigma_cross_rad * kArcsecPerRad, 5.0, 1e-9);  // sqrt((1 + 49) / 2)
  EXPECT_TRUE(contains(use.notes, "cross_x and cross_y differ")) << ::testing::PrintToString(use.notes);
}

TEST(SimOverlay, AccelerometerTermsAndTimeOffsetsBecomeSpecsAndWhatCannotBeSimulatedIsNamed) {
  sim::Scenario sc = scenario(
      "accelerometer: {bias_rad_s2: [1.0e-5, 0, -7.8e-4]}\n"
      "effects:\n"
      "  - {name: acc_bias, sensor: acc, x: 1.0e-8}\n"
      "  - {name: time_offset, sensor: all, offset_ms: 4}\n");
  model::Overlay ov;
  model::AccelerometerTerms a;
  a.bias_rad_s2 = model::Uncertain3{Vec3(0, 2e-9, 0), Vec3::Zero()};
  a.misalignment_rad = model::Uncertain3{Vec3(10, 0, -5) * kRadPerArcsec, Vec3::Zero()};
  a.nonorthogonality_rad = model::Uncertain3{Vec3(1, 0, 0) * kRadPerArcsec, Vec3::Zero()};
  ov.accelerometer = a;
  model::TimeOffsetEntry t;
  t.sensor = "accelerometer";
  t.relative_to = "heads";
  t.offset_s = 0.020;
  ov.time_offsets.push_back(t);
  model::TimeOffsetEntry t2 = t;
  t2.sensor = "head2";
  t2.relative_to = "head1";
  ov.time_offsets.push_back(t2);
  ov.published_frame = model::PublishedFrame{};
  model::Validity v;
  v.to = sc.start + 600'000'000;
  ov.accelerometer->valid = v;
  sim::ScenarioOverlayUse use;
  std::string err;
  ASSERT_TRUE(sim::applyOverlay(ov, "o.yaml", 3600, sc, use, &err)) << err;
  // the accelerometer model the simulator builds
  const model::AccelModel am(sc.acc, model::accEffectsFor(sc.effects));
  const Vec3 a_B(1e-6, -2e-6, 3e-6);
  const Vec3 want = model::quatExp(Vec3(10, 0, -5) * kRadPerArcsec).toRotationMatrix() * sc.acc.C_A_B * a_B + Vec3(0, 2e-9, 0);
  // the scenario's acc_bias spec and its nominal bias (7.8e-4 rad/s^2) replaced, not added
  EXPECT_LT((am.predict(a_B) - want).norm(), 1e-15);
  EXPECT_TRUE(contains(use.replaced, "nominal bias")) << ::testing::PrintToString(use.replaced);
  double acc_ms = 0;
  for (const auto& e : sc.effects)
    if (e.kind == model::EffectKind::TimeOffset && e.sensor == "acc") acc_ms += e.get("offset_ms");
  EXPECT_NEAR(acc_ms, 24.0, 1e-9);  // against the heads, which run 4 ms ahead themselves
  EXPECT_TRUE(contains(use.not_applied, "non-orthogonality"));
  EXPECT_TRUE(contains(use.not_applied, "head2 against head1"));
  EXPECT_TRUE(contains(use.not_applied, "published_frame"));
  EXPECT_TRUE(contains(use.notes, "accelerometer: valid to")) << ::testing::PrintToString(use.notes);

  // The ends of the span: a model written from data ends at its last epoch, a simulation of the span in
  // whole seconds runs a little past it - no note for 30 s either side, a note for 2 minutes.
  for (const auto& [margin_s, noted] : {std::pair<double, bool>{30, false}, {120, true}}) {
    sim::Scenario s2 = scenario();
    model::Overlay o2;
    model::AccelerometerTerms a2;
    a2.bias_rad_s2 = model::Uncertain3{Vec3(0, 1e-9, 0), Vec3::Zero()};
    a2.valid.from = s2.start + static_cast<TimeUs>(margin_s * 1e6);
    a2.valid.to = s2.start + static_cast<TimeUs>((3600 - margin_s) * 1e6);
    o2.accelerometer = a2;
    sim::ScenarioOverlayUse u2;
    ASSERT_TRUE(sim::applyOverlay(o2, "o.yaml", 3600, s2, u2, &err)) << err;
    EXPECT_EQ(contains(u2.notes, "accelerometer: valid from"), noted) << margin_s << " s: " << ::testing::PrintToString(u2.notes);
  }
}

TEST(SimOverlay, AnOverlayForAHeadTheScenarioLacksIsNamedAndABadDatumRefused) {
  sim::Scenario sc = scenario();
  model::Overlay ov;
  model::MountingEntry m;
  m.head = 7;
  ov.mountings.push_back(m);
  sim::ScenarioOverlayUse use;
  std::string err;
  ASSERT_TRUE(sim::applyOverlay(ov, "o.yaml", 3600, sc, use, &err)) << err;
  EXPECT_TRUE(contains(use.not_applied, "mountings: head 7: the scenario has no such head"));
  model::Overlay bad;
  bad.thermal = model::ThermalTerms{};
  bad.thermal->datum_head = 9;
  EXPECT_FALSE(sim::applyOverlay(bad, "o.yaml", 3600, sc, use, &err));
  EXPECT_NE(err.find("overlay o.yaml: thermal: the datum head 9 is not in the scenario"), std::string::npos) << err;
}

}  // namespace
