// Method C geometry shared by the seed solver, the Ceres refinement and the ground simulator.
//
// FRAMES (core/conventions.h): m = the laboratory level frame (x horizontal at theodolite azimuth 0,
// z up), t = the strapdown IMU case, s = the star sensor (boresight +z). C_s_t maps IMU axes to
// sensor axes; C_t_m maps lab axes to IMU axes.
//
// THEODOLITE ANGLES. Azimuth a counts from lab x towards lab y (counterclockwise seen from above),
// elevation e above the horizontal: a direction is (cos e cos a, cos e sin a, sin e). A surveyor's
// clockwise azimuth a' and zenith angle z convert as a = -a', e = 90 deg - z (measurement.h).
// At a direction the two tangent unit vectors
//   e_az = (-sin a, cos a, 0)                      (towards increasing azimuth)
//   e_el = (-sin e cos a, -sin e sin a, cos e)     (towards increasing elevation)
// turn a small direction error into two angles: (e_az . n, e_el . n) = (cos e da, de).
//
// PINHOLE (the sensor's line of sight d in s, boresight +z, d_z > 0):
//   x = d_x/d_z, y = d_y/d_z, k = 1 + k1 (x^2 + y^2)   (k1: radial distortion, 0 = none)
//   u = u0 + f k x,  v = v0 + f Sx k y
// Templated on the scalar so the same code serves double and Ceres Jets.
#pragma once

#include <boresight/core/conventions.h>

#include <cmath>

namespace boresight::ground {

/// Unit direction of theodolite angles (radians).
inline Vec3 directionFromAzEl(double az_rad, double el_rad) {
  const double ce = std::cos(el_rad);
  return Vec3(ce * std::cos(az_rad), ce * std::sin(az_rad), std::sin(el_rad));
}

/// Azimuth (rad, (-pi, pi]) and elevation (rad) of a (not necessarily unit) direction.
inline void azElFromDirection(const Vec3& d, double& az_rad, double& el_rad) {
  az_rad = std::atan2(d.y(), d.x());
  el_rad = std::atan2(d.z(), std::hypot(d.x(), d.y()));
}

/// The tangent unit vectors (e_az, e_el) at the direction of (az, el), see the header comment.
inline void tangentBasis(double az_rad, double el_rad, Vec3& e_az, Vec3& e_el) {
  const double sa = std::sin(az_rad), ca = std::cos(az_rad), se = std::sin(el_rad), ce = std::cos(el_rad);
  e_az = Vec3(-sa, ca, 0.0);
  e_el = Vec3(-se * ca, -se * sa, ce);
}

/// Camera intrinsics (pixels; Sx dimensionless; k1 per squared tangent of the field angle).
struct Intrinsics {
  double f = 2800.0;   ///< focal length, px
  double u0 = 512.0;   ///< principal point, px
  double v0 = 512.0;
  double sx = 1.0;     ///< pixel aspect: v scale over u scale
  double k1 = 0.0;     ///< radial distortion
};

/// Pinhole projection of the line of sight d (sensor axes) with intrinsics
/// intr = (f, u0, v0, Sx) and radial coefficient k1. Returns false when d_z <= 0 (behind the sensor).
template <typename T>
bool project(const T* d, const T* intr, const T& k1, T* uv) {
  if (!(d[2] > T(0))) return false;
  const T x = d[0] / d[2], y = d[1] / d[2];
  const T k = T(1) + k1 * (x * x + y * y);
  uv[0] = intr[1] + intr[0] * k * x;
  uv[1] = intr[2] + intr[0] * intr[3] * k * y;
  return true;
}

/// project() for Eigen types.
inline bool projectPoint(const Vec3& d_s, const Intrinsics& c, double& u, double& v) {
  const double intr[4] = {c.f, c.u0, c.v0, c.sx};
  double uv[2];
  if (!project(d_s.data(), intr, c.k1, uv)) return false;
  u = uv[0];
  v = uv[1];
  return true;
}

/// Line of sight (unit, sensor axes) of a pixel: the inverse of project() (fixed-point iteration on the
/// distortion factor; exact for k1 = 0).
inline Vec3 unprojectPixel(double u, double v, const Intrinsics& c) {
  const double xd = (u - c.u0) / c.f, yd = (v - c.v0) / (c.f * c.sx);
  double x = xd, y = yd;
  for (int i = 0; i < 20 && c.k1 != 0.0; ++i) {
    const double k = 1.0 + c.k1 * (x * x + y * y);
    x = xd / k;
    y = yd / k;
  }
  return Vec3(x, y, 1.0).normalized();
}

}  // namespace boresight::ground
