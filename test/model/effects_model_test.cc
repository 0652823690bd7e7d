// The effect model without the simulator: specs of one kind compose (sums, quadrature sums,
// independent processes), the new catalogue entries, the clock model, the parameter-vector form of
// the head rotation, and the stochastic models' statistics (gap fraction, outlier and flip rates,
// accelerometer Gauss-Markov noise, tag jitter).
#include <boresight/model/effects.h>
#include <boresight/model/sensors.h>
#include <boresight/model/stochastic.h>

#include <ceres/jet.h>
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>
#include <vector>

namespace boresight::model {
namespace {

EffectSpec spec(const std::string& arg) {
  EffectSpec s;
  std::string err;
  EXPECT_TRUE(parseEffectArg(arg, s, &err)) << arg << ": " << err;
  return s;
}

OrbitContext ctxAt(double t, double u = 0.3, double beta = 0.2) {
  OrbitContext c;
  c.t_s = t;
  c.arg_lat_rad = u;
  c.beta_rad = beta;
  return c;
}

TEST(GapProcessFixed, ExplicitGapsAndDropoutsAreTheirUnionWhateverTheirOrderAndOverlap) {
  // Thousands of explicit intervals (the audit's loop gives one per gap of the data) are looked up by
  // bisection over their disjoint union: the same answer as asking every interval.
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> at(-10.0, 5000.0), len(-2.0, 30.0);
  std::vector<Interval> fixed, drop;
  for (int k = 0; k < 3000; ++k) (k % 3 ? fixed : drop).push_back({at(rng), 0.0});
  for (auto* v : {&fixed, &drop})
    for (auto& i : *v) i.end_s = i.start_s + len(rng);  // some empty or reversed: nothing
  fixed.push_back({100.0, 200.0});
  fixed.push_back({150.0, 160.0});  // nested
  drop.push_back({199.0, 250.0});   // overlapping the end of another list's interval
  const GapProcess p({}, fixed, drop, 1, Stream::HeadGap, 1);
  int missing = 0;
  for (double t = -20.0; t < 5100.0; t += 0.37) {
    bool naive = false;
    for (const auto* v : {&fixed, &drop})
      for (const auto& i : *v) naive = naive || i.contains(t);
    ASSERT_EQ(p.fixedMissing(t), naive) << t;
    missing += naive;
  }
  EXPECT_GT(missing, 1000);
  // at every interval's ends exactly (half-open: the start is missing, the end is not unless covered)
  for (const auto* v : {&fixed, &drop})
    for (const auto& i : *v)
      for (double t : {i.start_s, i.end_s}) {
        bool naive = false;
        for (const auto* w : {&fixed, &drop})
          for (const auto& j : *w) naive = naive || j.contains(t);
        ASSERT_EQ(p.fixedMissing(t), naive) << t;
      }
}

TEST(EffectModel, TwoDriftsAddEachWithItsOwnStart) {
  const auto d1 = spec("drift:sensor=1,x_arcsec_per_day=86400,start_s=100");  // 1"/s
  const auto d2 = spec("drift:sensor=1,y_arcsec_per_day=172800,z_arcsec_per_day=-86400,start_s=300");
  const HeadEffects both = headEffectsFor({d1, d2}, 1), one = headEffectsFor({d1}, 1), two = headEffectsFor({d2}, 1);
  ASSERT_EQ(both.drifts.size(), 2u);
  for (double t : {0.0, 50.0, 100.0, 150.0, 299.0, 300.0, 301.0, 1000.0}) {
    const Vec3 sum = headSystematicRotVec(one, ctxAt(t)) + headSystematicRotVec(two, ctxAt(t));
    EXPECT_LT((headSystematicRotVec(both, ctxAt(t)) - sum).norm(), 1e-18) << t;
    // The first drift keeps its start (a second drift used to move it to 300 s).
    const Vec3 expect = Vec3(std::max(0.0, t - 100), 2 * std::max(0.0, t - 300), -std::max(0.0, t - 300)) * kRadPerArcsec;
    EXPECT_LT((headSystematicRotVec(both, ctxAt(t)) - expect).norm() * kArcsecPerRad, 1e-9) << t;
  }
  // One spec: exactly rate (t - start).
  const Vec3 r = Vec3(1, 0, 0) * kRadPerArcsec;
  EXPECT_EQ(headSystematicRotVec(one, ctxAt(160)), one.drifts[0].rate_rad_s * (160.0 - 100.0));
  EXPECT_NEAR(one.drifts[0].rate_rad_s.x(), r.x(), 1e-20);
}

TEST(EffectModel, NoiseSpecsAreIndependentSourcesVariancesAdd) {
  HeadConfig cfg;
  cfg.sigma_cross_rad = 6 * kRadPerArcsec;
  cfg.sigma_roll_rad = 48 * kRadPerArcsec;
  const HeadModel none(cfg, headEffectsFor({}, 1));
  EXPECT_EQ(none.sigmaCross(), cfg.sigma_cross_rad);
  EXPECT_EQ(none.sigmaAbout(), cfg.sigma_roll_rad);
  // One spec sets the level exactly (today's behaviour).
  const HeadModel one(cfg, headEffectsFor({spec("anisotropic_noise:sensor=1,about_arcsec=20"),
                                           spec("cross_noise:sensor=1,cross_arcsec=2.4")}, 1));
  EXPECT_EQ(one.sigmaAbout(), 20 * kRadPerArcsec);
  EXPECT_EQ(one.sigmaCross(), 2.4 * kRadPerArcsec);
  // Two specs: quadrature sum (3-4-5).
  const HeadModel two(cfg, headEffectsFor({spec("anisotropic_noise:sensor=all,about_arcsec=30"),
                                           spec("anisotropic_noise:sensor=1,about_arcsec=40"),
                                           spec("cross_noise:sensor=1,cross_arcsec=3"),
                                           spec("cross_noise:sensor=all,cross_arcsec=4")}, 1));
  EXPECT_NEAR(two.sigmaAbout() * kArcsecPerRad, 50.0, 1e-12);
  EXPECT_NEAR(two.sigmaCross() * kArcsecPerRad, 5.0, 1e-12);
  // The covariance uses both levels: cross axes 25 arcsec^2, boresight 2500.
  const Mat3 C = two.noiseCovariance() * kArcsecPerRad * kArcsecPerRad;
  const Vec3 b = cfg.boresight_Si.normalized();
  EXPECT_NEAR(b.dot(C * b), 2500.0, 1e-6);
  EXPECT_NEAR(C.trace(), 2500.0 + 2 * 25.0, 1e-6);
  // Head 2 is hit only by the 'all' specs.
  const HeadModel h2(cfg, headEffectsFor({spec("cross_noise:sensor=1,cross_arcsec=3"), spec("cross_noise:sensor=all,cross_arcsec=4")}, 2));
  EXPECT_NEAR(h2.sigmaCross() * kArcsecPerRad, 4.0, 1e-12);
}

TEST(EffectModel, OutlierAndFlipSpecsAreIndependentProcesses) {
  const auto a = spec("outliers:sensor=1,rate=0.03,arcsec=100"), b = spec("outliers:sensor=1,rate=0.05,arcsec=700");
  const HeadEffects e1 = headEffectsFor({a}, 1), e2 = headEffectsFor({a, b}, 1);
  ASSERT_EQ(e2.outliers.size(), 2u);
  EXPECT_EQ(e2.outliers[0].prob, 0.03);
  EXPECT_NEAR(e2.outliers[1].rad * kArcsecPerRad, 700, 1e-9);
  const OutlierSampler s1(e1.outliers, 9, 1), s2(e2.outliers, 9, 1);
  EXPECT_NEAR(s2.probability(), 1 - 0.97 * 0.95, 1e-15);
  const std::uint64_t N = 200000;
  std::uint64_t hit1 = 0, hit2 = 0, both = 0, f0 = 0, f1 = 0;
  for (std::uint64_t n = 0; n < N; ++n) {
    // The first process of two is the single spec's process, draw for draw.
    ASSERT_EQ(s1.fires(0, n), s2.fires(0, n));
    Quat q1 = Quat::Identity(), q2 = Quat::Identity();
    hit1 += s1.apply(n, q1);
    const bool h = s2.apply(n, q2);
    hit2 += h;
    f0 += s2.fires(0, n);
    f1 += s2.fires(1, n);
    both += s2.fires(0, n) && s2.fires(1, n);
    if (s2.fires(1, n) && !s2.fires(0, n)) {
      ASSERT_NEAR(2 * std::acos(std::min(1.0, std::abs(q2.w()))) * kArcsecPerRad, 700, 1e-6);
    }
  }
  auto within = [&](double count, double p) {
    const double np = p * static_cast<double>(N);
    EXPECT_NEAR(count, np, 5 * std::sqrt(np)) << "p " << p;
  };
  within(static_cast<double>(hit1), 0.03);
  within(static_cast<double>(f0), 0.03);
  within(static_cast<double>(f1), 0.05);
  within(static_cast<double>(both), 0.03 * 0.05);  // independent
  within(static_cast<double>(hit2), s2.probability());

  const HeadEffects fl = headEffectsFor({spec("sign_flips:sensor=all,rate=0.02"), spec("sign_flips:sensor=1,rate=0.04")}, 1);
  ASSERT_EQ(fl.sign_flip_probs.size(), 2u);
  const SignFlipSampler one(headEffectsFor({spec("sign_flips:sensor=all,rate=0.02")}, 1).sign_flip_probs, 9, 1);
  const SignFlipSampler two(fl.sign_flip_probs, 9, 1);
  EXPECT_NEAR(two.probability(), 1 - 0.98 * 0.96, 1e-15);
  std::uint64_t nf1 = 0, nf2 = 0;
  for (std::uint64_t n = 0; n < N; ++n) {
    nf1 += one.fires(n);
    nf2 += two.fires(n);
    if (one.fires(n)) {
      ASSERT_TRUE(two.fires(n));  // the first process is the single spec's
    }
  }
  within(static_cast<double>(nf1), 0.02);
  within(static_cast<double>(nf2), two.probability());
}

/// Fraction of 1-s-spaced times (offset 0.25 s into the slot... spread over the slot) a gap process misses.
double simulatedFraction(const std::vector<RandomGaps>& g, double span_s, std::uint64_t seed) {
  GapProcess p(g, {}, {}, seed, Stream::HeadGap, 1);
  std::uint64_t miss = 0, n = 0;
  for (double t = 0; t < span_s; t += 0.37) {
    miss += p.missing(t);
    ++n;
  }
  return static_cast<double>(miss) / static_cast<double>(n);
}

TEST(EffectModel, RandomGapSpecsAreSeparateProcessesWithTheirOwnMeanLength) {
  const auto a = spec("gaps:sensor=1,per_day=2000,mean_s=20"), b = spec("gaps:sensor=1,per_day=500,mean_s=300");
  const HeadEffects e = headEffectsFor({a, b}, 1);
  ASSERT_EQ(e.random_gaps.size(), 2u);
  EXPECT_EQ(e.random_gaps[0].mean_s, 20.0);  // a second spec no longer overwrites the first's length
  EXPECT_EQ(e.random_gaps[1].mean_s, 300.0);
  EXPECT_NEAR(e.random_gaps[0].per_s * 86400, 2000, 1e-9);
  // Expected fractions: small-rate limit per_s * mean_s, exact value a little below.
  const double fa = expectedMissingFraction(e.random_gaps[0]), fb = expectedMissingFraction(e.random_gaps[1]);
  EXPECT_NEAR(fa, 1 - std::exp(-2000.0 / 86400 * 20), 0.01 * fa);
  EXPECT_NEAR(fb, 1 - std::exp(-500.0 / 86400 * 300), 0.01 * fb);
  EXPECT_NEAR(expectedMissingFraction(e.random_gaps), 1 - (1 - fa) * (1 - fb), 1e-15);
  // A long draw of the process (10 days of slots; independent gap lengths make the estimate noisy,
  // so the tolerance is a few standard errors of about 4500 and 430 gaps).
  const double span = 10 * 86400.0;
  const double sa = simulatedFraction({e.random_gaps[0]}, span, 3), sab = simulatedFraction(e.random_gaps, span, 3);
  std::printf("gap fractions: one process %.4f (expected %.4f), two %.4f (expected %.4f)\n", sa, fa, sab,
              expectedMissingFraction(e.random_gaps));
  EXPECT_NEAR(sa, fa, 0.08 * fa);
  EXPECT_NEAR(sab, expectedMissingFraction(e.random_gaps), 0.15 * expectedMissingFraction(e.random_gaps));
  // Process 0 of two is the single spec's process: everything it misses the pair misses too.
  GapProcess p1({e.random_gaps[0]}, {}, {}, 3, Stream::HeadGap, 1), p2(e.random_gaps, {}, {}, 3, Stream::HeadGap, 1);
  for (double t = 0; t < 86400; t += 0.5) {
    const bool m1 = p1.missing(t), m2 = p2.missing(t);
    if (m1) {
      ASSERT_TRUE(m2) << t;
    }
  }
}

TEST(EffectModel, TimeOffsetAllTargetsEveryHeadNotTheAccelerometer) {
  const auto all = spec("time_offset:sensor=all,offset_ms=20"), h2 = spec("time_offset:sensor=2,offset_ms=5");
  EXPECT_NEAR(headEffectsFor({all, h2}, 1).time_offset_s, 0.020, 1e-15);
  EXPECT_NEAR(headEffectsFor({all, h2}, 2).time_offset_s, 0.025, 1e-15);
  EXPECT_EQ(accEffectsFor({all, h2}).time_offset_s, 0.0);
  EXPECT_NEAR(accEffectsFor({spec("time_offset:sensor=acc,offset_ms=7")}).time_offset_s, 0.007, 1e-15);
}

TEST(EffectModel, ClockDriftIsATagRateErrorAndComposes) {
  const auto c1 = spec("clock_drift:sensor=all,rate_ppm=50,offset_ms=3,start_s=1000");
  const auto c2 = spec("clock_drift:sensor=1,rate_ppm=-20");
  const auto ca = spec("clock_drift:sensor=acc,rate_ppm=-60");
  const HeadEffects e = headEffectsFor({c1, c2, ca, spec("time_offset:sensor=1,offset_ms=100")}, 1);
  ASSERT_EQ(e.clock_drifts.size(), 2u);
  EXPECT_EQ(accEffectsFor({c1, c2, ca}).clock_drifts.size(), 1u);  // 'all' is the heads
  for (double t : {0.0, 999.0, 1000.0, 5000.0, 86400.0}) {
    const double d = tagMinusTrue(e.time_offset_s, e.clock_drifts, t);
    const double expect = 0.100 + 0.003 + 50e-6 * (t - 1000) - 20e-6 * t;
    EXPECT_NEAR(d, expect, 1e-12) << t;
    // trueTimeOfTag inverts it.
    EXPECT_NEAR(trueTimeOfTag(e.time_offset_s, e.clock_drifts, t + d), t, 1e-9) << t;
  }
  // Without clock drift: exactly tag - offset.
  EXPECT_EQ(trueTimeOfTag(0.25, {}, 10.0), 10.0 - 0.25);
  // Validation.
  EffectSpec s;
  std::string err;
  EXPECT_FALSE(parseEffectArg("clock_drift:sensor=1,rate_ppm=2000", s, &err));
  EXPECT_NE(err.find("'rate_ppm'"), std::string::npos) << err;
  EXPECT_FALSE(parseEffectArg("clock_drift:sensor=1", s, &err));
  EXPECT_NE(err.find("'rate_ppm': required"), std::string::npos) << err;
  EXPECT_FALSE(parseEffectArg("cross_noise:sensor=acc,cross_arcsec=2", s, &err));
  EXPECT_FALSE(parseEffectArg("cross_noise:sensor=1,cross_arcsec=-1", s, &err));
  // Catalogue order: the older entries keep their positions, the new ones are appended.
  const auto& cat = effectCatalogue();
  ASSERT_GE(cat.size(), 16u);  // later entries (the coloured-noise effects) are appended after these
  EXPECT_STREQ(cat[0].name, "relative_misalignment");
  EXPECT_STREQ(cat[13].name, "head_dropout");
  EXPECT_STREQ(cat[14].name, "cross_noise");
  EXPECT_STREQ(cat[15].name, "clock_drift");
}

TEST(EffectModel, ParameterVectorFormAgreesWithHeadSystematicRotVec) {
  std::mt19937_64 g(5);
  std::uniform_real_distribution<double> U(-1, 1);
  auto num = [&](double scale) { return std::to_string(scale * U(g)); };
  for (int trial = 0; trial < 50; ++trial) {
    std::vector<EffectSpec> specs = {
        spec("relative_misalignment:sensor=1,x_arcsec=" + num(30) + ",y_arcsec=" + num(30) + ",z_arcsec=" + num(30)),
        spec("thermal_periodic:sensor=1,harmonic=1,x_arcsec=" + num(5) + ",y_arcsec=" + num(5) + ",z_arcsec=" + num(5) +
             ",phase_deg=" + num(180) + ",beta_gain=" + num(1) + ",beta_ref_deg=" + num(60)),
        spec("thermal_periodic:sensor=1,harmonic=3,z_arcsec=" + num(5) + ",phase_deg=" + num(180)),
        spec("drift:sensor=1,x_arcsec_per_day=" + num(100) + ",start_s=" + std::to_string(500 + 500 * U(g))),
        spec("drift:sensor=all,z_arcsec_per_day=" + num(100) + ",start_s=" + std::to_string(2000 + 500 * U(g))),
        spec("step:sensor=1,y_arcsec=" + num(10) + ",at_s=" + std::to_string(3000 + 1000 * U(g))),
    };
    const HeadEffects e = headEffectsFor(specs, 1);
    const HeadParamLayout L = headParamLayout(e);
    const std::vector<double> p = headParams(e);
    ASSERT_EQ(p.size(), L.size());
    ASSERT_EQ(L.size(), 3u * (1 + 4 + 2 + 1));
    for (int k = 0; k < 20; ++k) {
      const OrbitContext c = ctxAt(5000 * (U(g) + 1), kPi * U(g), 1.2 * U(g));
      double out[3];
      headRotationFromParams(L, p.data(), c, out);
      const Vec3 ref = headSystematicRotVec(e, c);
      EXPECT_LT((Vec3(out[0], out[1], out[2]) - ref).norm() * kArcsecPerRad, 1e-9) << trial << " " << k;
    }
  }
  // A hand-built HeadEffects (the audit's unit signatures) may use the single drift_rad_s term: it is
  // evaluated like a list entry and appears in the parameter vector.
  {
    HeadEffects h;
    h.drift_rad_s = Vec3(0, 2, 0);
    h.drift_start_s = 10;
    h.drifts.push_back({Vec3(1, 0, 0), 0.0});
    EXPECT_EQ(headSystematicRotVec(h, ctxAt(30)), Vec3(30, 40, 0));
    EXPECT_EQ(headSystematicRotVec(h, ctxAt(5)), Vec3(5, 0, 0));
    const HeadParamLayout Lh = headParamLayout(h);
    ASSERT_EQ(Lh.size(), 9u);
    double o[3];
    headRotationFromParams(Lh, headParams(h).data(), ctxAt(30), o);
    EXPECT_EQ(Vec3(o[0], o[1], o[2]), Vec3(30, 40, 0));
  }
  // Linearity: unit parameter k gives the k-th basis function (here the drift's x rate after its start).
  const HeadEffects e = headEffectsFor({spec("drift:sensor=1,x_arcsec_per_day=1,start_s=10")}, 1);
  const HeadParamLayout L = headParamLayout(e);
  std::vector<double> unit(L.size(), 0.0);
  unit[3] = 1.0;
  double out[3];
  headRotationFromParams(L, unit.data(), ctxAt(110), out);
  EXPECT_EQ(out[0], 100.0);
  EXPECT_EQ(out[1], 0.0);
}

TEST(EffectModel, ParameterVectorFormDifferentiatesWithCeresJets) {
  // With Jets, d phi / d p is the model's basis: one harmonic's cos/sin columns, the drift's elapsed
  // time after its start, the step's indicator (the function is linear, so exact).
  const HeadEffects e = headEffectsFor({spec("thermal_periodic:sensor=1,harmonic=2,x_arcsec=3,beta_gain=0.4,beta_ref_deg=30"),
                                        spec("drift:sensor=1,y_arcsec_per_day=5,start_s=100"),
                                        spec("step:sensor=1,z_arcsec=2,at_s=50")}, 1);
  const HeadParamLayout L = headParamLayout(e);
  constexpr int N = 15;
  ASSERT_EQ(L.size(), static_cast<std::size_t>(N));
  using J = ceres::Jet<double, N>;
  const std::vector<double> p = headParams(e);
  std::vector<J> pj(N);
  for (int k = 0; k < N; ++k) pj[static_cast<std::size_t>(k)] = J(p[static_cast<std::size_t>(k)], k);
  const OrbitContext c = ctxAt(400, 0.7, 0.5);
  J out[3];
  headRotationFromParams(L, pj.data(), c, out);
  const Vec3 ref = headSystematicRotVec(e, c);
  const double m = 1 + 0.4 * (std::cos(0.5) - std::cos(30 * kRadPerDeg));
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(out[k].a, ref[k], 1e-18);
    EXPECT_EQ(out[k].v[k], 1.0);                                   // misalignment
    EXPECT_NEAR(out[k].v[3 + k], m * std::cos(1.4), 1e-15);       // harmonic cos
    EXPECT_NEAR(out[k].v[6 + k], m * std::sin(1.4), 1e-15);       // harmonic sin
    EXPECT_EQ(out[k].v[9 + k], 300.0);                             // drift: t - start
    EXPECT_EQ(out[k].v[12 + k], 1.0);                              // step: t >= at
  }
}

TEST(EffectModel, AccelerometerNoiseDrawMatchesItsVarianceAutocovarianceAndPsd) {
  AccelConfig c;
  c.rate_hz = 10;
  c.white_rad_s2 = Vec3(1.5e-7, 3e-8, 5e-8);
  c.lowfreq_rad_s2 = Vec3(2e-7, 5e-8, 1e-7);
  c.lowfreq_tau_s = 20;
  const AccNoiseModel m(c, 4);
  EXPECT_NEAR(m.phi(), std::exp(-0.1 / 20), 1e-15);
  // Draw 200 000 samples (about 1000 correlation times).
  const std::uint64_t N = 200000;
  Vec3 lf = m.lowFreqInitial(), prev = Vec3::Zero();
  Vec3 s2 = Vec3::Zero(), s1lag = Vec3::Zero(), s10lag = Vec3::Zero();
  std::vector<Vec3> x(N);
  for (std::uint64_t n = 0; n < N; ++n) {
    Vec3 w, lin;
    m.white(n, w, lin);
    x[n] = w + lf;
    lf = m.lowFreqNext(lf, n);
  }
  for (std::uint64_t n = 10; n < N; ++n) {
    s2 += x[n].cwiseAbs2();
    s1lag += x[n].cwiseProduct(x[n - 1]);
    s10lag += x[n].cwiseProduct(x[n - 10]);
  }
  const double M = static_cast<double>(N - 10);
  for (int k = 0; k < 3; ++k) {
    // Sample variance of a correlated series: ~1000 effective samples for the GM part -> 10 % tolerance.
    EXPECT_NEAR(s2[k] / M, m.autocovariance(0)[k], 0.1 * m.autocovariance(0)[k]) << k;
    EXPECT_NEAR(s1lag[k] / M, m.autocovariance(1)[k], 0.1 * m.autocovariance(0)[k]) << k;
    EXPECT_NEAR(s10lag[k] / M, m.autocovariance(10)[k], 0.1 * m.autocovariance(0)[k]) << k;
  }
  (void)prev;
  // The one-sided PSD integrates to the variance over [0, rate/2].
  const int K = 200000;
  const double fmax = 0.5 * c.rate_hz, df = fmax / K;
  Vec3 integral = Vec3::Zero();
  for (int i = 0; i < K; ++i) integral += m.psdOneSided((i + 0.5) * df) * df;
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(integral[k], m.autocovariance(0)[k], 1e-4 * m.autocovariance(0)[k]) << k;
}

TEST(EffectModel, TagModelExpectedTagAndJitter) {
  const TagModel t = makeTagModel(738849600000000LL + 250000, 2.0, 29992, 30.0, 40.0, 1, Stream::HeadTagJitter);
  EXPECT_EQ(t.period, 500000);
  EXPECT_GE(t.start, 738849600000000LL + 250000);
  EXPECT_LT(t.start - t.period, 738849600000000LL + 250000);
  EXPECT_NEAR(t.jitterSigmaUs(), 40 / std::sqrt(3.0), 1e-12);
  double mean = 0, sq = 0, maxabs = 0;
  const int N = 20000;
  for (int k = 0; k < N; ++k) {
    const auto kk = static_cast<std::uint64_t>(k);
    const double d = static_cast<double>(t.tag(kk)) - t.expectedTag(kk);
    EXPECT_LE(std::abs(d - t.jitter(kk)), 1.0);  // integer rounding of drift and jitter
    mean += d;
    sq += d * d;
    maxabs = std::max(maxabs, std::abs(d));
  }
  mean /= N;
  EXPECT_NEAR(mean, 0.0, 5 * t.jitterSigmaUs() / std::sqrt(N) + 0.5);
  EXPECT_NEAR(std::sqrt(sq / N), t.jitterSigmaUs(), 0.05 * t.jitterSigmaUs());
  EXPECT_LE(maxabs, 41.0);
  // The drift: 30 ppm of 10000 s is 300 ms.
  EXPECT_NEAR(t.expectedTag(20000) - static_cast<double>(t.start), 20000 * 500000.0 * (1 + 30e-6), 1e-3);
}

}  // namespace
}  // namespace boresight::model
