// Orbits: the circular LEO model, and positions read back from a GNV1B file (simulated and real).
#include "real_data.h"
#include "sim_test_util.h"
#include "test_files.h"

#include <boresight/model/orbit_context.h>
#include <boresight/model/ephemeris.h>
#include <boresight/sim/output.h>

#include <filesystem>

namespace boresight {
namespace {

namespace fs = std::filesystem;

TEST(SimOrbit, CircularOrbitHasTheConfiguredGeometry) {
  sim::OrbitConfig c;
  c.altitude_m = 490e3;
  c.inclination_rad = 89 * kRadPerDeg;
  c.raan_rad = 120 * kRadPerDeg;
  c.arg_lat0_rad = 10 * kRadPerDeg;
  c.j2_nodal_precession = false;  // exact Keplerian geometry (J2 makes the node drift ~1e-8 rad/s)
  const double t0 = 738849600.0;
  sim::CircularOrbit o(c, t0);
  const auto s = o.state(t0);
  EXPECT_NEAR(s.r_I.norm(), model::kEarthRadius_m + 490e3, 1e-6);
  EXPECT_NEAR(s.arg_lat_rad, 10 * kRadPerDeg, 1e-12);
  EXPECT_NEAR(o.state(t0 + 1000).arg_lat_rad, 10 * kRadPerDeg + 1000 * o.meanMotion(), 1e-12);
  const Vec3 h = s.r_I.cross(s.v_I).normalized();
  EXPECT_NEAR(std::acos(h.z()), 89 * kRadPerDeg, 1e-6);
  // Period about 94.4 min at 490 km.
  EXPECT_NEAR(2 * kPi / o.meanMotion(), 5664, 10);
  EXPECT_NEAR(s.v_I.norm(), std::sqrt(model::kEarthMu_m3_s2 / (model::kEarthRadius_m + 490e3)), 1e-6);
  EXPECT_NEAR(s.v_I.norm(), 7618.1, 0.1);
}

TEST(SimOrbit, MeasuredDataGetTheSimulatorsOrbitContext) {
  // The context an estimator builds from GNI1B/GNV1B samples (model::effectContext) is the one the
  // simulator's effects saw: same u and beta definitions (one code path), Sun and Earth velocity from
  // the model's series instead of the simulator's.
  const auto sc = simtest::gracefo();
  sim::Simulator s;
  std::string err;
  ASSERT_TRUE(s.init(sc, 1, 6000, &err)) << err;
  for (double t_rel = 0; t_rel < 6000; t_rel += 613) {
    const double t = toSeconds(sc.start) + t_rel;
    Vec3 r, v;
    s.orbit().posVel(t, r, v);
    model::OrbitSample o;
    ASSERT_TRUE(model::orbitSampleFromInertial(sc.start + static_cast<TimeUs>(std::llround(t_rel * 1e6)), r, v, o));
    const model::OrbitContext a = model::effectContext(o, t_rel), b = s.context(t_rel);
    EXPECT_EQ(a.t_s, b.t_s);
    EXPECT_EQ(a.arg_lat_rad, b.arg_lat_rad);  // the same function of the same r, v
    EXPECT_NEAR(a.beta_rad, b.beta_rad, 2e-4);  // 0.01 deg: two low-precision Sun series
    EXPECT_EQ(a.v_sat_I, b.v_sat_I);
    EXPECT_LT((a.v_earth_I - b.v_earth_I).norm(), 1e-3 * b.v_earth_I.norm());
  }
}

TEST(SimOrbit, Gnv1bOrbitReproducesTheOrbitItWasWrittenFrom) {
  const auto sc = simtest::gracefo();
  const fs::path dir = testutil::makeTempDir("boresight_sim_gnv");
  sim::Simulator s;
  std::string err;
  ASSERT_TRUE(s.init(sc, 1, 900, &err)) << err;
  sim::Level1Sink l1;
  ASSERT_TRUE(l1.open(dir.string(), sc, &err)) << err;
  s.run(l1);
  ASSERT_TRUE(l1.close(&err)) << err;
  sim::OrbitConfig g;
  g.type = sim::OrbitConfig::Type::Gnv1b;
  g.gnv1b_file = l1.files()[2];
  auto o = sim::makeOrbit(g, toSeconds(sc.start), 800, &err);
  ASSERT_TRUE(o) << err;
  double max_dr = 0, max_dv = 0;
  for (double t = 0.37; t < 800; t += 13.1) {
    Vec3 r1, v1, r2, v2;
    s.orbit().posVel(toSeconds(sc.start) + t, r1, v1);
    o->posVel(toSeconds(sc.start) + t, r2, v2);
    max_dr = std::max(max_dr, (r1 - r2).norm());
    max_dv = std::max(max_dv, (v1 - v2).norm());
  }
  std::printf("GNV1B (1 Hz, Earth-fixed) -> inertial Hermite interpolation: max |dr| %.2e m, |dv| %.2e m/s\n", max_dr,
              max_dv);
  EXPECT_LT(max_dr, 1e-3);
  EXPECT_LT(max_dv, 1e-5);
  // A span the file does not cover is an error, not an extrapolation.
  EXPECT_FALSE(sim::makeOrbit(g, toSeconds(sc.start), 5000, &err));
  EXPECT_NE(err.find("do not cover"), std::string::npos) << err;
  fs::remove_all(dir);
}

TEST(SimOrbit, RealGnv1bExcerptDrivesTheSimulator) {
  BORESIGHT_REQUIRE_REAL_DATA();
  auto sc = simtest::gracefo();
  sc.orbit.type = sim::OrbitConfig::Type::Gnv1b;
  sc.orbit.gnv1b_file = test::realFile("gracefo/2023-06-01_L1B/GNV1B_2023-06-01_C_04.txt");
  simtest::Run r;
  std::string err;
  ASSERT_TRUE(r.sim.init(sc, 1, 90, &err)) << err;
  r.sim.run(r.cap);
  ASSERT_EQ(r.cap.orb.size(), 90u);
  const double alt = r.cap.orb[0].r_I.norm() - model::kEarthRadius_m;
  std::printf("real GNV1B: altitude above the equatorial radius %.1f km, speed %.1f m/s, beta %.1f deg\n", alt / 1e3,
              r.cap.orb[0].v_I.norm(), r.sim.context(0).beta_rad / kRadPerDeg);
  EXPECT_GT(alt, 350e3);
  EXPECT_LT(alt, 550e3);
  EXPECT_NEAR(r.cap.orb[0].v_I.norm(), 7600, 100);
  // The simulated GNV1B reproduces the real Earth-fixed positions at the same epochs (round trip
  // through the inertial frame).
  EXPECT_LT((r.cap.orb[0].r_E - Vec3(562516.6928322315, -2051148.109060925, -6546817.760876593)).norm(), 1e-3);
  EXPECT_GT(r.cap.head(1).size(), 100u);
}

}  // namespace
}  // namespace boresight
