// Head fusion (METHODS 1.3): information-weighted least squares of the heads' body attitudes.
//
// Head i measures C_I_Si = C_I_Si_true Exp(eps_i), eps_i ~ N(0, Sigma_i) in Si with
// Sigma_i = s_c^2 I + (s_r^2 - s_c^2) b b^T. Through its mounting, C_I_B_i = C_I_Si C_Si_B
// = C_I_B_true Exp(C_B_Si eps_i): the error in B has covariance C_B_Si Sigma_i C_Si_B, information W_i.
// The fused C_I_B minimises sum_i |Log(C_I_B^T C_I_B_i)|^2_{W_i} (weighted least squares on the
// small-angle differences): to first order dx = (sum W_i)^-1 sum W_i Log(C_ref^T C_I_B_i); the code
// takes a first-order step from the first head, then two steps with the exact SO(3) gradient and the
// first-order Hessian (all with P_B = (sum W_i)^-1, precomputed per head subset at configure).
// Any subset of the heads may be present; a head dropping out changes the weights, not the frame.
// Relative alignment: with setRelativeAlignment(a) head k is fused as C_I_Sk C_Sk_B^0 Exp(-c_k) (the
// in-flight relative alignment, see HeadAlignment; datum sum W_k c_k = 0): heads that disagree with
// their ground mountings then agree with each other, and a dropout leaves the fused attitude where it
// was. Without it (or after reset()) the nominal mountings are used.
#pragma once

#include "boresight/core/heads.h"

namespace boresight::core {

struct FusedAttitude {
  TimeUs t = 0;
  Quat q_I_B = Quat::Identity();  ///< fused body attitude, R = C_I_B; sign continuous over time
  Mat3 P_B = Mat3::Zero();        ///< covariance of the small-rotation error in B, rad^2
  int heads_used = 0;
  std::uint32_t mask = 0;         ///< slots used
};

class HeadFusion {
 public:
  Status configure(const HeadSetConfig& cfg);
  void reset();
  Status step(const ValidHeads& in);
  const FusedAttitude& output() const { return out_; }
  const Health& health() const { return health_; }
  /// Information matrix (rad^-2, in B) of one head at unit sigma_scale.
  const Mat3& information_B(int slot) const { return W_B_[static_cast<std::size_t>(slot)]; }
  /// Sets the relative alignment used from the next step on (allocation-free; a.mask == 0: nominal).
  /// kInvalidConfig (and no change) when a.mask does not cover every configured head or c is not finite.
  Status setRelativeAlignment(const HeadAlignment& a);
  const HeadAlignment& relativeAlignment() const { return align_; }

 private:
  HeadSetConfig cfg_{};
  bool configured_ = false;
  std::array<Quat, kMaxHeads> q_Si_B_ = filled<Quat, kMaxHeads>(Quat::Identity());   ///< nominal
  std::array<Quat, kMaxHeads> q_fuse_ = filled<Quat, kMaxHeads>(Quat::Identity());   ///< nominal Exp(-c_k)
  HeadAlignment align_{};
  std::array<Mat3, kMaxHeads> W_B_ = filled<Mat3, kMaxHeads>(Mat3::Zero());
  static constexpr std::uint32_t kMasks = 1u << kMaxHeads;
  std::array<Mat3, kMasks> P_mask_ = filled<Mat3, kMasks>(Mat3::Zero());  ///< (sum W_i)^-1 per head subset
  std::array<bool, kMasks> P_ok_{};
  bool have_last_ = false;
  TimeUs last_t_ = 0;
  FusedAttitude out_{};
  Health health_{};
};

}  // namespace boresight::core
