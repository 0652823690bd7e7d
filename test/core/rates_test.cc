// Rates: constant-rate and sinusoidal rotations give the right rate and angular acceleration in
// the head frames; the accelerometer's angular acceleration, low-passed by the same CRN, lands on the
// same tags in the same frame and agrees with the star-sensor value.
#include "boresight/core/rates.h"

#include "core_test_util.h"

#include <gtest/gtest.h>

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

}  // namespace
}  // namespace boresight::core
