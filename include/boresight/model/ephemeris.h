// Low-precision analytic Sun and Moon directions and Earth rotation: the simulator's geometry and the
// audit's (blinding cones, aberration), one model of each.
//
// Time argument: GPS seconds past 2000-01-01 12:00:00 GPS (conventions.h). Terrestrial time is
// taken as GPS + 51.184 s, UT1 as GPS - 18 s (the GPS-UTC offset since 2017; |UT1-UTC| < 0.9 s is
// ignored). Inertial frame: the mean equator and equinox of J2000 (precession and nutation are
// ignored: they move directions by up to ~0.4 deg over 25 years, harmless for exclusion cones and
// beta angles, and the simulator uses the same frame for stars and attitude, so the truth is
// self-consistent).
//   Sun:  Astronomical Almanac low-precision formulae, about 0.01 deg (1950-2050).
//   Moon: the AA low-precision series (6 longitude, 4 latitude, 4 parallax terms), about 0.3 deg.
#pragma once

#include <boresight/core/conventions.h>
#include <boresight/model/orbit_context.h>

namespace boresight::model {

constexpr double kAu_m = 1.495978707e11;
constexpr double kTtMinusGps = 51.184;  ///< TT - GPS, s
constexpr double kEarthRadius_m = 6378137.0;
constexpr double kEarthMu_m3_s2 = 3.986004418e14;
constexpr double kEarthRate_rad_s = 7.2921150e-5;
constexpr double kJ2 = 1.08262668e-3;

/// Geocentric Sun position, inertial, metres (sunPositionLowPrecision, model/orbit_context.h).
inline Vec3 sunPosition(double t_gps_s) { return sunPositionLowPrecision(t_gps_s); }
/// Unit vector to the Sun, inertial (geocentric).
inline Vec3 sunDirection(double t_gps_s) { return sunPosition(t_gps_s).normalized(); }
/// Earth velocity about the Sun (heliocentric, ~ barycentric to 0.05 %), inertial, m/s.
inline Vec3 earthVelocity(double t_gps_s) { return earthVelocityLowPrecision(t_gps_s); }
/// Geocentric Moon position, inertial, metres.
Vec3 moonPosition(double t_gps_s);
/// Greenwich mean sidereal angle (rad): C_E_I = R3(gmst) maps inertial to Earth-fixed.
double gmst(double t_gps_s);
/// Earth-fixed from inertial (rotation about z by gmst).
Mat3 C_E_I(double t_gps_s);

}  // namespace boresight::model
