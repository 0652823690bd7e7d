// Orbit context from Level-1 orbit products: the argument of latitude u (angle in the orbit plane from
// the ascending node), its rate, and the beta angle (Sun elevation above the orbit plane). Shared by the
// batch thermal model (calib/thermal_fit.h), the simulator and the model audit: geometry only, Eigen,
// no I/O (the Level-1 records are converted by their users; calib/thermal_fit.h takes io::GnvRecord).
//
// Time: GPS seconds past 2000-01-01 12:00:00 GPS (conventions.h). Inertial frame: GNI1B's (J2000 / GCRF).
//
// Two routes:
//   GNI1B (inertial r, v)        u = atan2(h . (n x r), n . r), n = unit(z x h), h = unit(r x v)
//   GNV1B (Earth-fixed r_E, v_E)  r_I = R3(-ERA) r_E,  v_I = R3(-ERA) (v_E + w_E x r_E)
// ERA is the IERS Earth rotation angle (UT1 taken as UTC = GPS - leap seconds, |UT1 - UTC| < 0.9 s
// ignored: 0.004 deg). Rotating by ERA alone gives the Celestial Intermediate frame, whose pole is the
// true pole of date: it differs from J2000 by precession-nutation of the pole (about 20"/year, so
// ~0.13 deg in 2023). u is measured from the node on that equator, so u from GNV1B agrees with u from
// GNI1B to about 0.1 deg (measured on the real 2023 sample: see test/model/orbit_context_test.cc);
// beta moves by the same order. Both are far below what a thermal harmonic fit needs (1 deg of u is
// 1.7 % of a first-harmonic amplitude at worst).
// The rate du/dt = |r x v| / |r|^2 (exact for any orbit).
#pragma once

#include <boresight/core/conventions.h>
#include <boresight/model/effects.h>

namespace boresight::model {

constexpr double kEarthRotationRate_rad_s = 7.2921150e-5;  ///< IERS nominal mean angular velocity

/// One orbit epoch with its derived angles.
struct OrbitSample {
  TimeUs t = 0;                 ///< us past the GPS J2000 epoch
  Vec3 r_I = Vec3::Zero();      ///< position, m, inertial
  Vec3 v_I = Vec3::Zero();      ///< velocity, m/s, inertial
  double u_rad = 0;             ///< argument of latitude, rad in (-pi, pi]
  double u_rate_rad_s = 0;      ///< du/dt, rad/s
  double beta_rad = 0;          ///< Sun elevation above the orbit plane, rad (positive on the side of h)
  bool from_earth_fixed = false;  ///< converted from GNV1B by the Earth rotation angle (~0.1 deg)
};

/// GPS - UTC in seconds at GPS time t (leap seconds 2006..2017; 13 before 2006).
double gpsMinusUtcSeconds(double t_gps_s);
/// IERS Earth rotation angle (rad, in [0, 2 pi)) at GPS time t.
double earthRotationAngle(double t_gps_s);
/// Low-precision geocentric Sun position, m, inertial (Astronomical Almanac, about 0.01 deg, 1950-2050).
Vec3 sunPositionLowPrecision(double t_gps_s);

/// Earth velocity about the Sun, m/s, inertial: central difference (+-300 s) of sunPositionLowPrecision
/// (the annual-aberration velocity; heliocentric, ~ barycentric to 0.05 %).
Vec3 earthVelocityLowPrecision(double t_gps_s);

/// Argument of latitude of (r, v), rad in (-pi, pi]. An equatorial orbit measures from +x.
double argumentOfLatitude(const Vec3& r_I, const Vec3& v_I);
/// Sun elevation above the plane of (r, v), rad; sun_I need not be unit.
double betaAngle(const Vec3& r_I, const Vec3& v_I, const Vec3& sun_I);

/// From inertial position and velocity (GNI1B). False when r or v is not finite or r x v vanishes.
bool orbitSampleFromInertial(TimeUs t, const Vec3& r_I, const Vec3& v_I, OrbitSample& out);
/// From Earth-fixed position and velocity (GNV1B), rotated by the Earth rotation angle.
bool orbitSampleFromEarthFixed(TimeUs t, const Vec3& r_E, const Vec3& v_E, OrbitSample& out);
/// From a GNI1B / GNV1B record's position and velocity by its coordinate frame flag ('I' inertial, 'E'
/// Earth-fixed); false for any other flag, or as the two above.
bool orbitSampleFromRecord(TimeUs t, char coord_ref, const Vec3& r, const Vec3& v, OrbitSample& out);

/// The effect models' context (effects.h) at an orbit sample of measured data: t_s = t_rel_s (seconds
/// since the data's start), u, beta, v_sat_I = the sample's inertial velocity, v_earth_I from
/// earthVelocityLowPrecision. Between samples, interpolate the orbit first (u from an interpolated
/// r, v), not the angles.
OrbitContext effectContext(const OrbitSample& o, double t_rel_s);

}  // namespace boresight::model
