// Shared helpers of the core tests: seeded random rotations, a GRACE-FO-like head set, noise.
#pragma once

#include "boresight/core/heads.h"
#include "boresight/core/rotation.h"

#include <cmath>
#include <random>

namespace boresight::core::test {

using Rng = std::mt19937_64;

inline Vec3 randomVec(Rng& rng, double sigma) {
  std::normal_distribution<double> n(0.0, sigma);
  return Vec3(n(rng), n(rng), n(rng));
}

inline Quat randomQuat(Rng& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  Quat q(n(rng), n(rng), n(rng), n(rng));
  q.normalize();
  return q;
}

inline Vec3 randomUnit(Rng& rng) { return randomVec(rng, 1.0).normalized(); }

/// Three heads with boresights about 90-100 deg apart (like GRACE-FO), GRACE noise model.
inline HeadSetConfig graceLikeHeads(int n_heads = 3) {
  HeadSetConfig c;
  c.n_heads = n_heads;
  const Vec3 axes[kMaxHeads] = {Vec3(1.2, 0.3, -0.4), Vec3(-1.1, 0.9, 0.2), Vec3(0.1, -1.3, 1.0), Vec3(0.5, 0.5, 2.0)};
  for (int k = 0; k < n_heads; ++k) {
    HeadConfig& h = c.head[static_cast<std::size_t>(k)];
    h.id = k + 1;
    h.q_Si_B = quatExp(axes[k]);
  }
  return c;
}

/// A measured q_I_Si = q_I_Si_true Exp(eps), eps ~ N(0, diag(sc^2, sc^2, sr^2)) about the head's boresight.
inline Quat noisyHead(Rng& rng, const Quat& q_I_Si_true, const HeadConfig& h, double scale = 1.0) {
  std::normal_distribution<double> n(0.0, 1.0);
  const Vec3 b = h.boresight_Si;
  const Vec3 e1 = b.unitOrthogonal();
  const Vec3 e2 = b.cross(e1);
  const Vec3 eps = scale * (h.sigma_cross_rad * (n(rng) * e1 + n(rng) * e2) + h.sigma_roll_rad * n(rng) * b);
  return (q_I_Si_true * quatExp(eps)).normalized();
}

}  // namespace boresight::core::test
