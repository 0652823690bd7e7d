// The raw-data Cramer-Rao bound of method A: what the raw measurements of a span can tell about each
// head's mounting, whatever the estimator. It is the yardstick every method A accuracy figure is
// stated against, and it is computed on its own code path: no CRN filter, no decimation, nothing of
// the solver (calib/solver.h) is used.
//
// Linearised raw model (small angles, about the true trajectory; phi is the body's attitude
// perturbation, a rotation vector in B, C_I_B = C_I_B,true Exp(phi)):
//   head i, axis j (e1, e2, b), at each delivered sample:
//       y_ij = (R_i phi)_j + e_ij [+ harmonics_ij(t)] + n_ij(t)
//     R_i = head axes x C_Si_B (body -> head axes), e_i the mounting error (head axes), n_ij the head
//     axis's noise model (white per sample plus Gauss-Markov terms: coloured error, thermal wander).
//   accelerometer (the datum), between its samples, drives the trajectory:
//       phi' = v,   v' = -[alpha]x phi - [w]x v - C_B_A (b + s o alpha_A + tau alpha_A' + g(t) + n(t))
//     alpha, w the true angular acceleration and rate (B), alpha_A = C_A_B alpha, b the bias, s the scale
//     error, tau the time offset, g the Gauss-Markov terms of the accelerometer's noise model (colour,
//     bias wander) and n its white part (a continuous white noise of density sigma^2 T per A axis, T
//     the sample interval: its mean over one sample has the per-sample variance sigma^2). Where the
//     accelerometer has no sample, the angular acceleration is free (a white density of
//     gap_sigma^2 T, no bias or scale terms).
// Everything above that is unknown and not a parameter - the trajectory's start (phi0, v0) and every
// noise state - is a nuisance: the trajectory is free at every head epoch except through the
// accelerometer. The parameters are e_i for every head, the bias, and (options) the scale, the time
// offset and orbit harmonics (cos, sin of k u, u = orbit rate x t) of heads 2..n's alignment.
//
// Why a mounting error is visible at all: a constant rotation of all heads together looks like a
// constant attitude offset to the heads; it differs from one only through [alpha]x phi, i.e. where
// the body accelerates about another axis (the mismatch alpha x e between the heads' and the
// accelerometer's angular acceleration). A rotation about the only excited axis stays undetermined.
//
// Computation: the Fisher information of a linear Gaussian model with a diffuse trajectory start is
// sum_k u_k^T u_k / F_k over the scalar head observations, u_k the Kalman filter's innovation of the
// parameter columns and F_k its innovation variance (the Kalman gain does not depend on the data, so
// the information is exact), with (phi0, v0) as extra columns eliminated at the end (Schur
// complement). The 6-state trajectory block is stepped at every accelerometer sample; the noise
// states and the full covariance only at head epochs (the accelerometer's Gauss-Markov states enter
// the trajectory with their mean over the interval: exact to O(dt / tau) with dt the head interval).
// Cost: O(n^2) per scalar head observation, n = 6 + noise states.
//
// Not included: the field-of-view error (a deterministic function of the stars in view, not a
// stationary noise), outliers, sign flips. Times are seconds since any fixed origin, non-decreasing.
#pragma once

#include <boresight/core/conventions.h>
#include <boresight/model/noise.h>

#include <Eigen/Core>

#include <array>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

namespace boresight::model {
class HeadModel;
class AccelModel;
struct NoiseInUse;
}  // namespace boresight::model
namespace boresight::core {
struct PipelineConfig;
}  // namespace boresight::core

namespace boresight::calib {

struct RawBoundHead {
  int id = 1;
  Mat3 R_axes_B = Mat3::Identity();        ///< body vector -> components on the head axes (e1, e2, b)
  Mat3 C_Si_B = Mat3::Identity();          ///< nominal mounting (the estimator's prediction; the bound needs only R_axes_B)
  Mat3 axes_Si = Mat3::Identity();         ///< rows e1, e2, b in Si (R_axes_B = axes_Si C_Si_B)
  std::array<model::NoiseModel, 3> noise;  ///< per head axis (e1, e2, b), rad: white per sample + colour
};

struct RawBoundOptions {
  bool bias = true;          ///< a constant accelerometer bias per A axis
  bool scale = false;        ///< a scale error per A axis
  bool time_offset = false;  ///< the accelerometer's time offset
  int harmonics = 0;         ///< orbit harmonics 1..K of heads 2..n's alignment (cos and sin per axis)
  /// Their argument: u = orbit_phase_rad + orbit_rate_rad_s t (t the samples' time; with the orbit's
  /// phase the terms are harmonics of the argument of latitude).
  double orbit_rate_rad_s = 0;
  double orbit_phase_rad = 0;
  double gap_sigma_rad_s2 = 1e-3;  ///< angular acceleration where the accelerometer has no sample
  /// A body direction of the common rotation whose sigma exceeds this is not observable: it is held at
  /// its nominal value (projected out of the covariance and of estimateRaw's update) and listed in
  /// RawBoundResult::unobservable_B, so that the other directions and every head axis keep the sigmas
  /// they have given it. Infinite (the default): only directions without any information.
  double unobservable_sigma_rad = std::numeric_limits<double>::infinity();
  /// estimateRaw: an accelerometer scale factor whose sigma (the span's information, every other
  /// parameter free) exceeds this is held at its value from then on (nominal unless a pass before
  /// determined it) and named in RawBoundResult::held. An axis without angular acceleration determines
  /// nothing about its scale; left free, the Gauss-Newton step takes it to whatever the noise says (14 %
  /// on a 3 h span excited about z alone), and the linearisation there biases the mountings by several
  /// sigma. A scale error that large is not in any accelerometer; 1 % is far beyond a calibrated one.
  double scale_hold_sigma = 1e-2;
  /// estimateRaw: from its second pass on, a variance factor per head and group (cross-boresight axes
  /// e1 and e2 together, the boresight axis b) estimated from the data (model::estimateVarianceComponents
  /// on the groups' parameter information and residuals) and applied to that group's whole noise model
  /// in the next pass.
  bool variance_components = true;
  /// estimateRaw: the parameters' scores (information minus its part at the estimate) summed over blocks
  /// of this length for the data's own covariance (RawEstimate::robust_covariance); the noise's
  /// correlations shorter than a block are counted. 0: none.
  double score_block_s = 600;
  /// estimateRaw with 3 passes or more: after the second pass, every head axis's noise model is fitted
  /// to that pass's data less the trajectory's prediction (model::selectNoise: white, white +
  /// Gauss-Markov, white + power law, by BIC) and replaces the model in use for the following passes
  /// (RawEstimate::fitted_noise).
  bool fit_noise = false;
  /// With fit_noise: the model in use before the fit (the platform file's, or an overlay's) keeps its
  /// Gauss-Markov parts (power laws expanded) too slow for the span to determine - a corner frequency
  /// below the fit's band, band_lo / span - beside the fitted model. The data cannot tell such noise from
  /// a constant mounting error, so no fit finds it; only a model stated beforehand puts it in the
  /// covariance (a white-only platform file adds nothing).
  bool keep_slow_noise = true;
  /// estimateRaw: the noise fits (one per head axis, independent) run on this many threads; the result
  /// does not depend on it (each fit is the same arithmetic on whichever thread runs it).
  unsigned threads = 1;
};

struct RawBoundConfig {
  std::vector<RawBoundHead> heads;
  Mat3 C_A_B = Mat3::Identity();                ///< body -> accelerometer frame
  std::array<model::NoiseModel, 3> acc_noise;   ///< per A axis, rad/s^2 (white: per sample)
  double acc_interval_s = 0.1;
  RawBoundOptions options;
  /// "" when usable, else the reason.
  std::string validate() const;
};

/// The configuration of a simulated instrument set: each head's nominal mounting and axes, its white
/// levels with coloured_noise and thermal_wander, the accelerometer's nominal frame, white, low-
/// frequency, acc_coloured_noise and acc_bias_wander models.
RawBoundConfig rawBoundConfig(const std::vector<model::HeadModel>& heads, const model::AccelModel& acc,
                              const RawBoundOptions& options);

/// The configuration of a platform file (with its overlay): the heads' nominal mountings and boresight
/// axes from the pipeline, every head axis's and accelerometer axis's noise model in use.
RawBoundConfig rawBoundConfig(const core::PipelineConfig& pipeline, const model::NoiseInUse& noise,
                              const RawBoundOptions& options);

struct RawBoundResult {
  std::vector<std::string> names;  ///< parameter names, in the order of `information`
  Eigen::MatrixXd information;     ///< of the parameters, the trajectory start eliminated (SI units)
  Eigen::MatrixXd covariance;      ///< its pseudo-inverse (eigenvalues below 1e-14 of the largest dropped)
  std::vector<Vec3> head_sigma_rad;  ///< per head, head axes (e1, e2, b)
  std::vector<Vec3> relative_sigma_rad;  ///< head i against head 1 (i >= 2; entry 0 zero), head i's axes
  /// The rotation common to all heads (head 1's error in B, the others tied to it), its information with
  /// every other parameter eliminated, as principal body directions (columns, unit) and sigmas (rad,
  /// infinite where the information is zero), smallest sigma first.
  Mat3 common_axes_B = Mat3::Identity();
  Vec3 common_sigma_rad = Vec3::Zero();
  Vec3 bias_sigma_rad_s2 = Vec3::Zero();  ///< zero when the bias is not a parameter
  /// Body directions of the common rotation held at their nominal value (options.unobservable_sigma_rad;
  /// the covariance and the sigmas above are those given it).
  std::vector<Vec3> unobservable_B;
  /// Parameters estimateRaw held at their value because the span does not determine them (a scale
  /// factor beyond options.scale_hold_sigma): their names; the covariance is given them held (their
  /// rows and columns zero).
  std::vector<std::string> held;
  double span_s = 0;
  std::vector<std::uint64_t> head_samples;
  std::uint64_t acc_samples = 0, acc_gaps = 0, head_samples_before_acc = 0;
};

/// Method A's estimate in the attitude domain: the bound's filter run on measured data. The trajectory's
/// reference is the filter's own (propagated with the measured angular acceleration, re-anchored at
/// every head sample: an error-state Kalman filter), the parameters are estimated by the regression
/// through the filter (their columns' innovations, as for the bound), so that at the end
/// theta = I^-1 sum u^T v / F, v the data's innovations. Passes linearise again about the previous
/// estimate (Gauss-Newton). A head sample whose innovations exceed 6 sigma is rejected (counted).
struct RawEstimate {
  RawBoundResult bound;            ///< information and sigmas at this estimate's linearisation
  std::vector<Vec3> mounting_rad;  ///< per head r, C_Si_B(true) = Exp(r) C_Si_B(nominal), Si axes; datum: the accelerometer
  Vec3 bias_rad_s2 = Vec3::Zero(), scale = Vec3::Zero();
  /// options.harmonics: the harmonic parameters in the order of bound.names (head 2's e1 h1 cos, sin,
  /// h2 ..., e2 ..., b ..., then head 3 ...); head i's alignment against the others moves by the rotation
  /// -axes_Si^T H(t) (Si), H its per-axis sum of the terms: as the mounting's parameter enters. Empty
  /// without harmonics.
  Eigen::VectorXd harmonics;
  double time_offset_s = 0;  ///< accelerometer tags late by this (s); with options.time_offset
  double chi2_per_obs = 0;  ///< sum v^2 / F over the head axes used, divided by their number
  std::uint64_t head_samples_rejected = 0;
  int passes = 0;
  /// Per head {cross-boresight, about the boresight}: the variance factor applied to the noise model in
  /// use in the last pass (the product of the passes' estimates; 1 without variance components), and the
  /// last pass's residual square sum over its redundancy (chi-square per degree of freedom: about 1 when
  /// the applied factor fits the data).
  std::vector<std::array<double, 2>> variance_factor, chi2_per_dof;
  /// The data's own covariance of the parameters (same order as bound.information): the sandwich
  /// C M C with C = bound.covariance and M the sum over score blocks of each block's score outer
  /// product, each divided by 1 - its leverage (options.score_block_s). Counts noise that the model in
  /// use lacks (colour, wander) as far as it decorrelates within a block. Empty without blocks.
  Eigen::MatrixXd robust_covariance;
  std::vector<Vec3> robust_head_sigma_rad;  ///< per head, head axes; infinite where not determined
  std::size_t score_blocks = 0;             ///< blocks with head samples
  /// options.fit_noise: per head and axis (e1, e2, b) the model fitted to the data less the trajectory's
  /// prediction (rad; not the innovation, which the noise states of a coloured model in use have
  /// whitened); empty otherwise. An approximation: the fused trajectory took part of each head's noise,
  /// so slow parts common to the trajectory are seen reduced.
  std::vector<std::array<model::NoiseModel, 3>> fitted_noise;
};

/// An attitude-domain estimate as mountings: each head's error angles in its own frame Si, their sigmas
/// (rad; NaN where the axis is not determined: no information about the head, or a sigma at or above
/// `not_determined_rad`, with the unobservable common directions held) and the Si-frame covariance of
/// every head's angles (3n x 3n, rad^2). What `boresight calibrate --raw` reports and the node's worker
/// publishes (one conversion).
struct RawMountings {
  std::vector<Vec3> r_Si, sigma_Si;
  Eigen::MatrixXd covariance_Si;
  bool common_determined = false;  ///< every body direction of the common rotation determined
};
RawMountings rawMountings(const RawEstimate& est, const RawBoundConfig& cfg, double not_determined_rad);

/// The 1-sigma of a named parameter of a result (RawBoundResult::names, e.g. "acc_time_offset",
/// "acc_scale.x"): NaN when the result has no such parameter, 0 when it lies in the covariance's null
/// space - the span does not determine it (or it is held) - which callers report as not determined.
double parameterSigma(const RawBoundResult& r, const std::string& name);

/// One orbit-harmonic term of a head's alignment against the others (options.harmonics): head i's
/// mounting rotates in its own frame Si by sum_k cos_k cos(k u) + sin_k sin(k u) (rad; the estimate's
/// head-axis parameters H enter as -axes_Si^T H), with the 3x3 covariance of each.
struct OrbitHarmonicTerm {
  std::size_t head = 0;  ///< index in cfg.heads (1..n-1)
  int harmonic = 1;
  Vec3 cos_Si = Vec3::Zero(), sin_Si = Vec3::Zero();
  Mat3 cov_cos_Si = Mat3::Zero(), cov_sin_Si = Mat3::Zero();
};
/// The estimate's orbit harmonics, head after head, harmonic after harmonic (empty without them). The
/// columns are found by the parameters' names (RawBoundResult::names), not by a copy of their layout.
std::vector<OrbitHarmonicTerm> orbitHarmonicTerms(const RawEstimate& est, const RawBoundConfig& cfg);

/// The measured data of a span (the estimator reads them once per pass): the head samples and the
/// accelerometer's, each in its own array (a day of GRACE-FO data is 0.5 million head samples at 56
/// bytes and 0.9 million accelerometer samples at 32: 57 MB). estimateRaw takes each array in time
/// order (sorting a copy when it is not), so they may be filled in any order.
struct RawData {
  struct Head {
    double t_s = 0;
    std::array<double, 4> q{1.0, 0, 0, 0};  ///< q_I_Si (w, x, y, z)
    /// The observer's inertial velocity (m/s; the Earth's and the satellite's) when the attitude carries
    /// the stars' aberration, which estimateRaw then removes (model/effects.h's aberration: the apparent
    /// boresight turned by b x v / c); zero: none to remove. Single precision: 6e-8 of the velocity (2 mm/s
    /// at the Earth's 30 km/s), an aberration error below 1e-11 rad.
    std::array<float, 3> v{0.0f, 0.0f, 0.0f};
    std::int32_t head = 0;  ///< head index (position in the configuration)

    static Head sample(double t_s, int head, const Quat& q_I_Si) {
      Head h;
      h.t_s = t_s;
      h.head = head;
      h.q = {q_I_Si.w(), q_I_Si.x(), q_I_Si.y(), q_I_Si.z()};
      return h;
    }
    Quat q_I_Si() const { return Quat(q[0], q[1], q[2], q[3]); }
    Vec3 v_obs_I() const { return Vec3(v[0], v[1], v[2]); }
    void setObserverVelocity(const Vec3& x) {
      v = {static_cast<float>(x.x()), static_cast<float>(x.y()), static_cast<float>(x.z())};
    }
  };
  struct Acc {
    double t_s = 0;
    std::array<double, 3> z{0, 0, 0};  ///< the measured angular acceleration, rad/s^2, A

    static Acc sample(double t_s, const Vec3& z_A) {
      Acc a;
      a.t_s = t_s;
      a.z = {z_A.x(), z_A.y(), z_A.z()};
      return a;
    }
    Vec3 z_A() const { return Vec3(z[0], z[1], z[2]); }
  };
  std::vector<Head> heads;
  std::vector<Acc> acc;
  std::size_t size() const { return heads.size() + acc.size(); }
  bool empty() const { return heads.empty() && acc.empty(); }
};

/// Runs `passes` passes of the estimator over the data (cfg's heads need C_Si_B and axes_Si; the
/// accelerometer's nominal bias is `bias0`, subtracted before the first pass).
RawEstimate estimateRaw(const RawBoundConfig& cfg, const RawData& data, const Vec3& bias0, int passes = 2);

/// Receives the discrete model as the bound steps it (for an independent batch computation in tests):
/// each transition x' = T x + G theta + w, Cov(w) = Q, and each scalar observation
/// y = h^T x + d^T theta + v, Var(v) = r. theta holds the parameters without the trajectory start.
class RawBoundRecorder {
 public:
  virtual ~RawBoundRecorder() = default;
  virtual void transition(const Eigen::MatrixXd& T, const Eigen::MatrixXd& Q, const Eigen::MatrixXd& G) = 0;
  virtual void observation(const Eigen::VectorXd& h, const Eigen::VectorXd& d, double r) = 0;
};

class RawBound {
 public:
  explicit RawBound(const RawBoundConfig& cfg);

  /// An accelerometer sample at t: the true mean angular acceleration over it and the rate (B).
  void accel(double t_s, const Vec3& alpha_B, const Vec3& w_B);
  /// A delivered sample of head `index` (position in the configuration) at t.
  void head(double t_s, std::size_t index);
  RawBoundResult result() const;

  std::size_t stateSize() const { return n_; }
  std::size_t parameterCount() const { return p_; }  ///< without the trajectory start
  /// The initial state covariance's diagonal: 0 for the trajectory start (free), the stationary
  /// variance of every noise state.
  Eigen::VectorXd initialVariance() const;
  void setRecorder(RawBoundRecorder* r) { recorder_ = r; }

 private:
  friend RawEstimate estimateRaw(const RawBoundConfig&, const RawData&, const Vec3&, int);
  /// Data mode (estimateRaw): the nominal trajectory is propagated with the measured angular
  /// acceleration and re-anchored at every head sample; mountings, bias and scale applied from a
  /// previous pass.
  void enableData(const std::vector<Mat3>& C_Si_B_applied, const Vec3& bias, const Vec3& scale);
  void accelData(double t_s, const Vec3& z_A, const Vec3& jerk_A);
  /// Head `index`'s mounting as this pass applies it at the time setHarmonics was last given: the
  /// applied constant with, for heads 2..n, the orbit harmonics of the passes before (harm_applied_).
  Mat3 appliedMounting(std::size_t index) const;
  void headData(double t_s, std::size_t index, const Quat& q_I_Si);
  Eigen::VectorXd solveParameters(const RawBoundResult& r) const;
  /// Data mode, before result(): the information and sum u^T v / F from the variance groups.
  void finishData();
  void stepAcc(double t_s, const Vec3& alpha_B);
  void advance(double t_s);
  void subStep(double h, bool gap);
  void flush(double t_s);
  /// One scalar head observation; in data mode y is the measured innovation of that axis.
  void observe(std::size_t head, int axis, double t_s, double y);

  RawBoundConfig cfg_;
  std::size_t n_ = 0, p_ = 0, pt_ = 0;  ///< states, parameters, parameters + trajectory start
  std::size_t ka_ = 0;                  ///< accelerometer noise states (after the 6 trajectory states)
  std::vector<int> acc_axis_;           ///< A axis of each accelerometer noise state
  std::vector<double> tau_, var_;       ///< every noise state's correlation time and variance
  std::vector<std::array<std::size_t, 3>> head_state_begin_, head_state_end_;
  std::vector<std::array<double, 3>> head_white_;
  std::size_t col_bias_ = 0, col_scale_ = 0, col_tau_ = 0, col_harm_ = 0, col_start_ = 0;
  Mat3 C_B_A_ = Mat3::Identity();
  Vec3 q_white_ = Vec3::Zero();  ///< white density per A axis, (rad/s^2)^2 s

  Eigen::MatrixXd P_, E_, info_;
  // Trajectory block accumulated since the last flush.
  Eigen::Matrix<double, 6, 6> Phi6_, Q6_;
  Eigen::Matrix<double, 6, 3> Psi3_, Sc3_;
  Eigen::Matrix<double, 6, 1> Tau1_;
  double t_flush_ = 0, t_cur_ = 0, t_acc_ = 0;
  bool started_ = false, gap_counted_ = false;
  Vec3 alpha_ = Vec3::Zero(), w_ = Vec3::Zero(), alpha_dot_A_ = Vec3::Zero();
  double first_t_ = 0, last_t_ = 0;
  std::vector<std::uint64_t> head_samples_;
  std::uint64_t acc_samples_ = 0, acc_gaps_ = 0, head_before_ = 0;
  RawBoundRecorder* recorder_ = nullptr;
  // Data mode.
  bool data_ = false;
  std::vector<Mat3> C_Si_B_applied_;
  Vec3 bias_applied_ = Vec3::Zero(), scale_applied_ = Vec3::Zero();
  Eigen::VectorXd harm_applied_;  ///< the harmonics' parameters of the passes before (empty: none)
  std::vector<std::size_t> held_cols_;  ///< parameter columns held (estimateRaw: undetermined scale factors)
  /// cos(k u), sin(k u), k = 1..options.harmonics, at the head sample in hand (setHarmonics).
  std::vector<double> harm_cos_, harm_sin_;
  void setHarmonics(double t_s);
  /// Scratch of observe() and flush(), sized once (no allocation per sample).
  Eigen::VectorXd ph_, dd_, qq_;
  Eigen::RowVectorXd u_, hE_;
  Eigen::MatrixXd psig_, g6_, top_, left_, etop_;
  Quat q_nom_ = Quat::Identity();  ///< q_I_B of the reference trajectory (w_ is its rate)
  Eigen::VectorXd x_, bvec_;       ///< the filter's error state; sum u^T v / F (data mode: finishData)
  double chi2_ = 0;
  std::uint64_t chi2_n_ = 0, rejected_ = 0;
  /// Variance groups (head i: 2 i cross, 2 i + 1 about) and score blocks: parameter information and
  /// sum u^T v / F (parameters only; the start columns are zero in data mode), sum v^2 / F, count.
  struct Acc {
    Eigen::MatrixXd N;
    Eigen::VectorXd b;
    double vv = 0, n = 0;
  };
  std::vector<Acc> groups_, blocks_;
  /// The information's rank-one terms u^T u / F, buffered per variance group as columns u / sqrt(F) and
  /// added as one product (to the group and to the score block of their time) when a buffer fills, the
  /// block changes, or finishData() runs: some 4x fewer operations than a rank-one update per sample
  /// into each of two matrices.
  std::vector<Eigen::MatrixXd> pending_;
  std::vector<int> pending_n_;
  std::size_t pending_block_ = 0;
  Eigen::MatrixXd pending_sum_;
  void flushPending();
  double block_t0_ = 0;
  bool record_innovations_ = false, collect_blocks_ = false;
  std::vector<model::NoiseSeries> innovations_;  ///< per head axis 3 i + j: t, data less the trajectory prediction (the noise fit)
  /// Every innovation_stride_[i]-th of head i's innovations is recorded (counted per head axis).
  std::vector<std::size_t> innovation_stride_, innovation_seen_;
  double gate_sigma_ = 6;  ///< head samples with an innovation beyond this many sigma are rejected (0: none)
};

}  // namespace boresight::calib
