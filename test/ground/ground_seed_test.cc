// The seed solver's steps against hand-computed cases.
#include <boresight/core/rotation.h>
#include <boresight/ground/simulate.h>
#include <boresight/ground/solver.h>

#include <gtest/gtest.h>

#include <cmath>

namespace {

using namespace boresight;
using namespace boresight::ground;

Mat3 rotZ(double a) { return core::so3Exp(Vec3(0, 0, a)); }

PrismReading prism(const Vec3& axis_t, double az_deg, double el_deg) {
  PrismReading p;
  p.axis_t = axis_t;
  p.az_rad = az_deg * kRadPerDeg;
  p.el_rad = el_deg * kRadPerDeg;
  return p;
}

TEST(GroundGeometry, AzimuthElevationConventions) {
  // azimuth counterclockwise from lab x seen from above: 90 deg is lab +y; elevation 90 is up
  EXPECT_NEAR((directionFromAzEl(0, 0) - Vec3::UnitX()).norm(), 0, 1e-15);
  EXPECT_NEAR((directionFromAzEl(90 * kRadPerDeg, 0) - Vec3::UnitY()).norm(), 0, 1e-15);
  EXPECT_NEAR((directionFromAzEl(0.3, 90 * kRadPerDeg) - Vec3::UnitZ()).norm(), 0, 1e-15);
  const Vec3 d = directionFromAzEl(30 * kRadPerDeg, 60 * kRadPerDeg);  // (cos60 cos30, cos60 sin30, sin60)
  EXPECT_NEAR(d.x(), 0.5 * std::sqrt(3.0) / 2, 1e-15);
  EXPECT_NEAR(d.y(), 0.25, 1e-15);
  EXPECT_NEAR(d.z(), std::sqrt(3.0) / 2, 1e-15);
  double a = 0, e = 0;
  azElFromDirection(d, a, e);
  EXPECT_NEAR(a, 30 * kRadPerDeg, 1e-15);
  EXPECT_NEAR(e, 60 * kRadPerDeg, 1e-15);
}

TEST(GroundGeometry, PinholeByHand) {
  // d = (0.1, -0.05, 1): u = 512 + 2800 * 0.1 = 792, v = 512 + 2800 * 1.001 * (-0.05) = 371.86
  Intrinsics c;
  c.sx = 1.001;
  double u = 0, v = 0;
  ASSERT_TRUE(projectPoint(Vec3(0.1, -0.05, 1.0), c, u, v));
  EXPECT_NEAR(u, 792.0, 1e-12);
  EXPECT_NEAR(v, 371.86, 1e-12);
  // k1 = 0.01: factor 1 + 0.01 * 0.0125 = 1.000125
  c.k1 = 0.01;
  ASSERT_TRUE(projectPoint(Vec3(0.1, -0.05, 1.0), c, u, v));
  EXPECT_NEAR(u, 512 + 280 * 1.000125, 1e-12);
  const Vec3 back = unprojectPixel(u, v, c);
  EXPECT_NEAR((back - Vec3(0.1, -0.05, 1.0).normalized()).norm(), 0, 1e-12);
  EXPECT_FALSE(projectPoint(Vec3(0.1, 0, -1.0), c, u, v));  // behind the sensor
}

TEST(GroundSeed, LevelAndYawLevelVehicle) {
  // level (f along +z), the +x face at azimuth 30 deg: x_t is lab (cos30, sin30, 0), so C_t_m = Rz(30)^T
  Mat3 C;
  ASSERT_TRUE(levelAndYaw(Vec3(0, 0, 9.8), {prism(Vec3::UnitX(), 30, 0)}, C));
  Mat3 expect;
  const double c = std::sqrt(3.0) / 2, s = 0.5;
  expect << c, s, 0, -s, c, 0, 0, 0, 1;
  EXPECT_NEAR((C - expect).norm(), 0, 1e-14);
  // the +y face at azimuth 120 deg says the same
  ASSERT_TRUE(levelAndYaw(Vec3(0, 0, 9.8), {prism(Vec3::UnitY(), 120, 0)}, C));
  EXPECT_NEAR((C - expect).norm(), 0, 1e-14);
}

TEST(GroundSeed, LevelAndYawPitchedVehicle) {
  // nose up by 10 deg about lab y, x_t at azimuth 0: f_t = g (sin10, 0, cos10) (sin(theta) = f_x / g),
  // C_t_m columns: x_m in t = (cos10, 0, -sin10), y_m = (0, 1, 0), z_m = (sin10, 0, cos10).
  const double th = 10 * kRadPerDeg;
  Mat3 C;
  ASSERT_TRUE(levelAndYaw(9.8 * Vec3(std::sin(th), 0, std::cos(th)), {prism(Vec3::UnitX(), 0, 10)}, C));
  Mat3 expect;
  expect << std::cos(th), 0, std::sin(th), 0, 1, 0, -std::sin(th), 0, std::cos(th);
  EXPECT_NEAR((C - expect).norm(), 0, 1e-14);
}

TEST(GroundSeed, YawIsTheWeightedMeanOfTwoFaces) {
  // +x face reads 31 deg, +y face reads 119 deg (i.e. 29 deg): equal weights, mean 30 deg
  Mat3 C;
  ASSERT_TRUE(levelAndYaw(Vec3(0, 0, 9.8), {prism(Vec3::UnitX(), 31, 0), prism(Vec3::UnitY(), 119, 0)}, C));
  EXPECT_NEAR((C - rotZ(30 * kRadPerDeg).transpose()).norm(), 0, 1e-14);
  // a face along the vertical carries no yaw: alone it is an error
  EXPECT_FALSE(levelAndYaw(Vec3(0, 0, 9.8), {prism(Vec3::UnitZ(), 0, 90)}, C));
}

TEST(GroundSeed, CoefficientMatrixAndOrthonormalisationByHand) {
  // C_s_m = Rz(90 deg): sensor x = lab y, sensor y = -lab x, boresight = lab z. Four targets at
  // (x, y) = (+-0.1, +-0.1) in the image: r_m = C_s_m^T (x, y, 1) / norm. P must be C_s_m up to scale.
  const Mat3 C_s_m = rotZ(90 * kRadPerDeg);
  std::vector<Vec3> r;
  std::vector<Eigen::Vector2d> xy;
  for (double x : {-0.1, 0.1})
    for (double y : {-0.1, 0.1}) {
      r.push_back(C_s_m.transpose() * Vec3(x, y, 1).normalized());
      xy.emplace_back(x, y);
    }
  Mat3 P, C;
  ASSERT_TRUE(coefficientMatrix(r, xy, P));
  EXPECT_NEAR((P / P(2, 2) - C_s_m).norm(), 0, 1e-12);  // P(2,2): the boresight row's z component
  ASSERT_TRUE(orthonormalise(P, C));
  EXPECT_NEAR((C - C_s_m).norm(), 0, 1e-12);
  // fewer than four targets: refused
  r.pop_back();
  xy.pop_back();
  EXPECT_FALSE(coefficientMatrix(r, xy, P));
}

TEST(GroundSeed, OrthonormaliseSharesTheSkewOfRows1And2) {
  // rows 1 and 2 skewed by 2e-3 rad towards each other, row 3 (perspective) off by 1e-2:
  // the result is the identity to second order (row 3 does not enter).
  Mat3 P;
  P << 1, 2e-3, 0, 2e-3, 1, 0, 1e-2, -1e-2, 1;
  Mat3 C;
  ASSERT_TRUE(orthonormalise(P, C));
  EXPECT_LT(core::so3Log(C).norm(), 1e-5);
  // a mirror image (row 3 against row1 x row2) is refused
  P << 1, 0, 0, 0, 1, 0, 0, 0, -1;
  EXPECT_FALSE(orthonormalise(P, C));
}

TEST(GroundSeed, MeanRotation) {
  const Mat3 a = core::so3Exp(Vec3(0.01, 0.02, -0.03));
  EXPECT_NEAR((meanRotation({a * rotZ(0.002), a * rotZ(-0.002)}) - a).norm(), 0, 1e-6);
  EXPECT_NEAR((meanRotation({a}) - a).norm(), 0, 1e-14);
}

SimConfig noiseless(const char* setup) {
  SimConfig cfg;
  applySetup(setup, cfg);
  cfg.seed = 5;
  cfg.centroid_sigma_px = 0;
  cfg.theodolite_sigma_arcsec = 0;
  cfg.accel_noise_ug = 0;
  cfg.draw_intrinsics = false;
  cfg.fixed_bias = true;
  cfg.bias_ug = Vec3::Zero();
  return cfg;
}

TEST(GroundSeed, NoiselessWithoutBiasIsExact) {
  for (const char* setup : {"single", "turned", "tilted"}) {
    Measurement m;
    SimTruth t;
    ASSERT_TRUE(simulateGround(noiseless(setup), m, t, nullptr));
    SeedResult s;
    std::string err;
    ASSERT_TRUE(solveSeed(m, s, &err)) << err;
    EXPECT_LT((s.error_angles_rad - t.error_angles_rad).norm() * kArcsecPerRad, 1e-6) << setup;
    for (std::size_t k = 0; k < t.C_t_m.size(); ++k) EXPECT_NEAR((s.C_t_m[k] - t.C_t_m[k]).norm(), 0, 1e-10);
  }
}

TEST(GroundSeed, BiasTiltsTheLevelByBOverG) {
  // Hand computation: with b = (0, b, 0) the seed's gravity direction in t is (0, b/g, 1)/norm, a
  // rotation of C_t_m by phi_t = (-b/g, 0, 0); so C_s_t(seed) = C_s_t Exp(-phi_t) and the seed's error
  // angles move by + C_s_t (b/g, 0, 0) (sensor axes). 100 ug -> 1e-4 rad = 20.6".
  SimConfig cfg = noiseless("single");
  cfg.bias_ug = Vec3(0, 100, 0);
  cfg.level_sigma_deg = 0;  // exactly level and at azimuth 0: the hand computation holds to 2nd order
  Measurement m;
  SimTruth t;
  ASSERT_TRUE(simulateGround(cfg, m, t, nullptr));
  SeedResult s;
  ASSERT_TRUE(solveSeed(m, s, nullptr));
  // (compared as Log(C_seed C_true^T): differences of error angles would add a BCH term e x phi / 2)
  const Mat3 C_true = t.q_s_t.toRotationMatrix();
  const Vec3 expect = C_true * Vec3(1e-4, 0, 0);
  const Vec3 got = core::so3Log(s.C_s_t * C_true.transpose());
  EXPECT_LT((got - expect).norm() * kArcsecPerRad, 1e-3) << got.transpose() * kArcsecPerRad;
}

}  // namespace
