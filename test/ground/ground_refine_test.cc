// The joint refinement: exact on noiseless data, the observability decision per set-up, the hidden
// tilt of an unseparated bias, the cross-boresight limit set by the principal point's prior.
#include <boresight/core/rotation.h>
#include <boresight/ground/simulate.h>
#include <boresight/ground/solver.h>
#include <boresight/model/jacobian_check.h>

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <set>
#include <string>

namespace {

using namespace boresight;
using namespace boresight::ground;

constexpr double kUg = 9.80665e-6;

SimConfig noiseless(const char* setup, const Vec3& bias_ug) {
  SimConfig cfg;
  applySetup(setup, cfg);
  cfg.seed = 11;
  cfg.centroid_sigma_px = 0;
  cfg.theodolite_sigma_arcsec = 0;
  cfg.accel_noise_ug = 0;
  cfg.draw_intrinsics = false;
  cfg.fixed_bias = true;
  cfg.bias_ug = bias_ug;
  return cfg;
}

/// Simulates, restores the default noise model (the simulator wrote zeros) and solves.
GroundResult solve(const SimConfig& cfg, SimTruth& t, const RefineOptions& opt = RefineOptions{}) {
  Measurement m;
  EXPECT_TRUE(simulateGround(cfg, m, t, nullptr));
  m.noise = NoiseModel{};
  m.noise.accel_sigma_mps2 = 50 * kUg;
  GroundResult r;
  std::string err;
  EXPECT_TRUE(solveGround(m, opt, r, &err)) << err;
  return r;
}

double errArcsec(const GroundResult& r, const SimTruth& t) {
  return core::so3Log(r.C_s_t * t.q_s_t.toRotationMatrix().transpose()).norm() * kArcsecPerRad;
}

TEST(GroundRefine, NoiselessSeparatingSetUpsAreExact) {
  for (const char* setup : {"two-faces", "tilted"}) {
    SimTruth t;
    const GroundResult r = solve(noiseless(setup, Vec3(100, -100, 100)), t);
    EXPECT_LT(errArcsec(r, t), 1e-3) << setup;
    EXPECT_LT((r.bias_mps2 - t.bias_mps2).norm() / kUg, 0.01) << setup << ": " << r.bias_mps2.transpose() / kUg;
    for (int j = 0; j < 3; ++j) EXPECT_TRUE(r.bias_observable[j]) << setup << " axis " << j;
    EXPECT_EQ(r.hidden_tilt_rad.norm(), 0.0);
    EXPECT_LT(r.residual_rms_px, 1e-6);
    // the seed, ignoring the bias, is off by about |b_xy| / g = 29"
    const double seed_err =
        core::so3Log(r.seed.C_s_t * t.q_s_t.toRotationMatrix().transpose()).norm() * kArcsecPerRad;
    EXPECT_GT(seed_err, 20.0) << setup;
  }
}

TEST(GroundRefine, ObservabilityPerSetUp) {
  struct Case {
    const char* setup;
    bool x, y, z;
  };
  // one face (+x): the pitch is referenced by the prism, the roll is not -> b_y hidden; b_z is
  // separated through |f| = g. Turning about the vertical adds nothing; a second face or a tilt does.
  for (const Case c : {Case{"single", true, false, true}, Case{"turned", true, false, true},
                       Case{"two-faces", true, true, true}, Case{"tilted", true, true, true}}) {
    SimTruth t;
    SimConfig cfg = noiseless(c.setup, Vec3(100, -100, 100));
    cfg.centroid_sigma_px = 0.05;  // realistic noise: the decision must not depend on exact data
    cfg.theodolite_sigma_arcsec = 1.5;
    cfg.accel_noise_ug = 50;
    const GroundResult r = solve(cfg, t);
    EXPECT_EQ(r.bias_observable[0], c.x) << c.setup;
    EXPECT_EQ(r.bias_observable[1], c.y) << c.setup;
    EXPECT_EQ(r.bias_observable[2], c.z) << c.setup;
    EXPECT_EQ(r.rank, c.y ? r.parameters : r.parameters - 1) << c.setup;  // one null direction when hidden
  }
}

TEST(GroundRefine, UnseparatedBiasIsReportedAsHiddenTilt) {
  // single position, one face, b = (0, 100 ug, 0): the refined mounting keeps the tilt b/g about x_t,
  // i.e. C_s_t (1e-4, 0, 0) rad in sensor axes (the hand computation of the seed test), and says so.
  SimConfig cfg = noiseless("single", Vec3(0, 100, 0));
  cfg.level_sigma_deg = 0;
  SimTruth t;
  const GroundResult r = solve(cfg, t);
  const Mat3 C = t.q_s_t.toRotationMatrix();
  const Vec3 tilt = C * Vec3(1e-4, 0, 0);
  const Vec3 err = core::so3Log(r.C_s_t * C.transpose());
  EXPECT_LT((err - tilt).norm() * kArcsecPerRad, 0.05) << err.transpose() * kArcsecPerRad;
  EXPECT_FALSE(r.bias_observable[1]);
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(r.hidden_tilt_rad[i], std::abs(tilt[i]), 0.02 * 1e-4) << i;
    // never a small sigma: at least the hidden tilt
    EXPECT_GE(std::sqrt(r.error_cov_rad2(i, i)), 0.99 * r.hidden_tilt_rad[i]) << i;
  }
  EXPECT_NEAR(r.bias_sigma_mps2.y(), 100 * kUg, 1 * kUg);  // the prior: nothing learnt
  ASSERT_FALSE(r.notes.empty());
  EXPECT_NE(r.notes.front().find("NOT separated"), std::string::npos);
  // the assumed bias is configurable and the hidden tilt scales with it
  RefineOptions half;
  half.assumed_bias_mps2 = 50 * kUg;
  const GroundResult r2 = solve(cfg, t, half);
  EXPECT_NEAR(r2.hidden_tilt_rad.norm(), 0.5 * r.hidden_tilt_rad.norm(), 1e-3 * r.hidden_tilt_rad.norm());
}

TEST(GroundRefine, CrossBoresightLimitIsThePrincipalPointPrior) {
  // A principal point shift moves every target alike, as a cross-boresight rotation does (up to the
  // field-curvature term x^2 ~ 1 %): the mounting's x and y sigmas stay at sigma_pp / f (3.68" for
  // 0.05 px at 2800 px) and grow when the prior is looser; the data cannot replace it.
  double sx[2] = {0, 0};
  int i = 0;
  for (double pp_sigma : {0.05, 0.5}) {
    SimConfig cfg = noiseless("tilted", Vec3(100, -100, 100));
    cfg.camera.pp_sigma_px = pp_sigma;
    SimTruth t;
    const GroundResult r = solve(cfg, t);
    const double limit = pp_sigma / cfg.camera.nominal.f;
    sx[i++] = std::sqrt(r.error_cov_rad2(0, 0));
    if (pp_sigma == 0.05) {
      EXPECT_GT(std::sqrt(r.error_cov_rad2(0, 0)), 0.98 * limit);
      EXPECT_GT(std::sqrt(r.error_cov_rad2(1, 1)), 0.98 * limit);
      EXPECT_LT(std::sqrt(r.error_cov_rad2(0, 0)), 1.2 * limit);
      EXPECT_NEAR(r.camera_sigma.u0, pp_sigma, 0.01 * pp_sigma);  // the data add (almost) nothing
      // about the boresight the targets decide: below the limit
      EXPECT_LT(std::sqrt(r.error_cov_rad2(2, 2)), limit);
    }
  }
  EXPECT_GT(sx[1], 3.0 * sx[0]);
}

TEST(GroundRefine, RadialDistortionUnderItsPrior) {
  SimConfig cfg = noiseless("tilted", Vec3(100, -100, 100));
  cfg.true_k1 = 0.02;
  cfg.camera.estimate_k1 = true;
  cfg.camera.k1_sigma = 0.05;
  SimTruth t;
  const GroundResult r = solve(cfg, t);
  // exact data, but the prior (mean 0) shrinks the estimate by (sigma_post / sigma_prior)^2
  EXPECT_GT(r.camera_sigma.k1, 0.0);
  EXPECT_LT(r.camera_sigma.k1, 0.005);
  EXPECT_NEAR(r.camera.k1, 0.02, 0.02 * std::pow(r.camera_sigma.k1 / 0.05, 2) * 1.5 + 1e-9);
  EXPECT_LT(errArcsec(r, t), 0.05);
  // a tight prior wins over the data: k1 stays near its prior mean and the fit degrades
  cfg.camera.k1_sigma = 1e-5;
  const GroundResult tight = solve(cfg, t);
  EXPECT_LT(std::abs(tight.camera.k1), 1e-3);
  EXPECT_LE(tight.camera_sigma.k1, 1e-5);
  // the same data with k1 held at 0: the model cannot fit (residuals of tenths of a pixel)
  cfg.camera.estimate_k1 = false;
  const GroundResult held = solve(cfg, t);
  EXPECT_GT(held.residual_rms_px, 0.05);
}

// Every cost functor of the refinement against central differences of the same functor
// (ceres::GradientChecker), on simulated measurements with noise, with k1 held and free: a functor that
// drops a derivative fails here.
TEST(GroundRefine, EveryCostFunctorsJacobianAgreesWithNumericalDifferences) {
  std::set<std::string> met;
  for (const char* setup : {"single", "two-faces", "tilted"})
    for (const bool k1 : {false, true}) {
      SimConfig cfg;
      applySetup(setup, cfg);
      cfg.seed = 5;
      cfg.true_k1 = k1 ? 0.01 : 0.0;
      cfg.camera.estimate_k1 = k1;
      cfg.camera.k1_sigma = 0.05;
      Measurement m;
      SimTruth t;
      ASSERT_TRUE(simulateGround(cfg, m, t, nullptr));
      std::string err;
      const std::vector<model::JacobianCheck> r = checkJacobians(m, RefineOptions{}, 1e-6, &err);
      ASSERT_FALSE(r.empty()) << err;
      for (const model::JacobianCheck& c : r) {
        SCOPED_TRACE(std::string(setup) + " " + c.functor);
        met.insert(c.functor);
        EXPECT_GT(c.blocks, 0u);
        EXPECT_EQ(c.failed, 0u) << c.first_error;
        EXPECT_LT(c.max_relative_error, 1e-6);
        std::printf("%-10s k1 %-5s %-21s %2zu blocks, largest relative error %.2e\n", setup, k1 ? "free" : "held", c.functor.c_str(),
                    c.blocks, c.max_relative_error);
      }
    }
  EXPECT_EQ(met, (std::set<std::string>{"AccelCost", "PrismCost", "PriorCost<1>", "PriorCost<3>", "PriorCost<4>", "TargetCost",
                                        "TargetCost (k1 free)"}));
}

TEST(GroundRefine, WrongAzimuthConventionIsAnErrorNotAResult) {
  SimConfig cfg = noiseless("single", Vec3::Zero());
  Measurement m;
  SimTruth t;
  ASSERT_TRUE(simulateGround(cfg, m, t, nullptr));
  Measurement mirrored = m, turned = m;
  for (auto& tg : mirrored.positions[0].targets) tg.az_rad = -tg.az_rad;  // clockwise read as counterclockwise
  GroundResult r;
  std::string err;
  EXPECT_FALSE(solveGround(mirrored, RefineOptions{}, r, &err));
  EXPECT_NE(err.find("mirror image"), std::string::npos) << err;
  for (auto& tg : turned.positions[0].targets) tg.az_rad += kPi;  // theodolite 2's zero 180 deg off
  EXPECT_FALSE(solveGround(turned, RefineOptions{}, r, &err));
  EXPECT_NE(err.find("deg from design_q_s_t"), std::string::npos) << err;
  EXPECT_TRUE(solveGround(m, RefineOptions{}, r, &err)) << err;
}

}  // namespace
