// Physical plausibility gates: what a measured quantity can be at all, declared once per quantity,
// beside the conventions (conventions.h). A value outside its gate is not data: the readers reject
// the record with "file:line: reason", the sources and the node count it once (never as used), and
// the core, which may be linked alone into flight software, applies the same gates to its inputs.
//
// The bounds are physical, not statistical: they are far outside anything a GRACE / GRACE-FO class
// spacecraft measures (the real 2023-06-01 GRACE C samples: |q| - 1 below 1e-9, angular acceleration
// below 8e-4 rad/s^2, linear acceleration below 1.1e-5 m/s^2, orbit radius 6.88e6 m, speed 7.6 km/s)
// and inside what a corrupt value gives (1e308, a zeroed quaternion component, a position of 1e30 m).
// Header-only, allocation-free, no exceptions: the real-time core uses it.
#pragma once

#include "boresight/core/conventions.h"

#include <cmath>
#include <cstdint>

namespace boresight::plausibility {

// ---- quaternions --------------------------------------------------------------------------------
/// Default tolerance on | |q| - 1 | of a measured attitude quaternion (SCA1A, STAR_HEAD): the core's
/// HeadSetConfig::unit_norm_tolerance default; a platform file may set another one (at most
/// kMaxQuatNormTolerance), and the readers then use that one, so that a record is counted once.
constexpr double kQuatNormTolerance = 1e-5;
/// A configured tolerance above this lets through quaternions that are not rotations.
constexpr double kMaxQuatNormTolerance = 1e-2;
/// Static alignment quaternions (QSA1B, configured mountings, NOMINAL_MOUNTINGS): written with full
/// precision, so a stricter tolerance.
constexpr double kAlignmentNormTolerance = 1e-6;

enum class Quaternion : std::uint8_t {
  kOk,
  kNonFinite,  ///< NaN or Inf in a component
  kZero,       ///< all components zero (a cleared record)
  kComponent,  ///< a component larger than 1 in magnitude: no rotation has it
  kNorm,       ///< | |q| - 1 | above the tolerance (a scaled or partly zeroed quaternion)
};

/// The gate of a scalar-first quaternion q[0..3] with tolerance `tol` on | |q| - 1 |.
inline Quaternion checkQuaternion(const double* q, double tol) {
  double n2 = 0;
  bool zero = true;
  for (int i = 0; i < 4; ++i) {
    if (!std::isfinite(q[i])) return Quaternion::kNonFinite;
    if (q[i] != 0.0) zero = false;
    n2 += q[i] * q[i];
  }
  if (zero) return Quaternion::kZero;
  if (std::abs(std::sqrt(n2) - 1.0) <= tol) return Quaternion::kOk;
  // Off unit norm; a component above 1 says more than the norm: no rotation has one.
  for (int i = 0; i < 4; ++i)
    if (std::abs(q[i]) > 1.0 + 0.01) return Quaternion::kComponent;
  return Quaternion::kNorm;
}

inline const char* quaternionReason(Quaternion v) {
  switch (v) {
    case Quaternion::kOk: return "ok";
    case Quaternion::kNonFinite: return "quaternion with a non-finite component";
    case Quaternion::kZero: return "quaternion of zeros (no rotation)";
    case Quaternion::kComponent: return "quaternion component above 1 in magnitude (no rotation)";
    case Quaternion::kNorm: return "quaternion norm off 1 by more than the tolerance (not a rotation)";
  }
  return "?";
}

/// | |q| - 1 |, for messages.
inline double quaternionNormError(const double* q) {
  double n2 = 0;
  for (int i = 0; i < 4; ++i) n2 += q[i] * q[i];
  return std::abs(std::sqrt(n2) - 1.0);
}

// ---- accelerometer ------------------------------------------------------------------------------
/// Largest plausible angular acceleration per axis, rad/s^2 (a spacecraft's thrusters give ~1e-3).
constexpr double kMaxAngularAccelRadS2 = 0.1;
/// Largest plausible non-gravitational linear acceleration per axis, m/s^2 (thrusters ~1e-4).
constexpr double kMaxLinearAccelMS2 = 1.0;

/// True when every component is finite and at most `limit` in magnitude.
inline bool withinPerAxis(const double* v, int n, double limit) {
  for (int i = 0; i < n; ++i)
    if (!(std::abs(v[i]) <= limit)) return false;
  return true;
}
inline bool angularAccelPlausible(const double* a) { return withinPerAxis(a, 3, kMaxAngularAccelRadS2); }
inline bool angularAccelPlausible(const Vec3& a) { return angularAccelPlausible(a.data()); }
inline bool linearAccelPlausible(const double* a) { return withinPerAxis(a, 3, kMaxLinearAccelMS2); }

// ---- orbit --------------------------------------------------------------------------------------
/// Orbit radius, m: above the Earth's surface (polar radius 6.357e6 m, less margin) and inside
/// 5e7 m (beyond geostationary); speed, m/s, inertial or Earth-fixed: below 12 km/s (escape from LEO).
constexpr double kMinOrbitRadiusM = 6.2e6;
constexpr double kMaxOrbitRadiusM = 5.0e7;
constexpr double kMaxOrbitSpeedMS = 1.2e4;

inline double norm3(const double* v) { return std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]); }
inline bool orbitRadiusPlausible(const double* r_m) {
  const double r = norm3(r_m);
  return r >= kMinOrbitRadiusM && r <= kMaxOrbitRadiusM;
}
inline bool orbitSpeedPlausible(const double* v_ms) { return norm3(v_ms) <= kMaxOrbitSpeedMS; }

// ---- star directions ----------------------------------------------------------------------------
/// | |s| - 1 | of a unit direction (star vectors in a head frame and in I).
constexpr double kDirectionNormTolerance = 1e-6;
inline bool directionPlausible(const double* s) {
  return withinPerAxis(s, 3, 1.0 + kDirectionNormTolerance) &&
         std::abs(norm3(s) - 1.0) <= kDirectionNormTolerance;
}

// ---- time ---------------------------------------------------------------------------------------
/// A record's tag may lie this far outside the time its file says it covers (the header's coverage,
/// else the date in its name): Level-1A receiver tags are off GPS by well under a second, a daily
/// file holds a few records of the neighbouring days.
constexpr TimeUs kFileTimeMarginUs = 86400 * kUsPerSecond;
/// A file named by its first day only (the simulator's multi-day files) may reach this far past it.
constexpr TimeUs kMaxFileSpanUs = 31 * 86400 * kUsPerSecond;

// ---- sampling rates -----------------------------------------------------------------------------
/// A stream's median sampling interval may differ from the configured one by this fraction; beyond it
/// the filters designed for the configured rate are wrong for the data (rates off by the ratio,
/// sigmas off by its square root).
constexpr double kRateTolerance = 0.05;
/// True when an observed median interval (s) matches the configured rate (Hz).
inline bool rateMatches(double median_interval_s, double fs_hz) {
  if (!(median_interval_s > 0) || !(fs_hz > 0)) return false;
  return std::abs(median_interval_s * fs_hz - 1.0) <= kRateTolerance;
}

}  // namespace boresight::plausibility
