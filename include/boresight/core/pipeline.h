// The whole real-time core wired together: what `boresight process` and the node call.
//
//   stepHeads(HeadEpoch)  -> validator -> HeadFusion -> AttitudeRates (CRN on q_I_B)
//                                     \-> RelativeAttitudeMeans, BoresightMonitor (IBA, corrections)
//   stepAcc(t, a_A)       -> AccAngularFilter (C_B_A, CRN low-pass), evaluated on the rows' tags
//   stepStars(StarEpoch)  -> MultiHeadWahba with the monitor's relative matrices C_SR_Sk (wahba_correction:
//                            by default the filtered three-axis deformation) and their covariances
//
// Rows: one per output epoch = a head epoch whose tag is within half a head interval of a multiple of
// crn_attitude.output_period_us (the same rule the rate filter uses for its centre taps, so the tags
// agree exactly). A row carries the fused attitude and IBAs of that epoch at once, and waits (up to
// kMaxPendingRows) for the centre-stamped CRN rate and the accelerometer value at the same tag, ~35 s
// later. Values a filter cannot give (start and end of data, gaps) are NaN with has_* false.
// Inputs must arrive in time order per stream, and the two streams should be merged by time (a
// stream that runs far ahead of the other makes rows complete without its values).
// flush() completes every pending row at the end of the data. popRow() takes rows in time order.
#pragma once

#include "boresight/core/head_fusion.h"
#include "boresight/core/rates.h"
#include "boresight/core/relative_attitude.h"
#include "boresight/core/ring.h"
#include "boresight/core/thermal.h"
#include "boresight/core/thermal_harmonics.h"
#include "boresight/core/wahba.h"

#include <limits>

namespace boresight::core {

/// Which head alignment the fusion uses.
enum class FusionAlignment : std::uint8_t {
  kNominal = 0,       ///< the configured (ground) mountings only
  kRunningMeans = 1,  ///< the running relative means (forgetting: heads.relative_time_constant_s)
};

/// A calibration of the accelerometer's angular acceleration, applied to every sample before the CRN:
/// a_A <- M (a_A - bias_A). For a sensor that measures a_A = K R(Exp(m)) C_A_B a_B + b (K = I + diag(s)
/// + N(n): scale s, symmetric non-orthogonality n; m the rotation of A from the configured C_B_A; the
/// conventions of model/effects.h and calib/solver.h), M = R(Exp(m))^T K^-1 and bias_A = b. Set from a
/// model overlay's accelerometer terms (io/overlay_apply.h); off by default.
struct AccCorrection {
  bool on = false;
  Vec3 bias_A = Vec3::Zero();
  Mat3 M = Mat3::Identity();
};

struct PipelineConfig {
  HeadSetConfig heads{};
  /// CRN of the fused attitude: fs_hz = head epoch rate (GRACE-FO 2 Hz); output_period_us = row period.
  CrnConfig crn_attitude = CrnConfig::at(2.0).outputEvery(kUsPerSecond).bridging(20);
  /// CRN of the accelerometer angular acceleration: fs_hz = its rate (GRACE-FO 10 Hz).
  CrnConfig crn_acc = CrnConfig::at(10.0).outputEvery(0).bridging(20);
  Mat3 C_B_A = accToBodyDefault();  ///< accelerometer frame A to body B
  bool use_accelerometer = true;    ///< false: rows do not wait for accelerometer values
  AccCorrection acc_correction{};   ///< applied to every accelerometer sample (off: as measured)
  int wahba_reference_slot = 0;     ///< frame of the star-vector solution
  /// Relative matrices for the star-vector solution and the deformation filter behind them (thermal.h).
  RelativeCorrection wahba_correction = RelativeCorrection::kFilteredThreeAxis;
  DeformationFilterConfig deformation{};
  FusionAlignment fusion_alignment = FusionAlignment::kRunningMeans;
  int alignment_update_epochs = 64; ///< head epochs between alignment updates from the running means
};

struct PipelineRow {
  TimeUs t = 0;                   ///< output epoch (a head epoch tag), us past GPS J2000
  Quat q_I_B = Quat::Identity();  ///< fused body attitude at t (unfiltered), R = C_I_B
  Mat3 P_B = Mat3::Zero();        ///< its covariance, rad^2 in B
  int heads_used = 0;
  std::uint32_t heads_mask = 0;   ///< slots fused (bit s: slot s of HeadSetConfig)
  bool has_rates = false;
  Vec3 w_B = Vec3::Constant(std::numeric_limits<double>::quiet_NaN());       ///< rad/s, B
  Vec3 a_sc_B = Vec3::Constant(std::numeric_limits<double>::quiet_NaN());    ///< star-sensor angular accel., rad/s^2, B
  /// Bridged attitude samples in the rate filter's window (0: all real). Rows with bridged samples are
  /// flagged: their sigmas below include the bridged values' bound (AttitudeRates, CrnStream).
  int rate_bridged = 0;
  /// 1-sigma per axis of w_B and a_sc_B: this epoch's fused covariance P_B taken as white noise through
  /// the CRN kernels (sqrt(P_kk sum g^2)), and the bridged values' bound in quadrature; NaN without
  /// rates (and for bridged rows under linear bridging, which has no uncertainty model). The filter's
  /// band-limit bias and coloured attitude noise are not in it.
  Vec3 w_sigma_B = Vec3::Constant(std::numeric_limits<double>::quiet_NaN());
  Vec3 a_sc_sigma_B = Vec3::Constant(std::numeric_limits<double>::quiet_NaN());
  bool has_acc = false;
  Vec3 a_acc_B = Vec3::Constant(std::numeric_limits<double>::quiet_NaN());   ///< accelerometer, same CRN, rad/s^2, B
  /// Bridged accelerometer samples in its filter window (0: all real) and the bound on their
  /// contribution per axis, rad/s^2 (AccOutput; the accelerometer's own noise is not configured in the
  /// core, so no nominal part)
  int acc_bridged = 0;
  double a_acc_sigma_bridge = 0;
  std::array<double, kMaxPairs> iba_rad{};      ///< per pair (pairIndex), NaN when a head is missing
  std::array<double, kMaxPairs> iba_dev_rad{};  ///< iba - ground, rad
};

class Pipeline {
 public:
  Status configure(const PipelineConfig& cfg);
  void reset();
  Status stepHeads(const HeadEpoch& in);
  Status stepAcc(TimeUs t, const Vec3& a_A);
  Status stepStars(const StarEpoch& in);
  /// A full mounting set (e.g. the batch solver's, slots 0..n_heads-1) for the fusion from the next head
  /// epoch on, with the datum of HeadAlignment; replaces the running means until reset(). No allocation.
  Status handMountings(const std::array<Quat, kMaxHeads>& q_Si_B);
  /// Back to the running means (with FusionAlignment::kRunningMeans), as before any handMountings: the
  /// next alignment update sets the fusion's alignment from them. No allocation.
  void releaseMountings();
  /// The batch thermal model (calib/thermal_fit.h: ThermalFitResult::coreModel()) after configure();
  /// from then on every head epoch that does not see a pair sets the monitor's predicted deformation
  /// of that pair (BoresightMonitor::setPredictedDeformation) from the model at the argument of
  /// latitude of the last stepOrbit(). Kept by reset(); replaced by the next call. No allocation.
  Status setThermalModel(const ThermalHarmonicModel& model);
  /// Orbit input for the thermal model: argument of latitude (rad), its rate (rad/s), beta angle (rad)
  /// at t. Without a thermal model: kOk and ignored. Time order as for the other streams.
  Status stepOrbit(TimeUs t, double u_rad, double u_rate_rad_s, double beta_rad);
  const ThermalPredictor& thermal() const { return thermal_; }
  /// End of data: every pending row is completed with what is available.
  void flush();
  bool popRow(PipelineRow& out);
  int rowsReady() const { return static_cast<int>(ready_.size()); }

  /// All counters of all components plus the pipeline's own.
  Health health() const;
  const PipelineConfig& config() const { return cfg_; }
  const HeadFusion& fusion() const { return fusion_; }
  /// The last head epoch as the validator left it (bad heads dropped, quaternions normalised, samples in
  /// slot order), or nullptr when the last stepHeads() refused it as a whole (or none came since the last
  /// reset): what the replay engine hands its observers, without validating the epoch a second time.
  const ValidHeads* lastValidHeads() const { return last_valid_ ? &validator_.output() : nullptr; }
  const RelativeAttitudeMeans& means() const { return means_; }
  const BoresightMonitor& monitor() const { return monitor_; }
  const AttitudeRates& rates() const { return rates_; }
  const AccAngularFilter& accelerometer() const { return acc_; }
  const MultiHeadWahba& wahba() const { return wahba_; }

 private:
  struct Pending {
    PipelineRow row;
    bool rate_done = false;
    bool acc_done = false;
  };
  void resolve();
  void emitOldest();
  void setRates(PipelineRow& row, const RateOutput& r) const;
  void predictBlindPairs(const ValidHeads& v);  ///< pipeline_thermal.cc
  void resetThermalAnchors();

  ThermalPredictor thermal_{};
  /// Per pair (pairIndex): the orbit angle of the last epoch that saw it and, while it is not seen,
  /// the anchor of ThermalPredictionMode::kAnchored (filter value minus model value at that epoch).
  struct ThermalAnchor {
    bool u_seen_ok = false;
    double u_seen = 0, cos_beta_seen = 1;
    bool blind = false;
    bool anchor_ok = false;
    Vec3 offset = Vec3::Zero();
    Mat3 cov = Mat3::Zero();
  };
  std::array<ThermalAnchor, kMaxPairs> thermal_anchor_{};

  PipelineConfig cfg_{};
  bool configured_ = false;
  HeadInputValidator validator_{};
  bool last_valid_ = false;  ///< the validator accepted the last head epoch (lastValidHeads)
  HeadFusion fusion_{};
  RelativeAttitudeMeans means_{};
  BoresightMonitor monitor_{};
  AttitudeRates rates_{};
  AccAngularFilter acc_{};
  MultiHeadWahba wahba_{};
  TimeUs head_dt_us_ = 0;
  double gain_w_ = 0, gain_a_ = 0;  ///< the rate filter's white-noise gains (AttitudeRates::noiseGain)
  bool handed_ = false;      ///< a mounting set was handed in: the running means no longer align
  int align_countdown_ = 0;  ///< head epochs to the next alignment update
  TimeUs last_grid_ = 0;
  bool have_grid_ = false;
  Ring<Pending, kMaxPendingRows> pending_{};  ///< rows waiting for their rates or accelerometer
  std::size_t rate_cursor_ = 0, acc_cursor_ = 0;  ///< first pending row (index into pending_) still waiting
  TimeUs acc_next_check_ = std::numeric_limits<TimeUs>::min();  ///< stepAcc resolves from this tag on
  Ring<PipelineRow, kMaxPendingRows> ready_{};  ///< rows for popRow
  Health health_{};
};

}  // namespace boresight::core
