// The Collector's state (shared by collector.cc and analyse.cc; not installed).
//
// Time bins hold sufficient statistics that merge exactly by addition, so that doubling the bin length
// (when the span outgrows max_bins) loses nothing the analysis uses:
//   - head epochs: count, sum of times, the sum of the epoch's mean body attitude (sign-aligned),
//   - per head-availability mask: count and sum of the stacked pair residuals (reference head = the
//     mask's lowest slot, pairs (ref, other) in slot order),
//   - per head pair: count and sum of outer products of first differences of the pair residual (noise),
//   - the core's rows: star-minus-accelerometer angular acceleration, its regressors (a_sc, jerk),
//   - the outside reference: count, sum and sum of squares of the fused-minus-reference rotation,
//   - raw accelerometer samples: count, sum and sum of squares (short spans, no CRN output).
#pragma once

#include <boresight/audit/audit.h>

#include <Eigen/Dense>

#include <array>
#include <vector>

namespace boresight::audit {

using core::kMaxHeads;
using core::kMaxPairs;

constexpr int kMasks = 1 << kMaxHeads;

struct MaskSum {
  double n = 0;
  Eigen::Matrix<double, 3 * (kMaxHeads - 1), 1> sum = Eigen::Matrix<double, 3 * (kMaxHeads - 1), 1>::Zero();
};

struct PairNoiseSum {
  double n = 0;
  Mat3 sdd = Mat3::Zero();
};

struct Bin {
  double n_ep = 0, sum_t = 0;
  Quat q_first = Quat::Identity();
  Eigen::Vector4d sum_q = Eigen::Vector4d::Zero();  ///< coefficients, aligned with q_first
  std::array<MaskSum, kMasks> mask{};
  std::array<PairNoiseSum, kMaxPairs> noise{};
  std::array<double, kMaxHeads> head_n{};  ///< samples per head
  // core rows with rates and accelerometer output
  double n_aa = 0;
  Vec3 sum_e = Vec3::Zero(), sum_e2 = Vec3::Zero(), sum_asc = Vec3::Zero(), sum_aacc = Vec3::Zero();
  double n_jerk = 0;
  Vec3 sum_jerk = Vec3::Zero();
  // outside reference
  double n_ref = 0;
  Vec3 sum_d = Vec3::Zero(), sum_d2 = Vec3::Zero();
  // inter-boresight angle deviations from ground (the core's monitor, per pair index)
  std::array<double, kMaxPairs> iba_n{}, iba_sum{};
  // raw accelerometer
  double n_acc = 0;
  Vec3 sum_a = Vec3::Zero(), sum_a2 = Vec3::Zero();

  void merge(const Bin& o);
};

/// A run of missing samples (head or accelerometer), seconds since the first epoch.
struct MissingRun {
  double start_s = 0, end_s = 0;
  double samples = 0;
  bool others_present = false;  ///< head runs: other heads delivered meanwhile (dropout, not a gap)
};

struct EpochRecord {
  TimeUs t = 0;
  std::uint32_t mask = 0;
  std::array<Quat, kMaxHeads> q_B{};  ///< body attitude implied by each head with its nominal mounting
  std::array<Vec3, kMaxPairs> rho{};  ///< pair residuals (pairs with both heads in mask)
  std::array<double, kMaxPairs> chi2{};
  bool consecutive_prev = false;  ///< the previous epoch is one sample period earlier
};

struct Collector::Impl {
  bool configured = false;
  core::PipelineConfig cfg{};
  AuditOptions opt{};
  int n_heads = 0;
  std::array<int, kMaxHeads> ids{};
  std::array<Mat3, kMaxHeads> C_B_S{};       ///< nominal C_B_Si
  std::array<Mat3, kMaxHeads> cov_model_B{};  ///< configured per-sample noise covariance of head k, in B
  TimeUs period_us = 500000, acc_period_us = 100000;

  // bins
  bool have_t0 = false;
  TimeUs t0 = 0, t_last = 0;
  TimeUs first_epoch_t = 0;  ///< the first epoch with a configured head (a head's run at the start counts from it)
  TimeUs bin_us = 500000;
  std::vector<Bin> bins;
  Bin& binAt(TimeUs t);

  // epochs (delay-two ring for the outlier test)
  std::array<EpochRecord, 3> ring{};
  int ring_n = 0;
  EpochRecord prev_final{};  ///< the last finalised epoch (outlier mask applied)
  bool have_prev_final = false;
  std::array<Mat3, kMaxPairs> pair_cov_inv{};  ///< inverse of the 1.5 x pair covariance for the outlier test
  /// The outlier gate from the data's noise: per pair the median of the second differences' chi2 under
  /// the configured covariance - exact over the pair's first kGateWarmup, then followed by a stochastic
  /// approximation in the logarithm (steps of 2 %); each chi2 is divided by it over the median of chi2(3),
  /// so the gate stands at outlier_min_sigma of the noise the data have (real heads 2.5x quieter than
  /// configured made it about 15 sigma; 2.5x noisier, 2.4 sigma), and an outlier barely moves a median.
  /// The warm-up epochs are not decided (as the first and last epochs): starting from the configured
  /// median instead called clean samples of noisier heads outliers while the estimate climbed.
  static constexpr int kGateWarmup = 64;
  std::array<double, kMaxPairs> chi2_median{};
  double chi2_median0 = 2.366;  ///< the median of chi2(3), set at configuration
  std::array<std::uint64_t, kMaxPairs> chi2_count{};
  std::array<std::array<double, kGateWarmup>, kMaxPairs> chi2_warmup{};
  std::array<PairNoiseSum, kMaxPairs> noise_total{};
  double outlier_chi2 = 1e300;

  // per head events
  std::array<TimeUs, kMaxHeads> last_tag{};
  std::array<bool, kMaxHeads> seen{};
  bool ended = false;  ///< onEnd() ran (the end seam's runs are added once)
  std::array<Quat, kMaxHeads> last_q{};
  std::array<std::uint64_t, kMaxHeads> flips{}, outliers{}, samples{};
  std::uint64_t outliers_unattributed = 0;
  std::vector<double> flip_times_s, outlier_times_s;
  std::vector<MissingRun> head_runs[kMaxHeads];
  std::vector<MissingRun> epoch_gaps;  ///< no head epoch at all
  std::vector<MissingRun> acc_gaps;
  std::uint64_t head_epochs = 0, acc_samples = 0, rows = 0, ref_used = 0;
  TimeUs last_epoch_t = 0, last_acc_t = 0;
  bool have_epoch = false, have_acc = false;

  // Coverage: the time bins serve the star data. Accelerometer samples and rows before the first head
  // epoch, or more than kStarCoverUs after the latest one, are counted here and not binned: every family
  // that uses them needs star data in the same bin, and an accelerometer file of another day would
  // otherwise stretch the bins over days and average the star span into a few of them.
  static constexpr TimeUs kStarCoverUs = 300 * kUsPerSecond;
  bool inStarCover(TimeUs t) const { return have_t0 && t >= t0 && t <= t_last + kStarCoverUs; }
  std::uint64_t acc_outside = 0, rows_outside = 0;
  bool have_acc_span = false;
  TimeUs acc_first = 0, acc_final = 0;  ///< every accelerometer sample's span, used or not

  // rows
  bool have_prev_row = false;
  TimeUs prev_row_t = 0;
  Vec3 prev_asc = Vec3::Zero();  ///< the previous row's accelerometer angular acceleration

  // reference
  std::vector<std::pair<TimeUs, Quat>> ref;
  std::size_t ref_cursor = 0;

  // orbit
  std::vector<model::OrbitSample> orbit;
  /// AuditOptions::applied_thermal: epochs corrected, epochs without an orbit sample near them.
  std::uint64_t thermal_applied = 0, thermal_no_orbit = 0;
  std::uint64_t orbit_unusable = 0;  ///< orbit samples without an orbit plane (not kept)
  /// The argument of latitude at t from the nearest orbit sample (within 60 s); false without one.
  bool argumentOfLatitude(TimeUs t, double& u) const;

  void finalizeEpoch(int k);
  void pushEpoch(const EpochRecord& e);
  double secs(TimeUs t) const { return static_cast<double>(t - t0) * 1e-6; }
};

/// Pair index of slots i < j among n heads (0, 1, ... in the order (0,1), (0,2), ..., (1,2), ...).
inline int pairOf(int i, int j, int n) {
  int k = 0;
  for (int a = 0; a < n; ++a)
    for (int b = a + 1; b < n; ++b) {
      if (a == i && b == j) return k;
      ++k;
    }
  return -1;
}

}  // namespace boresight::audit
