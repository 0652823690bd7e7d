// CRN filter: designed response against METHODS 1.4, derivatives of sinusoids, centre stamping,
// output decimation, gaps (restart and bridge), evaluation at arbitrary tags.
#include "boresight/core/crn.h"

#include <gtest/gtest.h>

#include <map>

#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

namespace boresight::core {
namespace {

CrnConfig grace(double fs = 10.0) {
  CrnConfig c;
  c.fs_hz = fs;
  c.nc = 7;
  c.bandwidth_hz = 0.1;
  c.length_s = 70.7;
  c.max_order = 2;
  return c;
}

double dB(double g) { return 20.0 * std::log10(std::abs(g)); }

double findCrossing(const CrnKernel& k, double level_db) {
  double lo = 0.05, hi = 0.2;
  for (int i = 0; i < 60; ++i) {
    const double m = 0.5 * (lo + hi);
    (dB(k.response(0, m)) > level_db ? lo : hi) = m;
  }
  return lo;
}

TEST(CrnDesign, GraceResponseMatchesMethods) {
  CrnKernel k;
  ASSERT_EQ(designCrn(grace(), k), Status::kOk);
  EXPECT_EQ(k.nf, 707);
  EXPECT_EQ(k.half, 353);
  EXPECT_EQ(k.nb, 7);
  double worst = 0;
  for (double f = 0; f <= 0.05 + 1e-12; f += 0.0005) worst = std::max(worst, std::abs(k.response(0, f) - 1.0));
  EXPECT_LT(worst, 0.0012) << "flat to 0.12 % up to 0.05 Hz";
  EXPECT_GT(worst, 0.0005) << "the CRN is not perfectly flat: a near-zero deviation means the design is wrong";
  EXPECT_NEAR(findCrossing(k, -3.0), 0.0955, 0.0010);
  EXPECT_NEAR(findCrossing(k, -6.0), 0.1065, 0.0010);
  EXPECT_NEAR(dB(k.response(0, 0.15)), -40.0, 1.5);
  for (double f = 0.2; f <= 5.0; f += 0.0013) EXPECT_LT(dB(k.response(0, f) + 1e-300), -95.0) << f;
  std::printf("CRN 10 Hz: max |H-1| to 0.05 Hz %.4f %%, -3 dB %.4f Hz, -6 dB %.4f Hz, %.1f dB at 0.15 Hz\n",
              100 * worst, findCrossing(k, -3.0), findCrossing(k, -6.0), dB(k.response(0, 0.15)));
}

TEST(CrnDesign, TwoHertzVersionHasNearlyTheSameResponse) {
  CrnKernel k10, k2;
  ASSERT_EQ(designCrn(grace(10.0), k10), Status::kOk);
  ASSERT_EQ(designCrn(grace(2.0), k2), Status::kOk);
  EXPECT_EQ(k2.nf, 141);
  for (double f = 0; f <= 0.3; f += 0.001) EXPECT_NEAR(k2.response(0, f), k10.response(0, f), 0.01) << f;
}

TEST(CrnDesign, DerivativeKernelsAreIdealTimesLowPass) {
  CrnKernel k;
  ASSERT_EQ(designCrn(grace(), k), Status::kOk);
  for (double f = 0.001; f <= 0.05; f += 0.001) {
    const double w = 2 * kPi * f;
    EXPECT_NEAR(k.response(1, f) / w, k.response(0, f), 2e-4) << f;
    EXPECT_NEAR(-k.response(2, f) / (w * w), k.response(0, f), 2e-4) << f;
  }
}

TEST(CrnDesign, RejectsBadParameters) {
  CrnKernel k;
  CrnConfig c = grace();
  c.length_s = 200;  // 2000 taps > kMaxCrnTaps
  EXPECT_EQ(designCrn(c, k), Status::kInvalidConfig);
  c = grace();
  c.fs_hz = std::nan("");
  EXPECT_EQ(designCrn(c, k), Status::kInvalidConfig);
  c = grace();
  c.nc = 0;
  EXPECT_EQ(designCrn(c, k), Status::kInvalidConfig);
}

// Feeds x(t) = sum of sinusoids below 0.05 Hz; every output must be stamped at its centre tap and
// give the value and the first two derivatives at that tag to 0.2 % of the amplitude of each.
TEST(CrnStreamTest, SinusoidDerivativesAndCentreStamping) {
  constexpr int kRuns = 50;  // random frequencies, phases, fs
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> fr(0.001, 0.05), ph(0, 2 * kPi);
  for (int run = 0; run < kRuns; ++run) {
    const double fs = (run % 2) ? 10.0 : 2.0;
    CrnConfig c = grace(fs);
    c.output_period_us = 2 * kUsPerSecond;
    CrnStream<1> s;
    ASSERT_EQ(s.configure(c), Status::kOk);
    const double f = fr(rng), p = ph(rng), w = 2 * kPi * f;
    const TimeUs dt = static_cast<TimeUs>(std::llround(1e6 / fs));
    const TimeUs t0 = 700000000LL * kUsPerSecond + 30000;  // GRACE-FO-like epoch, off-grid by 30 ms
    int outputs = 0;
    double e0 = 0, e1 = 0, e2 = 0;
    for (int i = 0; i < static_cast<int>(400 * fs); ++i) {
      const TimeUs t = t0 + i * dt;
      const double ts = toSeconds(t - t0);
      ASSERT_EQ(s.step(t, Eigen::Matrix<double, 1, 1>(std::sin(w * ts + p))), Status::kOk);
      for (int o = 0; o < s.numOutputs(); ++o) {
        const auto& out = s.output(o);
        // centre stamping: the tag is (Nf-1)/2 samples before the newest input
        EXPECT_EQ(out.t, t - s.kernel().half * dt);
        const double tc = toSeconds(out.t - t0);
        e0 = std::max(e0, std::abs(out.y[0][0] - std::sin(w * tc + p)));
        e1 = std::max(e1, std::abs(out.y[1][0] - w * std::cos(w * tc + p)) / w);
        e2 = std::max(e2, std::abs(out.y[2][0] + w * w * std::sin(w * tc + p)) / (w * w));
        ++outputs;
      }
    }
    EXPECT_GT(outputs, 100);
    EXPECT_LT(e0, 0.002) << "f " << f << " fs " << fs;
    EXPECT_LT(e1, 0.002) << "f " << f << " fs " << fs;
    EXPECT_LT(e2, 0.002) << "f " << f << " fs " << fs;
  }
}

// sum_j g[j] x[j] in long double and sum_j |g[j] x[j]| (the scale of the rounding of any order)
void plainDot(const double* g, const double* x, int n, double& dot, double& scale) {
  long double d = 0, a = 0;
  for (int j = 0; j < n; ++j) {
    d += static_cast<long double>(g[j]) * x[j];
    a += std::abs(static_cast<long double>(g[j]) * x[j]);
  }
  dot = static_cast<double>(d);
  scale = static_cast<double>(a);
}

TEST(CrnKernels, FoldedRateKernelEqualsThePlainDotProduct) {
  // crnDotFolded4x3 (even kernels on x[c+n] + x[c-n], the odd one on the difference) against the
  // plain full-window dot product, for the 2 Hz and 10 Hz designs and random windows of 4 channels;
  // also with a half length that is not a multiple of 4 (the scalar tail). 1e-15 of sum |g x|.
  std::mt19937_64 rng(5);
  std::normal_distribution<double> nd(0, 1);
  double worst = 0;
  for (double fs : {2.0, 10.0}) {
    CrnKernel k;
    ASSERT_EQ(designCrn(grace(fs), k), Status::kOk);
    const int M = k.half, L = 2 * M + 1;
    std::vector<double> h[3];
    for (int o = 0; o < 3; ++o)
      for (int i = 0; i < M; ++i) h[o].push_back(k.g[static_cast<std::size_t>(o)][static_cast<std::size_t>(M + 1 + i)]);
    for (int trial = 0; trial < 200; ++trial) {
      std::vector<double> x[4], xp[4], xm[4];
      for (int c = 0; c < 4; ++c) {
        const double mean = 10.0 * nd(rng);  // an offset as a quaternion component has
        for (int j = 0; j < L; ++j) x[c].push_back(mean + nd(rng));
        for (int i = 0; i < M; ++i) {
          xp[c].push_back(x[c][static_cast<std::size_t>(M + 1 + i)]);
          xm[c].push_back(x[c][static_cast<std::size_t>(M - 1 - i)]);
        }
      }
      const double* pp[4] = {xp[0].data(), xp[1].data(), xp[2].data(), xp[3].data()};
      const double* pm[4] = {xm[0].data(), xm[1].data(), xm[2].data(), xm[3].data()};
      const double xc[4] = {x[0][static_cast<std::size_t>(M)], x[1][static_cast<std::size_t>(M)],
                            x[2][static_cast<std::size_t>(M)], x[3][static_cast<std::size_t>(M)]};
      const auto um = static_cast<std::size_t>(M);
      const double centre[3] = {k.g[0][um], k.g[1][um], k.g[2][um]};
      double out[12];
      crnDotFolded4x3(h[0].data(), h[1].data(), h[2].data(), centre, pp, pm, xc, M, out);
      for (int c = 0; c < 4; ++c)
        for (int o = 0; o < 3; ++o) {
          double ref, scale;
          plainDot(k.g[static_cast<std::size_t>(o)].data(), x[c].data(), L, ref, scale);
          const double rel = std::abs(out[3 * c + o] - ref) / scale;
          worst = std::max(worst, rel);
          ASSERT_LT(rel, 1e-15) << "fs " << fs << " channel " << c << " order " << o;
        }
    }
  }
  std::printf("folded vs plain dot product: worst |difference| / sum|g x| = %.2e\n", worst);
}

TEST(CrnStreamTest, FoldedStreamOutputsEqualThePlainDotProductOverTheWindow) {
  // the rate filter's stream (4 channels, orders 0-2, folded with the reversed ring) against the
  // plain dot product over the window of the samples pushed, across three wraps of the ring
  CrnConfig c = grace(2.0);
  c.output_period_us = kUsPerSecond;
  CrnStream<4> s;
  ASSERT_EQ(s.configure(c), Status::kOk);
  const CrnKernel& k = s.kernel();
  const int M = k.half, L = 2 * M + 1;
  std::mt19937_64 rng(9);
  std::normal_distribution<double> nd(0, 1);
  std::vector<Eigen::Vector4d> hist;
  std::vector<TimeUs> tags;
  int outputs = 0;
  double worst = 0;
  for (int i = 0; i < 3 * kCrnRing + 300; ++i) {
    const TimeUs t = 1000 * kUsPerSecond + i * 500000;
    const Eigen::Vector4d x(0.5 + 0.1 * nd(rng), -0.3 + 0.1 * nd(rng), nd(rng), 0.2 * nd(rng));
    hist.push_back(x);
    tags.push_back(t);
    ASSERT_EQ(s.step(t, x), Status::kOk);
    for (int o = 0; o < s.numOutputs(); ++o) {
      const auto& out = s.output(o);
      const int ci = i - M;  // the centre sample
      ASSERT_EQ(out.t, tags[static_cast<std::size_t>(ci)]);
      for (int ch = 0; ch < 4; ++ch) {
        std::vector<double> w;
        for (int j = ci - M; j <= ci + M; ++j) w.push_back(hist[static_cast<std::size_t>(j)][ch]);
        for (int ord = 0; ord < 3; ++ord) {
          double ref, scale;
          plainDot(k.g[static_cast<std::size_t>(ord)].data(), w.data(), L, ref, scale);
          const double rel = std::abs(out.y[static_cast<std::size_t>(ord)][ch] - ref) / scale;
          worst = std::max(worst, rel);
          ASSERT_LT(rel, 1e-15) << "sample " << i << " channel " << ch << " order " << ord;
        }
      }
      ++outputs;
    }
  }
  EXPECT_GT(outputs, (3 * kCrnRing + 300 - L) / 2 - 2);
  std::printf("folded stream vs plain dot product over the window: worst %.2e (%d outputs)\n", worst, outputs);
}

TEST(CrnStreamTest, AboveTheBandIsSuppressed) {
  // a 0.3 Hz line (GRACE: below -95 dB from 0.2 Hz) disappears from all three outputs
  CrnStream<1> s;
  ASSERT_EQ(s.configure(grace()), Status::kOk);
  double worst = 0;
  for (int i = 0; i < 3000; ++i) {
    const TimeUs t = i * 100000;
    s.step(t, Eigen::Matrix<double, 1, 1>(std::sin(2 * kPi * 0.3 * toSeconds(t))));
    for (int o = 0; o < s.numOutputs(); ++o) worst = std::max(worst, std::abs(s.output(o).y[0][0]));
  }
  EXPECT_LT(worst, 1e-4);
}

TEST(CrnStreamTest, OutputCostFollowsTheOutputGrid) {
  // 10 Hz in, 1 s grid: exactly one output per second once the window is full, on whole seconds
  CrnStream<3> s;
  CrnConfig c = grace();
  c.output_period_us = kUsPerSecond;
  ASSERT_EQ(s.configure(c), Status::kOk);
  int outputs = 0;
  const int n = 10 * 600;
  for (int i = 0; i < n; ++i) {
    const TimeUs t = 5 * kUsPerSecond + i * 100000 + (i % 3) * 700;  // jitter of a few hundred us
    ASSERT_EQ(s.step(t, Vec3(1, 2, 3)), Status::kOk);
    for (int o = 0; o < s.numOutputs(); ++o) {
      EXPECT_LE(std::abs(s.output(o).t % kUsPerSecond), 2000);
      EXPECT_NEAR(s.output(o).y[0][2], 3.0, 1e-12);
      EXPECT_NEAR(s.output(o).y[1][2], 0.0, 1e-12);
      EXPECT_NEAR(s.output(o).y[2][2], 0.0, 1e-12);
      ++outputs;
    }
  }
  const int expected = (n - 707) / 10 + 1;
  EXPECT_NEAR(outputs, expected, 1);
}

TEST(CrnStreamTest, GapRestartsOrIsBridgedAndIsReported) {
  for (GapPolicy pol : {GapPolicy::kRestart, GapPolicy::kBridge}) {
    CrnConfig c = grace(2.0);
    c.gap_policy = pol;
    c.max_bridge_samples = 10;
    c.output_period_us = 500000;  // every sample
    CrnStream<1> s;
    ASSERT_EQ(s.configure(c), Status::kOk);
    auto x = [](TimeUs t) { return Eigen::Matrix<double, 1, 1>(0.3 + 0.01 * toSeconds(t)); };  // a ramp: bridged exactly
    TimeUs t = 0;
    int outputs_after_gap = 0;
    for (int i = 0; i < 400; ++i) {
      t += 500000;
      ASSERT_EQ(s.step(t, x(t)), Status::kOk);
    }
    // a gap of 5 missing samples
    t += 6 * 500000;
    const Status st = s.step(t, x(t));
    if (pol == GapPolicy::kBridge) {
      EXPECT_EQ(st, Status::kGapBridged);
      EXPECT_EQ(s.health().count(Status::kGapBridged), 1u);
      EXPECT_EQ(s.numOutputs(), 6);  // the centres passed over by the 6 pushed samples
      for (int o = 0; o < s.numOutputs(); ++o) EXPECT_NEAR(s.output(o).y[0][0], x(s.output(o).t)[0], 1e-9);
    } else {
      EXPECT_EQ(st, Status::kGapRestarted);
      EXPECT_EQ(s.health().count(Status::kGapRestarted), 1u);
      EXPECT_EQ(s.numOutputs(), 0);
      // nothing for a full window after a restart
      for (int i = 0; i < 139; ++i) {
        t += 500000;
        s.step(t, x(t));
        outputs_after_gap += s.numOutputs();
      }
      EXPECT_EQ(outputs_after_gap, 0);
      t += 500000;
      s.step(t, x(t));
      EXPECT_EQ(s.numOutputs(), 1);
    }
    // a gap longer than the bridge limit always restarts
    t += 30 * 500000;
    EXPECT_EQ(s.step(t, x(t)), Status::kGapRestarted);
  }
}

TEST(CrnStreamTest, EvaluateAtAnyTagInsideTheHistory) {
  constexpr int kRuns = 200;
  CrnConfig c = grace(10.0);
  c.output_period_us = 0;
  CrnStream<1> s;
  ASSERT_EQ(s.configure(c), Status::kOk);
  const double f = 0.03, w = 2 * kPi * f;
  auto x = [&](TimeUs t) { return std::cos(w * toSeconds(t)); };
  TimeUs t = 123456;
  for (int i = 0; i < 1000; ++i) {
    t += 100000;
    s.step(t, Eigen::Matrix<double, 1, 1>(x(t)));
  }
  std::mt19937_64 rng(3);
  std::uniform_int_distribution<TimeUs> tag(t - 60 * kUsPerSecond, t - 36 * kUsPerSecond);
  for (int r = 0; r < kRuns; ++r) {
    const TimeUs tau = tag(rng);
    CrnStream<1>::Output o;
    ASSERT_EQ(s.evaluateAt(tau, o), Status::kOk);
    EXPECT_EQ(o.t, tau);
    EXPECT_NEAR(o.y[0][0], x(tau), 0.002);
    EXPECT_NEAR(o.y[1][0] / w, -std::sin(w * toSeconds(tau)), 0.002);
  }
  CrnStream<1>::Output o;
  EXPECT_EQ(s.evaluateAt(t - 10 * kUsPerSecond, o), Status::kNotReady);
  EXPECT_EQ(s.evaluateAt(t - 100 * kUsPerSecond, o), Status::kUnavailable);
}

TEST(CrnStreamTest, BridgedSamplesAreEvenlySpacedAndLinearAndFractionalStepsAreClassified) {
  CrnConfig c = grace(2.0);
  c.gap_policy = GapPolicy::kBridge;
  c.bridge_fit = BridgeFit::kLinear;
  c.max_bridge_samples = 20;
  c.output_period_us = 500000;  // every centre sample is an output: the bridged ones show in the outputs
  const TimeUs dt = 500000;      // tolerance: a quarter interval, 125 ms
  // a ramp plus a parabola: the bridged samples lie on the line between their real neighbours
  auto x = [](TimeUs t) { return 0.3 + 0.01 * toSeconds(t) + 1e-4 * std::pow(toSeconds(t) - 150.0, 2); };
  for (int missing : {1, 2, 5, 20}) {
    CrnStream<1> s;
    ASSERT_EQ(s.configure(c), Status::kOk);
    TimeUs t = 0;
    for (int i = 0; i < 300; ++i) {
      t += dt;
      ASSERT_EQ(s.step(t, Eigen::Matrix<double, 1, 1>(x(t))), Status::kOk);
    }
    const TimeUs t_before = t;
    const TimeUs d = (missing + 1) * dt + 60000;  // the end of the gap 60 ms off the grid (within n tol)
    t += d;
    ASSERT_EQ(s.step(t, Eigen::Matrix<double, 1, 1>(x(t))), Status::kGapBridged) << missing;
    const TimeUs t_after = t;
    // push on until the gap has passed the centre tap, collecting the centre-stamped outputs
    std::vector<CrnStream<1>::Output> outs;
    for (int i = 0; i < 100; ++i) {
      t += dt;
      ASSERT_EQ(s.step(t, Eigen::Matrix<double, 1, 1>(x(t))), Status::kOk);
      for (int o = 0; o < s.numOutputs(); ++o) outs.push_back(s.output(o));
    }
    int bridged_seen = 0;
    for (std::size_t i = 1; i < outs.size(); ++i) EXPECT_GT(outs[i].t, outs[i - 1].t);
    for (int k = 1; k <= missing; ++k) {
      const TimeUs tk = t_before + d * k / (missing + 1);
      for (const auto& o : outs) {
        if (o.t != tk) continue;
        ++bridged_seen;
        // the low-pass of a parabola on a uniform grid is exact up to the curvature term; the linear
        // interpolation deviates from the parabola by at most 1e-4 (d/2)^2: both small against a
        // wrong tag (0.01 per s)
        const double f = static_cast<double>(k) / (missing + 1);
        const double line = x(t_before) + f * (x(t_after) - x(t_before));
        EXPECT_NEAR(o.y[0][0], line, 2e-4 + 1e-4 * std::pow(toSeconds(d) / 2, 2)) << missing << " " << k;
      }
    }
    EXPECT_EQ(bridged_seen, missing);
  }
  {  // fractional steps: 1.3 intervals is a late sample (dropped), the next on-grid sample bridges its slot
    CrnStream<1> s;
    ASSERT_EQ(s.configure(c), Status::kOk);
    TimeUs t = 0;
    for (int i = 0; i < 10; ++i) ASSERT_EQ(s.step(t += dt, Eigen::Matrix<double, 1, 1>(1.0)), Status::kOk);
    EXPECT_EQ(s.step(t + 13 * dt / 10, Eigen::Matrix<double, 1, 1>(1.0)), Status::kIrregularTime);
    EXPECT_EQ(s.step(t + 14 * dt / 10, Eigen::Matrix<double, 1, 1>(1.0)), Status::kIrregularTime);
    EXPECT_EQ(s.step(t + 6 * dt / 10, Eigen::Matrix<double, 1, 1>(1.0)), Status::kIrregularTime);  // early
    EXPECT_EQ(s.step(t + 12 * dt / 10, Eigen::Matrix<double, 1, 1>(1.0)), Status::kOk);            // within tol
    t += 12 * dt / 10;
    EXPECT_EQ(s.step(t + 16 * dt / 10, Eigen::Matrix<double, 1, 1>(1.0)), Status::kGapBridged);  // 2 intervals
    t += 16 * dt / 10;
    EXPECT_EQ(s.step(t + 2 * dt, Eigen::Matrix<double, 1, 1>(1.0)), Status::kGapBridged);
    t += 2 * dt;
    EXPECT_EQ(s.step(t + 22 * dt, Eigen::Matrix<double, 1, 1>(1.0)), Status::kGapRestarted);  // 21 missing > 20
    EXPECT_EQ(s.health().count(Status::kIrregularTime), 3u);
    EXPECT_EQ(s.health().count(Status::kGapBridged), 2u);
    EXPECT_EQ(s.health().count(Status::kGapRestarted), 1u);
  }
}

// The local fit: a cubic in time is bridged exactly (every output equals the no-gap run's, the
// bridged samples' sigmas vanish); a quartic is not, and the published bound holds the difference;
// outputs are flagged with the number of bridged samples in their window, and only those.
TEST(CrnStreamTest, LocalFitBridgesACubicExactlyAndBoundsAQuartic) {
  CrnConfig c = grace(2.0);
  c.gap_policy = GapPolicy::kBridge;
  c.max_bridge_samples = 20;
  c.output_period_us = 500000;  // an output at every sample
  const TimeUs dt = 500000;
  for (int degree : {3, 4}) {
    auto x = [degree](TimeUs t) {
      const double u = toSeconds(t) - 200.0;
      const double cubic = 0.3 + 1e-2 * u - 2e-4 * u * u + 3e-6 * u * u * u;
      return degree == 3 ? cubic : cubic + 4e-8 * u * u * u * u;
    };
    for (int missing : {1, 4, 20}) {
      CrnStream<1> gap, ref;
      ASSERT_EQ(gap.configure(c), Status::kOk);
      ASSERT_EQ(ref.configure(c), Status::kOk);
      std::map<TimeUs, CrnStream<1>::Output> ref_out;
      int flagged = 0;
      double worst_ratio = 0;
      const int first_missing = 400;
      for (int i = 1; i <= 800; ++i) {
        const TimeUs t = i * dt;
        const Eigen::Matrix<double, 1, 1> v(x(t));
        ASSERT_EQ(ref.step(t, v), Status::kOk);
        for (int o = 0; o < ref.numOutputs(); ++o) ref_out[ref.output(o).t] = ref.output(o);
        if (i >= first_missing && i < first_missing + missing) continue;
        const Status st = gap.step(t, v);
        ASSERT_EQ(st, i == first_missing + missing ? Status::kGapBridged : Status::kOk);
        for (int o = 0; o < gap.numOutputs(); ++o) {
          const auto& out = gap.output(o);
          const auto& r = ref_out.at(out.t);
          // bridged samples within M = 70 taps of the centre
          const long long centre = out.t / dt;
          int expect = 0;
          for (int k = first_missing; k < first_missing + missing; ++k) expect += std::llabs(k - centre) <= 70;
          ASSERT_EQ(out.bridged, expect) << out.t;
          for (int order = 0; order < 3; ++order) {
            const double d = std::abs(out.y[static_cast<std::size_t>(order)][0] - r.y[static_cast<std::size_t>(order)][0]);
            const double sb = out.sigma_bridge[static_cast<std::size_t>(order)][0];
            const double scale = order == 0 ? 1.0 : (order == 1 ? 1e-2 : 1e-3);  // the signal's size per order
            if (expect == 0) {
              EXPECT_EQ(d, 0.0);
              EXPECT_EQ(sb, 0.0);
              continue;
            }
            if (degree == 3) {
              EXPECT_LT(d, 1e-9 * scale) << missing << " order " << order;
              EXPECT_LT(sb, 1e-9 * scale) << missing << " order " << order;
            } else {
              EXPECT_LE(d, sb + 1e-12 * scale) << missing << " order " << order;
              if (d > 1e-11 * scale) worst_ratio = std::max(worst_ratio, d / sb);
            }
          }
          flagged += expect > 0;
        }
      }
      EXPECT_GT(flagged, 140);
      if (degree == 4) {
        EXPECT_GT(worst_ratio, 0.05) << missing;  // a bound, not a wild overestimate
        std::printf("quartic, %2d missing: worst |difference| / published bound %.2f\n", missing, worst_ratio);
      }
    }
  }
}

// The seams of the local fit: a gap closed right after a restart (fewer than 5 real points: a line,
// flagged with NaN bounds - no uncertainty is claimed) and the last epochs, evaluated at the end of the
// data while the gap is still being refined (flagged with a finite bound that holds the difference).
TEST(CrnStreamTest, LocalFitAtARestartAndAtTheEndOfTheData) {
  CrnConfig c = grace(2.0);
  c.gap_policy = GapPolicy::kBridge;
  c.max_bridge_samples = 20;
  c.output_period_us = 500000;
  const TimeUs dt = 500000;
  auto x = [](TimeUs t) {
    const double u = toSeconds(t) - 200.0;
    return Eigen::Matrix<double, 1, 1>(0.3 + 1e-2 * u - 2e-4 * u * u + 3e-6 * u * u * u + 4e-8 * u * u * u * u);
  };
  {  // restart (a 30-sample gap), two real samples, then a 3-sample gap: bridged by a line
    CrnStream<1> s;
    ASSERT_EQ(s.configure(c), Status::kOk);
    TimeUs t = 0;
    auto next = [&](TimeUs step) {
      t += step;
      return s.step(t, x(t));
    };
    for (int i = 0; i < 200; ++i) ASSERT_EQ(next(dt), Status::kOk);
    ASSERT_EQ(next(31 * dt), Status::kGapRestarted);
    ASSERT_EQ(next(dt), Status::kOk);
    ASSERT_EQ(next(4 * dt), Status::kGapBridged);
    int flagged = 0;
    for (int i = 0; i < 200; ++i) {
      ASSERT_EQ(next(dt), Status::kOk);
      for (int o = 0; o < s.numOutputs(); ++o) {
        const auto& out = s.output(o);
        if (out.bridged == 0) continue;
        ++flagged;
        EXPECT_LE(out.bridged, 3);  // the first full windows after the restart hold the gap at their old end
        EXPECT_TRUE(std::isnan(out.sigma_bridge[0][0]));  // a line: no uncertainty claimed
      }
    }
    EXPECT_GE(flagged, 3);
  }
  {  // the data end 3 samples after a 10-sample gap: the newest window holds the gap, still refined
    CrnStream<1> gap, ref;
    ASSERT_EQ(gap.configure(c), Status::kOk);
    ASSERT_EQ(ref.configure(c), Status::kOk);
    TimeUs t = 0;
    for (int i = 1; i <= 400; ++i) {
      t = i * dt;
      ASSERT_EQ(ref.step(t, x(t)), Status::kOk);
      if (i > 387 && i <= 397) continue;
      ASSERT_TRUE(accepted(gap.step(t, x(t))));
    }
    // the last epoch the filter can give (M = 70 samples before the newest), as flush() asks for it
    const TimeUs tau = t - 70 * dt;
    CrnStream<1>::Output og, orf;
    ASSERT_EQ(gap.evaluateAt(tau, og), Status::kOk);
    ASSERT_EQ(ref.evaluateAt(tau, orf), Status::kOk);
    EXPECT_EQ(og.bridged, 10);
    EXPECT_EQ(orf.bridged, 0);
    for (int order = 0; order < 3; ++order) {
      const auto o = static_cast<std::size_t>(order);
      ASSERT_TRUE(std::isfinite(og.sigma_bridge[o][0]));
      EXPECT_GT(og.sigma_bridge[o][0], 0.0);
      EXPECT_LE(std::abs(og.y[o][0] - orf.y[o][0]), og.sigma_bridge[o][0] + 1e-15) << order;
    }
  }
}

}  // namespace
}  // namespace boresight::core
