// Method A solver on synthetic spans through the real SpanBuilder (full CRN chain).
#include "synthetic.h"

#include <gtest/gtest.h>

namespace boresight::calib {
namespace {

synth::Config manoeuvreCase(std::uint64_t seed) {
  synth::Config c;
  c.seed = seed;
  c.q_S_B_nominal = synth::gracefoMountings();
  c.duration_s = 3900;
  c.manoeuvres = synth::threeAxisManoeuvres(150.0, 1200.0);
  c.truth.r_S[0] = Vec3(300, -200, 500) * kRadPerArcsec;
  c.truth.r_S[1] = Vec3(-250, 400, -300) * kRadPerArcsec;
  c.truth.r_S[2] = Vec3(100, 350, 600) * kRadPerArcsec;
  c.truth.acc_bias = Vec3(1.31e-5, 1.19e-4, -7.81e-4);
  return c;
}

CalibrationSpan build(const synth::Config& c) {
  SpanBuilder b;
  std::string err;
  EXPECT_TRUE(synth::generate(c, b, &err)) << err;
  return b.span();
}

TEST(CalibSpanBuilder, OneObservationPerDecimationWithAllHeads) {
  const synth::Config c = manoeuvreCase(1);
  const CalibrationSpan s = build(c);
  ASSERT_EQ(s.n_heads, 3);
  // the CRN needs ~35 s each side: (3900 - 2*35.35) / 10 epochs, give or take one
  EXPECT_NEAR(static_cast<double>(s.obs.size()), (3900 - 70.7) / 10.0, 2.0);
  for (std::size_t k = 1; k < s.obs.size(); ++k) EXPECT_EQ(s.obs[k].t - s.obs[k - 1].t, 10 * kUsPerSecond);
  for (const Observation& o : s.obs)
    for (int h = 0; h < 3; ++h) EXPECT_TRUE(o.has_head[static_cast<std::size_t>(h)]);
  EXPECT_EQ(s.relative.size(), 3u);
  EXPECT_GT(s.noise_correlation.size(), 2u);
  EXPECT_NEAR(s.noise_correlation[1], 0.40, 0.02);  // the CRN second-derivative kernel at 10 s
}

TEST(CalibSpanBuilder, HeadAccelerationMatchesTruthInHeadFrame) {
  // noise-free heads: alpha_S of the CRN equals the filtered truth C_Sh_B C_B_A K^-1 (a_A - b)
  synth::Config c = manoeuvreCase(2);
  c.sigma_cross_arcsec = 1e-6;
  c.sigma_roll_arcsec = 1e-6;
  c.acc_white = Vec3::Zero();
  const CalibrationSpan s = build(c);
  ASSERT_GT(s.obs.size(), 100u);
  const Mat3 Kinv = synth::accK(c.truth).inverse();
  double worst = 0, peak = 0;
  for (const Observation& o : s.obs)
    for (int h = 0; h < 3; ++h) {
      const Mat3 C = core::so3Exp(c.truth.r_S[static_cast<std::size_t>(h)]) *
                     c.q_S_B_nominal[static_cast<std::size_t>(h)].toRotationMatrix() * c.C_B_A;
      const Vec3 pred = C * Kinv * (o.alpha_A - c.truth.acc_bias);
      worst = std::max(worst, (o.alpha_S[static_cast<std::size_t>(h)] - pred).norm());
      peak = std::max(peak, o.alpha_S[static_cast<std::size_t>(h)].norm());
    }
  EXPECT_GT(peak, 3e-5);          // the manoeuvres are there (1 deg at 100 s: 6.9e-5 rad/s^2)
  EXPECT_LT(worst, 2e-3 * peak);  // same filter, same tags: only the filters' discretisation differs
}

TEST(CalibSolver, HardConstraintRecoversErrorAnglesWithinSigma) {
  const synth::Config c = manoeuvreCase(3);
  const CalibrationSpan s = build(c);
  SolveOptions o;
  const SolveResult r = solve(s, o);
  ASSERT_TRUE(r.ok) << r.message;
  ASSERT_EQ(r.heads.size(), 3u);
  for (int h = 0; h < 3; ++h)
    for (int i = 0; i < 3; ++i) {
      const auto& hr = r.heads[static_cast<std::size_t>(h)];
      ASSERT_TRUE(hr.observable[static_cast<std::size_t>(i)]);
      ASSERT_TRUE(hr.sigma_arcsec[static_cast<std::size_t>(i)].has_value());
      const double sig = *hr.sigma_arcsec[static_cast<std::size_t>(i)];
      const double err = hr.error_angles_arcsec[static_cast<std::size_t>(i)] -
                         c.truth.r_S[static_cast<std::size_t>(h)][i] * kArcsecPerRad;
      EXPECT_LT(std::abs(err), 4.5 * sig) << "head " << h << " axis " << i << " sigma " << sig;
      // three 1-deg manoeuvres through the 0.1 Hz CRN: several hundred arcsec (the bound, see the bench)
      EXPECT_LT(sig, 1500.0);
      EXPECT_GE(sig, 0.999 * hr.crlb_arcsec[static_cast<std::size_t>(i)]);
      EXPECT_LT(sig, 1.5 * hr.crlb_arcsec[static_cast<std::size_t>(i)]);
    }
  ASSERT_TRUE(r.acc_bias_radps2.has_value());
  for (int i = 0; i < 3; ++i)
    EXPECT_LT(std::abs(r.acc_bias_radps2->value[static_cast<std::size_t>(i)] - c.truth.acc_bias[i]),
              4.5 * r.acc_bias_radps2->sigma[static_cast<std::size_t>(i)].value_or(0));
  EXPECT_TRUE(r.unobservable_directions_B.empty());
}

TEST(CalibSolver, RefusesTooFewEpochs) {
  synth::Config c = manoeuvreCase(4);
  c.duration_s = 16;  // the real Level-1 excerpts: 16 s
  const CalibrationSpan s = build(c);
  EXPECT_TRUE(s.obs.empty());
  const SolveResult r = solve(s, SolveOptions{});
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.message.find("too few epochs"), std::string::npos) << r.message;
  EXPECT_NE(r.message.find("each side"), std::string::npos) << r.message;
}

}  // namespace
}  // namespace boresight::calib
