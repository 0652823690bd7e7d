// The model audit (METHODS 4): given measured data and the configured model, show what the model gets
// wrong, name the cause from the effect catalogue (model/effects.h), extend the model with it and
// measure the gain on data not used to fit.
//
// Data flow (bounded memory):
//   sources -> stream::Engine -> core::Pipeline -> rows ---------------> Collector (time bins)
//              stream::Engine -> InputObserver (validated head epochs, acc) -> Collector
//   orbit samples (GNI1B/GNV1B, simulator), outside reference (SCA1B) ---> Collector
//   Collector -> analyse() -> AuditResult -> writeAuditJson / writeAuditReport
//
// The Collector reduces every input to sufficient statistics in time bins. A bin starts at the head
// sample period and doubles (adjacent bins merge exactly) whenever the span would need more than
// AuditOptions::max_bins, so a 16 s excerpt is analysed sample by sample and a day in bins of a few
// seconds, in the same memory.
//
// Residual families (what the model is compared with):
//   relative    pair residuals rho_ij = Log(C_B_Sj C_Sj_I C_I_Si C_Si_B) in B, nominal mountings from the
//               configuration (QSA1B): rho_ij ~= phi_j - phi_i for head rotations phi (B components)
//   noise       per head and head axis (x, y cross-boresight; z about the boresight) the sample noise
//               level from first differences of the pair residuals, heads separated by the three-
//               cornered hat (three or more heads)
//   angular_acceleration   a_acc_B - a_sc_B (the core's rows: the same CRN on both), rad/s^2
//   reference   rotation from the outside reference (SCA1B) to the fused attitude, B, arcsec
//   data        sample-level events: gaps, dropouts, sign flips, outliers, time-tag irregularities
//
// Statistics: every candidate (effect, sensor) is a linear(ised) model extension of a family. Its
// statistic is the F statistic of adding it (residual variance estimated from the data, degrees of
// freedom reduced by the residuals' autocorrelation), threshold and p-value at a family-wise false-alarm
// rate over every candidate tested (Bonferroni). Causes are named by forward selection (the most
// significant candidate given those already named, until none passes); two candidates that each pass
// alone but not given the other are reported as ambiguous, with what data would separate them.
#pragma once

#include <boresight/core/conventions.h>
#include <boresight/core/pipeline.h>
#include <boresight/model/effects.h>
#include <boresight/model/orbit_context.h>
#include <boresight/model/overlay.h>
#include <boresight/stream/sinks.h>

#include <array>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace boresight::audit {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

struct AuditOptions {
  double false_alarm = 0.01;  ///< family-wise false-alarm probability over the whole catalogue
  int max_bins = 16384;       ///< time bins kept; the bin length doubles when the span needs more
  /// Held-out data, not used to fit, to measure the gain. With an orbit context and at least three
  /// orbits: whole orbits, alternately fitted and held out, the first and the last orbit fitted, the
  /// remainder of the span held out (on whole orbits the orbit harmonics stay orthogonal on the fitting
  /// rows; alternate shorter blocks mix a line at n cycles/rev into others, e.g. blocks of 900 s turn
  /// 6 cycles/rev into 3). Otherwise the span is cut into 2 * holdout_blocks blocks and the odd ones are
  /// held out, except the last (both ends fitted).
  int holdout_blocks = 4;
  /// Largest thermal harmonic tested (cycles per revolution); needs an orbit context. Every order
  /// 1..max_harmonic of every head is a candidate of its own in the family-wise selection, so the order
  /// named is the one the data supports at the family-wise rate; the "not explained" test looks for
  /// lines up to twice this order (at least 4), so a line beyond the catalogue is reported, not spread
  /// over the candidates.
  int max_harmonic = 4;
  /// Outlier threshold on a sample's whitened pair residual (chi-square, 3 dof) is set from the
  /// false-alarm rate and the number of samples; this is the smallest allowed (sigma units).
  double outlier_min_sigma = 6.0;
  /// A dropout run is explained by blinding when the Sun, the Earth's limb or the Moon comes within a
  /// head's blinding cone (the platform file's heads.blinding_deg; the scenario's for simulated data)
  /// plus this margin, deg.
  double blinding_margin_deg = 2;
  /// The data events' null hypothesis (the platform file's data_events section, or an overlay's;
  /// audit::runAudit fills it): missing-sample runs expected per day of span - of one head while the
  /// others deliver (outside its blinding cones; per head id), of every head at once, of the
  /// accelerometer - and the longest run of each kind expected. A count of runs is tested against
  /// Poisson(rate x span), and a run longer than its kind's longest is a finding; none expected by
  /// default, so any run is named.
  model::DataEventRates data_events;
  /// The relative and reference families' noise colour in time: a model per component (white, or white
  /// plus Gauss-Markov) fitted to the data under each test's null hypothesis, and the tests made on
  /// rows whitened in time by it (generalised least squares); non-white noise is a finding of its own
  /// (coloured_noise). False: the earlier rule, one lag-1 variance inflation per family from first
  /// differences (kept to compare: `boresight audit --white-rows`).
  bool time_colour = true;
  /// The configured noise as the noise-level tests see it: per head slot half the mean square of the
  /// first difference at the head epoch interval dt, var - autocovariance(dt) of the configured model
  /// (cross-boresight: the mean of x and y; about the boresight), rad^2. For white noise that is the
  /// core's sigma squared (the default, NaN); a slow coloured part adds little to it, so the level the
  /// tests compare with is not the total variance then (audit::runAudit fills it from the noise in use).
  std::array<double, core::kMaxHeads> configured_diff_cross2 = nanHeads(), configured_diff_about2 = nanHeads();
  /// The configured slow noise of the heads (the Gauss-Markov parts of the noise in use): per head slot
  /// the stationary 1-sigma cross-boresight (RMS of x and y) and about the boresight, rad, and one
  /// correlation time (variance-weighted over the heads' terms), s; 0 / NaN: none (white, the default).
  /// With it the relative family's colour test takes it as the null (coloured_noise is then named
  /// only when the data depart from it) and its tests whiten with it unless a free fit beats it by BIC.
  std::array<double, core::kMaxHeads> configured_gm_cross{}, configured_gm_about{};
  double configured_gm_tau_s = std::numeric_limits<double>::quiet_NaN();
  /// Thermal terms applied (a model overlay's, io::OverlayUse::thermal_model): every head epoch's
  /// mountings follow them, C_Sk_B(u) = Exp(-C0_kd delta_dk(u)) C0_Sk_B (the datum head d keeps its
  /// mounting; delta in S_d, core/thermal_harmonics.h; the constant and the harmonics of the argument of
  /// latitude u from the orbit context, the beta modulation not applied), so the relative family sees
  /// what the terms leave. Epochs without an orbit sample within 60 s keep the plain mountings (counted).
  std::optional<core::ThermalHarmonicModel> applied_thermal;
  static std::array<double, core::kMaxHeads> nanHeads() {
    std::array<double, core::kMaxHeads> a{};
    a.fill(std::numeric_limits<double>::quiet_NaN());
    return a;
  }
};

/// One parameter of an estimated effect, in the unit of the catalogue.
struct ParamValue {
  std::string key;  ///< catalogue key, e.g. "x_arcsec", "offset_ms"
  std::string unit;
  double value = kNaN;
  double sigma = kNaN;  ///< 1-sigma from the fit (NaN when not available)
  double truth = kNaN;  ///< from --truth, when given
};

/// The test of one candidate effect against the baseline.
struct EffectTest {
  std::string name;    ///< canonical catalogue name (model::effectCatalogue())
  std::string sensor;  ///< "1", "2", ..., "all", "acc", "reference"
  std::string family;  ///< residual family that carries the evidence
  double statistic = kNaN;  ///< F statistic of adding the effect to the baseline (or the test's own, see note)
  double threshold = kNaN;  ///< the statistic's value at the family-wise false-alarm rate
  double p_value = kNaN;    ///< per-test p-value (compare with false_alarm / tests)
  int dof = 0;              ///< parameters the effect adds
  bool detected = false;    ///< statistic > threshold
  bool named = false;       ///< kept by forward selection (a named cause)
  std::vector<ParamValue> params;  ///< estimate with 1-sigma, catalogue units
  std::string note;         ///< how the statistic was formed, when not the F test
};

/// A run of missing samples in the data that the geometry does not explain (seconds since the first
/// head epoch; start_s and end_s are the samples around it): one head's while other heads delivered,
/// outside the blinding cones (sensor: its id), every head's ("all"), the accelerometer's ("acc").
/// The audit's loop (`--simulate-model`) leaves the same holes in the simulation of the model.
struct DataGap {
  std::string sensor;
  double start_s = 0, end_s = 0;
  double samples = 0;  ///< samples missing in the run
};

/// A group of causes the data cannot tell apart.
struct Ambiguity {
  std::vector<std::string> causes;  ///< "name[sensor]"
  std::string separate_by;          ///< what data would separate them
  double correlation = kNaN;        ///< |correlation| of their fitted signatures
};

struct NotExplained {
  std::string family;
  std::string what;  ///< e.g. "relative pair 1-2 axis y: residual line at 3 cycles/rev"
  double statistic = kNaN;
  double threshold = kNaN;
};

/// Before/after the extension, for one residual family.
struct Gain {
  std::string family;
  std::string unit;
  double rms_before = kNaN, rms_after = kNaN;  ///< on the fitting data
  double heldout_rms_before = kNaN, heldout_rms_after = kNaN;
  /// Kurtosis m4 / m2^2 of the held-out baseline residual rows (3 for Gaussian rows; large where a few
  /// rows dominate, such as the edges of gaps): the relative sigma of an RMS of n rows is about
  /// sqrt((kurtosis - 1) / 4n). NaN where not formed (the noise family).
  double heldout_kurtosis_before = kNaN;
  /// lag-1 autocorrelation of the residuals (linear families: of the held-out rows)
  double whiteness_before = kNaN, whiteness_after = kNaN;
  /// Linear families: log-likelihood of the held-out rows under the extended model (named effects and the
  /// fitted noise models, every parameter fitted on the fitting rows) minus under the baseline (no effect,
  /// the rows' white unit noise), each conditional on the fitting rows (the noise filter runs through
  /// them); nats, positive: better. A noise cause's gain shows here only (it cannot change an RMS).
  double heldout_loglik_gain = kNaN;
  double heldout_rows = 0;
  /// BIC(extended) - BIC(baseline) on the held-out data: -2 heldout_loglik_gain + k ln(heldout_rows), k
  /// the extended model's parameters (effects and noise); negative: better
  double delta_bic = kNaN;
};

/// A residual series for the report (bin means), one per family component.
struct Series {
  std::string family, label, unit;  ///< e.g. "relative", "pair 1-2 x_B", "arcsec"
  std::vector<double> t_s;          ///< seconds since the first epoch
  std::vector<double> before, after;
};

/// Amplitude spectrum of a series (Lomb-Scargle on the bin means), frequency in cycles per revolution
/// when an orbit context exists, else in mHz (see `unit`).
struct Spectrum {
  std::string family, label, unit;
  std::vector<double> freq, before, after;
  /// The component's fitted noise model as the amplitude a least-squares sinusoid of pure noise has
  /// at each frequency (rms, sqrt(2 S(f) / T)), in the family's unit; empty where no model was fitted
  /// (AuditOptions::time_colour off, or a family without it). Approximate: whitened units are turned
  /// into the family's unit with the rows' median scale.
  std::vector<double> noise;
};

/// A parameter compared with the truth (given --truth).
struct TruthCompare {
  std::string effect, sensor, key, unit;
  double truth = kNaN, before = kNaN, after = kNaN;  ///< before: baseline value (0 when absent)
};

struct Baseline {
  std::string description;
  double span_s = 0;
  double bin_s = 0;
  std::uint64_t head_epochs = 0, acc_samples = 0, reference_samples = 0, orbit_samples = 0;
  /// accelerometer samples outside the star data's span (before its first epoch or over 300 s after
  /// its last): counted in acc_samples, not used
  std::uint64_t acc_samples_outside = 0;
  std::vector<std::string> families;  ///< families with data
  std::vector<std::string> missing;   ///< families without (and why), e.g. "angular_acceleration: span 16 s < CRN 70.7 s"
  std::map<std::string, double> values;  ///< model parameters used (sigma_cross_arcsec, ...)
  std::string holdout;  ///< which data were held out (whole orbits, or blocks of the span), in words
};

struct AuditResult {
  Baseline baseline;
  std::vector<EffectTest> effects;      ///< every candidate tested
  int tests = 0;                        ///< number of tests (Bonferroni divisor)
  std::vector<EffectTest> named;        ///< the named causes, in the order selected
  std::vector<NotExplained> not_explained;
  std::vector<Ambiguity> ambiguous;
  std::vector<EffectTest> extended;     ///< the extended model's effects re-estimated together
  Gain gain;                            ///< the family with the largest gain
  std::vector<Gain> gains;              ///< every family
  std::vector<TruthCompare> truth;
  std::vector<Series> series;
  std::vector<Spectrum> spectra;
  std::vector<DataGap> gaps;            ///< the data's unexplained missing-sample runs (at most 5000 per stream)
  std::vector<std::string> findings;    ///< one plain sentence per finding (printed by the command)
  /// canonical names of the named causes (deduplicated), e.g. {"relative_misalignment", "acc_bias"}
  std::vector<std::string> namedCauseNames() const;
};

class Collector final : public stream::InputObserver, public stream::RowSink {
 public:
  Collector();
  ~Collector() override;
  Collector(const Collector&) = delete;
  Collector& operator=(const Collector&) = delete;
  /// The configuration the core runs (heads, nominal mountings, noise model, C_B_A, CRNs).
  bool configure(const core::PipelineConfig& cfg, const AuditOptions& opt, std::string* error);
  // stream::InputObserver: validated head epochs and accelerometer samples, in time order.
  void onHeads(const core::HeadEpoch& e, core::Status core_status) override;
  void onAcc(TimeUs t, const Vec3& a_A, core::Status core_status) override;
  void onEnd() override;
  // stream::RowSink: the core's rows (fused attitude, rates, angular accelerations).
  bool write(const core::PipelineRow& row) override;
  /// Orbit context (GNI1B / GNV1B / simulator), any order; kept decimated to one per 10 s. A sample
  /// without an orbit plane (NaN angles) is counted (orbitUnusable) and not kept.
  void addOrbit(const model::OrbitSample& o);
  // stream::InputObserver: the orbit from the engine's stream (GNI1B / GNV1B files, an LCM log's ORBIT
  // messages), in time order with the head epochs.
  bool wantsOrbit() const override { return true; }
  void onOrbit(const model::OrbitSample& o) override { addOrbit(o); }
  std::uint64_t orbitUnusable() const;
  /// Outside reference attitude q_I_B (SCA1B), time order.
  void addReference(TimeUs t, const Quat& q_I_B);

  struct Impl;
  const Impl& impl() const { return *impl_; }

 private:
  std::unique_ptr<Impl> impl_;
};

/// Truth for the parameter comparison (a simulation's truth.yaml).
struct Truth {
  std::vector<model::EffectSpec> effects;
  std::map<int, Vec3> mounting_error_rad;  ///< per head id, in the head frame
};

/// Runs the tests, selection, extension and gain. `truth` may be null.
AuditResult analyse(const Collector& c, const AuditOptions& opt, const Truth* truth = nullptr);

}  // namespace boresight::audit
