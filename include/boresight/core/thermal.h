// Inter-boresight monitor and thermal correction (METHODS 2.1-2.3 and the three-axis extension).
//
// For a pair of slots i < j with ground relative matrix C0 = C_Si_Sj^0 = C_Si_B^0 (C_Sj_B^0)^T and
// boresights b_i, b_j (in their own frames):
//   ground IBA        alpha0 = angle(b_i, C0 b_j)
//   in-orbit IBA      alpha  = angle(b_i, v),  v = C_Si_I C_I_Sj b_j     (atan2 form, exact near 0)
//   deviation         d = alpha - alpha0
//   correction T_ij   rotation by d about n = unit(b_i x C0 b_j), so T C0 b_j makes alpha with b_i
// Full relative deformation (all three axes): D = C_Si_I C_I_Sj C0^T = Exp(delta), delta in Si. With
// the head error model (head_fusion.h), delta has covariance Sigma_i + C0 Sigma_j C0^T (first order):
// well known across both boresights, poorly about them. The IBA sees only n . delta (to first order);
// the other two components are what the three-axis estimate adds. A running information-weighted
// mean of delta gives the slowly varying deformation with the covariance of the mean.
#pragma once

#include "boresight/core/heads.h"

namespace boresight::core {

struct PairDeformation {
  bool valid = false;            ///< both heads present at this epoch
  double iba_rad = 0;            ///< in-orbit inter-boresight angle, rad
  double iba_ground_rad = 0;     ///< ground value, rad
  double iba_dev_rad = 0;        ///< iba - ground, rad
  Mat3 T_Si = Mat3::Identity();  ///< real-time correction matrix (acts in Si on C0 b_j)
  Vec3 delta_Si = Vec3::Zero();  ///< three-axis relative deformation this epoch, rad, in Si
  Mat3 cov_delta_Si = Mat3::Zero();  ///< its covariance, rad^2
  Vec3 n_iba_Si = Vec3::Zero();  ///< unit axis that the IBA senses (n . delta = d to first order)
};

struct DeformationMean {
  bool valid = false;
  std::uint64_t n = 0;
  Vec3 delta_Si = Vec3::Zero();  ///< information-weighted mean deformation, rad, in Si
  Mat3 cov_Si = Mat3::Zero();    ///< covariance of the mean, rad^2
  double iba_dev_mean_rad = 0;   ///< mean IBA deviation, rad
};

class BoresightMonitor {
 public:
  Status configure(const HeadSetConfig& cfg);
  void reset();
  Status step(const ValidHeads& in);
  /// This epoch's result of the pair a < b (valid false when a head is missing).
  const PairDeformation& pair(int a, int b) const { return cur_[static_cast<std::size_t>(pairIndex(a, b))]; }
  DeformationMean mean(int a, int b) const;
  /// Relative matrix C_Sa_Sb with the latest correction (T C0 for a < b; transposed for a > b);
  /// the ground matrix until the pair has been seen. Identity for a == b.
  Mat3 correctedRelative(int a, int b) const;
  Mat3 groundRelative(int a, int b) const;
  const Health& health() const { return health_; }

 private:
  HeadSetConfig cfg_{};
  bool configured_ = false;
  std::array<Mat3, kMaxPairs> C0_ = filled<Mat3, kMaxPairs>(Mat3::Zero());        ///< C_Si_Sj^0
  std::array<Vec3, kMaxPairs> n_ = filled<Vec3, kMaxPairs>(Vec3::Zero());         ///< IBA sensing axis in Si
  std::array<double, kMaxPairs> alpha0_{};
  std::array<Mat3, kMaxPairs> cov_ = filled<Mat3, kMaxPairs>(Mat3::Zero());       ///< Sigma_i + C0 Sigma_j C0^T
  std::array<Mat3, kMaxPairs> W1_ = filled<Mat3, kMaxPairs>(Mat3::Zero());        ///< its inverse
  std::array<Quat, kMaxPairs> q0_ = filled<Quat, kMaxPairs>(Quat::Identity());        ///< C0 as a quaternion
  std::array<Mat3, kMaxPairs> T_last_ = filled<Mat3, kMaxPairs>(Mat3::Identity());
  std::array<PairDeformation, kMaxPairs> cur_{};
  struct Acc {
    std::uint64_t n = 0;
    Mat3 W_sum = Mat3::Zero();
    Vec3 W_delta = Vec3::Zero();
    double dev_sum = 0;
  };
  std::array<Acc, kMaxPairs> acc_{};
  bool have_last_ = false;
  TimeUs last_t_ = 0;
  Health health_{};
};

}  // namespace boresight::core
