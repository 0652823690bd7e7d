// The coloured processes the simulator draws (model/stochastic.h NoiseProcess on noise.h's
// NoiseSimulator), the accelerometer noise model as a user of the noise library, the new effects'
// parsing and composition, and the field-of-view error model (model/sensors.h).
//
// Spectra are compared with the exact expectation of a Hann-windowed Welch estimate under the model's
// closed-form autocovariance (psd_check.h); the tolerance is the normal quantile at a family-wise
// level of 1e-3 over the bands, times the standard deviation that the number of averaged segments and
// bins gives. Nothing is tuned to a seed.
#include "psd_check.h"

#include <boresight/model/effects.h>
#include <boresight/model/noise.h>
#include <boresight/model/rotation.h>
#include <boresight/model/sensors.h>
#include <boresight/model/stochastic.h>

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace boresight::model {
namespace {

constexpr double kFamilyAlpha = 1e-3;

EffectSpec spec(const std::string& arg) {
  EffectSpec s;
  std::string err;
  EXPECT_TRUE(parseEffectArg(arg, s, &err)) << err;
  return s;
}

/// Draws n samples every T seconds of one axis of m.
std::vector<double> draw(const NoiseModel& m, double T, std::size_t n, std::uint64_t seed, Stream stream = Stream::HeadColouredNoise) {
  NoiseProcess p(m, seed, stream, 1, 0);
  std::vector<double> x(n);
  for (std::size_t i = 0; i < n; ++i) x[i] = p.next(static_cast<double>(i) * T);
  return x;
}

void expectSpectrum(const std::vector<double>& x, const NoiseModel& m, double T, std::size_t L, const char* what) {
  const testpsd::Welch W = testpsd::welch(x, T, L);
  const auto bands = testpsd::bandCheck(W, [&](double lag) { return m.autocovariance(lag); }, 2, 6);
  const double zc = testpsd::zCrit(kFamilyAlpha, static_cast<int>(bands.size()));
  ASSERT_GE(bands.size(), 5u);
  for (const auto& b : bands) EXPECT_LT(std::abs(b.z), zc) << what << ": " << b.describe() << " (|z| limit " << zc << ")";
}

TEST(NoiseProcess, GaussMarkovPeriodogramMatchesItsClosedForm) {
  NoiseModel m;
  m.add(NoiseTerm::gaussMarkov(1.0, 40.0));
  const double T = 0.5;
  expectSpectrum(draw(m, T, std::size_t(1) << 20, 3), m, T, 4096, "GM(1, 40 s)");
}

TEST(NoiseProcess, PowerLawOfThreeDecadesMatchesItsClosedForm) {
  // Three decades: ten Gauss-Markov terms, more than the eight normals one counter index carries (the
  // simulator draws each sample from two indices).
  NoiseModel m;
  m.add(NoiseTerm::powerLaw(1.0, 1.0, 1e-3, 1.0));
  ASSERT_EQ(m.markovTerms().size(), 10u);
  const double T = 0.5;
  expectSpectrum(draw(m, T, std::size_t(1) << 20, 4), m, T, 4096, "PL(1, f^-1, 1e-3..1 Hz)");
}

TEST(NoiseProcess, SumOfTermsWithWhiteMatchesItsClosedForm) {
  NoiseModel m;
  m.add(NoiseTerm::white(0.7)).add(NoiseTerm::gaussMarkov(0.5, 5.0)).add(NoiseTerm::powerLaw(0.8, 1.5, 1e-3, 0.1));
  const double T = 0.1;
  expectSpectrum(draw(m, T, std::size_t(1) << 20, 5), m, T, 4096, "white + GM + PL");
}

TEST(NoiseProcess, IrregularTimesAndGapsFollowTheAutocovariance) {
  // Independent pairs (t, t + dt): their product has mean R(dt) and variance R(0)^2 + R(dt)^2 (normal
  // pairs). The pairs are 2e5 s apart, far beyond every correlation time, so they are independent.
  NoiseModel m;
  m.add(NoiseTerm::gaussMarkov(1.0, 100.0)).add(NoiseTerm::powerLaw(0.5, 1.0, 1e-4, 0.5));
  const std::vector<double> dts = {0.37, 10.0, 150.0, 600.0, 2500.0};
  const std::size_t pairs = 40000;
  NoiseProcess p(m, 11, Stream::HeadThermalWander, 2, 1);
  std::vector<double> sum(dts.size(), 0.0), sq(dts.size(), 0.0);
  std::vector<std::size_t> cnt(dts.size(), 0);
  for (std::size_t j = 0; j < pairs; ++j) {
    const std::size_t g = j % dts.size();
    const double t = static_cast<double>(j) * 2e5;
    const double a = p.next(t), b = p.next(t + dts[g]);
    sum[g] += a * b;
    sq[g] += a * a;
    ++cnt[g];
  }
  const double zc = testpsd::zCrit(kFamilyAlpha, 2 * static_cast<int>(dts.size()));
  const double v = m.variance();
  for (std::size_t g = 0; g < dts.size(); ++g) {
    const double n = static_cast<double>(cnt[g]), r = m.autocovariance(dts[g]);
    const double z = (sum[g] / n - r) / std::sqrt((v * v + r * r) / n);
    EXPECT_LT(std::abs(z), zc) << "dt " << dts[g] << ": mean product " << sum[g] / n << " against R " << r;
    const double zv = (sq[g] / n - v) / std::sqrt(2 * v * v / n);
    EXPECT_LT(std::abs(zv), zc) << "variance at dt " << dts[g];
  }
}

TEST(NoiseProcess, ATermsDrawsDoNotDependOnTheTermsAfterIt) {
  NoiseModel one, two;
  one.add(NoiseTerm::gaussMarkov(1.0, 30.0));
  two = one;
  two.add(NoiseTerm::powerLaw(2.0, 1.0, 1e-3, 1.0));  // 10 more terms: a second chunk
  NoiseModel second;
  second.add(NoiseTerm::powerLaw(2.0, 1.0, 1e-3, 1.0));
  NoiseProcess a(one, 9, Stream::HeadColouredNoise, 3, 2), b(two, 9, Stream::HeadColouredNoise, 3, 2);
  // the difference is the second term's process: its variance and no correlation with the first
  const std::size_t n = 200000;
  double s_d = 0, s_ad = 0;
  std::vector<double> d(n);
  for (std::size_t i = 0; i < n; ++i) {
    const double t = 0.5 * static_cast<double>(i);
    const double x = a.next(t), y = b.next(t);
    d[i] = y - x;
    s_d += d[i] * d[i];
    s_ad += x * d[i];
  }
  // The variance of a sample mean of squares of a stationary normal series: 2 sum_k (1 - |k|/n) R(kT)^2 / n.
  double acc = 0;
  for (std::size_t k = 0; k < n; ++k) {
    const double r = second.autocovariance(0.5 * static_cast<double>(k));
    if (r < 1e-9) break;
    acc += (k == 0 ? 1.0 : 2.0) * r * r;
  }
  const double zc = testpsd::zCrit(kFamilyAlpha, 1);
  EXPECT_LT(std::abs(s_d / n - second.variance()) / std::sqrt(2 * acc / n), zc) << s_d / n << " vs " << second.variance();
  // the first term's draws are unchanged: the two processes are uncorrelated
  double acc2 = 0;
  for (std::size_t k = 0; k < n; ++k) {
    const double r1 = one.autocovariance(0.5 * static_cast<double>(k)), r2 = second.autocovariance(0.5 * static_cast<double>(k));
    if (r1 * r2 < 1e-9) break;
    acc2 += (k == 0 ? 1.0 : 2.0) * r1 * r2;
  }
  EXPECT_LT(std::abs(s_ad / n) / std::sqrt(acc2 / n), zc);
}

TEST(AccNoise, IsTheNoiseLibrarysModelAndKeepsItsDraws) {
  AccelConfig c;
  c.rate_hz = 10;
  c.white_rad_s2 = Vec3(1.5e-7, 3e-8, 5e-8);
  c.lowfreq_rad_s2 = Vec3(2e-8, 5e-9, 7e-9);
  c.lowfreq_tau_s = 2000;
  const AccNoiseModel m(c, 4);
  for (int k = 0; k < 3; ++k) {
    NoiseModel expect;
    expect.add(NoiseTerm::white(c.white_rad_s2[k])).add(NoiseTerm::gaussMarkov(c.lowfreq_rad_s2[k], c.lowfreq_tau_s));
    EXPECT_EQ(m.model(k), expect) << k;
    for (std::uint64_t lag : {0, 1, 7, 500})
      EXPECT_EQ(m.autocovariance(lag)[k], expect.autocovariance(static_cast<double>(lag) * 0.1)) << k;
    EXPECT_EQ(m.psdOneSided(0.37)[k], expect.psdSampled(0.37, 0.1)) << k;
  }
  // The Gauss-Markov step keeps the draws of the simulator before the move, bit for bit: the formula
  // the simulator had (one vector expression) against the library user's.
  const CounterRng rng(4, Stream::AccLowFreq, 0);
  Vec3 lf = m.lowFreqInitial();
  const double phi = std::exp(-(1.0 / c.rate_hz) / c.lowfreq_tau_s);
  EXPECT_EQ(m.phi(), phi);
  for (std::uint64_t n = 0; n < 5000; ++n) {
    double g0, g1, g2, g3;
    rng.normal2(n + 1, 0, g0, g1);
    rng.normal2(n + 1, 1, g2, g3);
    const Vec3 before = phi * lf + std::sqrt(1 - phi * phi) * c.lowfreq_rad_s2.cwiseProduct(Vec3(g0, g1, g2));
    const Vec3 now = m.lowFreqNext(lf, n);
    ASSERT_EQ(before, now) << n;
    lf = now;
  }
}

TEST(NoiseEffects, ParsedIntoOneTermPerSpecPerAxisAndVariancesAdd) {
  const std::vector<EffectSpec> specs = {
      spec("coloured_noise:sensor=2,cross_arcsec=0.5,about_arcsec=3,tau_s=600"),
      spec("coloured_noise:sensor=all,cross_arcsec=1,f_lo_hz=1e-4,f_hi_hz=1e-2,alpha=1.2"),
      spec("thermal_wander:sensor=2,about_arcsec=4,tau_s=3000"),
      spec("fov_error:sensor=2,arcsec=3"),
      spec("fov_error:sensor=all,arcsec=1,order=2"),
      spec("acc_coloured_noise:x=1e-8,z=2e-8,tau_s=500"),
      spec("acc_bias_wander:y=5e-9"),
  };
  const HeadEffects h2 = headEffectsFor(specs, 2), h1 = headEffectsFor(specs, 1);
  ASSERT_EQ(h2.coloured_cross.terms.size(), 2u);
  ASSERT_EQ(h2.coloured_about.terms.size(), 1u);  // the power-law spec has no about level
  EXPECT_EQ(h1.coloured_cross.terms.size(), 1u);
  const double a = kRadPerArcsec;
  EXPECT_NEAR(h2.coloured_cross.variance(), (0.25 + 1.0) * a * a, 1e-12 * a * a);
  EXPECT_EQ(h2.coloured_cross.terms[0], NoiseTerm::gaussMarkov(0.5 * a, 600));
  EXPECT_EQ(h2.coloured_cross.terms[1], NoiseTerm::powerLaw(1.0 * a, 1.2, 1e-4, 1e-2));
  EXPECT_TRUE(h2.wander_cross.empty());
  EXPECT_EQ(h2.wander_about.terms[0], NoiseTerm::gaussMarkov(4 * a, 3000));
  EXPECT_FALSE(h1.hasWander());
  ASSERT_EQ(h2.fov.size(), 2u);
  EXPECT_EQ(h2.fov[0].order, 3);
  EXPECT_EQ(h2.fov[1].order, 2);
  EXPECT_EQ(h1.fov.size(), 1u);
  const AccEffects acc = accEffectsFor(specs);
  EXPECT_EQ(acc.coloured[0].terms[0], NoiseTerm::gaussMarkov(1e-8, 500));
  EXPECT_TRUE(acc.coloured[1].empty());
  EXPECT_EQ(acc.bias_wander[1].terms[0], NoiseTerm::gaussMarkov(5e-9, 864000));
  EXPECT_TRUE(acc.bias_wander[0].empty());

  // Validation names the key.
  EffectSpec s;
  std::string err;
  EXPECT_FALSE(parseEffectArg("coloured_noise:sensor=1,cross_arcsec=1", s, &err));
  EXPECT_NE(err.find("key 'tau_s': required"), std::string::npos) << err;
  EXPECT_FALSE(parseEffectArg("coloured_noise:sensor=1,cross_arcsec=1,tau_s=10,f_lo_hz=1e-3,f_hi_hz=1", s, &err));
  EXPECT_NE(err.find("not both"), std::string::npos) << err;
  EXPECT_FALSE(parseEffectArg("thermal_wander:sensor=1,cross_arcsec=1,f_lo_hz=1e-3,f_hi_hz=1e-4", s, &err));
  EXPECT_NE(err.find("key 'f_lo_hz'"), std::string::npos) << err;
  EXPECT_FALSE(parseEffectArg("thermal_wander:sensor=1,cross_arcsec=1,f_lo_hz=1e-3,f_hi_hz=1,alpha=2", s, &err));
  EXPECT_NE(err.find("alpha"), std::string::npos) << err;
  EXPECT_FALSE(parseEffectArg("coloured_noise:sensor=acc,cross_arcsec=1,tau_s=1", s, &err));
  EXPECT_FALSE(parseEffectArg("acc_coloured_noise:sensor=1,x=1,tau_s=1", s, &err));
  EXPECT_FALSE(parseEffectArg("acc_coloured_noise:x=-1,tau_s=1", s, &err));
  EXPECT_FALSE(parseEffectArg("fov_error:sensor=1,arcsec=1,order=7", s, &err));
  EXPECT_NE(err.find("key 'order'"), std::string::npos) << err;
  EXPECT_FALSE(parseEffectArg("fov_error:sensor=1", s, &err));
  EXPECT_FALSE(parseEffectArg("acc_bias_wander:x=1e-9,tau_s=0", s, &err));
  // The catalogue keeps the older order; the new entries are appended.
  const auto& cat = effectCatalogue();
  ASSERT_EQ(cat.size(), 21u);
  EXPECT_STREQ(cat[15].name, "clock_drift");
  EXPECT_STREQ(cat[16].name, "coloured_noise");
  EXPECT_STREQ(cat[17].name, "fov_error");
  EXPECT_STREQ(cat[18].name, "thermal_wander");
  EXPECT_STREQ(cat[19].name, "acc_coloured_noise");
  EXPECT_STREQ(cat[20].name, "acc_bias_wander");
}

// ---------------------------------------------------------------------------------------------
// Field-of-view error

HeadModel headWithField(int order, double rms_arcsec, std::uint64_t seed) {
  HeadConfig c;
  c.fov_half_angle_rad = 10 * kRadPerDeg;
  c.boresight_Si = Vec3(0.1, -0.2, 1).normalized();  // not a coordinate axis: the head basis matters
  HeadModel h(c, HeadEffects{});
  FovErrorSpec s;
  s.order = order;
  s.rms_rad = rms_arcsec * kRadPerArcsec;
  h.setFovFields({drawFovErrorField(s, CounterRng(seed, Stream::HeadFovField, 1))});
  return h;
}

/// n random unit directions inside the head's FOV cone, head frame.
std::vector<Vec3> starsInFov(const HeadModel& h, std::size_t n, std::uint64_t seed) {
  std::mt19937_64 g(seed);
  std::uniform_real_distribution<double> U(-1, 1);
  Vec3 e1, e2, b;
  boresightBasis(h.config().boresight_Si, e1, e2, b);
  const double t = std::tan(h.config().fov_half_angle_rad);
  std::vector<Vec3> s;
  while (s.size() < n) {
    const double x = U(g) * t, y = U(g) * t;
    if (x * x + y * y > t * t) continue;
    s.push_back((x * e1 + y * e2 + b).normalized());
  }
  return s;
}

TEST(FovError, FieldRmsOverTheDetectorIsTheConfiguredSizeAndTermsAreOrthonormal) {
  // 8-point Gauss-Legendre quadrature is exact for the squared field (degree <= 12) on [-1, 1]^2.
  const double xq[8] = {-0.9602898564975363, -0.7966664774136267, -0.5255324099163290, -0.1834346424956498,
                        0.1834346424956498,  0.5255324099163290,  0.7966664774136267,  0.9602898564975363};
  const double wq[8] = {0.1012285362903763, 0.2223810344533745, 0.3137066458778873, 0.3626837833783620,
                        0.3626837833783620, 0.3137066458778873, 0.2223810344533745, 0.1012285362903763};
  for (int order = 1; order <= 6; ++order) {
    FovErrorSpec s;
    s.order = order;
    s.rms_rad = 2.5 * kRadPerArcsec;
    const FovErrorField f = drawFovErrorField(s, CounterRng(order, Stream::HeadFovField, 1));
    EXPECT_EQ(f.cx.size(), fovTerms(order).size());
    EXPECT_EQ(f.cx.size(), static_cast<std::size_t>((order + 1) * (order + 2) / 2 - 1));
    double mx = 0, my = 0;
    for (int i = 0; i < 8; ++i)
      for (int j = 0; j < 8; ++j) {
        const Eigen::Vector2d d = f.displacement(xq[i], xq[j]);
        mx += wq[i] * wq[j] * d.x() * d.x() / 4;
        my += wq[i] * wq[j] * d.y() * d.y() / 4;
      }
    EXPECT_NEAR(std::sqrt(0.5 * (mx + my)), s.rms_rad, 1e-12 * s.rms_rad) << order;
    EXPECT_GT(mx, 0) << order;
    EXPECT_GT(my, 0) << order;
    // no uniform rotation about the boresight (dx = -t v, dy = t u): that is a mounting error
    EXPECT_NEAR(f.cy[0], f.cx[1], 1e-15 * s.rms_rad) << order;
  }
  // Different heads (sensor keys) draw different fields.
  FovErrorSpec s;
  s.rms_rad = 1;
  EXPECT_NE(drawFovErrorField(s, CounterRng(1, Stream::HeadFovField, 1)).cx,
            drawFovErrorField(s, CounterRng(1, Stream::HeadFovField, 2)).cx);
}

TEST(FovError, DisplacementsOfARotatedHeadGiveThatRotation) {
  // The convention: a head whose delivered attitude is q_I_Si Exp(phi) predicts its stars at
  // Exp(-phi) s; stars measured there are displaced by exactly that, and the least-squares rotation
  // of the displacements is phi (to second order in phi).
  const HeadModel h = headWithField(3, 1, 1);
  const auto s = starsInFov(h, 40, 2);
  const Vec3 b = h.config().boresight_Si.normalized();
  for (const Vec3& phi0 : {Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1), Vec3(0.3, -0.7, 2.0)}) {
    const Vec3 phi = phi0 * 5e-5;
    std::vector<Eigen::Vector2d> d(s.size());
    const Mat3 R = quatExp(-phi).toRotationMatrix();
    for (std::size_t k = 0; k < s.size(); ++k) {
      const Vec3 p = R * s[k];
      d[k] = h.focalPlane(p) - h.focalPlane(s[k]);
      d[k] *= std::tan(h.config().fov_half_angle_rad);  // normalised -> tangent-plane rad
    }
    const Vec3 est = h.rotationFromDisplacements(s.data(), d.data(), s.size());
    EXPECT_LT((est - phi).norm(), 1e-3 * phi.norm()) << phi.transpose() << " -> " << est.transpose();
    (void)b;
  }
  // Fewer than two stars: no attitude, no error.
  EXPECT_EQ(h.fovAttitudeError(s.data(), 1), Vec3::Zero());
}

TEST(FovError, AttitudeErrorIsLinearInTheFieldAndFollowsTheStars) {
  const HeadModel h1 = headWithField(3, 2, 5), h2 = headWithField(3, 4, 5);
  const auto s = starsInFov(h1, 30, 3);
  const Vec3 e1 = h1.fovAttitudeError(s.data(), s.size()), e2 = h2.fovAttitudeError(s.data(), s.size());
  EXPECT_GT(e1.norm(), 0);
  EXPECT_LT((e2 - 2 * e1).norm(), 1e-12 * e2.norm());  // same shape (same draws), twice the size
  // Another set of stars gives another error: it is a function of where the stars are.
  const auto s2 = starsInFov(h1, 30, 4);
  EXPECT_GT((h1.fovAttitudeError(s2.data(), s2.size()) - e1).norm(), 0.1 * e1.norm());
  // The measured star: the true direction moved on the tangent plane by the displacement.
  const Vec3 m = h1.fovDisplacedStar(s[0]);
  const Eigen::Vector2d d = (h1.focalPlane(m) - h1.focalPlane(s[0])) * std::tan(h1.config().fov_half_angle_rad);
  EXPECT_LT((d - h1.fovDisplacement(s[0])).norm(), 1e-12);
  EXPECT_NEAR(m.norm(), 1.0, 1e-15);
}

}  // namespace
}  // namespace boresight::model
