// Multi-head attitude from star vectors (METHODS 2.4).
//
// Star j seen by head k: unit vector s_j in Sk and its catalogue direction r_j in I. Into the frame of
// the reference head R: u_j = C_SR_Sk s_j, with C_SR_Sk the ground relative matrix or, after
// setRelative(), the thermally corrected one (BoresightMonitor::correctedRelative). Wahba:
//   C_SR_I = argmin sum_j w_j |u_j - C r_j|^2,   w_j = 1 / sigma_j^2
// solved by SVD of the attitude profile matrix sum_j w_j u_j r_j^T (proper rotation enforced).
// Covariance of the small-rotation error in SR: P = (sum_j w_j (I - u_j u_j^T))^-1 from the star noise,
// plus the uncertainty of the relative matrices: an error C_SR_Sk,true = Exp(e_k) C_SR_Sk (e_k in SR,
// covariance Q_k, set with setRelative) rotates every star of head k by the same e_k, so it does not
// average down over the stars; to first order the solution moves by G_k e_k, G_k = P A_k with
// A_k = sum_{j in k} w_j (I - u_j u_j^T) (a common rotation of all stars, e_k = e for every k, moves it
// by P sum_k A_k e = e). Hence
//   P_SR = P + sum_k G_k Q_k G_k^T.
// (Adding skew(u) Q_k skew(u)^T to each star's own noise instead would treat the common error as
// independent per star and understate its effect by about the number of stars of the head.)
// The weights stay the stars' own (1/sigma^2); the head correlation is carried in P_SR only.
// Selection: at most kMaxStars of the inputs, greedily: each pick is the star most perpendicular to
// the currently weakest direction (smallest eigenvector of the information collected so far), i.e.
// the star that adds most information where it is missing; the first pick is the most precise star.
#pragma once

#include "boresight/core/heads.h"

namespace boresight::core {

struct StarObservation {
  int head_id = 0;               ///< telemetry id of the head that saw the star
  Vec3 s_Sk = Vec3::UnitZ();     ///< measured unit direction in the head frame
  Vec3 r_I = Vec3::UnitZ();      ///< catalogue unit direction in I (aberration applied by the caller)
  double sigma_rad = 0;          ///< 1-sigma direction error, rad; 0: the head's configured sigma_star_rad
};

struct StarEpoch {
  TimeUs t = 0;
  int n = 0;  ///< observations used in `star`
  std::array<StarObservation, kMaxStarInputs> star{};
};

struct WahbaConfig {
  HeadSetConfig heads{};
  int reference_slot = 0;          ///< the head whose frame the solution is expressed in
  double min_information = 0;      ///< reject when the smallest info eigenvalue (rad^-2) is below; 0: 1/(10 sigma)^2 of the best star
  double unit_tolerance = 1e-6;    ///< | |s| - 1 | and | |r| - 1 | above this reject the star
};

struct WahbaSolution {
  TimeUs t = 0;
  Quat q_I_SR = Quat::Identity();  ///< attitude of the reference head, R = C_I_SR
  Quat q_I_B = Quat::Identity();   ///< body attitude through the reference head's mounting
  Mat3 P_SR = Mat3::Zero();        ///< covariance of the small-rotation error in SR, rad^2 (stars + relative matrices)
  Mat3 P_stars_SR = Mat3::Zero();  ///< the star-noise part of P_SR alone, rad^2
  int stars_in = 0;                ///< valid inputs
  int stars_used = 0;              ///< selected (<= kMaxStars)
  std::array<std::int16_t, kMaxStars> used{};  ///< indices into StarEpoch::star
  double residual_rms_rad = 0;     ///< RMS of |u - C r| over the used stars
};

class MultiHeadWahba {
 public:
  Status configure(const WahbaConfig& cfg);
  void reset();
  /// Relative matrix C_SR_Sk used for head `slot` until reset() (ground value after configure).
  Status setRelative(int slot, const Mat3& C_SR_Sk);
  /// The same with the covariance (rad^2, in SR) of its error e: C_true = Exp(e) C_SR_Sk.
  Status setRelative(int slot, const Mat3& C_SR_Sk, const Mat3& cov_SR);
  Status step(const StarEpoch& in);
  const WahbaSolution& output() const { return out_; }
  const Health& health() const { return health_; }

 private:
  WahbaConfig cfg_{};
  bool configured_ = false;
  std::array<Mat3, kMaxHeads> C_SR_Sk0_ = filled<Mat3, kMaxHeads>(Mat3::Identity());
  std::array<Mat3, kMaxHeads> C_SR_Sk_ = filled<Mat3, kMaxHeads>(Mat3::Identity());
  std::array<Mat3, kMaxHeads> Q_SR_ = filled<Mat3, kMaxHeads>(Mat3::Zero());  ///< relative-matrix error covariance
  std::array<std::int8_t, kMaxStarInputs> slot_{};
  Quat q_SR_B_ = Quat::Identity();
  std::array<Vec3, kMaxStarInputs> u_ = filled<Vec3, kMaxStarInputs>(Vec3::Zero());
  std::array<double, kMaxStarInputs> w_{};
  std::array<std::int16_t, kMaxStarInputs> idx_{};
  bool have_last_ = false;
  TimeUs last_t_ = 0;
  WahbaSolution out_{};
  Health health_{};
};

}  // namespace boresight::core
