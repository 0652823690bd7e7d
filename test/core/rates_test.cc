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

GapRun runRates(const NoisyStream& s, int gap_first, int gap_len, GapPolicy pol) {
  CrnConfig c = attitudeCrn();
  c.gap_policy = pol;
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

}  // namespace
}  // namespace boresight::core
