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
//
// Filtered deformation (what Wahba uses): the deformation follows the orbit's thermal cycle (~5400 s),
// so the all-time mean cannot serve as a correction. Per pair, an information-weighted mean with
// exponential forgetting of time constant tau:
//   Wf <- f Wf + W_k,  yf <- f yf + W_k delta_k,  Vf <- f^2 Vf + W_k,   f = exp(-(t_k - t_prev)/tau)
//   delta_f = Wf^-1 yf,   cov(delta_f) = Wf^-1 Vf Wf^-1   (exact for independent epochs: the noise part)
// The covariance does not contain the lag of the filter behind a changing deformation (about
// tau * d(delta)/dt; for a sinusoid of amplitude A and period T the lag error has amplitude
// A w tau / sqrt(1 + (w tau)^2), w = 2 pi / T): tau trades noise (~ sigma sqrt(dt / 2 tau)) against
// lag; DeformationFilterConfig documents the default and test/core/thermal_test measures the trade.
// While the pair is not seen the estimate is held and its covariance grows by (hold_drift * age)^2
// per axis; setPredictedDeformation() replaces the held value by an external prediction (the batch
// solver's harmonic model) until the pair is seen again. A prediction not renewed (no orbit input) is
// held the same way: its covariance grows by (hold_drift * its age)^2.
//
// Corrections handed to Wahba (relativeFor):
//   kNone               C0, covariance 0
//   kIbaOneAxis         T C0 of the last epoch that saw the pair (the seed's METHODS 2.3 correction),
//                       covariance sigma_iba^2 n n^T (its own noise; the two other axes are unmodelled)
//   kFilteredThreeAxis  Exp(delta_f) C0 with cov(delta_f) (+ hold growth)
#pragma once

#include "boresight/core/heads.h"

namespace boresight::core {

using Mat6 = Eigen::Matrix<double, 6, 6>;
using Vec6 = Eigen::Matrix<double, 6, 1>;

struct PairDeformation {
  bool valid = false;            ///< both heads present at this epoch
  double iba_rad = 0;            ///< in-orbit inter-boresight angle, rad
  double iba_ground_rad = 0;     ///< ground value, rad
  double iba_dev_rad = 0;        ///< iba - ground, rad
  /// Real-time correction matrix (acts in Si on C0 b_j): rotation by iba_dev_rad about n_iba_Si
  /// (formed on demand: the monitor's step does not need it).
  Mat3 T_Si() const { return so3Exp(iba_dev_rad * n_iba_Si); }
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

/// Which relative matrix the star-vector solution uses for a head (see relativeFor).
enum class RelativeCorrection : std::uint8_t {
  kNone = 0,               ///< ground matrices only
  kIbaOneAxis = 1,         ///< rotation by the last epoch's IBA deviation about the IBA axis (seed)
  kFilteredThreeAxis = 2,  ///< filtered three-axis deformation with its covariance (default)
};

/// The deformation model inside the forgetting window.
enum class DeformationModel : std::uint8_t {
  kLevel = 0,   ///< constant: lags a changing deformation by about tau d(delta)/dt
  kLinear = 1,  ///< level and rate at the current epoch (exponentially weighted local line): no
                ///< first-order lag; the residual for a sinusoid is about A (w tau)^2; noisier than kLevel
};

struct DeformationFilterConfig {
  DeformationModel model = DeformationModel::kLinear;
  /// Forgetting time constant, s. Default 150 s with kLinear. Measured (thermal_test,
  /// FilterTimeConstantTradeOff: GRACE-like geometry, sigma 6"/48", 2 Hz, deformation 20/15/25"
  /// sinusoids of 5400 s; 3-D RMS error of the filtered deformation against the injected truth):
  ///   level : tau 30/60/100/150/300 s -> 6.4/5.0/4.8/5.5/8.9", mean NEES 3.2/5.0/12.9/37/256
  ///   linear: tau 30/60/100/150/300 s -> 9.8/7.0/5.5/4.7/4.7", mean NEES 3.0/3.0/3.0/3.5/13
  /// The linear model at 150 s is as accurate as the best level filter and its covariance stays
  /// honest (NEES ~3: the lag it leaves is small against its noise), which Wahba's covariance needs;
  /// the level filter's best error comes with a covariance 4x too small (lag-dominated).
  double tau_s = 150.0;
  /// Growth of the held estimate's 1-sigma per axis while the pair is not seen, rad/s. Default: the
  /// largest rate of a 20" sinusoid of 5400 s period (2 pi 20" / 5400 s = 0.023"/s).
  double hold_drift_rad_per_s = 0.023 * kRadPerArcsec;
};

/// The filtered deformation of a pair at the latest epoch.
struct FilteredDeformation {
  bool valid = false;             ///< the pair has been seen (or a prediction was set)
  bool predicted = false;         ///< the value is an external prediction, not the filter's
  TimeUs t = 0;                   ///< last epoch that updated it
  Vec3 delta_Si = Vec3::Zero();   ///< rad, in Si (C_Si_Sj = Exp(delta) C0)
  Mat3 cov_Si = Mat3::Zero();     ///< rad^2 (noise part, without the hold growth)
  double n_eff = 0;               ///< effective number of epochs in the filter
  std::uint64_t solve_failures = 0;  ///< times the filter's normal equations were singular (value kept)
};

class BoresightMonitor {
 public:
  Status configure(const HeadSetConfig& cfg) { return configure(cfg, DeformationFilterConfig{}); }
  Status configure(const HeadSetConfig& cfg, const DeformationFilterConfig& filter);
  void reset();
  Status step(const ValidHeads& in);
  /// The same with the epoch's pair relatives already formed (the pipeline shares them with the means;
  /// formed here when they do not belong to `in`).
  Status step(const ValidHeads& in, const PairRelatives& rel);
  /// This epoch's result of the pair a < b (valid false when a head is missing).
  const PairDeformation& pair(int a, int b) const { return cur_[static_cast<std::size_t>(pairIndex(a, b))]; }
  DeformationMean mean(int a, int b) const;
  /// Relative matrix C_Sa_Sb with the latest correction (T C0 for a < b; transposed for a > b);
  /// the ground matrix until the pair has been seen. Identity for a == b.
  Mat3 correctedRelative(int a, int b) const;
  Mat3 groundRelative(int a, int b) const;
  /// Filtered deformation of the pair a < b (invalid otherwise or before the pair was seen).
  FilteredDeformation filtered(int a, int b) const;
  /// Relative matrix C_Sa_Sb for the chosen correction at time t (>= the last head epoch) and the
  /// covariance of its error e in Sa (C_true = Exp(e) C), rad^2. Any order of a and b.
  /// kInvalidConfig for bad slots; kOk otherwise (the ground matrix before the pair has been seen).
  Status relativeFor(int a, int b, RelativeCorrection mode, TimeUs t, Mat3& C_Sa_Sb, Mat3& cov_Sa) const;
  /// Seam for the batch solver: a predicted deformation of the pair a < b (e.g. from a harmonic
  /// model) used instead of the held filter value while the pair is not seen; the next epoch that
  /// sees the pair clears it. kNonFinite / kInvalidConfig on bad input.
  Status setPredictedDeformation(int a, int b, TimeUs t, const Vec3& delta_Si, const Mat3& cov_Si);
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
  std::array<double, kMaxPairs> cos0_{}, sin0_{};  ///< cos and sin of alpha0
  std::array<double, kMaxPairs> sigma_iba2_nom_{};  ///< n^T cov n at unit sigma scales
  std::array<double, kMaxPairs> dev_last_{};        ///< IBA deviation of the last epoch that saw the pair
  std::array<PairDeformation, kMaxPairs> cur_{};
  struct Acc {
    std::uint64_t n = 0;
    std::uint64_t n_nom = 0;        ///< epochs at unit sigma scales (information W1: counted, not summed)
    Vec3 delta_nom = Vec3::Zero();  ///< sum of their delta
    Mat3 W_sum = Mat3::Zero();      ///< the other epochs: sum W, sum W delta
    Vec3 W_delta = Vec3::Zero();
    double dev_sum = 0;
  };
  std::array<Acc, kMaxPairs> acc_{};
  struct Filt {
    bool seen = false;
    TimeUs t = 0;
    // sums over the epochs k with weights g_k = exp((t_k - anchor) / tau), s_k = t_k - anchor (s):
    //   S_m = sum g_k s_k^m W_k, N_m = sum g_k^2 s_k^m W_k (m = 0..2), y_m = sum g_k s_k^m W_k delta_k
    // (a common factor of the weights changes neither the estimate nor M^-1 N M^-1). Epochs with the
    // nominal information W1 (sigma scales 1, almost all) go into scalar and vector sums
    // (a_m = sum g s^m, b_m = sum g^2 s^m, z_m = sum g s^m delta; S_m = a_m W1 + ...), the others
    // into the matrix sums below (`general` once there is one).
    double a0 = 0, a1 = 0, a2 = 0, b0 = 0, b1 = 0, b2 = 0;
    Vec3 z0 = Vec3::Zero(), z1 = Vec3::Zero();
    bool general = false;
    Mat3 S0 = Mat3::Zero(), S1 = Mat3::Zero(), S2 = Mat3::Zero();
    Mat3 N0 = Mat3::Zero(), N1 = Mat3::Zero(), N2 = Mat3::Zero();
    Vec3 y0 = Vec3::Zero(), y1 = Vec3::Zero();
    double wsum = 0, w2sum = 0;  ///< scalar weights, for the effective count
    // the solution, computed on demand from the sums (const accessors: a cache)
    mutable bool dirty = false;
    mutable Vec3 delta = Vec3::Zero();
    mutable Mat3 cov = Mat3::Zero();
    mutable std::uint64_t solve_failures = 0;  ///< singular normal equations (estimate kept)
    bool predicted = false;
    TimeUs t_pred = 0;
    Vec3 delta_pred = Vec3::Zero();
    Mat3 cov_pred = Mat3::Zero();
  };
  std::array<Filt, kMaxPairs> filt_{};
  /// The weights of one epoch (g = exp((t - anchor) / tau), s = t - anchor) and their products, shared by its pairs.
  struct EpochWeights {
    double g = 0, g2 = 0, sa = 0, gs = 0, gss = 0, g2s = 0, g2ss = 0;
  };
  EpochWeights epochWeights(TimeUs t) const;
  __attribute__((always_inline)) inline void updateFilter(Filt& F, TimeUs t, const EpochWeights& w, bool nominal,
                                                          const Mat3& W, const Vec3& delta);
  void reanchor(TimeUs t);
  /// Re-anchoring period of the filters' time origin, s (weights up to e^(kReanchorS / tau); the
  /// shift s -> s - d at a solve loses about (kReanchorS / tau)^2 of relative precision: fine).
  static constexpr double kReanchorS = 600.0;
  TimeUs anchor_ = 0;
  bool have_anchor_ = false;
  void solveFilter(const Filt& F, const Mat3& W1) const;
  std::array<double, kMaxPairs> sigma_iba2_{};  ///< n^T cov n, rad^2 (last epoch)
  DeformationFilterConfig fcfg_{};
  bool have_last_ = false;
  TimeUs last_t_ = 0;
  mutable Health health_{};  ///< mutable: the on-demand filter solve (const accessors) counts its failures
};

}  // namespace boresight::core
