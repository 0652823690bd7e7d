// boresight::calib - method A's orchestration, one for every caller: `boresight calibrate` (fed by the
// replay engine's input observer) and the node's calibration worker (fed from its ring) run the same
// steps here, so the two cannot drift apart:
// - the feed (CalibrationFeed): head epochs as the core's validator leaves them, the accelerometer
//   samples the core accepted (as measured: method A estimates its own bias), into the span builder
//   (today's CRN rows) and, when asked, as raw samples for the attitude-domain estimate
//   (calib::estimateRaw); when a thermal fit or the aberration is wanted, the orbit from the same
//   stream (GNI1B / GNV1B files, ORBIT messages);
// - the run (runCalibration): the solve, the attitude-domain estimate from the raw samples when asked,
//   the thermal harmonic fit where an orbit was seen, and, when
//   the span is refused for its length or its excitation, what would be needed - the CRN's length and
//   the Cramer-Rao bound's span at a planning excitation and at this span's own weakest-axis
//   excitation (the RMS about the mean of the accelerometer's angular acceleration in B).
// Not real time: allocates (the span's observations, Ceres).
#pragma once

#include "boresight/calib/raw_bound.h"
#include "boresight/calib/solver.h"
#include "boresight/calib/span_builder.h"
#include "boresight/calib/thermal_fit.h"
#include "boresight/core/pipeline.h"
#include "boresight/model/orbit_context.h"

#include <memory>
#include <optional>
#include <string>

namespace boresight::calib {

/// What a span needs before method A can say anything, from the configuration alone (said when a span
/// is refused):
/// - the CRN: one angular acceleration needs a whole filter length Tf of data centred on it (heads
///   and accelerometer), so nothing comes out of a span shorter than Tf;
/// - the bound: with white head noise sigma_cross per sample through the CRN second-derivative kernel
///   (sigma_alpha = sigma_cross sqrt(sum g2^2)), one decorrelated observation per decimation_s and an
///   excitation of `excitation_rms_radps2` per axis, an error angle's Cramer-Rao bound is
///   sigma_alpha / (excitation sqrt(N)); N = (sigma_alpha / (excitation target))^2 observations reach
///   `target_sigma_arcsec`. Accelerometer noise and the boresight axis (sigma_roll) are left out, so
///   this is a lower limit on what is needed.
struct SpanNeed {
  double crn_s = 0.0;                ///< Tf: the shortest span with one CRN output
  double sigma_alpha_radps2 = 0.0;   ///< head noise through the CRN, per output, cross-boresight
  double observations = 0.0;         ///< decorrelated observations the bound needs
  double bound_s = 0.0;              ///< Tf + observations x decimation_s
};
SpanNeed spanNeed(const core::PipelineConfig& cfg, double decimation_s, double excitation_rms_radps2,
                  double target_sigma_arcsec);

/// The span's weakest-axis excitation: the RMS about the mean of the accelerometer's angular
/// acceleration, per B axis (C_B_A of the span), the smallest of the three, rad/s^2; 0 without
/// accelerometer samples. From the accelerometer moments, which every span keeps.
double weakestExcitation(const CalibrationSpan& span);

/// The data of one calibration, pushed in time order (the engine's merge, or the node's ring).
/// Copyable: the node's worker hands a copy to its solver thread and keeps feeding the original.
class CalibrationFeed {
 public:
  CalibrationFeed() = default;
  CalibrationFeed(const CalibrationFeed& o);
  CalibrationFeed& operator=(const CalibrationFeed& o);
  CalibrationFeed(CalibrationFeed&&) = default;
  CalibrationFeed& operator=(CalibrationFeed&&) = default;
  ~CalibrationFeed();

  /// The span builder with the core configuration (heads, nominal mountings, C_B_A, CRNs) and the span
  /// options; with_thermal: also collect the heads' relative attitude for the thermal harmonic fit (two
  /// heads or more; the orbit must come in the same stream). False with *error: the configuration
  /// cannot be run (said at start-up, never found later).
  /// with_raw: also keep every head and accelerometer sample (and the orbit's velocity, for the stars'
  /// aberration) for the attitude-domain estimate - the whole span in memory (56 bytes a head sample,
  /// 32 an accelerometer sample: 57 MB per day of GRACE-FO data), so only when asked; with SpanOptions::max_observations the same window of data time
  /// as the observations (max_observations x decimation_s).
  /// with_crn false (with_raw only): the span builder is configured (its configuration checked) but fed
  /// nothing, so the feed holds no CRN rows and runCalibration runs the attitude-domain estimate alone
  /// (what calibrate's windows use: a day's CRN rows and their solve are some 20 MB and 3 % of the time).
  bool configure(const core::PipelineConfig& cfg, const SpanOptions& so, bool with_thermal, std::string* error,
                 bool with_raw = false, bool with_crn = true);
  bool configured() const { return configured_; }
  /// Head epochs as the core's validator leaves them.
  void pushHeads(const core::HeadEpoch& e);
  /// An accelerometer sample the core accepted, a_A as measured.
  void pushAcc(TimeUs t, const Vec3& a_A);
  /// An orbit sample (taken with the thermal fit and with the raw samples).
  void pushOrbit(const model::OrbitSample& o);
  bool wantsOrbit() const { return thermal_ != nullptr || with_raw_; }
  std::uint64_t orbitSamples() const { return orbit_samples_; }
  /// End of data (runCalibration calls it when the caller has not).
  void finish();
  /// The next window of a record (WindowedCalibration): the configuration kept, the data dropped - the
  /// raw samples' buffer keeps its capacity, so a record of many windows holds no more than its longest
  /// one - and the orbit samples from `keep_orbit_from` on kept (the segment across the new window's
  /// start, which its first head samples' observer velocity needs).
  void restart(TimeUs keep_orbit_from);
  /// The same, the data handed over instead of dropped: the returned feed holds this window's data (to be
  /// run on another thread), this one is restarted as by restart(keep_orbit_from).
  CalibrationFeed handOver(TimeUs keep_orbit_from);
  /// Room for this many raw samples (a window as long as the last: filled without a copy at every
  /// doubling of the arrays).
  void reserveRaw(std::size_t heads, std::size_t acc) {
    raw_.heads.reserve(heads);
    raw_.acc.reserve(acc);
  }
  bool finished() const { return finished_; }

  const CalibrationSpan& span() const { return builder_.span(); }
  const SpanBuilder& builder() const { return builder_; }
  const core::PipelineConfig& config() const { return cfg_; }
  const SpanOptions& spanOptions() const { return so_; }
  ThermalCollector* thermal() { return thermal_.get(); }
  bool collectsRaw() const { return with_raw_; }
  bool collectsCrn() const { return with_crn_; }
  /// The raw samples (with_raw), times in seconds since the first; finish() gives every head sample
  /// inside the orbit's span the observer velocity (the satellite's, linear between orbit samples no
  /// more than 60 s apart, plus the Earth's).
  const RawData& raw() const { return raw_; }
  /// The mean of the accelerometer samples taken (A, rad/s^2): the estimate's starting bias.
  Vec3 rawMeanAcc() const { return n_acc_ ? Vec3(sum_A_ / static_cast<double>(n_acc_)) : Vec3::Zero(); }
  /// Head samples given an observer velocity (finish()).
  std::uint64_t aberratedSamples() const { return aberrated_; }
  /// The orbit's argument of latitude over the raw samples' window as a line in the raw time (finish()):
  /// u(t) = phase + rate t, unwrapped with each sample's own rate, fitted by least squares; rms is the
  /// line's residual (the eccentricity's part: about 2 e rad). Not ok without two orbit samples in the
  /// window. What the attitude-domain estimate's orbit harmonics take (RawBoundOptions::harmonics).
  struct OrbitLine {
    bool ok = false;
    double rate_rad_s = 0, phase_rad = 0, rms_rad = 0, span_s = 0;
    std::size_t samples = 0;
  };
  const OrbitLine& rawOrbitLine() const { return orbit_line_; }

 private:
  core::PipelineConfig cfg_;
  SpanOptions so_;
  SpanBuilder builder_;
  std::unique_ptr<ThermalCollector> thermal_;
  std::uint64_t orbit_samples_ = 0;
  bool configured_ = false, finished_ = false, with_raw_ = false, with_crn_ = true;
  // The raw samples (with_raw).
  double rawTime(TimeUs t);
  /// With SpanOptions::max_observations: drops the raw samples (and orbit velocities) older than the
  /// builder's window in data time (max_observations x decimation_s before `newest`).
  void trimRaw(TimeUs newest);
  void fitOrbitLine();  ///< orbit_line_ from orbit_v_ (sorted)
  RawData raw_;
  Vec3 sum_A_ = Vec3::Zero();
  std::uint64_t n_acc_ = 0, aberrated_ = 0;
  struct OrbitPoint {
    TimeUs t = 0;
    Vec3 v_I = Vec3::Zero();
    double u = 0, u_rate = 0;
  };
  std::vector<OrbitPoint> orbit_v_;  ///< the orbit samples of the raw window
  OrbitLine orbit_line_;
  TimeUs t0_ = 0;
  bool have_t0_ = false;
};

struct RunOptions {
  SolveOptions solve;
  /// For a refused span: the excitation (rad/s^2 RMS per axis) and the target sigma (arcsec) the
  /// needed span is computed for.
  double plan_excitation_radps2 = 4.9e-5;
  double plan_sigma_arcsec = 30.0;
  std::string plan_excitation_name = "the planning excitation";  ///< how the advice names it
  /// Fit the thermal harmonic model when the feed collected it and saw an orbit.
  bool thermal_fit = true;
  /// The attitude-domain estimate from the feed's raw samples (the feed must collect them), whether the
  /// CRN solver solved or refused the span (the estimate needs neither its filter nor its rows): its
  /// configuration (rawBoundConfig of the platform and the noise in use) and passes.
  std::optional<RawBoundConfig> raw;
  int raw_passes = 3;
  /// The attitude-domain estimate's orbit harmonics 1..K of heads 2..n's alignment (the thermal motion of
  /// the relative alignment, in its model and so in its covariance): used when the feed saw an orbit
  /// over at least one revolution of the raw window (CalibrationFeed::rawOrbitLine), else none and said
  /// in CalibrationRun::raw_harmonics_note. 0: none.
  int raw_harmonics = 0;
};

struct CalibrationRun {
  bool ok = false;
  /// The solver's result (epochs counted from the span when it solved from the moments). A span with
  /// no CRN output at all is refused here as kTooFewEpochs without calling the solver.
  SolveResult result;
  /// Refused: "refused: <why>", and for a refusal about the span's length or excitation a second line
  /// "Needed: ..." with the CRN's length and the bound's span. Empty when ok.
  std::string refusal_text;
  double weakest_excitation_radps2 = 0.0;  ///< this span's (weakestExcitation)
  SpanNeed need;                           ///< at the planning excitation
  SpanNeed need_own;                       ///< at this span's weakest excitation (when > 0)
  bool thermal_fitted = false;
  ThermalFitResult thermal;                ///< when thermal_fitted
  bool raw_estimated = false;
  RawEstimate raw;                         ///< when raw_estimated
  RawBoundConfig raw_config;               ///< the configuration it ran with (harmonics and orbit line set)
  std::string raw_harmonics_note;          ///< why RunOptions::raw_harmonics were not used ("" when they were)
  std::string raw_note;                    ///< why RunOptions::raw was asked for and not estimated ("" otherwise)
};

/// Solves the feed's span (finishing the feed first), runs the attitude-domain estimate when wanted
/// (also on a span the CRN solver refuses: `ok` false, `raw_estimated` true) and, when the solve is ok,
/// fits the thermal model.
CalibrationRun runCalibration(CalibrationFeed& feed, const RunOptions& o);

}  // namespace boresight::calib
