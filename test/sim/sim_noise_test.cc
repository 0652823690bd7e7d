// Output noise statistics match the configuration: standard deviation and a flat (white) spectrum
// for the heads and the accelerometer, and the Gauss-Markov low-frequency accelerometer noise.
// Monte Carlo: every statistic pools several seeds (the number is stated in each test).
#include "sim_test_util.h"

#include <complex>

namespace boresight {
namespace {

using simtest::gracefo;
using simtest::run;

sim::Scenario noExclusion() {
  auto sc = gracefo();
  for (auto& h : sc.heads) {
    h.sun_exclusion_rad = 0;
    h.moon_exclusion_rad = 0;
    h.earth_exclusion_rad = -60 * kRadPerDeg;
  }
  return sc;
}

/// Power in `bands` equal frequency bands (0..Nyquist) of a real series (plain DFT, mean removed).
std::vector<double> bandPowers(const std::vector<double>& x, int bands) {
  const std::size_t n = x.size();
  double mean = 0;
  for (double v : x) mean += v;
  mean /= static_cast<double>(n);
  std::vector<double> p(static_cast<std::size_t>(bands), 0.0);
  const std::size_t kmax = n / 2;
  for (std::size_t k = 1; k < kmax; ++k) {
    std::complex<double> acc = 0;
    const double w = -2 * kPi * static_cast<double>(k) / static_cast<double>(n);
    std::complex<double> rot(std::cos(w), std::sin(w)), ph = 1;
    for (std::size_t i = 0; i < n; ++i) {
      acc += (x[i] - mean) * ph;
      ph *= rot;
      if ((i & 255) == 255) ph /= std::abs(ph);
    }
    p[std::min(static_cast<std::size_t>(bands) - 1, k * static_cast<std::size_t>(bands) / kmax)] += std::norm(acc);
  }
  return p;
}

TEST(SimNoise, HeadNoiseStdAndWhitenessMatchTheConfigurationPerAxis) {
  // 4 Monte Carlo runs x 1800 s x 2 Hz = 14400 samples per head and axis: the relative standard error
  // of a standard deviation is 1/sqrt(2N) = 0.6 %; tolerance 3 %.
  auto sc = noExclusion();
  sc.heads[1].sigma_cross_rad = 3 * kRadPerArcsec;
  sc.heads[1].sigma_roll_rad = 30 * kRadPerArcsec;
  const int runs = 4;
  std::vector<Vec3> sum2(3, Vec3::Zero());
  std::vector<std::size_t> n(3, 0);
  std::vector<double> band(4, 0.0);
  for (int r = 0; r < runs; ++r) {
    auto res = run(sc, 100 + static_cast<std::uint64_t>(r), 1800);
    for (int id = 1; id <= 3; ++id) {
      const auto h = res->cap.head(id);
      std::vector<double> about;
      for (const auto& s : h) {
        const Vec3 e = simtest::rotBetween(s.q_I_Si_expected, s.q_I_Si);
        sum2[static_cast<std::size_t>(id - 1)] += e.cwiseProduct(e);
        about.push_back(e.z());
      }
      n[static_cast<std::size_t>(id - 1)] += h.size();
      if (id == 2) {
        ASSERT_EQ(h.size(), 3600u);
        const auto p = bandPowers(about, 4);
        for (int b = 0; b < 4; ++b) band[static_cast<std::size_t>(b)] += p[static_cast<std::size_t>(b)];
      }
    }
  }
  for (int id = 1; id <= 3; ++id) {
    const auto i = static_cast<std::size_t>(id - 1);
    const Vec3 sd = (sum2[i] / static_cast<double>(n[i])).cwiseSqrt() * kArcsecPerRad;
    const double c = sc.heads[i].sigma_cross_rad * kArcsecPerRad, a = sc.heads[i].sigma_roll_rad * kArcsecPerRad;
    std::printf("head %d noise [arcsec]: x %.3f y %.3f about %.3f (configured %.1f / %.1f, N=%zu)\n", id, sd.x(), sd.y(),
                sd.z(), c, a, n[i]);
    EXPECT_NEAR(sd.x(), c, 0.03 * c);
    EXPECT_NEAR(sd.y(), c, 0.03 * c);
    EXPECT_NEAR(sd.z(), a, 0.03 * a);
  }
  // White: the four quarter-bands of the spectrum hold equal power (each band: ~1800 periodogram
  // bins pooled, relative error ~2.4 %); tolerance 12 %.
  const double mean = (band[0] + band[1] + band[2] + band[3]) / 4;
  for (int b = 0; b < 4; ++b) {
    std::printf("head 2 about-boresight noise, band %d power / mean = %.3f\n", b, band[static_cast<std::size_t>(b)] / mean);
    EXPECT_NEAR(band[static_cast<std::size_t>(b)] / mean, 1.0, 0.12);
  }
}

TEST(SimNoise, AccelerometerWhiteNoiseStdAndSpectrum) {
  // 3 Monte Carlo runs x 600 s x 10 Hz = 18000 samples per axis: std error 0.5 %, tolerance 3 %.
  auto sc = noExclusion();
  sc.acc.lowfreq_rad_s2.setZero();
  const int runs = 3;
  Vec3 sum2 = Vec3::Zero();
  std::size_t n = 0;
  std::vector<double> band(4, 0.0);
  for (int r = 0; r < runs; ++r) {
    auto res = run(sc, 200 + static_cast<std::uint64_t>(r), 600);
    std::vector<double> x;
    for (const auto& a : res->cap.acc) {
      const Vec3 e = a.ang_A - res->sim.accel().predict(a.a_B_true);
      sum2 += e.cwiseProduct(e);
      x.push_back(e.x());
      ++n;
    }
    const auto p = bandPowers(x, 4);
    for (int b = 0; b < 4; ++b) band[static_cast<std::size_t>(b)] += p[static_cast<std::size_t>(b)];
  }
  const Vec3 sd = (sum2 / static_cast<double>(n)).cwiseSqrt();
  std::printf("accelerometer white noise [rad/s^2]: %.4g %.4g %.4g (configured %.4g %.4g %.4g, N=%zu)\n", sd.x(), sd.y(),
              sd.z(), sc.acc.white_rad_s2.x(), sc.acc.white_rad_s2.y(), sc.acc.white_rad_s2.z(), n);
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(sd[k], sc.acc.white_rad_s2[k], 0.03 * sc.acc.white_rad_s2[k]);
  const double mean = (band[0] + band[1] + band[2] + band[3]) / 4;
  for (int b = 0; b < 4; ++b) EXPECT_NEAR(band[static_cast<std::size_t>(b)] / mean, 1.0, 0.12) << "band " << b;
}

TEST(SimNoise, AccelerometerLowFrequencyNoiseIsGaussMarkov) {
  // White noise off; Gauss-Markov sigma 2e-8 rad/s^2, tau 20 s. 4 Monte Carlo runs x 4000 s (200 tau):
  // the std estimate has about 400 independent pieces (5 % error), tolerance 12 %; the autocorrelation
  // at lag tau must be exp(-1) = 0.37 +- 0.08.
  auto sc = noExclusion();
  sc.acc.white_rad_s2.setZero();
  sc.acc.lowfreq_rad_s2 = Vec3(2e-8, 2e-8, 2e-8);
  sc.acc.lowfreq_tau_s = 20;
  double s2 = 0, c_tau = 0;
  std::size_t n = 0, m = 0;
  for (int r = 0; r < 4; ++r) {
    auto res = run(sc, 300 + static_cast<std::uint64_t>(r), 4000);
    std::vector<double> x;
    for (const auto& a : res->cap.acc) x.push_back((a.ang_A - res->sim.accel().predict(a.a_B_true)).y());
    for (double v : x) s2 += v * v;
    n += x.size();
    for (std::size_t i = 0; i + 200 < x.size(); ++i) c_tau += x[i] * x[i + 200];
    m += x.size() - 200;
  }
  const double sd = std::sqrt(s2 / static_cast<double>(n));
  const double rho = (c_tau / static_cast<double>(m)) / (s2 / static_cast<double>(n));
  std::printf("low-frequency noise: std %.4g (configured 2e-8), autocorrelation at tau %.3f (expected 0.368)\n", sd, rho);
  EXPECT_NEAR(sd, 2e-8, 0.12 * 2e-8);
  EXPECT_NEAR(rho, std::exp(-1.0), 0.08);
}

TEST(SimNoise, AngularAccelerationsAreInTheGraceFoRange) {
  // Thruster pulses and torquers give angular accelerations of about 1e-6 .. 1e-4 rad/s^2.
  const auto sc = gracefo();
  auto res = run(sc, 7, 6000);
  const auto& st = res->sim.stats();
  double rms = 0;
  for (const auto& a : res->cap.acc) rms += a.a_B_true.squaredNorm();
  rms = std::sqrt(rms / static_cast<double>(res->cap.acc.size()));
  std::printf("6000 s: %llu thruster pulses, max |alpha| %.3g rad/s^2, rms |alpha| %.3g rad/s^2\n",
              static_cast<unsigned long long>(st.thruster_pulses), st.max_abs_alpha, rms);
  EXPECT_GT(st.thruster_pulses, 10u);
  EXPECT_GT(st.max_abs_alpha, 1e-6);
  EXPECT_LT(st.max_abs_alpha, 3e-4);
  EXPECT_GT(rms, 1e-8);
}

}  // namespace
}  // namespace boresight
