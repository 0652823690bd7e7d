// The noise library (model/noise.h) against independent computations: spectra against their
// integrals and against periodograms of long simulations, the Kalman whitener against a dense
// Cholesky factor of the covariance matrix built from the closed-form autocovariance, whiteness
// tests at their nominal rate, fits against the simulated truth, variance components against the
// closed form of one group.
#include "noise_test_util.h"

#include <boresight/model/noise.h>
#include <boresight/model/stats.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <gtest/gtest.h>

#include <cmath>

using namespace boresight::model;
using boresight::model::noisetest::gappedSeries;

namespace {

NoiseModel gmModel() { return NoiseModel::white(1.0).add(NoiseTerm::gaussMarkov(2.0, 30.0)); }
NoiseModel plModel() { return NoiseModel::white(1.0).add(NoiseTerm::powerLaw(3.0, 1.2, 1e-3, 5e-2)); }
/// More than seven Gauss-Markov terms: the simulator's draws span two counter indices per sample.
NoiseModel wideModel() { return NoiseModel::white(1.0).add(NoiseTerm::powerLaw(3.0, 1.0, 4.6e-4, 2.5e-2, 12)); }
NoiseModel sumModel() {
  return NoiseModel::white(0.5).add(NoiseTerm::gaussMarkov(1.0, 5.0)).add(NoiseTerm::powerLaw(2.0, 0.8, 2e-3, 2e-2));
}

/// Trapezoid integral of the sampled PSD over [0, 1/(2T)].
double integratePsd(const NoiseModel& m, double T) {
  const int n = 200000;
  const double fn = 0.5 / T, h = fn / n;
  double s = 0.5 * (m.psdSampled(0, T) + m.psdSampled(fn, T));
  for (int i = 1; i < n; ++i) s += m.psdSampled(i * h, T);
  return s * h;
}

}  // namespace

TEST(NoiseModel, SampledPsdIntegratesToTheVariance) {
  for (const NoiseModel& m : {gmModel(), plModel(), sumModel(), NoiseModel::white(3.0)}) {
    const double T = 0.5;
    EXPECT_NEAR(integratePsd(m, T), m.variance(), 1e-6 * m.variance()) << m.describe();
    EXPECT_DOUBLE_EQ(m.autocovariance(0), m.variance());
  }
}

TEST(NoiseModel, PowerLawFollowsItsSlopeInsideTheBandAndIsSmoothInItsCorners) {
  // In the middle two decades of a five-decade band the local log-log slope of the continuous PSD is
  // -alpha within 0.08 (the terms near the corners shape the slope a few decades into the band: the
  // figures of the header comment), and for alpha = 1 the PSD times f stays within 2 %.
  for (double alpha : {0.5, 1.0, 1.5}) {
    const NoiseModel m = NoiseModel().add(NoiseTerm::powerLaw(1.0, alpha, 1e-5, 1.0));
    double lo = 1e300, hi = 0;
    for (double lf = -3.5; lf <= -1.5; lf += 0.01) {
      const double f = std::pow(10.0, lf), f2 = std::pow(10.0, lf + 0.01);
      const double slope = std::log(m.psdContinuous(f2, 1.0) / m.psdContinuous(f, 1.0)) / std::log(f2 / f);
      EXPECT_NEAR(slope, -alpha, 0.08) << "alpha " << alpha << " at " << f << " Hz";
      const double v = m.psdContinuous(f, 1.0) * f;
      lo = std::min(lo, v);
      hi = std::max(hi, v);
    }
    if (alpha == 1.0) {
      EXPECT_LT(hi / lo, 1.02);
    }
  }
  // For a fixed number of terms the PSD is smooth in the corners (what the fit differentiates): second
  // differences in log f_hi are of the order of the step squared.
  for (double f : {2e-3, 8e-3, 3e-2}) {
    auto at = [&](double lf) {
      return std::log(NoiseModel().add(NoiseTerm::powerLaw(1.0, 1.0, 1e-3, std::exp(lf), 7)).psdContinuous(f, 1.0));
    };
    const double x = std::log(1e-2), h = 1e-3;
    EXPECT_LT(std::abs(at(x + h) - 2 * at(x) + at(x - h)), 10 * h * h);
  }
}

TEST(NoiseModel, ValidateRefusesImpossibleTerms) {
  EXPECT_EQ(gmModel().validate(), "");
  EXPECT_NE(NoiseModel().add(NoiseTerm::gaussMarkov(1.0, 0.0)).validate(), "");
  EXPECT_NE(NoiseModel().add(NoiseTerm::gaussMarkov(std::nan(""), 1.0)).validate(), "");
  EXPECT_NE(NoiseModel().add(NoiseTerm::powerLaw(1.0, 2.5, 1e-3, 1e-2)).validate(), "");
  EXPECT_NE(NoiseModel().add(NoiseTerm::powerLaw(1.0, 0.0, 1e-3, 1e-2)).validate(), "");
  EXPECT_NE(NoiseModel().add(NoiseTerm::powerLaw(1.0, 1.0, 1e-2, 1e-3)).validate(), "");
}

TEST(NoiseSimulator, PeriodogramOfALongSimulationMatchesThePsd) {
  // 2^20 samples at 2 Hz, Welch with 4096-sample Hann segments, 50 % overlap (511 segments). The
  // estimate averaged over a band of B bins has a relative standard deviation of about
  // sqrt(1.5 / B) * sqrt(1.1 / M) (Hann: 1.5 bins of equivalent bandwidth; overlap: 10 % more
  // variance than M independent segments); every band must be within 5 of those of the PSD.
  const double T = 0.5;
  const std::size_t n = std::size_t{1} << 20, seg = 4096;
  for (const NoiseModel& m : {gmModel(), plModel(), sumModel(), wideModel()}) {
    NoiseSimulator sim(m, CounterRng(7, Stream::HeadNoise, 3));
    std::vector<double> y(n);
    for (std::size_t i = 0; i < n; ++i) y[i] = sim.next(static_cast<double>(i) * T);
    const Spectrum sp = welchPsd(y, T, seg);
    ASSERT_GT(sp.segments, 500);
    // log-spaced bands from bin 2 (bin 1 carries the per-segment mean removal)
    std::size_t k = 1;
    int bands = 0;
    while (k < sp.f_hz.size()) {
      const std::size_t B = std::max<std::size_t>(4, k / 4);
      const std::size_t end = std::min(sp.f_hz.size(), k + B);
      double ratio = 0;
      for (std::size_t j = k; j < end; ++j) ratio += sp.psd[j] / m.psdSampled(sp.f_hz[j], T);
      ratio /= static_cast<double>(end - k);
      const double sd = std::sqrt(1.5 / static_cast<double>(end - k)) * std::sqrt(1.1 / sp.segments);
      EXPECT_NEAR(ratio, 1.0, 5 * sd) << m.describe() << " band at " << sp.f_hz[k] << " Hz";
      k = end;
      ++bands;
    }
    EXPECT_GT(bands, 10);
  }
}

TEST(NoiseSimulator, DrawsArePureFunctionsOfTheSampleIndexAndStartStationary) {
  const NoiseModel m = sumModel();
  NoiseSimulator a(m, CounterRng(3, Stream::HeadNoise, 1)), b(m, CounterRng(3, Stream::HeadNoise, 1));
  for (int i = 0; i < 100; ++i) EXPECT_EQ(a.next(i * 0.5), b.next(i * 0.5));
  // first sample over many seeds: the stationary variance
  double s2 = 0;
  const int seeds = 20000;
  for (int s = 0; s < seeds; ++s) {
    NoiseSimulator c(m, CounterRng(static_cast<std::uint64_t>(s), Stream::HeadNoise, 1));
    const double v = c.next(0.0);
    s2 += v * v;
  }
  // variance of a chi-square(seeds) / seeds estimate: 2 / seeds
  EXPECT_NEAR(s2 / seeds / m.variance(), 1.0, 5 * std::sqrt(2.0 / seeds));
}

namespace {

/// Dense covariance of the series from the closed-form autocovariance.
Eigen::MatrixXd denseCovariance(const NoiseModel& m, const NoiseSeries& s) {
  const auto n = static_cast<Eigen::Index>(s.size());
  Eigen::MatrixXd S(n, n);
  for (Eigen::Index i = 0; i < n; ++i)
    for (Eigen::Index j = 0; j < n; ++j)
      S(i, j) = m.autocovariance(s.t_s[static_cast<std::size_t>(i)] - s.t_s[static_cast<std::size_t>(j)]);
  return S;
}

}  // namespace

TEST(KalmanWhitener, EqualsTheDenseCholeskyFactorOnIrregularSamplesWithGaps) {
  // Irregular times (jittered 0.5 s grid), a long gap and short ones; dense: z = L^-1 y with
  // S = L L^T, -2 log L = n log 2 pi + log det S + |z|^2; GLS with a constant and a trend.
  for (const NoiseModel& m : {gmModel(), plModel(), sumModel()}) {
    NoiseSeries s = gappedSeries(m, 900, 0.5, 0.08, 11, /*jitter=*/0.1);
    const auto n = static_cast<Eigen::Index>(s.size());
    const Eigen::MatrixXd S = denseCovariance(m, s);
    const Eigen::LLT<Eigen::MatrixXd> llt(S);
    ASSERT_EQ(llt.info(), Eigen::Success);
    Eigen::Map<const Eigen::VectorXd> y(s.y.data(), n);
    const Eigen::VectorXd z_dense = llt.matrixL().solve(y);
    const std::vector<double> z = whitenSeries(m, s);
    for (Eigen::Index i = 0; i < n; ++i) ASSERT_NEAR(z[static_cast<std::size_t>(i)], z_dense[i], 1e-7) << i;
    const double logdet = 2 * llt.matrixL().toDenseMatrix().diagonal().array().log().sum();
    const double m2ll_dense = static_cast<double>(n) * std::log(2 * M_PI) + logdet + z_dense.squaredNorm();
    EXPECT_NEAR(minusTwoLogLikelihood(m, s, Eigen::MatrixXd(), false), m2ll_dense, 1e-7 * std::abs(m2ll_dense));
    // GLS with regressors, ML and REML
    Eigen::MatrixXd X(n, 2);
    for (Eigen::Index i = 0; i < n; ++i) X(i, 0) = 1, X(i, 1) = s.t_s[static_cast<std::size_t>(i)] / 100;
    const Eigen::MatrixXd Si = llt.solve(Eigen::MatrixXd::Identity(n, n));
    const Eigen::MatrixXd A = X.transpose() * Si * X;
    const Eigen::VectorXd b_dense = A.ldlt().solve(X.transpose() * Si * y);
    const Eigen::VectorXd r = y - X * b_dense;
    const double rss = r.dot(Si * r);
    Eigen::VectorXd b;
    Eigen::MatrixXd bc;
    const double ml = minusTwoLogLikelihood(m, s, X, false, &b, &bc);
    EXPECT_NEAR(ml, static_cast<double>(n) * std::log(2 * M_PI) + logdet + rss, 1e-7 * std::abs(ml));
    const double reml = minusTwoLogLikelihood(m, s, X, true);
    EXPECT_NEAR(reml, static_cast<double>(n - 2) * std::log(2 * M_PI) + logdet + rss + std::log(A.determinant()),
                1e-7 * std::abs(reml));
    for (int j = 0; j < 2; ++j) {
      EXPECT_NEAR(b[j], b_dense[j], 1e-7 * (1 + std::abs(b_dense[j])));
      EXPECT_NEAR(bc(j, j), A.inverse()(j, j), 1e-6 * A.inverse()(j, j));
    }
  }
}

TEST(KalmanWhitener, FrozenGainOnARegularGridMatchesTheDenseFactor) {
  // A regular grid long enough for the covariance to settle and the gain to freeze, then a gap
  // (the filter thaws), then the grid again.
  const NoiseModel m = NoiseModel::white(1.0).add(NoiseTerm::gaussMarkov(1.5, 4.0));
  NoiseSeries s;
  NoiseSimulator sim(m, CounterRng(5, Stream::HeadNoise, 9));
  for (int i = 0; i < 1600; ++i) {
    if (i >= 700 && i < 740) continue;
    s.t_s.push_back(i * 0.5);
    s.y.push_back(sim.next(i * 0.5));
  }
  const Eigen::LLT<Eigen::MatrixXd> llt(denseCovariance(m, s));
  Eigen::Map<const Eigen::VectorXd> y(s.y.data(), static_cast<Eigen::Index>(s.size()));
  const Eigen::VectorXd z_dense = llt.matrixL().solve(y);
  const std::vector<double> z = whitenSeries(m, s);
  double worst = 0;
  for (std::size_t i = 0; i < s.size(); ++i) worst = std::max(worst, std::abs(z[i] - z_dense[static_cast<Eigen::Index>(i)]));
  EXPECT_LT(worst, 1e-6);
}

TEST(KalmanWhitener, ColourIsTheExactInverseOfWhiten) {
  const NoiseModel m = sumModel();
  const NoiseSeries s = gappedSeries(m, 5000, 0.5, 0.05, 21, 0.05);
  KalmanWhitener w(m), c(m);
  for (std::size_t i = 0; i < s.size(); ++i) {
    const double z = w.whiten(s.t_s[i], s.y[i]);
    ASSERT_NEAR(c.colour(s.t_s[i], z), s.y[i], 1e-9 * (1 + std::abs(s.y[i])));
  }
  EXPECT_NEAR(w.minusTwoLogLikelihood(), c.minusTwoLogLikelihood(), 1e-9 * std::abs(w.minusTwoLogLikelihood()));
}

TEST(ScoreLikelihood, GradientIsTheLikelihoodsAndTheInformationIsTheScoresCovariance) {
  // Parameters x = (log sigma_w, log sigma_gm, log tau) of white + Gauss-Markov; 200 seeded gapped,
  // jittered series of 2000 samples with a fitted mean (REML). At each series: the gradient equals the
  // central difference of minusTwoLogLikelihood (the same filters), and m2ll equals it. Over the seeds
  // at the truth: the score of -2 log L has covariance 2 I (I = its expected Hessian, the information
  // returned), and the observed (finite-difference) Hessian averages to I. With the derivatives of log F
  // left out, or the innovations' term not doubled, the covariance check fails (eigenvalues of
  // I^-1/2 C I^-1/2 / 2 outside [0.75, 1.33]; 200 draws give about +-0.2 on the worst of three).
  // Forward differences give the same gradient and information to O(h).
  const auto model = [](const Eigen::VectorXd& x) {
    return NoiseModel::white(std::exp(x[0])).add(NoiseTerm::gaussMarkov(std::exp(x[1]), std::exp(x[2])));
  };
  Eigen::VectorXd x0(3);
  x0 << std::log(1.0), std::log(1.5), std::log(40.0);
  const NoiseModel truth = model(x0);
  constexpr int kRuns = 200;
  Eigen::MatrixXd C = Eigen::MatrixXd::Zero(3, 3), Imean = Eigen::MatrixXd::Zero(3, 3), Hmean = Eigen::MatrixXd::Zero(3, 3);
  Eigen::Vector3d gmean = Eigen::Vector3d::Zero();
  for (int run = 0; run < kRuns; ++run) {
    const NoiseSeries s = gappedSeries(truth, 2000, 0.5, 0.05, static_cast<std::uint64_t>(900 + run), 0.1);
    const Eigen::MatrixXd X = Eigen::MatrixXd::Ones(static_cast<Eigen::Index>(s.size()), 1);
    const LikelihoodScore sc = scoreLikelihood(model, x0, 1e-4, s, X, true);
    const auto f = [&](const Eigen::VectorXd& x) { return minusTwoLogLikelihood(model(x), s, X, true); };
    ASSERT_NEAR(sc.m2ll, f(x0), 1e-9 * std::abs(sc.m2ll));
    for (Eigen::Index i = 0; i < 3; ++i) {
      Eigen::VectorXd a = x0, b = x0;
      a[i] += 1e-4;
      b[i] -= 1e-4;
      ASSERT_NEAR(sc.gradient[i], (f(a) - f(b)) / 2e-4, 1e-6 * (1 + std::abs(sc.gradient[i])));
    }
    if (run < 5) {  // forward differences (x and x + h e_i): the same to O(h)
      const LikelihoodScore fw = scoreLikelihood(model, x0, 1e-4, s, X, true, false);
      ASSERT_EQ(fw.m2ll, sc.m2ll);
      for (Eigen::Index i = 0; i < 3; ++i) {
        ASSERT_NEAR(fw.gradient[i], sc.gradient[i], 1e-4 * sc.information(i, i) + 1e-3);
        for (Eigen::Index j = 0; j < 3; ++j)
          ASSERT_NEAR(fw.information(i, j), sc.information(i, j), 1e-2 * std::sqrt(sc.information(i, i) * sc.information(j, j)));
      }
    }
    if (run < 40) {  // the observed Hessian by central differences (h = 1e-3), on the first 40
      const double h = 1e-3, f0 = f(x0);
      for (Eigen::Index i = 0; i < 3; ++i)
        for (Eigen::Index j = 0; j < 3; ++j) {
          Eigen::VectorXd pp = x0, pm = x0, mp = x0, mm = x0;
          pp[i] += h, pp[j] += h, pm[i] += h, pm[j] -= h, mp[i] -= h, mp[j] += h, mm[i] -= h, mm[j] -= h;
          Hmean(i, j) += (i == j ? (f(pp) - 2 * f0 + f(mm)) / (4 * h * h) : (f(pp) - f(pm) - f(mp) + f(mm)) / (4 * h * h)) / 40;
        }
    }
    gmean += sc.gradient / kRuns;
    C += sc.gradient * sc.gradient.transpose() / kRuns;
    Imean += sc.information / kRuns;
  }
  C -= gmean * gmean.transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(Imean);
  const Eigen::MatrixXd Ih = es.operatorInverseSqrt();
  const Eigen::VectorXd ev = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(Ih * C * Ih / 2).eigenvalues();
  EXPECT_GT(ev.minCoeff(), 0.75) << "score covariance / 2I eigenvalues " << ev.transpose();
  EXPECT_LT(ev.maxCoeff(), 1.33) << "score covariance / 2I eigenvalues " << ev.transpose();
  // The mean observed Hessian of 40 runs against the information (diagonal within 20 %).
  for (Eigen::Index i = 0; i < 3; ++i) EXPECT_NEAR(Hmean(i, i) / Imean(i, i), 1.0, 0.2) << i;
}

TEST(LjungBox, WhitenedColouredNoisePassesAtItsNominalRateAndUnwhitenedFails) {
  // 100 seeded series of 4000 samples at 2 Hz with 5 % gaps; Ljung-Box with 20 lags at 5 %. The
  // whitened series must be rejected at the nominal rate: at most 12 of 100 (P(Bin(100, 0.05) > 12)
  // = 0.002); the raw coloured series nearly always; whitened with a wrong (white-only) model too.
  const NoiseModel m = NoiseModel::white(1.0).add(NoiseTerm::gaussMarkov(0.6, 60.0));
  int rej_white = 0, rej_raw = 0, rej_wrong = 0;
  for (int seed = 0; seed < 100; ++seed) {
    const NoiseSeries s = gappedSeries(m, 4000, 0.5, 0.05, static_cast<std::uint64_t>(100 + seed), 0.0);
    rej_white += ljungBox(whitenSeries(m, s), 20).p_value < 0.05;
    rej_raw += ljungBox(s.y, 20).p_value < 0.05;
    rej_wrong += ljungBox(whitenSeries(NoiseModel::white(std::sqrt(m.variance())), s), 20).p_value < 0.05;
  }
  EXPECT_LE(rej_white, 12);
  EXPECT_GE(rej_raw, 95);
  EXPECT_GE(rej_wrong, 95);
}

TEST(LjungBox, MatchesTheTextbookStatistic) {
  // hand-computed for a short series: r1 = -0.5 ... computed independently below
  const std::vector<double> z = {1, -1, 1, -1, 1, -1, 1, -1};
  // mean 0, c0 = 8, c1 = -7, c2 = 6: r1 = -7/8, r2 = 6/8
  const double Q = 8 * 10 * ((49.0 / 64) / 7 + (36.0 / 64) / 6);
  const LjungBox lb = ljungBox(z, 2);
  EXPECT_NEAR(lb.Q, Q, 1e-12);
  EXPECT_NEAR(lb.p_value, std::exp(-Q / 2), 1e-12);  // chi-square with 2 degrees of freedom
}

TEST(VarianceComponents, OneGroupIsTheUnbiasedResidualVarianceAndTwoGroupsSeparate) {
  // y = a + b x + e, group 1 with sigma 2, group 2 with sigma 0.5, both weighted 1 at the start.
  CounterRng rng(42, Stream::HeadNoise, 0);
  const int n1 = 4000, n2 = 3000;
  std::vector<double> f1(1, 1.0), f2(1, 1.0);
  Eigen::Vector2d x_hat;
  VarianceComponents vc;
  for (int it = 0; it < 30; ++it) {
    Eigen::Matrix2d N1 = Eigen::Matrix2d::Zero(), N2 = Eigen::Matrix2d::Zero();
    Eigen::Vector2d b1 = Eigen::Vector2d::Zero(), b2 = Eigen::Vector2d::Zero();
    auto row = [&](int i, double& y, Eigen::Vector2d& a, double& sig) {
      const double xx = (i % 100) / 10.0;
      a << 1, xx;
      sig = i < n1 ? 2.0 : 0.5;
      y = 3 - 0.5 * xx + sig * rng.normal(static_cast<std::uint64_t>(i));
    };
    for (int i = 0; i < n1 + n2; ++i) {
      double y, sig;
      Eigen::Vector2d a;
      row(i, y, a, sig);
      const double w = 1.0 / (i < n1 ? f1[0] : f2[0]);
      (i < n1 ? N1 : N2) += w * a * a.transpose();
      (i < n1 ? b1 : b2) += w * a * y;
    }
    x_hat = (N1 + N2).ldlt().solve(b1 + b2);
    double s1 = 0, s2 = 0;
    for (int i = 0; i < n1 + n2; ++i) {
      double y, sig;
      Eigen::Vector2d a;
      row(i, y, a, sig);
      const double e = y - a.dot(x_hat);
      (i < n1 ? s1 : s2) += e * e / (i < n1 ? f1[0] : f2[0]);
    }
    vc = estimateVarianceComponents({{"g1", N1, s1, n1}, {"g2", N2, s2, n2}});
    ASSERT_TRUE(vc.ok) << vc.message;
    f1[0] *= vc.factor[0];
    f2[0] *= vc.factor[1];
    if (std::abs(vc.factor[0] - 1) < 1e-10 && std::abs(vc.factor[1] - 1) < 1e-10) break;
  }
  // the variance estimates of n samples scatter by sqrt(2 / n): within 4 of those
  EXPECT_NEAR(f1[0] / 4.0, 1.0, 4 * std::sqrt(2.0 / n1));
  EXPECT_NEAR(f2[0] / 0.25, 1.0, 4 * std::sqrt(2.0 / n2));
  EXPECT_NEAR(vc.redundancy[0] + vc.redundancy[1], n1 + n2 - 2, 1e-6);
  // one group: the factor is ssr / (n - p)
  Eigen::Matrix2d N = Eigen::Matrix2d::Identity() * 10;
  const VarianceComponents one = estimateVarianceComponents({{"all", N, 35.0, 37}});
  EXPECT_NEAR(one.factor[0], 35.0 / 35.0, 1e-12);
  // A direction no group determines (a parameter without any information, and a combination of two):
  // it takes no redundancy, the others count as before.
  Eigen::Matrix3d N3 = Eigen::Matrix3d::Zero();
  N3.topLeftCorner<2, 2>() << 4, 4, 4, 4;  // only p1 + p2 is determined; p3 not at all
  const VarianceComponents rd = estimateVarianceComponents({{"g", N3, 18.0, 10}});
  ASSERT_TRUE(rd.ok) << rd.message;
  EXPECT_NEAR(rd.redundancy[0], 9.0, 1e-9);
  EXPECT_NEAR(rd.factor[0], 2.0, 1e-9);
  EXPECT_FALSE(estimateVarianceComponents({{"g", Eigen::Matrix3d::Zero(), 1.0, 10}}).ok);
}

TEST(BandedWhitener, WhitensAMovingAverageToUnitVarianceIndependentSamples) {
  // x_k = e_k + 0.6 e_{k-1}: correlation 0.6 / 1.36 at lag 1, 0 beyond; on a grid with gaps.
  const double r1 = 0.6 / 1.36;
  CounterRng rng(9, Stream::HeadNoise, 2);
  std::vector<std::int64_t> t;
  std::vector<double> x;
  double prev = rng.normal(0);
  for (int k = 1; k < 60000; ++k) {
    const double e = rng.normal(static_cast<std::uint64_t>(k));
    const double v = (e + 0.6 * prev) / std::sqrt(1.36);
    prev = e;
    if (k % 97 < 5) continue;  // gaps
    t.push_back(static_cast<std::int64_t>(k) * 1000000);
    x.push_back(v);
  }
  const BandedWhitener w(t, 1.0, {1.0, r1});
  const std::vector<double> z = w.whiten(x);
  double s2 = 0;
  for (double v : z) s2 += v * v;
  EXPECT_NEAR(s2 / static_cast<double>(z.size()), 1.0, 5 * std::sqrt(2.0 / static_cast<double>(z.size())));
  EXPECT_GT(ljungBox(z, 10).p_value, 0.001);
  EXPECT_LT(ljungBox(x, 10).p_value, 1e-6);
}

TEST(BandedWhitener, EqualsTheDenseCholeskyFactorWithGaps) {
  // epochs on a 10 s grid with two missing (lags 2 and 3 appear at index distance 1)
  std::vector<std::int64_t> t;
  for (int k = 0; k < 40; ++k)
    if (k != 7 && k != 20 && k != 21) t.push_back(k * 10 * 1000000LL);
  const std::vector<double> rho{1.0, 0.3992, 0.0582, 0.0045};
  const BandedWhitener L(t, 10.0, rho);
  const int n = static_cast<int>(t.size()), K = 3;
  Eigen::MatrixXd C = Eigen::MatrixXd::Zero(n, n);
  for (int a = 0; a < n; ++a)
    for (int b = 0; b < n; ++b) {
      const auto lag = static_cast<std::size_t>(std::llabs(t[static_cast<std::size_t>(a)] - t[static_cast<std::size_t>(b)]) / (10 * 1000000LL));
      C(a, b) = lag < rho.size() ? rho[lag] : 0.0;
    }
  const Eigen::MatrixXd Ld = C.llt().matrixL();
  double worst = 0;
  for (int k = 0; k < n; ++k)
    for (int m = std::max(0, k - K); m <= k; ++m)
      worst = std::max(worst, std::abs(L.factor(static_cast<std::size_t>(k), static_cast<std::size_t>(m)) - Ld(k, m)));
  EXPECT_LT(worst, 1e-12);
  // and nothing outside the band: the dense factor is banded too
  for (int k = 0; k < n; ++k)
    for (int m = 0; m < k - K; ++m) EXPECT_LT(std::abs(Ld(k, m)), 1e-12);
}
