// boresight::calib - method A over many windows of data (days, or hours): each window calibrated on
// its own by the attitude-domain estimate (runCalibration on a CalibrationFeed that is emptied - or
// handed to a thread - at every window's end, so the memory is one window's, or `concurrent` windows',
// whatever the length of the record), the windows' solutions kept as a time series, and combined into
// one joint solution.
//
// Windows are whole multiples of `window_s` after 2000-01-01 00:00:00 GPS (the GRACE epoch is noon, so
// a window of 86400 s is a GPS calendar day, as the Level-1 daily files); a window without data is not
// a window. Each window has its own trajectory, accelerometer bias, scale and time offset and its own
// noise fit (a bias that wanders from day to day is a new bias every day); the mountings are what the
// windows share.
//
// The joint solution (combineWindows): the windows' mounting estimates weighted by their information
// (the pseudo-inverse of each window's Si-frame covariance on its determined axes), with the scatter
// of the windows about it as a test of the one-mounting model: chi-square per degree of freedom over
// all axes and per head axis, and per head axis the between-window spread that the windows' own sigmas
// do not explain (the random-effects level tau, Paule-Mandel, with a 95 % interval by the Q-profile):
// thermal wander and anything else that moves the alignment from window to window, measured from the
// data. The joint per-axis sigma with that spread added is the one written out.
//
// Not real time: allocates (each window's estimate).
#pragma once

#include "boresight/calib/calibration.h"
#include "boresight/calib/raw_bound.h"

#include <cstdint>
#include <deque>
#include <functional>
#include <future>
#include <optional>
#include <string>
#include <vector>

namespace boresight::calib {

/// One window's attitude-domain solution.
struct WindowSolution {
  TimeUs from = 0, to = 0;          ///< the window [from, to), data time
  TimeUs first = 0, last = 0;       ///< its first and last head epoch
  std::uint64_t head_epochs = 0, acc_samples = 0;
  bool estimated = false;
  std::string note;                 ///< why not estimated (too few samples, no body direction determined)
  RawMountings mountings;           ///< when estimated: r_Si, sigma_Si (NaN: not determined), covariance_Si
  /// The information the window's data carry about every head's error angles (Si frames, 3n x 3n, 1/rad^2):
  /// the estimate's information with its other parameters (accelerometer terms, time offset, orbit
  /// harmonics) marginalised out, before any direction is held. Singular along what the window cannot
  /// see - a rotation common to all heads about a body direction without excitation - where
  /// `mountings` holds the nominal value and its covariance, conditional on that, says nothing; the
  /// combination takes each window's information, so a held value never counts. Empty: the pseudo-inverse
  /// of `mountings.covariance_Si` on its determined axes is used instead.
  Eigen::MatrixXd information_Si;
  double chi2_per_obs = 0;
  Vec3 bias_rad_s2 = Vec3::Zero();
  std::optional<double> time_offset_s, time_offset_sigma_s;  ///< when estimated and determined
  double seconds = 0;               ///< wall time of the window's estimate
  /// The window's orbit harmonics of heads 2..n's alignment (when estimated), and the mean beta angle of
  /// the orbit samples inside the window (none without an orbit).
  std::vector<OrbitHarmonicTerm> harmonics;
  std::optional<double> beta_rad;
};

/// The windows' solutions combined (per configured head slot, Si axes, rad).
struct JointMountings {
  std::size_t windows = 0;          ///< windows that took part (estimated)
  /// The information-weighted mean, windows independent: r = C sum_w I_w r_w, C = (sum_w I_w)^+.
  std::vector<Vec3> r_Si, sigma_Si;  ///< sigma NaN: not determined in any window (or above not_determined_rad)
  Eigen::MatrixXd covariance_Si;
  /// The windows' scatter about it: sum_w (r_w - r)^T I_w (r_w - r) over dof = sum_w rank I_w - rank sum I_w.
  double chi2 = 0, dof = 0;
  /// Per head axis (windows with that axis determined; NaN with fewer than two):
  /// chi-square per degree of freedom of the axis's scatter (Cochran's Q: the windows about their
  /// weighted mean on that axis over their own variances, windows - 1 degrees of freedom); tau, the
  /// spread between windows beyond their own sigmas (0 when the sigmas explain it), with its 95 %
  /// interval; the random-effects mean and sigma (weights 1 / (sigma_w^2 + tau^2)): what the mounting
  /// over the record is known to when it moves by tau between windows. With few windows tau itself is
  /// uncertain and the random-effects mean's error over that sigma follows Student's t with windows - 1
  /// degrees of freedom rather than a normal law (its RMS sqrt((m - 1) / (m - 3)): 1.13 for 10 windows).
  std::vector<Vec3> axis_chi2_per_dof, tau, tau_lo, tau_hi, sigma_with_tau, r_with_tau;
  std::vector<Vec3> axis_windows;   ///< windows with the axis determined (as doubles)
  /// The sigma to write with r_Si: the larger of sigma_Si and sigma_with_tau (sigma_Si where there is
  /// no tau: one window); NaN where not determined.
  std::vector<Vec3> sigma_written;
};

/// Combines the estimated windows (the others are skipped) by their information (WindowSolution::
/// information_Si). An axis of the joint is determined when no direction that the summed information
/// leaves without information touches it (and its sigma is below not_determined_rad); a window
/// contributes to an axis's scatter and spread only where that window alone determines the axis.
JointMountings combineWindows(const std::vector<WindowSolution>& windows, std::size_t n_heads, double not_determined_rad);

/// The information about every head's error angles (Si frames) in an attitude-domain estimate, its other
/// parameters marginalised out (WindowSolution::information_Si).
Eigen::MatrixXd mountingInformation(const RawEstimate& est, const RawBoundConfig& cfg);
/// The thermal beta-angle modulation from the windows' orbit harmonics: per head (2..n), harmonic, cos
/// or sin term and axis of the head's frame Si, the weighted line value = a + b (cos beta - cos_ref)
/// through the windows that have the term and a beta (cos_ref: the mean cos beta of those windows, so a
/// is the term there and b its change per unit of cos beta). Determined only when beta moves `min_range_rad`
/// or more across those windows (10 deg by default; a day moves it about 1 deg); the sigmas are scaled
/// by sqrt(chi-square per dof) when the windows scatter about the line more than their sigmas say
/// (day-to-day wander), never shrunk.
struct BetaModulation {
  bool determined = false;
  std::string note;                 ///< why not determined
  /// The correlation over the windows between cos beta and the windows' time. Near +-1 (beta moving
  /// one way over the record: |r| > 0.9 sets `caution`), a modulation with beta and a drift of the
  /// harmonics with time are the same regressor, and the fit gives whatever drifts to beta.
  double time_correlation = 0;
  std::string caution;
  double beta_min_rad = 0, beta_max_rad = 0, cos_ref = 0;
  std::size_t windows = 0;
  struct Component {
    std::size_t head = 0;  ///< index in the heads (1..n-1)
    int harmonic = 1;
    bool sine = false;
    Vec3 a = Vec3::Zero(), b = Vec3::Zero(), sigma_a = Vec3::Zero(), sigma_b = Vec3::Zero();  ///< rad, rad per unit cos beta
    Vec3 chi2_per_dof = Vec3::Zero();  ///< of the line (windows - 2 dof)
  };
  std::vector<Component> terms;
};
BetaModulation fitBetaModulation(const std::vector<WindowSolution>& windows, double min_range_rad = 10.0 * kRadPerDeg);

/// Paule-Mandel random-effects level for values x with sigmas s: tau >= 0 with
/// sum (x - m(tau))^2 / (s^2 + tau^2) = q, m(tau) the weighted mean with weights 1 / (s^2 + tau^2);
/// 0 when the sum at tau = 0 is already at or below q. q = n - 1 gives the estimate; chi-square
/// quantiles with n - 1 degrees of freedom give the Q-profile interval's ends. Needs n >= 2.
double randomEffectsTau(const std::vector<double>& x, const std::vector<double>& s, double q);

/// Method A window after window (see the top of this file). Feed it as a CalibrationFeed, in time order.
class WindowedCalibration {
 public:
  /// run.raw must be set (the attitude-domain estimate is what each window runs); window_s > 0. False
  /// with *error when the span builder refuses the configuration.
  /// concurrent: windows in estimation at once. 1 (the default): a window is estimated when it closes, on
  /// the caller's thread, and is in windows() on return. n > 1: a closed window's data is handed to a
  /// thread of its own and the caller goes on feeding the next window; when n windows are in estimation
  /// the caller waits for the oldest before it takes the next window's first sample, so at most n
  /// windows' samples are held (the one being fed among them). The windows and their order are those of
  /// the sequential run (each window's estimate depends on its own data alone); windows() holds those
  /// finished so far, in time order, and all of them after finish().
  bool configure(const core::PipelineConfig& cfg, const SpanOptions& so, double window_s, const RunOptions& run,
                 double not_determined_rad, std::string* error, unsigned concurrent = 1);
  void pushHeads(const core::HeadEpoch& e);
  void pushAcc(TimeUs t, const Vec3& a_A);
  void pushOrbit(const model::OrbitSample& o);
  bool wantsOrbit() const { return feed_.wantsOrbit(); }
  /// End of data: the last window is estimated.
  void finish();

  const std::vector<WindowSolution>& windows() const { return windows_; }
  /// Called after each window's estimate (progress for the user).
  void onWindow(std::function<void(const WindowSolution&)> f) { on_window_ = std::move(f); }
  /// The most raw samples one window held.
  std::size_t peakRawSamples() const { return peak_raw_; }
  /// Samples older than the open window's start (its predecessor is already estimated): not taken, counted.
  /// The replay engine hands samples out in time order, so calibrate has none.
  std::uint64_t lateSamples() const { return late_; }
  /// The window [from, to) that holds t.
  static std::pair<TimeUs, TimeUs> windowOf(TimeUs t, double window_s);

 private:
  void advance(TimeUs t);  ///< closes the open window when t is past its end
  /// Estimates the open window (or hands it to a thread) and restarts the feed, keeping the orbit from
  /// keep_orbit_from on.
  void close(TimeUs keep_orbit_from);
  /// Moves the oldest window in estimation into windows_ (waits for it when `wait`, else only if done).
  bool collect(bool wait);
  void report();  ///< on_window_ for the last of windows_
  CalibrationFeed feed_;
  RunOptions run_;
  double window_s_ = 0, not_determined_rad_ = 0;
  bool open_ = false, finished_ = false;
  TimeUs from_ = 0, to_ = 0, first_ = 0, last_ = 0;
  std::uint64_t head_epochs_ = 0, acc_samples_ = 0;
  std::size_t peak_raw_ = 0;
  std::uint64_t late_ = 0;
  /// The beta angle's sum and count per window start (orbit samples may run ahead of the heads).
  std::vector<std::pair<TimeUs, std::pair<double, std::size_t>>> beta_;
  std::vector<WindowSolution> windows_;
  unsigned concurrent_ = 1;
  std::deque<std::future<WindowSolution>> pending_;  ///< in estimation, oldest first (concurrent_ > 1)
  std::function<void(const WindowSolution&)> on_window_;
};

}  // namespace boresight::calib
