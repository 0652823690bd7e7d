// boresight::calib - the method A solver (METHODS 1.7): Ceres over a CalibrationSpan, with the
// relative attitude as a hard constraint or a prior, optional accelerometer bias / scale /
// non-orthogonality and a star-camera-to-accelerometer time offset, the covariance, the Fisher
// information of the same model (Cramer-Rao bound) and the observability of every head axis.
//
// Model (METHODS 1.7). Per decimated epoch k and head h, in the head frame S_h:
//   alpha_S,h(t_k) = C_Sh_B C_B_A K^-1 (alpha_A(t_k + tau) - b) + noise,
//   K = I + diag(s) + N(n) (scale s, symmetric non-orthogonality n: N = [0 n2 n1; n2 0 n0; n1 n0 0]),
//   alpha_A(t + tau) = alpha_A(t) + tau jerk_A(t) (first order: tau << the CRN's 10 s time scale).
// C_Sh_B = Exp([r_h]x) M_h (r_h the error angles). A is the datum: no rotation of A is estimated (its
// antisymmetric part is a common rotation of all heads); K's symmetric part is what A's axes can
// have beyond a rotation.
// Relative attitude: kHardConstraint first fits the relative alignment of the heads to the pair means
// (C_Sh_B = Exp(psi_h) M_h Exp(-phi), psi_0 = 0, the psi_h from the pair means alone, closure
// consistent with three or more heads), then one common rotation phi (in B) with the accelerometer;
// kPrior estimates every r_h with the pair means as residuals with their covariance.
// Noise: each head's epochs are whitened in time with CalibrationSpan::noise_correlation (banded
// Cholesky of the correlation matrix of the epochs' CRN noise) and in space with the epoch's
// covariance (head noise plus the accelerometer's rotated into S_h); whiten = false treats epochs as
// independent (optimistic: the Monte Carlo shows it).
// Covariance and bound: from the information matrix J^T J of the whitened residuals (not
// ceres::Covariance): the covariance with the robust loss weights at the solution, the Cramer-Rao
// bound without them (cramerRao() evaluates it at any parameters, e.g. the truth). Directions with no
// information (exactly degenerate) or a sigma above unobservable_sigma_arcsec are "not determined".
//
// Contract owned by the solver; the CLI (`boresight calibrate`) only reads the result.
#pragma once

#include "boresight/calib/problem.h"

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace boresight::model {
struct JacobianCheck;
}

namespace boresight::calib {

enum class RelativeMode { kHardConstraint, kPrior };

struct SolveOptions {
  RelativeMode relative = RelativeMode::kHardConstraint;
  bool estimate_acc_bias = true;
  bool estimate_acc_scale = false;
  bool estimate_acc_nonorthogonality = false;
  bool estimate_time_offset = false;
  double huber_sigma = 5.0;           ///< robust loss threshold in whitened residual units (0 = none)
  int max_iterations = 200;
  int threads = 1;                    ///< Ceres threads (1 = deterministic)
  /// A direction is "not determined" when its information gives a sigma above this, arcsec.
  double unobservable_sigma_arcsec = 3600.0;
  bool whiten = true;                 ///< temporal whitening with the CRN noise correlation
  /// Outlier rounds: after a solve, head epochs whose raw residual exceeds this many sigma (the
  /// Mahalanobis norm with the epoch's covariance) are left out and the problem is solved again (at
  /// most outlier_rounds times; 0 = off). A transient on one sensor spreads over ~3 epochs in the
  /// whitened residuals; leaving the raw epoch out keeps it from its neighbours.
  double outlier_sigma = 6.0;
  int outlier_rounds = 3;
  /// Solve from CalibrationSpan::moments (the exact least-squares cost of all epochs in constant
  /// memory) instead of the observations: no robust loss and no outlier rounds (huber_sigma and
  /// outlier_sigma are ignored). Forced when the span kept no observations.
  bool from_moments = false;
  /// Fewest observations (decimated epochs with the accelerometer) accepted.
  std::size_t min_epochs = 20;
};

/// The model's parameters (an estimate, or the truth for the Monte Carlo): SI units, head frames.
struct ModelParameters {
  std::array<Vec3, kMaxHeads> r_S{};   ///< error angles by slot, rad (C_Sh_B = Exp([r]x) M_h)
  Vec3 acc_bias = Vec3::Zero();        ///< rad/s^2 in A
  Vec3 acc_scale = Vec3::Zero();       ///< s, -
  Vec3 acc_nonorth = Vec3::Zero();     ///< n, rad
  double time_offset_s = 0.0;          ///< tau, s (+: accelerometer tags late)
};

/// The accelerometer's axes beyond a rotation, the solver's K = I + diag(s) + N(n) with
/// N = [0 n2 n1; n2 0 n0; n1 n0 0] (the one place the model's matrix is written for doubles).
Mat3 accAxes(const Vec3& scale, const Vec3& nonorth);

/// The solver's model at the parameters `p`, per observation and head slot, in the head frame (rad/s^2):
/// alpha_S - Exp([r]x) M C_B_A K^-1 (alpha_A + tau jerk_A - b); NaN where the head has no value; times
/// in seconds since the first observation. What the report plots (it computes none of it itself).
struct SpanResiduals {
  std::vector<double> t_s;
  std::vector<std::array<Vec3, kMaxHeads>> r_S;  ///< by observation, slot
};
SpanResiduals residuals(const CalibrationSpan& span, const ModelParameters& p);

/// Covariance of the head angles (3 n_heads, by slot and axis), rad^2; determined[i] false where the
/// information has no (or too little) support: the variance is then meaningless (reported as inf).
struct HeadCovariance {
  Eigen::MatrixXd P;
  std::vector<bool> determined;
  Mat3 common_info_B = Mat3::Zero();   ///< information of a common rotation of all heads, in B, 1/rad^2
};

/// One estimated quantity with its sigma; sigma is empty when not determined (never a small number).
struct Estimate3 {
  std::array<double, 3> value{};
  std::array<std::optional<double>, 3> sigma{};
};

struct HeadResult {
  int id = 0;
  std::array<double, 3> error_angles_arcsec{};             ///< r in S_h
  std::array<std::optional<double>, 3> sigma_arcsec{};     ///< empty where not determined
  std::array<double, 3> crlb_arcsec{};                     ///< Cramer-Rao bound (inf where not determined)
  std::array<bool, 3> observable{};
};

/// Why solve() refused (ok = false), for callers and tests to branch on; the message says it in words
/// with what would be needed.
enum class Refusal : std::uint8_t {
  kNone,           ///< solved (ok)
  kInvalidSpan,    ///< an input the solver relies on is malformed (heads, ids, C_B_A, times, non-finite)
  kTooFewEpochs,   ///< fewer calibration epochs than min_epochs
  kHeadsNotLinked, ///< hard relative mode: a head never observed together with the others (singular)
  kSolverFailed,   ///< Ceres returned no usable solution
  kTooQuiet,       ///< solved, but no head axis is determined (too little angular acceleration)
};
const char* refusalName(Refusal r);

struct SolveResult {
  bool ok = false;
  Refusal refusal = Refusal::kNone;               ///< why not ok (kNone when ok)
  std::string message;                            ///< why not ok, or the solver's summary line
  std::vector<HeadResult> heads;
  std::vector<Vec3> unobservable_directions_B;    ///< unit vectors, shared by all heads
  std::vector<double> covariance_arcsec2;         ///< all head angles, (3n x 3n) row-major
  std::optional<Estimate3> acc_bias_radps2, acc_scale, acc_nonorthogonality_arcsec;
  std::optional<double> time_offset_s, time_offset_sigma_s;  ///< + : accelerometer tags late
  double residual_rms_radps2 = 0.0;
  std::size_t epochs = 0;
  double span_s = 0.0;
  std::vector<double> excitation_eigenvalues;     ///< of sum a a^T in B, ascending, rad^2/s^4
  ModelParameters estimate;                       ///< the raw estimate (SI), all slots
  HeadCovariance covariance;                      ///< with the robust weights (rad^2)
  HeadCovariance crlb;                            ///< Fisher information at the estimate, no loss
  int iterations = 0;
  std::size_t rejected_head_epochs = 0;           ///< left out as outliers (outlier_sigma)
  double closure_arcsec = 0.0;                    ///< hard mode, 3+ heads: pair means' closure error
};

/// Refuses (ok = false, message says why and what would be needed) a span too short or too quiet.
SolveResult solve(const CalibrationSpan& span, const SolveOptions& opt);

/// The Cramer-Rao bound of the head angles for this span and model (the options' free parameters) at
/// the parameters `at`: the inverse Fisher information of the whitened residuals, no robust loss. In
/// hard mode the relative alignment is fitted to the pair means first, as solve() does. Empty P on
/// refusal (the same checks as solve()), with *message.
HeadCovariance cramerRao(const CalibrationSpan& span, const SolveOptions& opt, const ModelParameters& at,
                         std::string* message = nullptr);

/// The solver's cost functors against numerical derivatives (ceres::GradientChecker: each residual
/// block's automatic Jacobian against central differences of the same functor), on the problem the span
/// and options build (the functors those options use: EpochCost with scale, non-orthogonality or time
/// offset free, EpochCostReduced without them, MomentCost from the moments, RelativeCost in prior mode)
/// at the parameters `at`. Up to `max_blocks` blocks of each functor, spread over the span. One entry per
/// functor met (model/jacobian_check.h); empty with *message on refusal (the same checks as solve()).
std::vector<model::JacobianCheck> checkJacobians(const CalibrationSpan& span, const SolveOptions& opt, const ModelParameters& at,
                                          std::size_t max_blocks, double relative_precision, std::string* message = nullptr);

}  // namespace boresight::calib
