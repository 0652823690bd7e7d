// Rotation helpers of the core (header-only, allocation-free).
// Conventions are those of boresight/core/conventions.h: R(q_a_b) = C_a_b, Hamilton product,
// right perturbations: a measured C_I_S = C_I_S_true Exp(eps) has its error eps in S components.
#pragma once

#include "boresight/core/conventions.h"
#include "boresight/core/rotation_t.h"

#include <array>
#include <cmath>
#include <cstddef>

namespace boresight::core {

/// An array with every element set (Eigen types are not initialised by their default constructors).
template <typename T, std::size_t N>
std::array<T, N> filled(const T& value) {
  std::array<T, N> a;
  a.fill(value);
  return a;
}

/// Cross-product matrix: skew(a) b = a x b.
inline Mat3 skew(const Vec3& a) {
  Mat3 m;
  m << 0, -a.z(), a.y(),  //
      a.z(), 0, -a.x(),   //
      -a.y(), a.x(), 0;
  return m;
}

/// Exp: rotation vector (rad) -> unit quaternion (rot::quatExp of rotation_t.h).
inline Quat quatExp(const Vec3& phi) {
  const double p[3] = {phi.x(), phi.y(), phi.z()};
  double q[4];
  rot::quatExp(p, q);
  return Quat(q[0], q[1], q[2], q[3]);
}

/// Log: unit quaternion -> rotation vector (rad) of the shortest rotation (q and -q give the same)
/// (rot::quatLog of rotation_t.h).
inline Vec3 quatLog(const Quat& q) {
  const double a[4] = {q.w(), q.x(), q.y(), q.z()};
  double phi[3];
  rot::quatLog(a, phi);
  return Vec3(phi[0], phi[1], phi[2]);
}

/// Log of a unit quaternion near the identity without a division: theta/2 = asin(|v|), so
/// Log = 2 asin(n)/n v, a series in n^2 (the first omitted term, 35 n^8/1152, is below 1e-17 relative
/// for n < 0.01; for products of unit quaternions |q| = 1 to rounding). Otherwise the general Log.
inline Vec3 quatLogNearIdentity(const Quat& q) {
  const double n2 = q.vec().squaredNorm();
  if (q.w() > 0 && n2 < 1e-4) return (2.0 * (1.0 + n2 * (1.0 / 6.0 + n2 * (3.0 / 40.0 + n2 * (5.0 / 112.0))))) * q.vec();
  return quatLog(q);
}

/// Exp to a matrix: Rodrigues, R = I + s [phi]x + k [phi]x^2 = (1 - k th^2) I + s [phi]x + k phi phi^T,
/// s = sin(th)/th, k = (1 - cos th)/th^2; series below 0.01 rad (truncation below 1e-16).
inline Mat3 so3Exp(const Vec3& phi) {
  const double t2 = phi.squaredNorm();
  double s, k;
  if (t2 < 1e-4) {
    s = 1.0 - t2 * (1.0 / 6.0) * (1.0 - t2 * (1.0 / 20.0));
    k = 0.5 * (1.0 - t2 * (1.0 / 12.0) * (1.0 - t2 * (1.0 / 30.0)));
  } else {
    const double th = std::sqrt(t2);
    s = std::sin(th) / th;
    k = (1.0 - std::cos(th)) / t2;
  }
  const double d = 1.0 - k * t2;
  const double x = phi.x(), y = phi.y(), z = phi.z();
  Mat3 R;
  R << d + k * x * x, k * x * y - s * z, k * x * z + s * y,  //
      k * x * y + s * z, d + k * y * y, k * y * z - s * x,   //
      k * x * z - s * y, k * y * z + s * x, d + k * z * z;
  return R;
}
inline Vec3 so3Log(const Mat3& C) { return quatLog(Quat(C)); }

/// Inverse left Jacobian of SO(3): Log(Exp(-x) Exp(r)) = r - jacobianLeftInverse(r) x + O(x^2).
inline Mat3 jacobianLeftInverse(const Vec3& r) {
  const double th = r.norm();
  const Mat3 R = skew(r);
  double c;
  if (th < 1e-2) {  // series: the next term, th^4/30240, is below 4e-13
    c = 1.0 / 12.0 + th * th * (1.0 / 720.0);
  } else {
    c = 1.0 / (th * th) - (1.0 + std::cos(th)) / (2.0 * th * std::sin(th));
  }
  return Mat3::Identity() - 0.5 * R + c * R * R;
}

/// Rotation angle (rad, in [0, pi]) between two attitudes.
inline double angleBetween(const Quat& a, const Quat& b) { return quatLog(a.conjugate() * b).norm(); }

inline bool allFinite(const Quat& q) {
  return std::isfinite(q.w()) && std::isfinite(q.x()) && std::isfinite(q.y()) && std::isfinite(q.z());
}
inline bool allFinite(const Vec3& v) { return std::isfinite(v.x()) && std::isfinite(v.y()) && std::isfinite(v.z()); }

/// q or -q, whichever is closer to prev (sign continuity for differentiation and averaging).
inline Quat continuous(const Quat& q, const Quat& prev) {
  return (q.coeffs().dot(prev.coeffs()) < 0) ? Quat(-q.w(), -q.x(), -q.y(), -q.z()) : q;
}

/// Anisotropic head error covariance in the head frame (rad^2): sigma_cross^2 about every axis
/// perpendicular to the unit boresight b, sigma_roll^2 about b.
inline Mat3 headCovariance(double sigma_cross, double sigma_roll, const Vec3& b) {
  const double c2 = sigma_cross * sigma_cross;
  const double r2 = sigma_roll * sigma_roll;
  return c2 * Mat3::Identity() + (r2 - c2) * b * b.transpose();
}

/// Inverse of a symmetric positive-definite 3x3 matrix; false when it is not (no allocation).
inline bool invertSpd3(const Mat3& a, Mat3& inv) {
  const double det = a.determinant();
  if (!(det > 0) || !std::isfinite(det)) return false;
  inv = a.inverse();
  inv = 0.5 * (inv + inv.transpose()).eval();
  return inv.allFinite();
}

}  // namespace boresight::core
