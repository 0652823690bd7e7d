// Rotation functions templated on the scalar (double, float, or an automatic-differentiation type such
// as ceres::Jet): the ONE implementation of Exp, Log, products and matrix conversions used by the core
// (core/rotation.h wraps it for Eigen types), the sensor models (model/rotation.h) and the solver.
//
// Plain arrays, no Eigen, no allocation, no exceptions. Quaternions are scalar first here,
// q = [w, x, y, z] (as in the files; Eigen stores [x, y, z, w]), Hamilton product, R(q) = C_a_b for
// q_a_b (see conventions.h). Matrices are 3x3 row major, R[3 * row + col].
// Derivatives: Exp and Log switch to a Taylor series near zero that depends on the squared norm
// only (no sqrt of zero), so their derivatives at (and near) the identity are finite and exact.
// The scalar type needs +, -, *, /, comparison with T, and sqrt, sin, cos, atan2 found by ADL or in std.
#pragma once

#include <cmath>

namespace boresight::rot {

template <typename T>
inline T dot3(const T a[3], const T b[3]) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

template <typename T>
inline void cross3(const T a[3], const T b[3], T out[3]) {
  const T x = a[1] * b[2] - a[2] * b[1];
  const T y = a[2] * b[0] - a[0] * b[2];
  const T z = a[0] * b[1] - a[1] * b[0];
  out[0] = x;
  out[1] = y;
  out[2] = z;
}

/// Hamilton product ab = a * b (out may alias a or b).
template <typename T>
inline void quatProduct(const T a[4], const T b[4], T ab[4]) {
  const T w = a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3];
  const T x = a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2];
  const T y = a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1];
  const T z = a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0];
  ab[0] = w;
  ab[1] = x;
  ab[2] = y;
  ab[3] = z;
}

/// Conjugate (the inverse of a unit quaternion).
template <typename T>
inline void quatConjugate(const T q[4], T out[4]) {
  out[0] = q[0];
  out[1] = -q[1];
  out[2] = -q[2];
  out[3] = -q[3];
}

/// Exp: rotation vector phi (rad) -> unit quaternion. Below |phi| = 0.01 rad a series in |phi|^2:
/// truncation below 1e-15 relative, and |q|^2 - 1 = O(|phi|^12) < 1e-17, so no normalisation (no
/// sqrt, no division: the branch the real-time core takes for every small correction).
template <typename T>
inline void quatExp(const T phi[3], T q[4]) {
  using std::cos;
  using std::sin;
  using std::sqrt;
  const T t2 = dot3(phi, phi);
  if (t2 < T(1e-4)) {
    // (constant reciprocals multiplied, not divided: the terms are small corrections, rounding only)
    const T s = T(0.5) * (T(1.0) - t2 * T(1.0 / 24.0) * (T(1.0) - t2 * T(1.0 / 80.0)));  // sin(th/2)/th
    const T c = T(1.0) - t2 * T(0.125) * (T(1.0) - t2 * T(1.0 / 48.0));                 // cos(th/2)
    q[0] = c;
    q[1] = s * phi[0];
    q[2] = s * phi[1];
    q[3] = s * phi[2];
    return;
  }
  const T th = sqrt(t2);
  const T s = sin(T(0.5) * th) / th;
  q[0] = cos(T(0.5) * th);
  q[1] = s * phi[0];
  q[2] = s * phi[1];
  q[3] = s * phi[2];
}

/// Log: unit quaternion -> rotation vector (rad) of the shortest rotation (q and -q give the same).
/// Below x = |v|/w = 0.01 a series 2/w (1 - x^2/3 + x^4/5) v in x^2 (truncation below 1e-15 relative).
template <typename T>
inline void quatLog(const T q[4], T phi[3]) {
  using std::atan2;
  using std::sqrt;
  const bool flip = q[0] < T(0.0);
  const T w = flip ? -q[0] : q[0];
  const T sg = flip ? T(-1.0) : T(1.0);
  const T v[3] = {sg * q[1], sg * q[2], sg * q[3]};
  const T n2 = dot3(v, v);
  T k;
  if (n2 < T(1e-4) * w * w) {
    const T iw = T(1.0) / w;  // one division
    const T x2 = n2 * iw * iw;
    k = T(2.0) * iw * (T(1.0) - x2 * (T(1.0 / 3.0) - x2 * T(0.2)));
  } else {
    const T n = sqrt(n2);
    k = T(2.0) * atan2(n, w) / n;
  }
  phi[0] = k * v[0];
  phi[1] = k * v[1];
  phi[2] = k * v[2];
}

/// out = R(q) p for a unit quaternion (out may alias p): p + 2 w (v x p) + 2 v x (v x p).
template <typename T>
inline void quatRotate(const T q[4], const T p[3], T out[3]) {
  const T v[3] = {q[1], q[2], q[3]};
  T t[3];
  cross3(v, p, t);
  t[0] = T(2.0) * t[0];
  t[1] = T(2.0) * t[1];
  t[2] = T(2.0) * t[2];
  T u[3];
  cross3(v, t, u);
  const T r0 = p[0] + q[0] * t[0] + u[0];
  const T r1 = p[1] + q[0] * t[1] + u[1];
  const T r2 = p[2] + q[0] * t[2] + u[2];
  out[0] = r0;
  out[1] = r1;
  out[2] = r2;
}

/// Rotation matrix (row major) of a unit quaternion.
template <typename T>
inline void quatToMatrix(const T q[4], T R[9]) {
  const T w = q[0], x = q[1], y = q[2], z = q[3];
  R[0] = T(1.0) - T(2.0) * (y * y + z * z);
  R[1] = T(2.0) * (x * y - w * z);
  R[2] = T(2.0) * (x * z + w * y);
  R[3] = T(2.0) * (x * y + w * z);
  R[4] = T(1.0) - T(2.0) * (x * x + z * z);
  R[5] = T(2.0) * (y * z - w * x);
  R[6] = T(2.0) * (x * z - w * y);
  R[7] = T(2.0) * (y * z + w * x);
  R[8] = T(1.0) - T(2.0) * (x * x + y * y);
}

/// Unit quaternion (w >= 0) of a rotation matrix (row major), from the largest of the four
/// diagonal combinations (numerically safe for every rotation, including 180 degrees).
template <typename T>
inline void matrixToQuat(const T R[9], T q[4]) {
  using std::sqrt;
  const T tr = R[0] + R[4] + R[8];
  if (tr >= R[0] && tr >= R[4] && tr >= R[8]) {
    const T s = T(2.0) * sqrt(T(1.0) + tr);  // 4 w
    q[0] = T(0.25) * s;
    q[1] = (R[7] - R[5]) / s;
    q[2] = (R[2] - R[6]) / s;
    q[3] = (R[3] - R[1]) / s;
  } else if (R[0] >= R[4] && R[0] >= R[8]) {
    const T s = T(2.0) * sqrt(T(1.0) + R[0] - R[4] - R[8]);  // 4 x
    q[0] = (R[7] - R[5]) / s;
    q[1] = T(0.25) * s;
    q[2] = (R[1] + R[3]) / s;
    q[3] = (R[2] + R[6]) / s;
  } else if (R[4] >= R[8]) {
    const T s = T(2.0) * sqrt(T(1.0) + R[4] - R[0] - R[8]);  // 4 y
    q[0] = (R[2] - R[6]) / s;
    q[1] = (R[1] + R[3]) / s;
    q[2] = T(0.25) * s;
    q[3] = (R[5] + R[7]) / s;
  } else {
    const T s = T(2.0) * sqrt(T(1.0) + R[8] - R[0] - R[4]);  // 4 z
    q[0] = (R[3] - R[1]) / s;
    q[1] = (R[2] + R[6]) / s;
    q[2] = (R[5] + R[7]) / s;
    q[3] = T(0.25) * s;
  }
  if (q[0] < T(0.0)) {
    q[0] = -q[0];
    q[1] = -q[1];
    q[2] = -q[2];
    q[3] = -q[3];
  }
}

}  // namespace boresight::rot
