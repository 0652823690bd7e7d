// boresight conventions: the one place where frames, quaternions and time scales are defined.
//
// ROTATIONS
//   C_a_b   direction-cosine matrix mapping coordinates in frame b to frame a:  v_a = C_a_b * v_b.
//   q_a_b   unit quaternion with R(q_a_b) = C_a_b.
//   Quaternions are SCALAR-FIRST (q0, q1, q2, q3) = (w, x, y, z) everywhere outside Eigen: in files,
//   LCM messages, CSV, YAML and reports. Product is Hamilton's (i*j = k), and R(q) v = q (0,v) q*.
//   Eigen::Quaterniond follows the same algebra but STORES x,y,z,w: the only conversions between the
//   two orders are quatFromScalarFirst() / quatToScalarFirst() below. Never index q.coeffs() elsewhere.
//   q and -q are the same attitude; code that differentiates or averages makes the sign continuous.
//
// FRAMES
//   I   inertial (ICRF / J2000 equator and equinox)
//   B   spacecraft body; for GRACE and GRACE-FO the Science Reference Frame (SRF)
//   Si  star-sensor head i (1-based ids as in the telemetry); its boresight is a configured unit axis
//       of Si (+z for GRACE-FO heads)
//   A   accelerometer frame (the frame of the ACC1A columns)
//   m, t, s  ground frames of method C: intermediate level frame, strapdown IMU case, star sensor
//   Names carry frames: C_S1_I, w_S1 (rate of S1 relative to I, in S1 components), a_B.
//
// UNITS
//   SI inside: radians, seconds, rad/s, rad/s^2, m/s^2. Arcseconds only in reports and logs.
//
// TIME
//   GPS time, seconds past 2000-01-01 12:00:00 GPS (the GRACE / GRACE-FO epoch, "J2000 GPS"); no leap
//   seconds inside this scale. Time tags are integer MICROSECONDS past that epoch (int64, TimeUs),
//   never a bare double of unknown origin. GRACE Level-1A time tags are receiver (OBC) time
//   (time_ref 'R'): integer seconds plus a microsecond field; Level-1B tags are GPS time ('G').
//
// GRACE / GRACE-FO FACTS (decided from the real samples, tested in test/io/conventions_real_test.cc)
//   SCA1A quaternion (per head)    = q_I_Si  (head to inertial): the boresight in I is R(q) * z.
//       With this reading the inter-boresight angles of the 2023-06-01 GRACE C excerpt are constant to
//       ~4"; the transposed reading scatters them by ~1700-2000".
//   QSA1B alignment quaternion     = q_Si_B  (body/SRF to head): the boresight in B is R(q)^T * z.
//       With this reading QSA1B's inter-boresight angles agree with the in-flight ones to ~50";
//       the other reading gives 36-44 deg instead of 80-100 deg.
//   SCA1B combined quaternion      = q_I_B   (SRF to inertial): C_I_B = C_I_Si * C_Si_B agrees with
//       SCA1B to ~100-170" per head at one epoch; the transposed reading is off by ~18 deg.
//   ACC1A axes: file columns (x, y, z) are SRF (y, z, x): a_B = C_B_A a_A with the permutation
//       kAccToBodyDefault below. It is a configuration value; this is only the default.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <cstdint>

namespace boresight {

/// Time tag: integer microseconds past 2000-01-01 12:00:00 GPS time (or receiver time for L1A).
using TimeUs = std::int64_t;
constexpr TimeUs kUsPerSecond = 1000000;

/// Seconds (double) past the GPS J2000 epoch from a microsecond tag.
constexpr double toSeconds(TimeUs t) { return static_cast<double>(t) * 1e-6; }

/// GPS seconds of the GPS epoch 1980-01-06 relative to the GRACE epoch (2000-01-01 12:00:00 GPS).
constexpr std::int64_t kGraceEpochMinusGpsEpochSeconds = 630763200;

constexpr double kPi = 3.14159265358979323846;
constexpr double kArcsecPerRad = 180.0 * 3600.0 / kPi;
constexpr double kRadPerArcsec = 1.0 / kArcsecPerRad;
constexpr double kRadPerDeg = kPi / 180.0;

using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;
using Quat = Eigen::Quaterniond;

/// The single boundary between scalar-first storage (files, messages) and Eigen's x,y,z,w storage.
inline Quat quatFromScalarFirst(double q0, double q1, double q2, double q3) { return Quat(q0, q1, q2, q3); }
inline Quat quatFromScalarFirst(const double* q) { return Quat(q[0], q[1], q[2], q[3]); }
inline void quatToScalarFirst(const Quat& q, double* out) {
  out[0] = q.w();
  out[1] = q.x();
  out[2] = q.y();
  out[3] = q.z();
}

/// Default rotation from the GRACE accelerometer frame A to the SRF B: ACC1A x,y,z are SRF y,z,x,
/// so a_B = (a_A.z, a_A.x, a_A.y).
inline Mat3 accToBodyDefault() {
  Mat3 C_B_A;
  C_B_A << 0, 0, 1,  //
      1, 0, 0,       //
      0, 1, 0;
  return C_B_A;
}

/// Default boresight axis of a GRACE-FO head, in its own frame.
inline Vec3 boresightDefault() { return Vec3::UnitZ(); }

}  // namespace boresight
