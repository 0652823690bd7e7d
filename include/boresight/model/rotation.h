// Small-rotation helpers shared by the sensor/effect models and the simulator.
//
// A rotation vector phi (radians, components in a named frame) maps to the unit quaternion
// Exp(phi) = (cos(|phi|/2), sin(|phi|/2) phi/|phi|), scalar first in files, Eigen storage inside
// (see core/conventions.h). R(Exp(phi)) v = v + phi x v + O(|phi|^2): an ACTIVE rotation of v about
// phi. Log() is the inverse on the shortest arc (|phi| <= pi).
#pragma once

#include <boresight/core/conventions.h>
#include <boresight/core/rotation.h>

#include <cmath>

namespace boresight::model {

// The one Exp/Log (templated in core/rotation_t.h, wrapped for Eigen types in core/rotation.h).
using core::quatExp;
using core::quatLog;

/// Orthonormal axes (e1, e2, b) of a head frame with boresight b: e1, e2 span the cross-boresight
/// plane. Deterministic: e1 is the unit vector of b x (the Si axis least aligned with b).
inline void boresightBasis(const Vec3& b_in, Vec3& e1, Vec3& e2, Vec3& b) {
  b = b_in.normalized();
  Vec3 ref = Vec3::UnitX();
  if (std::abs(b.x()) > std::abs(b.y()) && std::abs(b.x()) > std::abs(b.z()) - 1e-12) ref = Vec3::UnitY();
  if (std::abs(b.y()) >= std::abs(b.x()) && std::abs(b.y()) > std::abs(b.z())) ref = Vec3::UnitZ();
  e1 = b.cross(ref).normalized();
  e2 = b.cross(e1);
}

}  // namespace boresight::model
