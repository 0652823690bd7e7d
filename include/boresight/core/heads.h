// Head configuration, per-epoch head input, and the input validator shared by the head components.
//
//   HeadEpoch (raw telemetry: head ids, q_I_Si)  --HeadInputValidator-->  ValidHeads (by slot)
//
// A "slot" is the index of a head in HeadSetConfig::head (0..n_heads-1); head ids are the
// telemetry's (SCA1A sca_id, 1-based). Every component below consumes ValidHeads.
#pragma once

#include "boresight/core/capacities.h"
#include "boresight/core/conventions.h"
#include "boresight/core/rotation.h"
#include "boresight/core/status.h"

#include <array>
#include <cstdint>

namespace boresight::core {

/// One head's fixed configuration.
struct HeadConfig {
  int id = 0;                                  ///< telemetry head id (SCA1A sca_id), unique, > 0
  Quat q_Si_B = Quat::Identity();              ///< mounting, R(q_Si_B) = C_Si_B (QSA1B reading)
  Vec3 boresight_Si = Vec3::UnitZ();           ///< unit boresight axis in Si (GRACE-FO: +z)
  double sigma_cross_rad = 6.0 * kRadPerArcsec;  ///< 1-sigma attitude error about cross-boresight axes, rad
  double sigma_roll_rad = 48.0 * kRadPerArcsec;  ///< 1-sigma attitude error about the boresight, rad
  double sigma_star_rad = 5.0 * kRadPerArcsec;   ///< 1-sigma error of one star direction, rad (Wahba)
  /// Blinding cones (platform file heads.blinding_deg): the head delivers nothing while the Sun, the
  /// Earth's limb or the Moon is within this angle of its boresight (the simulator blinds the heads by
  /// them; the audit explains dropouts by them).
  double sun_exclusion_rad = 30 * kRadPerDeg;
  double earth_exclusion_rad = 20 * kRadPerDeg;  ///< beyond the limb; negative: the limb may enter the field
  double moon_exclusion_rad = 10 * kRadPerDeg;
};

/// The set of heads of one spacecraft.
struct HeadSetConfig {
  int n_heads = 0;                         ///< 1..kMaxHeads
  std::array<HeadConfig, kMaxHeads> head{};  ///< slots 0..n_heads-1
  double unit_norm_tolerance = 1e-5;       ///< reject a quaternion when | |q| - 1 | exceeds this (-)
  /// Time constant of the exponential forgetting of the running relative means, s (0: no forgetting).
  /// Several orbits: the in-flight relative alignment follows slow (seasonal, beta-angle) changes.
  double relative_time_constant_s = 3 * 5400.0;
  /// Epochs every head pair needs before the running means align the fusion (start-up: nominal).
  int relative_min_epochs = 120;
};

/// In-flight relative alignment of the heads, as corrections c_k (rad, in B) to the nominal mountings:
/// head k enters the fusion as C_I_Sk C_Sk_B^0 Exp(-c_k). The datum: sum_k W_k c_k = 0 over all
/// configured heads (W_k: head k's information in B at unit sigma scale), so with every head present
/// the fused attitude is where the nominal mountings put it, and a head's dropout does not move it.
/// mask == 0: no correction (nominal mountings).
struct HeadAlignment {
  std::uint32_t mask = 0;  ///< slots with a correction (all configured heads, or none)
  std::array<Vec3, kMaxHeads> c_B = filled<Vec3, kMaxHeads>(Vec3::Zero());
};

/// Checks a HeadSetConfig (ids unique and positive, unit boresights and mountings, sigmas > 0).
Status validate(const HeadSetConfig& cfg);

/// Ground (nominal) relative matrix C_Sa_Sb^0 = C_Sa_B (C_Sb_B)^T of slots a and b from the configured
/// mountings; identity for a == b. The one definition used by the pair means, the IBA monitor and Wahba.
inline Mat3 groundRelative(const HeadSetConfig& cfg, int a, int b) {
  if (a == b) return Mat3::Identity();
  const Mat3 C_Sa_B = cfg.head[static_cast<std::size_t>(a)].q_Si_B.normalized().toRotationMatrix();
  const Mat3 C_Sb_B = cfg.head[static_cast<std::size_t>(b)].q_Si_B.normalized().toRotationMatrix();
  return C_Sa_B * C_Sb_B.transpose();
}

/// Slot of a head id, or -1.
inline int slotOf(const HeadSetConfig& cfg, int head_id) {
  for (int s = 0; s < cfg.n_heads && s < kMaxHeads; ++s)
    if (cfg.head[static_cast<std::size_t>(s)].id == head_id) return s;
  return -1;
}

/// Index of the unordered pair (a < b) of slots in 0..kMaxPairs-1.
constexpr int pairIndex(int a, int b) {
  // rows of the strict upper triangle, row a has kMaxHeads-1-a entries
  return a * (2 * kMaxHeads - a - 1) / 2 + (b - a - 1);
}

/// One head's raw sample.
struct HeadSample {
  int head_id = 0;               ///< telemetry id
  Quat q_I_Si = Quat::Identity();  ///< head attitude, R = C_I_Si (SCA1A reading), unit
  double sigma_scale = 1.0;      ///< multiplies the head's configured sigmas (>= 0 finite; 1 nominal)
};

/// All heads' raw samples of one epoch (one common time tag).
struct HeadEpoch {
  TimeUs t = 0;  ///< time tag, us past the GPS J2000 epoch
  int n = 0;     ///< number of samples used in `sample`
  std::array<HeadSample, kMaxHeads> sample{};
};

/// Validated heads of one epoch, by slot. q_I_Si is normalised. Only the slots in `mask` are this
/// epoch's (the validator builds it in place: other slots may hold an earlier epoch's values).
struct ValidHeads {
  TimeUs t = 0;
  std::uint32_t mask = 0;  ///< bit s set when slot s is valid
  std::array<Quat, kMaxHeads> q_I_Si = filled<Quat, kMaxHeads>(Quat::Identity());
  std::array<double, kMaxHeads> sigma_scale{};

  bool has(int slot) const { return (mask >> slot) & 1u; }
  int count() const {
    int c = 0;
    for (int s = 0; s < kMaxHeads; ++s) c += has(s) ? 1 : 0;
    return c;
  }
};

/// Relative attitudes of the pairs of valid heads of one epoch, q_Sa_Sb = q_I_Sa^* q_I_Sb (slots a < b,
/// by pairIndex; only pairs with both heads in `mask`): formed once per epoch and shared by the pair
/// means and the monitor (both also accept ValidHeads alone and form them).
struct PairRelatives {
  TimeUs t = 0;
  std::uint32_t mask = 0;  ///< the ValidHeads mask they were formed from
  /// Only the pairs of `mask` are set (not initialised otherwise: constructed every epoch, read by mask).
  std::array<Quat, kMaxPairs> q_Sa_Sb;
};

/// Forms `out` from `in` for slots 0..n_heads-1.
inline void formPairRelatives(const ValidHeads& in, int n_heads, PairRelatives& out) {
  out.t = in.t;
  out.mask = in.mask;
  for (int a = 0; a < n_heads; ++a) {
    if (!in.has(a)) continue;
    const Quat q_Sa_I = in.q_I_Si[static_cast<std::size_t>(a)].conjugate();
    for (int b = a + 1; b < n_heads; ++b)
      if (in.has(b))
        out.q_Sa_Sb[static_cast<std::size_t>(pairIndex(a, b))] = q_Sa_I * in.q_I_Si[static_cast<std::size_t>(b)];
  }
}

/// Rejects bad samples (each counted by reason) and maps ids to slots.
/// step(): kOk when at least one head is valid (bad heads are dropped and counted); otherwise the
/// reason of the epoch's rejection. Time must strictly increase from epoch to epoch.
class HeadInputValidator {
 public:
  Status configure(const HeadSetConfig& cfg);
  void reset();
  Status step(const HeadEpoch& in);
  const ValidHeads& output() const { return out_; }
  const Health& health() const { return health_; }

 private:
  HeadSetConfig cfg_{};
  bool configured_ = false;
  bool have_last_ = false;
  TimeUs last_t_ = 0;
  ValidHeads out_{};
  Health health_{};
};

}  // namespace boresight::core
