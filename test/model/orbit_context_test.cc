// The orbit context (model/orbit_context.h): u and beta against the simulator's orbit, the Earth-fixed
// route against the inertial one, and the real GRACE-FO GNI1B / GNV1B sample (same epochs, both frames).
#include <boresight/io/level1.h>
#include <boresight/model/orbit_context.h>
#include <boresight/model/ephemeris.h>
#include <boresight/sim/orbit.h>

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <map>

#include "real_data.h"

namespace boresight {
namespace {

constexpr double kT0 = 738849600.0;  // 2023-06-01 00:00 GPS, s past GPS J2000

double wrap(double a) { return std::remainder(a, 2.0 * kPi); }

TEST(OrbitContext, ArgumentOfLatitudeAndBetaMatchTheSimulatorsOrbit) {
  sim::OrbitConfig c;
  c.inclination_rad = 89.0 * kRadPerDeg;
  c.raan_rad = 0.7;
  c.arg_lat0_rad = 1.1;
  const sim::CircularOrbit o(c, kT0);
  double max_du = 0, max_db = 0, max_rate = 0;
  for (int i = 0; i < 2000; ++i) {
    const double t = kT0 + 43.7 * i;
    const sim::OrbitState s = o.state(t);
    model::OrbitSample m;
    ASSERT_TRUE(model::orbitSampleFromInertial(static_cast<TimeUs>(std::llround(t * 1e6)), s.r_I, s.v_I, m));
    max_du = std::max(max_du, std::fabs(wrap(m.u_rad - s.arg_lat_rad)));
    max_db = std::max(max_db, std::fabs(m.beta_rad - s.beta_rad));
    max_rate = std::max(max_rate, std::fabs(m.u_rate_rad_s / o.meanMotion() - 1.0));
    // the truth of the circular orbit: u0 + n (t - t0) (the osculating plane of r x v differs from the
    // precessing plane by the nodal rate's share of the velocity: ~2e-7 rad)
    ASSERT_NEAR(wrap(m.u_rad - (c.arg_lat0_rad + o.meanMotion() * (t - kT0))), 0.0, 1e-6) << i;
  }
  std::printf("sim orbit: max |du| %.2e rad, max |dbeta| %.2e rad, max |rate/n - 1| %.2e\n", max_du, max_db, max_rate);
  EXPECT_LT(max_du, 1e-9);
  EXPECT_LT(max_db, 1e-12);  // the simulator's Sun is this one (model::sunPosition delegates)
  EXPECT_LT(max_rate, 1e-6);  // J2 nodal precession changes du/dt by ~1e-7 of n
}

TEST(OrbitContext, EarthFixedRouteGivesTheSameArgumentOfLatitude) {
  sim::OrbitConfig c;
  c.raan_rad = -2.0;
  const sim::CircularOrbit o(c, kT0);
  double max_du = 0, max_db_gmst = 0;
  for (int i = 0; i < 500; ++i) {
    const double t = kT0 + 97.3 * i;
    Vec3 r, v;
    o.posVel(t, r, v);
    const TimeUs tu = static_cast<TimeUs>(std::llround(t * 1e6));
    model::OrbitSample mi, me, mg;
    ASSERT_TRUE(model::orbitSampleFromInertial(tu, r, v, mi));
    // to Earth-fixed with the Earth rotation angle and back: exact
    const double th = model::earthRotationAngle(t), ct = std::cos(th), st = std::sin(th);
    Mat3 C_E_I;
    C_E_I << ct, st, 0, -st, ct, 0, 0, 0, 1;
    const Vec3 w(0, 0, model::kEarthRotationRate_rad_s);
    const Vec3 rE = C_E_I * r, vE = C_E_I * v - w.cross(rE);
    ASSERT_TRUE(model::orbitSampleFromEarthFixed(tu, rE, vE, me));
    EXPECT_TRUE(me.from_earth_fixed);
    // a record's frame flag picks the route; any other flag is refused
    model::OrbitSample ri, re, rx;
    ASSERT_TRUE(model::orbitSampleFromRecord(tu, 'I', r, v, ri));
    ASSERT_TRUE(model::orbitSampleFromRecord(tu, 'E', rE, vE, re));
    EXPECT_EQ(ri.u_rad, mi.u_rad);
    EXPECT_EQ(re.u_rad, me.u_rad);
    EXPECT_TRUE(re.from_earth_fixed);
    EXPECT_FALSE(ri.from_earth_fixed);
    EXPECT_FALSE(model::orbitSampleFromRecord(tu, 'X', r, v, rx));
    max_du = std::max(max_du, std::fabs(wrap(me.u_rad - mi.u_rad)));
    EXPECT_NEAR(me.beta_rad, mi.beta_rad, 1e-9);
    // the simulator's Earth-fixed frame (mean sidereal angle): u does not depend on a rotation about z,
    // beta moves by the angle between the two (precession in right ascension, ~0.3 deg in 2023)
    const Mat3 C = model::C_E_I(t);
    const Vec3 rG = C * r, vG = C * v - w.cross(rG);
    ASSERT_TRUE(model::orbitSampleFromEarthFixed(tu, rG, vG, mg));
    EXPECT_NEAR(wrap(mg.u_rad - mi.u_rad), 0.0, 1e-9);
    max_db_gmst = std::max(max_db_gmst, std::fabs(mg.beta_rad - mi.beta_rad));
  }
  std::printf("Earth-fixed route: max |du| %.2e rad; GMST instead of ERA moves beta by up to %.3f deg\n", max_du,
              max_db_gmst / kRadPerDeg);
  EXPECT_LT(max_du, 1e-9);
  EXPECT_LT(max_db_gmst, 0.5 * kRadPerDeg);
  // without the w x r term the velocity is wrong by ~465 m/s: the orbit plane tilts by degrees
  Vec3 r, v;
  o.posVel(kT0, r, v);
  model::OrbitSample a, b;
  ASSERT_TRUE(model::orbitSampleFromInertial(0, r, v, a));
  ASSERT_TRUE(model::orbitSampleFromInertial(0, r, v - Vec3(0, 0, model::kEarthRotationRate_rad_s).cross(r), b));
  EXPECT_GT(std::fabs(a.beta_rad - b.beta_rad) + std::fabs(wrap(a.u_rad - b.u_rad)), 0.01 * kRadPerDeg);
}

TEST(OrbitContext, EarthRotationAngleAndLeapSeconds) {
  EXPECT_EQ(model::gpsMinusUtcSeconds(0.0), 13.0);
  EXPECT_EQ(model::gpsMinusUtcSeconds(kT0), 18.0);
  EXPECT_EQ(model::gpsMinusUtcSeconds(4563.0 * 86400.0), 15.0);  // 2012-06-30
  // ERA advances by 2 pi in one sidereal day (86164.0989 s)
  const double a = model::earthRotationAngle(kT0), b = model::earthRotationAngle(kT0 + 86164.0989);
  EXPECT_NEAR(wrap(b - a), 0.0, 1e-6);
  // J2000.0 (UT1): ERA = 2 pi 0.7790572732640
  EXPECT_NEAR(model::earthRotationAngle(13.0), 2 * kPi * 0.7790572732640, 1e-9);
  // GMST - ERA is the accumulated precession in right ascension plus the equation of the origins
  // (~0.33 deg in 2023; 0 at J2000 within the terms GMST's short formula drops)
  const double d = wrap(model::gmst(kT0) - model::earthRotationAngle(kT0)) / kRadPerDeg;
  std::printf("GMST - ERA at 2023-06-01: %.3f deg\n", d);
  EXPECT_GT(d, 0.25);
  EXPECT_LT(d, 0.40);
}

TEST(OrbitContextReal, Gni1bAndGnv1bAgreeOnTheArgumentOfLatitude) {
  BORESIGHT_REQUIRE_REAL_DATA();
  const std::string dir = test::realFile("gracefo/2023-06-01_L1B/");
  const auto gni = io::readProduct<io::GnvRecord>(dir + "GNI1B_2023-06-01_C_04.txt");
  const auto gnv = io::readProduct<io::GnvRecord>(dir + "GNV1B_2023-06-01_C_04.txt");
  ASSERT_GT(gni.records.size(), 10u);
  ASSERT_GT(gnv.records.size(), 10u);
  std::map<TimeUs, model::OrbitSample> inertial;
  for (const io::GnvRecord& r : gni.records) {
    ASSERT_EQ(r.coord_ref, 'I');
    model::OrbitSample s;
    ASSERT_TRUE(model::orbitSampleFromInertial(r.t, Vec3(r.pos[0], r.pos[1], r.pos[2]), Vec3(r.vel[0], r.vel[1], r.vel[2]), s));
    inertial[r.t] = s;
  }
  int n = 0;
  double max_du = 0, max_db = 0, max_dr = 0;
  for (const io::GnvRecord& r : gnv.records) {
    ASSERT_EQ(r.coord_ref, 'E');
    const auto it = inertial.find(r.t);
    if (it == inertial.end()) continue;
    model::OrbitSample s;
    ASSERT_TRUE(model::orbitSampleFromEarthFixed(r.t, Vec3(r.pos[0], r.pos[1], r.pos[2]), Vec3(r.vel[0], r.vel[1], r.vel[2]), s));
    ++n;
    max_du = std::max(max_du, std::fabs(wrap(s.u_rad - it->second.u_rad)));
    max_db = std::max(max_db, std::fabs(s.beta_rad - it->second.beta_rad));
    max_dr = std::max(max_dr, (s.r_I - it->second.r_I).norm());
  }
  std::printf("real GRACE-FO C 2023-06-01, %d common epochs: |u(GNV1B via ERA) - u(GNI1B)| <= %.4f deg, "
              "|dbeta| <= %.4f deg, |dr| <= %.0f m; u(GNI1B) %.2f..%.2f deg, beta %.2f deg\n",
              n, max_du / kRadPerDeg, max_db / kRadPerDeg, max_dr, inertial.begin()->second.u_rad / kRadPerDeg,
              inertial.rbegin()->second.u_rad / kRadPerDeg, inertial.begin()->second.beta_rad / kRadPerDeg);
  ASSERT_GT(n, 10);
  EXPECT_LT(max_du, 0.2 * kRadPerDeg);  // "good to about 0.1 deg": the pole of date against J2000's
  EXPECT_LT(max_db, 0.2 * kRadPerDeg);
  // a GRACE-FO orbit: du/dt about 2 pi / 94.5 min
  EXPECT_NEAR(inertial.begin()->second.u_rate_rad_s, 2 * kPi / (94.5 * 60), 0.02 * 2 * kPi / (94.5 * 60));
}

}  // namespace
}  // namespace boresight
