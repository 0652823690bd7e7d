// Synthetic head epochs for the audit's collector tests: three heads in a fixed, non-degenerate geometry,
// the configured noise per sample (cross-boresight and about the boresight), an orbit-rate pitch turn.
#pragma once

#include <boresight/core/pipeline.h>
#include <boresight/model/rotation.h>

#include <random>

namespace audittest {

using namespace boresight;

/// The first epoch of every synthetic span (2023-06-01 12:00 GPS).
inline constexpr TimeUs kT0 = 738849600LL * kUsPerSecond;

/// Three heads, ids 1..3, mountings far from each other; everything else the pipeline's defaults.
inline core::PipelineConfig threeHeads() {
  core::PipelineConfig cfg;
  cfg.heads.n_heads = 3;
  const Vec3 axes[3] = {Vec3(1.2, 0, 0), Vec3(0, 1.1, 0.3), Vec3(0.7, -0.6, 0.9)};
  for (int k = 0; k < 3; ++k) {
    auto& h = cfg.heads.head[static_cast<std::size_t>(k)];
    h.id = k + 1;
    h.q_Si_B = model::quatExp(axes[k]);
  }
  return cfg;
}

/// The body attitude t seconds after kT0: a pitch turn at the orbital rate.
inline Quat pitchTurn(double t) { return model::quatExp(Vec3(0, -1.1e-3 * t, 0)); }

/// Appends head k's sample to `e`: its attitude from the body attitude through the true mounting
/// q_S_B, with the configured per-sample noise (three draws of `n01`, cross, cross, about).
inline void addSample(core::HeadEpoch& e, const core::PipelineConfig& cfg, int k, const Quat& q_I_B, const Quat& q_S_B,
                      std::mt19937_64& rng, std::normal_distribution<double>& n01) {
  const auto& h = cfg.heads.head[static_cast<std::size_t>(k)];
  const Vec3 noise(h.sigma_cross_rad * n01(rng), h.sigma_cross_rad * n01(rng), h.sigma_roll_rad * n01(rng));
  auto& s = e.sample[static_cast<std::size_t>(e.n++)];
  s.head_id = h.id;
  s.q_I_Si = (q_I_B * q_S_B.conjugate() * model::quatExp(noise)).normalized();
}

}  // namespace audittest
