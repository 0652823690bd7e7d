// Rates: constant-rate and sinusoidal rotations give the right rate and angular acceleration in
// the head frames; the accelerometer's angular acceleration, low-passed by the same CRN, lands on the
// same tags in the same frame and agrees with the star-sensor value.
#include "boresight/core/rates.h"

#include "core_test_util.h"

#include <gtest/gtest.h>

#include <map>
#include <vector>

namespace boresight::core {
namespace {

using test::Rng;

CrnConfig attitudeCrn() {
  CrnConfig c;
  c.fs_hz = 2.0;
  c.output_period_us = kUsPerSecond;
  return c;
}

// Body motion: constant rate w0 (in the intermediate frame) then a libration theta(t) n.
struct Motion {
  Quat q0 = Quat::Identity();
  Vec3 w0 = Vec3::Zero();
  Vec3 n = Vec3::UnitX();
  double amp = 0, f = 0;
  TimeUs t0 = 0;
  double th(double t) const { return amp * std::sin(2 * kPi * f * t); }
  double thd(double t) const { return amp * 2 * kPi * f * std::cos(2 * kPi * f * t); }
  double thdd(double t) const { return -amp * std::pow(2 * kPi * f, 2) * std::sin(2 * kPi * f * t); }
  Quat q_I_B(TimeUs tu) const {
    const double t = toSeconds(tu - t0);
    return q0 * quatExp(w0 * t) * quatExp(th(t) * n);
  }
  Vec3 w_B(TimeUs tu) const {
    const double t = toSeconds(tu - t0);
    return quatExp(th(t) * n).conjugate() * w0 + thd(t) * n;
  }
  Vec3 alpha_B(TimeUs tu) const {
    const double t = toSeconds(tu - t0);
    const Vec3 w0b = quatExp(th(t) * n).conjugate() * w0;
    return thdd(t) * n - thd(t) * n.cross(w0b);
  }
};

TEST(Rates, ConstantRateInEveryHeadFrame) {
  constexpr int kRuns = 20;  // random attitudes and rate vectors
  Rng rng(21);
  const HeadSetConfig heads = test::graceLikeHeads(3);
  for (int run = 0; run < kRuns; ++run) {
    Motion m;
    m.q0 = test::randomQuat(rng);
    m.w0 = test::randomVec(rng, 5e-3);  // up to ~1 deg/s, GRACE-FO orbit rate is 1.1e-3 rad/s
    m.t0 = 738849600LL * kUsPerSecond;
    for (int k = 0; k < 3; ++k) {
      const HeadConfig& h = heads.head[static_cast<std::size_t>(k)];
      AttitudeRates r;
      ASSERT_EQ(r.configure(attitudeCrn()), Status::kOk);
      int outs = 0;
      for (int i = 0; i < 600; ++i) {
        const TimeUs t = m.t0 + 30000 + i * 500000;
        const Quat q_I_Si = m.q_I_B(t) * h.q_Si_B.conjugate();
        // flip the sign every third sample: the filter must make it continuous
        const Quat fed = (i % 3 == 0) ? Quat(-q_I_Si.w(), -q_I_Si.x(), -q_I_Si.y(), -q_I_Si.z()) : q_I_Si;
        ASSERT_EQ(r.step(t, fed), Status::kOk);
        for (int o = 0; o < r.numOutputs(); ++o) {
          const RateOutput& out = r.output(o);
          const Vec3 w_Si = h.q_Si_B * m.w_B(out.t);
          EXPECT_LT((out.w_X - w_Si).norm(), 1e-6 * w_Si.norm()) << "head " << k;
          EXPECT_LT(out.alpha_X.norm(), 1e-6 * w_Si.norm());
          EXPECT_LT(angleBetween(out.q_I_X, m.q_I_B(out.t) * h.q_Si_B.conjugate()), 1e-9);
          ++outs;
        }
      }
      EXPECT_GT(outs, 200);
    }
  }
}

TEST(Rates, SinusoidalLibrationOnAnOrbitingBodyInHeadFrames) {
  constexpr int kRuns = 30;  // random frequencies below 0.05 Hz, axes and attitudes
  Rng rng(22);
  std::uniform_real_distribution<double> fr(0.002, 0.05);
  const HeadSetConfig heads = test::graceLikeHeads(3);
  double worst_w = 0, worst_a = 0;
  for (int run = 0; run < kRuns; ++run) {
    Motion m;
    m.q0 = test::randomQuat(rng);
    m.w0 = Vec3(0, -1.1e-3, 0);
    m.n = test::randomUnit(rng);
    m.amp = 2e-4;
    m.f = fr(rng);
    const double w_amp = m.amp * 2 * kPi * m.f, a_amp = w_amp * 2 * kPi * m.f;
    for (int k = 0; k < 3; ++k) {
      const HeadConfig& h = heads.head[static_cast<std::size_t>(k)];
      AttitudeRates r;
      ASSERT_EQ(r.configure(attitudeCrn()), Status::kOk);
      for (int i = 0; i < 500; ++i) {
        const TimeUs t = m.t0 + 530000 + i * 500000;
        ASSERT_EQ(r.step(t, m.q_I_B(t) * h.q_Si_B.conjugate()), Status::kOk);
        for (int o = 0; o < r.numOutputs(); ++o) {
          const RateOutput& out = r.output(o);
          const Vec3 w_Si = h.q_Si_B * m.w_B(out.t);
          const Vec3 a_Si = h.q_Si_B * m.alpha_B(out.t);
          // the libration part must be right to 0.2 % of its amplitude
          worst_w = std::max(worst_w, (out.w_X - w_Si).norm() / w_amp);
          worst_a = std::max(worst_a, (out.alpha_X - a_Si).norm() / (a_amp + w_amp * 1.1e-3));
        }
      }
    }
  }
  EXPECT_LT(worst_w, 0.002);
  EXPECT_LT(worst_a, 0.002);
  std::printf("libration: worst rate error %.4f %% of amplitude, acceleration %.4f %%\n", 100 * worst_w, 100 * worst_a);
}

TEST(Rates, AccelerometerOnTheSameTagsAndFrameAgreesWithStarSensor) {
  // The body librates; the accelerometer (10 Hz, own jittered clock, frame A with the GRACE
  // permutation) measures alpha_B rotated to A plus a bias; both go through the same CRN.
  Motion m;
  m.w0 = Vec3(0, -1.1e-3, 0);
  m.n = Vec3(0.3, -0.5, 0.8).normalized();
  m.amp = 3e-4;
  m.f = 0.01;
  const Mat3 C_B_A = accToBodyDefault();
  const Vec3 bias_A(2e-7, -1e-7, 5e-8);
  AttitudeRates rates;
  ASSERT_EQ(rates.configure(attitudeCrn()), Status::kOk);
  AccAngularFilter acc;
  CrnConfig ca;
  ca.fs_hz = 10.0;
  ca.output_period_us = 0;
  ASSERT_EQ(acc.configure(ca, C_B_A), Status::kOk);
  TimeUs ta = m.t0 + 506901;
  int compared = 0;
  double worst = 0;
  const double a_amp = m.amp * std::pow(2 * kPi * m.f, 2);
  std::array<RateOutput, 64> waiting{};
  int n_wait = 0;
  for (int i = 0; i < 800; ++i) {
    const TimeUs ts = m.t0 + 30000 + i * 500000;
    while (ta <= ts) {  // merge by time
      ASSERT_EQ(acc.step(ta, C_B_A.transpose() * m.alpha_B(ta) + bias_A), Status::kOk);
      ta += 99994;  // the ACC1A clock runs 6 us short per sample
    }
    ASSERT_EQ(rates.step(ts, m.q_I_B(ts)), Status::kOk);
    for (int o = 0; o < rates.numOutputs(); ++o) waiting[static_cast<std::size_t>(n_wait++)] = rates.output(o);
    int keep = 0;
    for (int j = 0; j < n_wait; ++j) {
      AccOutput a;
      const Status s = acc.evaluateAt(waiting[static_cast<std::size_t>(j)].t, a);
      if (s == Status::kNotReady) {
        waiting[static_cast<std::size_t>(keep++)] = waiting[static_cast<std::size_t>(j)];
        continue;
      }
      if (s == Status::kUnavailable) {  // only before the accelerometer's first full window
        EXPECT_LT(waiting[static_cast<std::size_t>(j)].t, m.t0 + 506901 + acc.stream().delayUs());
        continue;
      }
      ASSERT_EQ(s, Status::kOk);
      EXPECT_EQ(a.t, waiting[static_cast<std::size_t>(j)].t);
      const Vec3 diff = a.a_X - C_B_A * bias_A - waiting[static_cast<std::size_t>(j)].alpha_X;
      worst = std::max(worst, diff.norm() / a_amp);
      ++compared;
    }
    n_wait = keep;
  }
  EXPECT_GT(compared, 250);
  EXPECT_LT(worst, 0.002);
  std::printf("star-sensor vs accelerometer angular acceleration: worst difference %.2e of the amplitude\n", worst);
}

// ---- gaps: every output row of a run with a gap against the same seed's run without it ----

struct GapRun {
  std::map<TimeUs, RateOutput> rows;  // by tag
  Health health;
};

// Noisy samples of a smooth motion (orbit-rate pitch plus a libration), 2 Hz, 2 arcsec per axis.
struct NoisyStream {
  Motion m;
  std::vector<TimeUs> t;
  std::vector<Quat> q;
  explicit NoisyStream(int n) {
    Rng rng(31);
    m.q0 = test::randomQuat(rng);
    m.w0 = Vec3(0, -1.1e-3, 0);
    m.n = Vec3(0.3, -0.5, 0.8).normalized();
    m.amp = 2e-4;
    m.f = 0.01;
    m.t0 = 738849600LL * kUsPerSecond;
    for (int i = 0; i < n; ++i) {
      t.push_back(m.t0 + 30000 + static_cast<TimeUs>(i) * 500000);
      q.push_back(m.q_I_B(t.back()) * quatExp(test::randomVec(rng, 2.0 * kRadPerArcsec)));
    }
  }
};

GapRun runRates(const NoisyStream& s, int gap_first, int gap_len, GapPolicy pol,
               BridgeFit fit = BridgeFit::kLocalFit) {
  CrnConfig c = attitudeCrn();
  c.gap_policy = pol;
  c.bridge_fit = fit;
  c.max_bridge_samples = 20;
  AttitudeRates r;
  EXPECT_EQ(r.configure(c), Status::kOk);
  GapRun out;
  for (std::size_t i = 0; i < s.t.size(); ++i) {
    const int ii = static_cast<int>(i);
    if (ii >= gap_first && ii < gap_first + gap_len) continue;
    EXPECT_TRUE(accepted(r.step(s.t[i], s.q[i])));
    for (int o = 0; o < r.numOutputs(); ++o) {
      EXPECT_EQ(out.rows.count(r.output(o).t), 0u) << "a tag output twice";
      out.rows[r.output(o).t] = r.output(o);
    }
  }
  out.health = r.health();
  return out;
}

// rms of |w - w_true| and |alpha - alpha_true| of a run
std::pair<double, double> rmsErrors(const GapRun& run, const Motion& m) {
  double sw = 0, sa = 0;
  for (const auto& [t, o] : run.rows) {
    sw += (o.w_X - m.w_B(t)).squaredNorm();
    sa += (o.alpha_X - m.alpha_B(t)).squaredNorm();
  }
  const double n = static_cast<double>(run.rows.size());
  return {std::sqrt(sw / n), std::sqrt(sa / n)};
}

// Tolerance: a bridged gap replaces the noisy samples of the gap by a noise-free line, so the
// difference to the no-gap run is the filter's response to those samples' noise plus the line's
// curvature error: bounded by the no-gap run's own error against truth, times kGapFactor.
constexpr double kGapFactor = 4.0;

TEST(RatesGaps, BridgedGapsOf1_2_5_20SamplesChangeNoRowBeyondTheNoGapError) {
  const NoisyStream s(1200);
  const GapRun ref = runRates(s, 0, 0, GapPolicy::kBridge);
  const auto [ew, ea] = rmsErrors(ref, s.m);
  ASSERT_GT(ref.rows.size(), 400u);
  for (int gap : {1, 2, 5, 20}) {
    const GapRun run = runRates(s, 600, gap, GapPolicy::kBridge);
    EXPECT_EQ(run.health.count(Status::kGapBridged), 1u) << gap;
    EXPECT_EQ(run.health.count(Status::kGapRestarted), 0u) << gap;
    // every row of the no-gap run exists, on the same tag, and agrees within the tolerance
    EXPECT_EQ(run.rows.size(), ref.rows.size()) << gap;
    double worst_w = 0, worst_a = 0;
    for (const auto& [t, o] : ref.rows) {
      const auto it = run.rows.find(t);
      ASSERT_NE(it, run.rows.end()) << "gap " << gap << ": row " << toSeconds(t - s.m.t0) << " s missing";
      worst_w = std::max(worst_w, (it->second.w_X - o.w_X).norm() / ew);
      worst_a = std::max(worst_a, (it->second.alpha_X - o.alpha_X).norm() / ea);
    }
    EXPECT_LT(worst_w, kGapFactor) << gap;
    EXPECT_LT(worst_a, kGapFactor) << gap;
    std::printf("bridged gap of %2d samples: worst row difference / no-gap rms error: rate %.2f, accel %.2f\n", gap,
                worst_w, worst_a);
  }
}

TEST(RatesGaps, RestartLeavesEveryOtherRowUnchangedAndOnlyTheWindowAroundTheGapWithout) {
  const NoisyStream s(1200);
  const GapRun ref = runRates(s, 0, 0, GapPolicy::kBridge);
  const auto [ew, ea] = rmsErrors(ref, s.m);
  for (GapPolicy pol : {GapPolicy::kRestart, GapPolicy::kBridge}) {
    const int gap = pol == GapPolicy::kRestart ? 5 : 30;  // 30 > the bridge limit (20)
    const GapRun run = runRates(s, 600, gap, pol);
    EXPECT_EQ(run.health.count(Status::kGapRestarted), 1u);
    EXPECT_EQ(run.health.count(Status::kGapBridged), 0u);
    const TimeUs half = 70 * 500000;  // M = 70 samples at 2 Hz
    const TimeUs last_before = s.t[599], first_after = s.t[static_cast<std::size_t>(600 + gap)];
    int expected = 0;
    for (const auto& [t, o] : ref.rows) {
      const bool window_clear = t + half <= last_before || t - half >= first_after;
      const auto it = run.rows.find(t);
      if (!window_clear) {
        EXPECT_EQ(it, run.rows.end()) << toSeconds(t - s.m.t0);
        continue;
      }
      ++expected;
      ASSERT_NE(it, run.rows.end()) << toSeconds(t - s.m.t0);
      EXPECT_LT((it->second.w_X - o.w_X).norm(), 1e-3 * ew);
      EXPECT_LT((it->second.alpha_X - o.alpha_X).norm(), 1e-3 * ea);
    }
    EXPECT_EQ(static_cast<int>(run.rows.size()), expected);
  }
}

// ---- gaps at the peaks of angular acceleration inside manoeuvres ----

// Rest-to-rest slews about one axis n on top of an orbit-rate pitch: each lasts Tm with the angular
// acceleration A (sin(w1 t)/2 - sin(2 w1 t)/4), w1 = 2 pi / Tm (zero with its first derivative at both
// ends; peaks |alpha| = 0.65 A at Tm/3 and 2 Tm/3), integrated in closed form.
struct Manoeuvres {
  Quat q0 = Quat::Identity();
  Vec3 w0 = Vec3(0, -1.1e-3, 0);
  Vec3 n = Vec3::UnitX();
  double A = 2e-5, Tm = 120.0, first = 100.0, spacing = 300.0;
  int count = 6;
  TimeUs t0 = 738849600LL * kUsPerSecond;
  // theta, theta', theta'' of one slew at tau seconds from its start
  void one(double tau, double& th, double& thd, double& thdd) const {
    const double w1 = 2 * kPi / Tm, w2 = 2 * w1;
    if (tau <= 0) {
      th = thd = thdd = 0;
      return;
    }
    const double u = std::min(tau, Tm);
    th = A * ((u - std::sin(w1 * u) / w1) / (2 * w1) - (u - std::sin(w2 * u) / w2) / (4 * w2));
    thd = A * ((1 - std::cos(w1 * u)) / (2 * w1) - (1 - std::cos(w2 * u)) / (4 * w2));
    thdd = tau < Tm ? A * (std::sin(w1 * u) / 2 - std::sin(w2 * u) / 4) : 0.0;
    if (tau > Tm) th += thd * (tau - Tm);  // thd(Tm) = 0: at rest
  }
  void theta(TimeUs tu, double& th, double& thd, double& thdd) const {
    const double t = toSeconds(tu - t0);
    th = thd = thdd = 0;
    for (int k = 0; k < count; ++k) {
      double a, b, c;
      one(t - first - k * spacing, a, b, c);
      th += a;
      thd += b;
      thdd += c;
    }
  }
  TimeUs peak(int k, int which) const {  // which = 0: Tm/3, 1: 2 Tm/3
    return t0 + static_cast<TimeUs>((first + k * spacing + (which + 1) * Tm / 3) * 1e6);
  }
  Quat q_I_B(TimeUs tu) const {
    double th, thd, thdd;
    theta(tu, th, thd, thdd);
    return q0 * quatExp(w0 * toSeconds(tu - t0)) * quatExp(th * n);
  }
  Vec3 w_B(TimeUs tu) const {
    double th, thd, thdd;
    theta(tu, th, thd, thdd);
    return quatExp(th * n).conjugate() * w0 + thd * n;
  }
  Vec3 alpha_B(TimeUs tu) const {
    double th, thd, thdd;
    theta(tu, th, thd, thdd);
    const Vec3 w0b = quatExp(th * n).conjugate() * w0;
    return thdd * n - thd * n.cross(w0b);
  }
};

struct ManoeuvreRun {
  std::map<TimeUs, RateOutput> rows;
  Health health;
};

// The rate filter over the samples (t, q) except those marked in `drop`.
ManoeuvreRun runManoeuvres(const std::vector<TimeUs>& t, const std::vector<Quat>& q,
                           const std::vector<bool>& drop, BridgeFit fit) {
  CrnConfig c = attitudeCrn();
  c.gap_policy = GapPolicy::kBridge;
  c.max_bridge_samples = 20;
  c.bridge_fit = fit;
  AttitudeRates r;
  EXPECT_EQ(r.configure(c), Status::kOk);
  ManoeuvreRun out;
  for (std::size_t i = 0; i < t.size(); ++i) {
    if (drop[i]) continue;
    EXPECT_TRUE(accepted(r.step(t[i], q[i])));
    for (int o = 0; o < r.numOutputs(); ++o) out.rows[r.output(o).t] = r.output(o);
  }
  out.health = r.health();
  return out;
}

// The test: gaps of 1-20 samples of the attitude stream (every head) at the peaks of angular
// acceleration inside manoeuvres. Unflagged rows within 3x of the no-gap run's rms error against truth;
// flagged rows (their window holds bridged samples) within 3 of their published sigmas: the attitude
// noise through the kernel (noiseGain) and the bridged samples' bound, in quadrature. Straight-line
// bridging fails the same check.
// slow: the nominal sigmas are checked against truth too (fast slews carry the CRN's band-limit bias,
// which no sigma here claims to cover).
void gapsAtPeaks(double A, double Tm, bool slow) {
  Rng rng(41);
  Manoeuvres m;
  m.A = A;
  m.Tm = Tm;
  m.q0 = test::randomQuat(rng);
  m.n = Vec3(0.4, 0.8, -0.45).normalized();
  const double sigma = 2.0 * kRadPerArcsec;  // white attitude noise per axis
  std::vector<TimeUs> t;
  std::vector<Quat> q;
  const int n = static_cast<int>((m.first + m.count * m.spacing) * 2);
  for (int i = 0; i < n; ++i) {
    t.push_back(m.t0 + 30000 + static_cast<TimeUs>(i) * 500000);
    q.push_back(m.q_I_B(t.back()) * quatExp(test::randomVec(rng, sigma)));
  }
  const std::vector<bool> none(t.size(), false);
  const ManoeuvreRun ref = runManoeuvres(t, q, none, BridgeFit::kLocalFit);
  double sw = 0, sa = 0;
  for (const auto& [tt, o] : ref.rows) {
    sw += (o.w_X - m.w_B(tt)).squaredNorm();
    sa += (o.alpha_X - m.alpha_B(tt)).squaredNorm();
    EXPECT_EQ(o.bridged, 0);
  }
  const double ew = std::sqrt(sw / ref.rows.size()), ea = std::sqrt(sa / ref.rows.size());
  ASSERT_GT(ref.rows.size(), 1500u);

  AttitudeRates probe;
  ASSERT_EQ(probe.configure(attitudeCrn()), Status::kOk);
  const double nom_w = sigma * probe.noiseGain(1), nom_a = sigma * probe.noiseGain(2);
  // the no-gap rows against truth (per axis, the nominal sigma): the reference is itself consistent
  int ref_out = 0;
  for (const auto& [tt, o] : ref.rows) {
    const Vec3 dw = o.w_X - m.w_B(tt), da = o.alpha_X - m.alpha_B(tt);
    ref_out += dw.cwiseAbs().maxCoeff() > 3 * nom_w || da.cwiseAbs().maxCoeff() > 3 * nom_a;
  }
  if (slow) {
    EXPECT_LT(ref_out, static_cast<int>(ref.rows.size()) / 50);  // white: ~1.6 % beyond 3 sigma on one of 6
  }
  std::printf("no gap: %d of %zu rows beyond 3 nominal sigmas on one of their 6 components\n", ref_out, ref.rows.size());

  const std::vector<int> lengths = {1, 2, 5, 10, 15, 20};
  for (int arrangement = 0; arrangement < 2; ++arrangement) {
    std::vector<bool> drop(t.size(), false);
    std::vector<TimeUs> gap_tags;
    for (int k = 0; k < m.count; ++k) {
      const int len = lengths[static_cast<std::size_t>(arrangement == 0 ? k : m.count - 1 - k)];
      const TimeUs pk = m.peak(k, (k + arrangement) % 2);
      const auto centre = static_cast<int>((pk - t[0] + 250000) / 500000);
      for (int i = centre - len / 2; i < centre - len / 2 + len; ++i) {
        drop[static_cast<std::size_t>(i)] = true;
        gap_tags.push_back(t[static_cast<std::size_t>(i)]);
      }
    }
    double worst[2] = {0, 0}, worst_unflagged[2] = {0, 0}, worst_diff[2] = {0, 0};
    int flagged[2] = {0, 0}, beyond_diff[2] = {0, 0}, beyond_truth[2] = {0, 0};
    const CrnKernel& kern = probe.stream().kernel();
    std::map<TimeUs, RateOutput> local_rows;  // the local fit's rows: the published sigmas
    for (BridgeFit fit : {BridgeFit::kLocalFit, BridgeFit::kLinear}) {
      const int f = fit == BridgeFit::kLocalFit ? 0 : 1;
      const ManoeuvreRun run = runManoeuvres(t, q, drop, fit);
      EXPECT_EQ(run.health.count(Status::kGapBridged), 6u);
      EXPECT_EQ(run.health.count(Status::kGapRestarted), 0u);
      ASSERT_EQ(run.rows.size(), ref.rows.size());
      if (f == 0) local_rows = run.rows;
      for (const auto& [tt, o] : run.rows) {
        // flagged exactly when the window (+-35 s: M = 70 samples) holds a dropped sample; the noise
        // those samples had in the no-gap run, through the kernel (per axis)
        int expect_bridged = 0;
        double g1 = 0, g2 = 0;
        for (TimeUs g : gap_tags) {
          const long long j = (g - tt + (g > tt ? 250000 : -250000)) / 500000;
          if (std::llabs(j) > kern.half) continue;
          ++expect_bridged;
          g1 += std::pow(kern.g[1][static_cast<std::size_t>(j + kern.half)], 2);
          g2 += std::pow(kern.g[2][static_cast<std::size_t>(j + kern.half)], 2);
        }
        ASSERT_EQ(o.bridged, expect_bridged) << toSeconds(tt - m.t0);
        const Vec3 dw = o.w_X - m.w_B(tt), da = o.alpha_X - m.alpha_B(tt);
        if (o.bridged == 0) {
          worst_unflagged[f] = std::max({worst_unflagged[f], dw.norm() / ew, da.norm() / ea});
          continue;
        }
        ++flagged[f];
        worst[f] = std::max({worst[f], dw.norm() / ew, da.norm() / ea});
        const RateOutput& pub = local_rows.at(tt);
        ASSERT_TRUE(std::isfinite(pub.w_sigma_bridge) && std::isfinite(pub.alpha_sigma_bridge));
        // (a) against the no-gap run: the bridged values against the removed samples
        const RateOutput& r0 = ref.rows.at(tt);
        // (floors far below any error: a sample on the window's outermost tap has a zero weight, and
        // the difference is then rounding only)
        const double sdw = std::max(std::hypot(pub.w_sigma_bridge, sigma * std::sqrt(g1)), 1e-9 * ew);
        const double sda = std::max(std::hypot(pub.alpha_sigma_bridge, sigma * std::sqrt(g2)), 1e-9 * ea);
        const double rd = std::max((o.w_X - r0.w_X).cwiseAbs().maxCoeff() / sdw,
                                   (o.alpha_X - r0.alpha_X).cwiseAbs().maxCoeff() / sda);
        worst_diff[f] = std::max(worst_diff[f], rd);
        beyond_diff[f] += rd > 3;
        if (rd > 3 && f == 0)
          std::printf("row %.1f s bridged %d: dw %.3e sdw %.3e (pub %.3e) da %.3e sda %.3e\n", toSeconds(tt - m.t0),
                      o.bridged, (o.w_X - r0.w_X).cwiseAbs().maxCoeff(), sdw, pub.w_sigma_bridge,
                      (o.alpha_X - r0.alpha_X).cwiseAbs().maxCoeff(), sda);
        // (b) against truth: the published total (nominal noise and bridging in quadrature)
        const double rt = std::max(dw.cwiseAbs().maxCoeff() / std::hypot(nom_w, pub.w_sigma_bridge),
                                   da.cwiseAbs().maxCoeff() / std::hypot(nom_a, pub.alpha_sigma_bridge));
        beyond_truth[f] += rt > 3;
        if (f == 1) {
          EXPECT_TRUE(std::isnan(o.w_sigma_bridge));  // a line has no uncertainty model
        }
      }
    }
    std::printf("A %.0e, Tm %.0f s, arrangement %d, %d flagged rows. Local fit: worst error / no-gap rms %.2f (unflagged rows %.2f); "
                "difference to no-gap / its sigma worst %.2f, beyond 3: %d; error beyond 3 published sigmas: %d rows. "
                "Straight line: %.1f; %.1f, %d; %d rows\n",
                A, Tm, arrangement, flagged[0], worst[0], worst_unflagged[0], worst_diff[0], beyond_diff[0], beyond_truth[0],
                worst[1], worst_diff[1], beyond_diff[1], beyond_truth[1]);
    EXPECT_EQ(flagged[0], flagged[1]);
    EXPECT_GT(flagged[0], 6 * 60);
    EXPECT_LE(worst_unflagged[0], 3.0);
    EXPECT_EQ(beyond_diff[0], 0);  // every flagged row
    // the straight line fails it: flagged rows beyond 3 of the local fit's sigmas, errors far larger
    EXPECT_GT(beyond_diff[1], 0);
    EXPECT_GT(worst[1], 3.0 * worst[0]);
    if (slow) {
      // against truth the nominal part is Gaussian: as many rows beyond 3 sigma as without the gap
      EXPECT_LE(beyond_truth[0], std::max(3, 2 * flagged[0] * ref_out / static_cast<int>(ref.rows.size())));
      EXPECT_GT(beyond_truth[1], beyond_truth[0]);
    }
  }
}

// Six 1-deg slews of 120 s (peak angular acceleration 1.3e-5 rad/s^2).
TEST(RatesGaps, GapsAtPeaksOfManoeuvreAccelerationFollowTheMotionAndFlaggedRowsCarryTheirSigma) {
  gapsAtPeaks(2e-5, 120.0, true);
}

// Slews of 40 s and 16 deg (peak 2e-3 rad/s^2, as the short calibration scenario's manoeuvres): the
// curvature changes within the gap, the fit takes the shortest span.
TEST(RatesGaps, GapsAtPeaksOfFastManoeuvresStayWithinTheirSigmas) { gapsAtPeaks(3e-3, 40.0, false); }

}  // namespace
}  // namespace boresight::core
