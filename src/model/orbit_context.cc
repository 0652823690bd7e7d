#include <boresight/model/orbit_context.h>
#include <boresight/model/ephemeris.h>

#include <algorithm>
#include <cmath>

namespace boresight::model {
namespace {
constexpr double kSecondsPerDay = 86400.0;
inline double deg(double d) { return d * kRadPerDeg; }

/// Leap seconds since 2000: (UTC day at whose start GPS - UTC became `offset`, counted in days past
/// 2000-01-01 12:00 UTC, offset). GPS - UTC was 13 s from 1999 to 2005.
struct Leap {
  double days;
  double offset;
};
constexpr Leap kLeaps[] = {{2190.5, 14}, {3286.5, 15}, {4563.5, 16}, {5658.5, 17}, {6208.5, 18}};
}  // namespace

double gpsMinusUtcSeconds(double t) {
  double off = 13.0;
  for (const Leap& l : kLeaps)
    if (t >= l.days * kSecondsPerDay + (l.offset - 13.0)) off = l.offset;
  return off;
}

double earthRotationAngle(double t) {
  // IERS 2010 (eq. 5.15): ERA = 2 pi (0.7790572732640 + 1.00273781191135448 Du), Du = JD(UT1) - 2451545.0.
  // t = 0 is 2000-01-01 12:00:00 GPS = 11:59:47 UTC; the UTC clock has lost the leap seconds since.
  const double du = (t - gpsMinusUtcSeconds(t)) / kSecondsPerDay;
  const double whole = std::floor(du);
  double turns = (du - whole) + 0.7790572732640 + 0.00273781191135448 * du;
  turns -= std::floor(turns);
  return 2.0 * kPi * turns;
}

Vec3 sunPositionLowPrecision(double t) {
  const double n = (t + kTtMinusGps) / kSecondsPerDay;
  const double L = deg(280.460 + 0.9856474 * n);
  const double g = deg(357.528 + 0.9856003 * n);
  const double lam = L + deg(1.915) * std::sin(g) + deg(0.020) * std::sin(2 * g);
  const double eps = deg(23.439 - 0.0000004 * n);
  const double R = (1.00014 - 0.01671 * std::cos(g) - 0.00014 * std::cos(2 * g)) * kAu_m;
  return R * Vec3(std::cos(lam), std::cos(eps) * std::sin(lam), std::sin(eps) * std::sin(lam));
}

Vec3 earthVelocityLowPrecision(double t) {
  const double h = 300.0;
  return -(sunPositionLowPrecision(t + h) - sunPositionLowPrecision(t - h)) / (2 * h);
}

OrbitContext effectContext(const OrbitSample& o, double t_rel_s) {
  OrbitContext c;
  c.t_s = t_rel_s;
  c.arg_lat_rad = o.u_rad;
  c.beta_rad = o.beta_rad;
  c.v_sat_I = o.v_I;
  c.v_earth_I = earthVelocityLowPrecision(toSeconds(o.t));
  return c;
}

double argumentOfLatitude(const Vec3& r, const Vec3& v) {
  const Vec3 h = r.cross(v).normalized();
  Vec3 node = Vec3::UnitZ().cross(h);
  if (node.norm() < 1e-12) node = Vec3::UnitX();  // equatorial orbit: measure u from x
  node.normalize();
  const Vec3 rn = r.normalized();
  return std::atan2(h.dot(node.cross(rn)), node.dot(rn));
}

double betaAngle(const Vec3& r, const Vec3& v, const Vec3& sun) {
  const Vec3 h = r.cross(v).normalized();
  return std::asin(std::clamp(h.dot(sun.normalized()), -1.0, 1.0));
}

bool orbitSampleFromInertial(TimeUs t, const Vec3& r, const Vec3& v, OrbitSample& out) {
  if (!r.allFinite() || !v.allFinite()) return false;
  const double h = r.cross(v).norm(), r2 = r.squaredNorm();
  if (!(h > 0) || !(r2 > 0)) return false;
  out.t = t;
  out.r_I = r;
  out.v_I = v;
  out.u_rad = argumentOfLatitude(r, v);
  out.u_rate_rad_s = h / r2;
  out.beta_rad = betaAngle(r, v, sunPositionLowPrecision(toSeconds(t)));
  out.from_earth_fixed = false;
  return true;
}

bool orbitSampleFromEarthFixed(TimeUs t, const Vec3& r_E, const Vec3& v_E, OrbitSample& out) {
  if (!r_E.allFinite() || !v_E.allFinite()) return false;
  const double th = earthRotationAngle(toSeconds(t)), c = std::cos(th), s = std::sin(th);
  Mat3 C_I_E;  // R3(-ERA)
  C_I_E << c, -s, 0, s, c, 0, 0, 0, 1;
  const Vec3 w(0, 0, kEarthRotationRate_rad_s);
  if (!orbitSampleFromInertial(t, C_I_E * r_E, C_I_E * (v_E + w.cross(r_E)), out)) return false;
  out.from_earth_fixed = true;
  return true;
}

bool orbitSampleFromRecord(TimeUs t, char coord_ref, const Vec3& r, const Vec3& v, OrbitSample& out) {
  if (coord_ref == 'I') return orbitSampleFromInertial(t, r, v, out);
  if (coord_ref == 'E') return orbitSampleFromEarthFixed(t, r, v, out);
  return false;
}

}  // namespace boresight::model
