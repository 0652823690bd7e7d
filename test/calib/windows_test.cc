// Method A over many windows (calib/windows.h): the windows' combination against closed forms, the
// spread between windows against simulated windows with a known spread, the windows' calendar, and
// two windows estimated at once against one at a time. (The windows' estimates against the truth,
// and their memory, are tested end to end in test/tools/calibrate_test.cc, `ctest -R Window`.)
#include "synthetic.h"

#include <boresight/calib/windows.h>
#include <boresight/model/overlay.h>

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <cmath>
#include <cstdio>
#include <random>

namespace boresight::calib {
namespace {

/// A window with one head: error angles r, covariance C (rad), every axis determined unless its sigma
/// is set NaN by `undetermined`.
WindowSolution window1(const Vec3& r, const Mat3& C, int undetermined = -1) {
  WindowSolution w;
  w.estimated = true;
  w.mountings.r_Si = {r};
  w.mountings.covariance_Si = C;
  Vec3 s = C.diagonal().cwiseSqrt();
  if (undetermined >= 0) s(undetermined) = std::nan("");
  w.mountings.sigma_Si = {s};
  return w;
}

TEST(CombineWindows, TheInformationWeightedMeanOfCorrelatedWindows) {
  // Two windows with full covariances: r = (I1 + I2)^-1 (I1 r1 + I2 r2), C = (I1 + I2)^-1, and the
  // scatter chi2 = sum (r_w - r)^T I_w (r_w - r) on 3 + 3 - 3 = 3 degrees of freedom.
  Mat3 A;
  A << 4, 1, 0.5, 1, 9, -2, 0.5, -2, 16;
  Mat3 B;
  B << 25, -3, 1, -3, 4, 0.5, 1, 0.5, 9;
  const Vec3 r1(1, -2, 3), r2(4, 0, -1);
  const JointMountings j = combineWindows({window1(r1, A), window1(r2, B)}, 1, 1e9);
  const Mat3 I1 = A.inverse(), I2 = B.inverse();
  const Mat3 C = (I1 + I2).inverse();
  const Vec3 r = C * (I1 * r1 + I2 * r2);
  EXPECT_EQ(j.windows, 2u);
  EXPECT_LT((j.r_Si[0] - r).norm(), 1e-12);
  EXPECT_LT((j.covariance_Si - C).norm(), 1e-12);
  for (int a = 0; a < 3; ++a) EXPECT_NEAR(j.sigma_Si[0](a), std::sqrt(C(a, a)), 1e-12);
  EXPECT_NEAR(j.chi2, (r1 - r).dot(I1 * (r1 - r)) + (r2 - r).dot(I2 * (r2 - r)), 1e-10);
  EXPECT_NEAR(j.dof, 3.0, 1e-12);
  // Per axis, Cochran's Q: each window about the axis's own weighted mean over its variance; two
  // windows, one degree of freedom: (r1 - r2)^2 / (s1^2 + s2^2).
  for (int a = 0; a < 3; ++a) {
    EXPECT_NEAR(j.axis_chi2_per_dof[0](a), std::pow(r1(a) - r2(a), 2) / (A(a, a) + B(a, a)), 1e-10) << a;
    EXPECT_EQ(j.axis_windows[0](a), 2.0);
  }
}

TEST(CombineWindows, AnAxisAWindowDoesNotDetermineTakesNothingFromIt) {
  // Window 1 does not determine z (sigma NaN): the joint z is window 2's, with window 2's sigma; x and y
  // are the weighted means; a window that was not estimated is skipped.
  const Mat3 A = Vec3(1, 4, 9).asDiagonal();
  const Mat3 B = Vec3(4, 4, 16).asDiagonal();
  WindowSolution refused;
  refused.note = "no body direction";
  const JointMountings j = combineWindows({window1(Vec3(1, 1, 100), A, 2), refused, window1(Vec3(3, 5, 7), B)}, 1, 1e9);
  EXPECT_EQ(j.windows, 2u);
  EXPECT_NEAR(j.r_Si[0](0), (1.0 / 1 + 3.0 / 4) / (1.0 / 1 + 1.0 / 4), 1e-12);
  EXPECT_NEAR(j.r_Si[0](1), 3.0, 1e-12);
  EXPECT_NEAR(j.r_Si[0](2), 7.0, 1e-12);
  EXPECT_NEAR(j.sigma_Si[0](2), 4.0, 1e-12);
  EXPECT_EQ(j.axis_windows[0](2), 1.0);
  EXPECT_TRUE(std::isnan(j.tau[0](2)));  // one window: no spread to measure
  // Nothing determines an axis: not determined in the joint either.
  const JointMountings k = combineWindows({window1(Vec3(1, 1, 1), A, 2), window1(Vec3(1, 1, 1), B, 2)}, 1, 1e9);
  EXPECT_TRUE(std::isnan(k.sigma_Si[0](2)));
  EXPECT_TRUE(std::isfinite(k.sigma_Si[0](0)));
  // A sigma above the threshold is not determined.
  const JointMountings t = combineWindows({window1(Vec3(1, 1, 1), A)}, 1, 2.5);
  EXPECT_TRUE(std::isfinite(t.sigma_Si[0](1)));  // 2 < 2.5
  EXPECT_TRUE(std::isnan(t.sigma_Si[0](2)));     // 3 > 2.5
}

TEST(CombineWindows, AHeldCommonDirectionCarriesNoInformation) {
  // Two heads whose window covariance is singular along a common rotation (both heads' x together, as a
  // held body direction leaves it): that direction comes from the other window alone.
  Eigen::MatrixXd C1 = Eigen::MatrixXd::Identity(6, 6);
  Eigen::VectorXd u = Eigen::VectorXd::Zero(6);
  u(0) = u(3) = std::sqrt(0.5);
  C1 -= u * u.transpose();  // no variance along u: the pseudo-inverse gives no information there
  WindowSolution w1, w2;
  w1.estimated = w2.estimated = true;
  w1.mountings.covariance_Si = C1;
  w2.mountings.covariance_Si = 4.0 * Eigen::MatrixXd::Identity(6, 6);
  w1.mountings.r_Si = {Vec3(10, 0, 0), Vec3(10, 0, 0)};  // 10 along u (held: any value)
  w2.mountings.r_Si = {Vec3(2, 0, 0), Vec3(2, 0, 0)};
  for (auto* w : {&w1, &w2}) w->mountings.sigma_Si = {w->mountings.covariance_Si.diagonal().head<3>().cwiseSqrt(),
                                                       w->mountings.covariance_Si.diagonal().tail<3>().cwiseSqrt()};
  const JointMountings j = combineWindows({w1, w2}, 2, 1e9);
  EXPECT_NEAR(j.r_Si[0](0), 2.0, 1e-9);
  EXPECT_NEAR(j.r_Si[1](0), 2.0, 1e-9);
  EXPECT_NEAR(j.dof, 5.0 + 6.0 - 6.0, 1e-12);
}

TEST(CombineWindows, TheMountingsInformationHasTheOtherParametersMarginalisedOut) {
  // One head whose head axes are turned against Si, and one other parameter correlated with the angles:
  // the information about the angles is the Schur complement, in Si.
  RawEstimate est;
  Eigen::MatrixXd I(4, 4);
  I << 10, 1, 0, 2,  //
      1, 20, 0, 3,   //
      0, 0, 30, 0,   //
      2, 3, 0, 5;
  est.bound.information = I;
  RawBoundConfig cfg;
  cfg.heads.resize(1);
  cfg.heads[0].axes_Si = Eigen::AngleAxisd(0.7, Vec3(1, 2, 3).normalized()).toRotationMatrix();  // rows: the head axes in Si
  const Eigen::MatrixXd M = I.topLeftCorner(3, 3) - I.topRightCorner(3, 1) * (1.0 / 5.0) * I.bottomLeftCorner(1, 3);
  // Angles: head axes = axes_Si Si, so the information in Si is axes_Si^T M axes_Si.
  const Eigen::MatrixXd want = cfg.heads[0].axes_Si.transpose() * M * cfg.heads[0].axes_Si;
  EXPECT_LT((mountingInformation(est, cfg) - want).norm(), 1e-12);
  // The marginal information's inverse is the covariance's block, as it must be.
  const Eigen::MatrixXd C = I.inverse();
  EXPECT_LT((M.inverse() - C.topLeftCorner(3, 3)).norm(), 1e-12);
}

TEST(RandomEffects, TauInClosedFormAndZeroWhenTheSigmasExplainTheScatter) {
  // Two values 0 and d with equal sigma s: the scatter about the mean is d^2 / (2 (s^2 + tau^2)), so
  // tau^2 = d^2 / (2 q) - s^2 for the target q.
  const double d = 10, s = 2;
  for (double q : {1.0, 0.2, 3.0}) {
    const double want = d * d / (2 * q) - s * s;
    EXPECT_NEAR(randomEffectsTau({0, d}, {s, s}, q), want > 0 ? std::sqrt(want) : 0.0, 1e-9) << q;
  }
  EXPECT_EQ(randomEffectsTau({0, 1}, {2, 2}, 1.0), 0.0);  // 1/8 below 1
  EXPECT_TRUE(std::isnan(randomEffectsTau({1}, {1}, 1.0)));
}

TEST(RandomEffects, TheSpreadBetweenWindowsIsFoundAndItsIntervalCoversIt) {
  // 400 records of 10 windows each, the windows' sigmas from 1 to 3, the mounting moving between windows
  // by tau (normal, independent): the 95 % interval covers the true tau in 95 % of the records (within the
  // binomial spread of 400: 90-99 %), the random-effects sigma is the honest one for the joint (its
  // normalised error is Student-t with 9 degrees of freedom, RMS sqrt(9 / 7) = 1.13, where tau is
  // estimated; 1 where it is 0) and the windows-independent sigma is not (too small by far at tau = 2).
  // Without a spread, the scatter's chi-square per degree of freedom averages 1 and the two agree.
  std::mt19937_64 rng(42);
  std::normal_distribution<double> N(0, 1);
  std::uniform_real_distribution<double> U(1, 3);
  for (const double tau : {0.0, 2.0}) {
    int covered = 0;
    double z2_re = 0, z2_ind = 0, z2_written = 0, chi2 = 0, tau_sum = 0;
    const int records = 400, windows = 10;
    for (int k = 0; k < records; ++k) {
      std::vector<WindowSolution> ws;
      for (int w = 0; w < windows; ++w) {
        const double s = U(rng);
        const Vec3 r(tau * N(rng) + s * N(rng), s * N(rng), s * N(rng));  // x moves, y and z do not
        ws.push_back(window1(r, Mat3(Vec3(s * s, s * s, s * s).asDiagonal())));
      }
      const JointMountings j = combineWindows(ws, 1, 1e9);
      if (j.tau_lo[0](0) <= tau && tau <= j.tau_hi[0](0)) ++covered;
      EXPECT_LE(j.tau_lo[0](0), j.tau[0](0));
      EXPECT_LE(j.tau[0](0), j.tau_hi[0](0));
      tau_sum += j.tau[0](0);
      z2_re += std::pow(j.r_with_tau[0](0) / j.sigma_with_tau[0](0), 2);
      z2_ind += std::pow(j.r_Si[0](0) / j.sigma_Si[0](0), 2);
      z2_written += std::pow(j.r_Si[0](0) / j.sigma_written[0](0), 2);  // what calibrate writes
      EXPECT_GE(j.sigma_written[0](0), j.sigma_Si[0](0));
      chi2 += j.axis_chi2_per_dof[0](0);
    }
    const double rate = static_cast<double>(covered) / records;
    EXPECT_GE(rate, 0.90) << "tau " << tau;
    EXPECT_LE(rate, 0.995) << "tau " << tau;
    const double rms_re = std::sqrt(z2_re / records), rms_ind = std::sqrt(z2_ind / records),
                 rms_written = std::sqrt(z2_written / records);
    std::printf("tau %.1f: interval covers %.1f %%, mean tau %.2f, joint error RMS over the random-effects sigma %.3f, over the "
                "windows-independent sigma %.3f, the written value over the written sigma %.3f, mean chi2/dof %.3f (%d records of "
                "%d windows)\n",
                tau, 100 * rate, tau_sum / records, rms_re, rms_ind, rms_written, chi2 / records, records, windows);
    // What calibrate writes (the information-weighted value with the larger sigma): never optimistic
    // beyond Student-t's spread, and about as honest as the random-effects pair.
    EXPECT_LT(rms_written, std::sqrt(9.0 / 7.0) + 0.12) << "tau " << tau;
    EXPECT_GT(rms_written, 0.8) << "tau " << tau;
    if (tau == 0.0) {
      EXPECT_NEAR(rms_re, 1.0, 0.12);
      EXPECT_NEAR(chi2 / records, 1.0, 0.08);
      EXPECT_NEAR(rms_ind, 1.0, 0.12);
    } else {
      EXPECT_NEAR(rms_re, std::sqrt(9.0 / 7.0), 0.12);
      EXPECT_GT(rms_ind, 1.3);
      EXPECT_NEAR(tau_sum / records, tau, 0.3);
    }
  }
}

/// A window with one orbit-harmonic term (head 1, 1/rev) of value cos_Si, sigma s per axis, at beta.
WindowSolution harmonicWindow(double beta_deg, const Vec3& cos_Si, double s) {
  WindowSolution w = window1(Vec3::Zero(), Mat3::Identity());
  OrbitHarmonicTerm t;
  t.head = 1;
  t.harmonic = 1;
  t.cos_Si = cos_Si;
  t.cov_cos_Si = t.cov_sin_Si = Mat3(Vec3::Constant(s * s).asDiagonal());
  w.harmonics = {t};
  w.beta_rad = beta_deg * kRadPerDeg;
  return w;
}

TEST(BetaModulation, TheLineThroughTheWindowsHarmonicsAgainstCosBeta) {
  // 30 windows, beta from 46 to 16 deg, a term (4, -3, 10) x (1 + 0.3 (cos beta - 1)) with noise of
  // 0.3 per axis: a at the mean cos beta and b = 0.3 x (4, -3, 10) within 3 sigma, the sin term (zero)
  // with b within 3 sigma of 0; the same windows over 5 deg of beta: not determined, and said why.
  std::mt19937_64 rng(7);
  std::normal_distribution<double> N(0, 1);
  const Vec3 amp(4, -3, 10);
  std::vector<WindowSolution> ws, narrow;
  double cos_mean = 0;
  for (int d = 0; d < 30; ++d) {
    const double beta = 46.0 - d * 1.0, cb = std::cos(beta * kRadPerDeg);
    cos_mean += cb / 30;
    ws.push_back(harmonicWindow(beta, amp * (1 + 0.3 * (cb - 1)) + 0.3 * Vec3(N(rng), N(rng), N(rng)), 0.3));
    ws.back().from = ws.back().to = d * 86400 * kUsPerSecond;
    narrow.push_back(harmonicWindow(46.0 - d * 5.0 / 30, amp, 0.3));
  }
  const BetaModulation m = fitBetaModulation(ws);
  ASSERT_TRUE(m.determined) << m.note;
  EXPECT_NEAR(m.cos_ref, cos_mean, 1e-12);
  EXPECT_EQ(m.windows, 30u);
  ASSERT_EQ(m.terms.size(), 2u);  // cos and sin
  const auto& c = m.terms[0];
  EXPECT_FALSE(c.sine);
  for (int a = 0; a < 3; ++a) {
    EXPECT_NEAR(c.a(a), amp(a) * (1 + 0.3 * (cos_mean - 1)), 3 * c.sigma_a(a)) << a;
    EXPECT_NEAR(c.b(a), 0.3 * amp(a), 3 * c.sigma_b(a)) << a;
    EXPECT_LT(c.sigma_b(a), 1.0);
    EXPECT_NEAR(m.terms[1].b(a), 0.0, 3 * m.terms[1].sigma_b(a));
  }
  // Beta moving one way over the record: the fit says a drift would look the same. Beta going down and
  // back up (its cos not following time): no caution.
  EXPECT_GT(m.time_correlation, 0.9);  // beta falls, its cosine rises
  EXPECT_NE(m.caution.find("drift"), std::string::npos) << m.caution;
  std::vector<WindowSolution> vee;
  for (int d = 0; d < 30; ++d) {
    WindowSolution w = harmonicWindow(16.0 + std::abs(d - 15) * 2.0, amp, 0.3);
    w.from = w.to = d * 86400 * kUsPerSecond;
    vee.push_back(w);
  }
  const BetaModulation v = fitBetaModulation(vee);
  ASSERT_TRUE(v.determined) << v.note;
  EXPECT_LT(std::abs(v.time_correlation), 0.5);
  EXPECT_TRUE(v.caution.empty()) << v.caution;
  const BetaModulation n = fitBetaModulation(narrow);
  EXPECT_FALSE(n.determined);
  EXPECT_NE(n.note.find("beta moved 4.8"), std::string::npos) << n.note;
}

TEST(WindowedCalibration, ASampleOlderThanTheOpenWindowIsCountedNotTaken) {
  // Heads in one window, then a sample of the next (the first window is closed and estimated - refused
  // here: one head epoch, no accelerometer - and said), then a sample older than the open window's
  // start: not taken into the closed window or the open one, counted.
  const synth::Config c = synth::manoeuvreCase(1);
  SpanOptions so;
  so.decimation_s = c.decimation_s;
  RunOptions ro;
  ro.raw = RawBoundConfig{};
  WindowedCalibration w;
  std::string err;
  ASSERT_TRUE(w.configure(synth::pipelineConfig(c), so, 3600, ro, 1.0, &err)) << err;
  const TimeUs june = 738849600LL * kUsPerSecond;
  core::HeadEpoch e;
  e.t = june + 10 * kUsPerSecond;
  w.pushHeads(e);
  w.pushAcc(june + 3600 * kUsPerSecond + 5, Vec3::Zero());  // the next window: the first is closed
  ASSERT_EQ(w.windows().size(), 1u);
  EXPECT_FALSE(w.windows()[0].estimated);
  EXPECT_FALSE(w.windows()[0].note.empty());
  w.pushAcc(june + 20 * kUsPerSecond, Vec3::Zero());  // older than the open window
  e.t = june + 30 * kUsPerSecond;
  w.pushHeads(e);
  EXPECT_EQ(w.lateSamples(), 2u);
  w.finish();
  ASSERT_EQ(w.windows().size(), 2u);
  EXPECT_EQ(w.windows()[1].acc_samples, 1u);
  EXPECT_EQ(w.windows()[1].head_epochs, 0u);
}

// Two windows in estimation at once (calibrate's default on two cores) against one at a time: the same
// windows in the same order with the same numbers, bit for bit (each window's estimate depends on its
// own data alone, and the feed handed to a thread holds exactly what the sequential feed held).
TEST(WindowedCalibration, WindowsEstimatedTwoAtATimeAreTheSequentialWindowsExactly) {
  // The calibration span (three one-axis manoeuvres, 3900 s) in 1200 s windows: one manoeuvre in each of
  // the first three, none in the last 300 s.
  const synth::Config c = synth::manoeuvreCase(3);
  SpanOptions so;
  so.decimation_s = c.decimation_s;
  model::NoiseInUse noise;
  for (std::size_t s = 0; s < static_cast<std::size_t>(c.n_heads); ++s) {
    noise.head[s][0].noise.model = noise.head[s][1].noise.model = model::NoiseModel::white(c.sigma_cross_arcsec * kRadPerArcsec);
    noise.head[s][2].noise.model = model::NoiseModel::white(c.sigma_roll_arcsec * kRadPerArcsec);
  }
  for (std::size_t a = 0; a < 3; ++a) noise.acc[a].noise.model = model::NoiseModel::white(c.acc_white[static_cast<Eigen::Index>(a)]);
  RunOptions ro;
  ro.raw = rawBoundConfig(synth::pipelineConfig(c), noise, RawBoundOptions{});
  std::vector<std::vector<TimeUs>> reported(2);
  std::vector<std::vector<WindowSolution>> got(2);
  for (unsigned k = 0; k < 2; ++k) {
    WindowedCalibration w;
    std::string err;
    ASSERT_TRUE(w.configure(synth::pipelineConfig(c), so, 1200, ro, 1.0, &err, k + 1)) << err;
    w.onWindow([&, k](const WindowSolution& x) { reported[k].push_back(x.from); });
    synth::stream(c, w);
    w.finish();
    got[k] = w.windows();
    EXPECT_EQ(w.peakRawSamples(), 1200u * 16u);  // 2 Hz x 3 heads and 10 Hz, 1200 s
  }
  ASSERT_EQ(got[0].size(), 4u);
  ASSERT_EQ(got[1].size(), got[0].size());
  EXPECT_EQ(reported[0], reported[1]);
  for (std::size_t i = 0; i < got[0].size(); ++i) {
    const WindowSolution& a = got[0][i];
    const WindowSolution& b = got[1][i];
    SCOPED_TRACE("window " + std::to_string(i));
    EXPECT_EQ(reported[1][i], b.from);  // reported in time order
    EXPECT_EQ(a.from, b.from);
    EXPECT_EQ(a.head_epochs, b.head_epochs);
    EXPECT_EQ(a.acc_samples, b.acc_samples);
    EXPECT_EQ(a.note, b.note);
    ASSERT_EQ(a.estimated, b.estimated);
    if (i < 3) {
      ASSERT_TRUE(a.estimated) << a.note;
    }
    if (!a.estimated) continue;
    EXPECT_EQ(a.chi2_per_obs, b.chi2_per_obs);
    EXPECT_EQ(a.bias_rad_s2, b.bias_rad_s2);
    ASSERT_EQ(a.mountings.r_Si.size(), 3u);
    for (std::size_t h = 0; h < 3; ++h) {
      EXPECT_EQ(a.mountings.r_Si[h], b.mountings.r_Si[h]);
      for (int j = 0; j < 3; ++j)  // NaN where not determined: the same axes
        EXPECT_TRUE(a.mountings.sigma_Si[h](j) == b.mountings.sigma_Si[h](j) ||
                    (std::isnan(a.mountings.sigma_Si[h](j)) && std::isnan(b.mountings.sigma_Si[h](j))));
    }
    EXPECT_EQ(a.information_Si, b.information_Si);
  }
}

TEST(WindowedCalibration, WindowsAreWholeMultiplesAfterGpsMidnight) {
  // The GRACE epoch is noon: a day's window starts at 00:00 GPS, -43200 s on the axis.
  const TimeUs day = 86400 * kUsPerSecond, h = 3600 * kUsPerSecond;
  const TimeUs midnight = -12 * h;
  EXPECT_EQ(WindowedCalibration::windowOf(0, 86400), std::make_pair(midnight, midnight + day));
  EXPECT_EQ(WindowedCalibration::windowOf(midnight, 86400), std::make_pair(midnight, midnight + day));
  EXPECT_EQ(WindowedCalibration::windowOf(midnight - 1, 86400), std::make_pair(midnight - day, midnight));
  // 2023-06-01 00:00 GPS (738849600 s past the epoch, which is noon): a whole day's start.
  const TimeUs june = 738849600LL * kUsPerSecond;
  EXPECT_EQ(WindowedCalibration::windowOf(june + 5 * h, 86400).first, june);
  EXPECT_EQ(WindowedCalibration::windowOf(june + 5 * h, 21600), std::make_pair(june, june + 6 * h));
  EXPECT_EQ(WindowedCalibration::windowOf(june + 6 * h, 21600).first, june + 6 * h);
  std::string err;
  WindowedCalibration w;
  EXPECT_EQ(w.lateSamples(), 0u);
  RunOptions ro;
  EXPECT_FALSE(w.configure(core::PipelineConfig{}, SpanOptions{}, 3600, ro, 1.0, &err));  // no attitude-domain configuration
  EXPECT_NE(err.find("attitude-domain"), std::string::npos) << err;
  ro.raw = RawBoundConfig{};
  EXPECT_FALSE(w.configure(core::PipelineConfig{}, SpanOptions{}, 0.5, ro, 1.0, &err));
}

}  // namespace
}  // namespace boresight::calib
