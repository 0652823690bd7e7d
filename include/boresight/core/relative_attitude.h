// Running mean relative attitude of every head pair (METHODS 1.2) and the closure check.
//
// For slots i < j, B_ij = C_Si_I C_I_Sj = C_Si_Sj (independent of the body attitude). With the head
// error model of head_fusion.h, a measured B_ij = B_ij_true Exp(eta), eta = eps_j - C_Sj_Si eps_i in
// Sj, covariance S_ij = s_j^2 Sigma_j + s_i^2 C_Sj_Si Sigma_i C_Si_Sj (C_Sj_Si from the configured
// mountings), information W_ij = S_ij^-1 - very anisotropic.
// The running mean is the information-weighted mean in the tangent space of an anchor B_ref:
// mean = B_ref Exp((sum W)^-1 sum W eta_k), eta_k = Log(B_ref^T B_k); the anchor moves to the mean
// (first-order re-anchoring of the sums) when they drift apart by more than kReanchorRad.
// Covariance of the mean: (sum W)^-1 (model). Spread: the sample covariance of eta (data).
// Forgetting: the sums are multiplied by exp(-dt/tau) (tau = HeadSetConfig::relative_time_constant_s;
// 0 keeps everything) every kForgetBlockS seconds or tau/1000, whichever is shorter (epochs inside a
// block share one weight), so the means follow slow changes; the
// model covariance (sum lambda^k W)^-1 is then an upper bound of the mean's true covariance.
// Alignment (for the fusion): from the pair means, r_ab = Log(C_B_Sa^0 B_ab C_Sb_B^0) = d_b - d_a to
// first order, d_k the mounting error of head k in B; the information-weighted least squares over all
// pairs with the datum sum_k W_k d_k = 0 gives the corrections c_k = d_k (see HeadAlignment).
// Closure (three heads i<j<k): Log(B_ik^T B_ij B_jk) should vanish. At epochs where all three heads
// are present the head noise cancels from the closure to first order, so the chi2 below (which
// treats the three means as independent) is an upper bound of the noise: a closure error well
// above it points at bookkeeping (time tags, frames, head ids), not at noise.
#pragma once

#include "boresight/core/heads.h"

namespace boresight::core {

struct PairMean {
  bool valid = false;
  std::uint64_t n = 0;              ///< epochs averaged
  Quat q_Si_Sj = Quat::Identity();  ///< mean relative attitude, R = C_Si_Sj
  Mat3 cov_mean_Sj = Mat3::Zero();  ///< model covariance of the mean (small rotation in Sj), rad^2
  Mat3 spread_Sj = Mat3::Zero();    ///< sample covariance of single epochs about the mean, rad^2
};

struct ClosureCheck {
  bool valid = false;
  int i = 0, j = 0, k = 0;          ///< slots, i < j < k
  Vec3 error_Si = Vec3::Zero();     ///< Log(B_ik^T B_ij B_jk), rotated to Si (rad)
  double angle_rad = 0;             ///< |error|
  double chi2 = 0;                  ///< error^T cov^-1 error with cov from the three means (3 dof)
};

class RelativeAttitudeMeans {
 public:
  static constexpr double kReanchorRad = 1e-3;
  /// Forgetting is applied to the sums at most this often (s); see step().
  static constexpr double kForgetBlockS = 8.0;

  Status configure(const HeadSetConfig& cfg);
  void reset();
  Status step(const ValidHeads& in);
  /// The same with the epoch's pair relatives already formed (shared with the monitor; formed here
  /// when they do not belong to `in`).
  Status step(const ValidHeads& in, const PairRelatives& rel);
  /// Mean of the pair of slots a < b.
  PairMean mean(int a, int b) const;
  /// Closure of slots i < j < k (all three pair means must exist).
  ClosureCheck closure(int i, int j, int k) const;
  /// Relative alignment of all heads from the current means (datum: sum_k W_k c_k = 0). false (and
  /// out.mask = 0) until every head is linked to the others through pairs with relative_min_epochs.
  bool alignment(HeadAlignment& out) const;
  /// Corrections from a full set of mountings (e.g. the batch solver's), with the same datum.
  bool alignmentFromMountings(const std::array<Quat, kMaxHeads>& q_Si_B, HeadAlignment& out) const;
  const Health& health() const { return health_; }
  /// Anchor moves so far (all pairs; diagnostics and tests).
  std::uint64_t reanchors() const { return reanchors_; }

 private:
  struct Acc {
    std::uint64_t n = 0;    ///< epochs added
    double n_w = 0;         ///< forgotten count (sum of lambda^k)
    TimeUs t_last = 0;
    Quat q_ref = Quat::Identity();
    // epochs at unit sigma scales (almost all) have the information W1: a forgotten count and sum of
    // eta; the others go into W_sum, W_eta. The full sums: w_nom W1 + W_sum, W1 eta_nom + W_eta.
    double w_nom = 0;
    Vec3 eta_nom = Vec3::Zero();
    Mat3 W_sum = Mat3::Zero();
    Vec3 W_eta = Vec3::Zero();
    Vec3 eta_sum = Vec3::Zero();
    Mat3 eta_eta = Mat3::Zero();
  };
  HeadSetConfig cfg_{};
  bool configured_ = false;
  std::array<Mat3, kMaxHeads> Sigma_ = filled<Mat3, kMaxHeads>(Mat3::Zero());           ///< head covariance in its own frame
  std::array<Mat3, kMaxPairs> C_Sj_Si0_ = filled<Mat3, kMaxPairs>(Mat3::Zero());         ///< ground relative matrices
  std::array<Mat3, kMaxPairs> W1_ = filled<Mat3, kMaxPairs>(Mat3::Zero());               ///< pair information at unit sigma scales
  std::array<Mat3, kMaxHeads> W_B_ = filled<Mat3, kMaxHeads>(Mat3::Zero());             ///< head information in B
  std::array<Acc, kMaxPairs> acc_{};
  Mat3 P_all_ = Mat3::Zero();  ///< (sum_k W_k)^-1 over the configured heads (the datum)
  Eigen::Matrix<double, 3 * kMaxHeads, 3 * kMaxHeads> H_datum_ =
      Eigen::Matrix<double, 3 * kMaxHeads, 3 * kMaxHeads>::Zero();  ///< the datum's part of the alignment's normal matrix
  bool datumProject(HeadAlignment& a) const;
  Mat3 infoSum(const Acc& A, std::size_t p) const { return A.w_nom * W1_[p] + A.W_sum; }
  Vec3 infoEtaSum(const Acc& A, std::size_t p) const { return W1_[p] * A.eta_nom + A.W_eta; }
  bool have_last_ = false;
  TimeUs last_t_ = 0;
  std::uint64_t reanchors_ = 0;
  Health health_{};
};

}  // namespace boresight::core
