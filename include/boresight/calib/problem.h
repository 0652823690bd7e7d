// boresight::calib - the batch calibration problem of method A (METHODS 1.2, 1.5-1.7): what the span
// builder collects from the core's streams and what the Ceres solver takes and returns.
//
// This header is the contract between the span builder / `boresight calibrate` (producers and
// consumers) and the solver (include/boresight/calib/solver.h). Frames and units follow
// include/boresight/core/conventions.h. Error angles: C_S_B(true) = Exp([r]x) C_S_B(nominal), r in the
// head frame, rad. The accelerometer frame A is the datum (a rotation of A cannot be told from a common
// rotation of all heads): B here means "the body frame as the configured C_B_A puts A into it".
#pragma once

#include "boresight/core/capacities.h"
#include "boresight/core/conventions.h"

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace boresight::calib {

using core::kMaxHeads;

/// One calibration epoch (decimated, see SpanOptions): per-head CRN angular accelerations in each head's
/// own frame and the accelerometer's through the same CRN low-pass on the same tag.
struct Observation {
  TimeUs t = 0;                                   ///< centre tag of the CRN outputs, us past GPS J2000
  std::array<bool, kMaxHeads> has_head{};         ///< slot h observed at t
  std::array<Vec3, kMaxHeads> alpha_S{};          ///< head h angular acceleration in S_h, rad/s^2
  std::array<Mat3, kMaxHeads> cov_alpha_S{};      ///< its covariance (head noise through the CRN), rad^2/s^4
  Vec3 alpha_A = Vec3::Zero();                    ///< accelerometer angular acceleration in A, rad/s^2 (CRN)
  Mat3 cov_alpha_A = Mat3::Zero();                ///< its covariance, rad^2/s^4
  Vec3 jerk_A = Vec3::Zero();                     ///< d(alpha_A)/dt in A, rad/s^3 (for the time offset)
  Vec3 w_B = Vec3::Zero();                        ///< fused angular rate in B, rad/s (context, plots)
};

/// Mean relative attitude of a head pair over the span (METHODS 1.2), from core::RelativeAttitudeMeans.
struct RelativeMean {
  int slot_i = 0, slot_j = 1;          ///< head slots (0-based, as in HeadSetConfig)
  Quat q_Si_Sj = Quat::Identity();     ///< R = C_Si_Sj
  Mat3 cov_Sj = Mat3::Zero();          ///< covariance of the mean, small rotation in Sj, rad^2
  std::uint64_t epochs = 0;
};

/// Joint relative alignment of all heads from every epoch with two or more heads (normal equations).
/// Head h's attitude implies a body attitude R_h = C_I_Sh A_h (A_h the anchor mounting: M_0 for the
/// first head, the others from the epoch where they were first seen with an anchored head); with
/// x_h = Log(R_ref^T R_h) (in B) and C_B_Sh(true) A_h = Exp(delta_h), x_h = theta + delta_h + noise
/// (theta the epoch's common offset). Eliminating theta per epoch (its information-weighted mean) gives
/// info = sum P^T W P and info_x = sum P^T W x over the epochs, P the projector; the pair means of the
/// core treat the three pairs of three heads as independent though they share the heads' noise (too
/// optimistic by up to the number of pairs sharing a head), this does not. delta is found up to a
/// common rotation (fix one head); first order in |delta| (the anchors make it the noise level).
struct RelativeNormal {
  std::array<Quat, kMaxHeads> q_S_B_anchor{};       ///< A_h, R = C_Sh_B
  std::array<bool, kMaxHeads> anchored{};
  std::array<std::array<bool, kMaxHeads>, kMaxHeads> together{};  ///< heads h, g seen in one epoch
  Eigen::Matrix<double, 3 * kMaxHeads, 3 * kMaxHeads> info = Eigen::Matrix<double, 3 * kMaxHeads, 3 * kMaxHeads>::Zero();
  Eigen::Matrix<double, 3 * kMaxHeads, 1> info_x = Eigen::Matrix<double, 3 * kMaxHeads, 1>::Zero();
  std::uint64_t epochs = 0;
};

/// Sufficient statistics of one head's epochs (SpanBuilder, always accumulated): the model is linear
/// in the data vector d = (alpha_S, alpha_A, jerk_A, 1) (10 values) for given parameters, so the
/// least-squares cost over any number of epochs is exactly tr(A D A^T) with D = sum d d^T. `whitened`:
/// d after the temporal whitening (streaming banded Cholesky, the same recurrences as the solver's);
/// `raw`: d as observed (residual RMS). Constant memory: what SolveOptions::from_moments solves.
struct HeadMoments {
  std::uint64_t n = 0;
  Eigen::Matrix<double, 10, 10> whitened = Eigen::Matrix<double, 10, 10>::Zero();
  Eigen::Matrix<double, 10, 10> raw = Eigen::Matrix<double, 10, 10>::Zero();
  Mat3 cov = Mat3::Zero();  ///< the epochs' covariance (the same for every epoch of the head)
};

/// Everything the solver needs; bounded in memory by SpanOptions::max_observations.
struct CalibrationSpan {
  int n_heads = 0;
  std::array<int, kMaxHeads> head_ids{};            ///< telemetry ids by slot
  std::array<Quat, kMaxHeads> q_S_B_nominal{};      ///< nominal mountings, R = C_Si_B
  Mat3 C_B_A = Mat3::Identity();                    ///< configured accelerometer-to-body rotation
  std::vector<Observation> obs;                     ///< decimated epochs in time order
  std::vector<RelativeMean> relative;               ///< one per head pair with data (reports, closure)
  RelativeNormal relative_normal;                   ///< what the solver uses for the relative attitude
  std::array<HeadMoments, kMaxHeads> moments{};     ///< per head, every epoch (also those not kept in obs)
  Eigen::Matrix4d acc_moments = Eigen::Matrix4d::Zero();  ///< sum of (alpha_A, 1)(alpha_A, 1)^T
  std::uint64_t epochs_total = 0;                   ///< epochs made (obs holds them unless not kept)
  TimeUs t_first = 0, t_last = 0;                   ///< first and last head epoch pushed
  std::uint64_t head_epochs = 0, acc_samples = 0;   ///< inputs that went into the span
  double decimation_s = 0.0;                        ///< spacing of obs (multiples of it between epochs)
  /// Correlation of one head's CRN acceleration noise between epochs k decimation intervals apart,
  /// k = 0, 1, ... (entry 0 is 1; the list ends where the kernels no longer overlap or |rho| < 1e-4).
  /// The head noise is white at the head rate, so this is sum_n g2[n] g2[n + k D fs] / sum_n g2[n]^2
  /// of the CRN second-derivative kernel. The solver whitens each head's epochs with it.
  std::vector<double> noise_correlation;
  /// The white part added to noise_correlation so that its spectrum stays at or above 0.05 (fine
  /// decimations, where the kernel's correlation matrix is nearly singular); 0 at 8 s and coarser.
  double noise_white_fraction = 0.0;
  /// CRN outputs of the heads that never became observations (no accelerometer value at their tag:
  /// accelerometer gap, start or end of its data), and head epochs the validator rejected.
  std::uint64_t dropped_no_acc = 0, head_epochs_rejected = 0;
  /// Head outputs that came after the observation of their tag had gone to the span (a head whose
  /// CRN waited one sample longer across a missing sample): left out, one head-observation each.
  std::uint64_t late_head_outputs = 0;
  double crn_half_length_s = 0.0;                   ///< CRN data needed each side of an epoch, s
};

}  // namespace boresight::calib
