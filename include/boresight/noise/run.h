// `boresight noise`: the noise of every head axis and accelerometer axis, estimated from the data,
// with a fitted model per axis (model/noise.h), in one place for the command and the tests.
//
//   files -> stream::classifyInputs / prepareConfig -> stream::Engine
//         -> HeadResiduals (InputObserver): per head axis, the head against the fused attitude of the
//            OTHER heads, in the head's own axes (cross-boresight x, y and about the boresight): the
//            attitude cancels; what the other heads add is known (their fusion weights) and is
//            carried into the fit as a fixed part of the model (its "contamination"); the first
//            differences of consecutive epochs of all head series give the white levels of every
//            head axis at once (noise/joint_white.h), which set the white part of it
//         -> AccSeries (InputObserver + RowSink): the accelerometer's white level from first
//            differences of the raw samples (robust: thruster pulses do not count), and its
//            low-frequency part from block means of star-minus-accelerometer angular acceleration
//            (the same CRN on both; blocks of `acc_block_s`), where the span allows
//   -> per axis: the candidate structures fitted by exact likelihood, chosen by BIC, with
//      uncertainties and what the span and the sampling can determine.
//
// Memory is flat in the span: each axis keeps at most `max_samples` samples; when full it keeps every
// other one (decimation by whole factors keeps the noise model exact: white stays white per sample,
// a Gauss-Markov term stays one at the longer interval), so long spans reach the slow noise they are
// for, and the fastest determinable correlation time grows with them.
#pragma once

#include <boresight/core/pipeline.h>
#include <boresight/model/noise.h>
#include <boresight/model/overlay.h>
#include <boresight/stream/source.h>

#include <functional>
#include <string>
#include <vector>

namespace boresight::noise {

struct NoiseOptions {
  std::vector<model::NoiseStructure> structures = model::defaultNoiseStructures();
  std::size_t max_samples = std::size_t{1} << 16;  ///< per axis; more are decimated by 2 until they fit
  double acc_block_s = 100;  ///< block of the star-minus-accelerometer series, s (longer than the CRN)
  int contamination_passes = 2;  ///< fits of the head axes with the other heads' fitted coloured parts
  /// Auto: the Whittle likelihood on series with few, long gaps (a day's fits in milliseconds), the
  /// exact one otherwise (model/noise.h: NoiseLikelihood)
  model::NoiseLikelihood likelihood = model::NoiseLikelihood::Auto;
  /// false: the other heads' part of a head's series is not modelled (its whole noise is put on the
  /// head: a diagnostic, the levels come out too high)
  bool model_other_heads = true;
  /// true: every candidate structure is fitted on every axis (model/noise.h:
  /// NoiseFitOptions::skip_when_no_colour off; slower, for comparing the candidates)
  bool every_structure = false;
};

/// One axis's result.
struct AxisResult {
  std::string sensor;  ///< "head 1", "accelerometer"
  std::string axis;    ///< head: cross_x, cross_y, about_boresight; accelerometer: x, y, z (A frame)
  std::string unit;    ///< unit of the fitted values: "arcsec", "rad/s^2"
  std::string series;  ///< what was fitted (for the report)
  std::size_t samples = 0;
  double span_s = 0, interval_s = 0;  ///< span and median interval of the fitted series
  int decimation = 1;                  ///< every how many samples of the input were kept
  model::NoiseSelection selection;     ///< every candidate; chosen() is the axis's model
  model::NoiseModel contamination;     ///< heads: what the other heads add to the series (fixed in the fit)
  model::NoiseModel configured;        ///< what the platform file says for this axis
  model::Spectrum spectrum;            ///< the series' Welch PSD (report plots)
  double f_det_lo = 0, f_det_hi = 0;   ///< band in which correlation times / corners are determined, Hz
  std::vector<std::string> notes;
  bool fitted() const { return selection.best >= 0; }
};

/// An axis's spectrum at one frequency of its determinable band: the chosen model's log PSD (natural
/// log of unit^2/Hz, the axis's own model without the other heads' part) with its own standard error
/// (model::NoiseFit::logPsd), and the fitted candidates averaged with Akaike weights with the
/// unconditional standard error, which holds the uncertainty of the choice between them
/// (model::NoiseSelection::averagedLogPsd). Infinite: not determined there.
struct BandPoint {
  double f_hz = 0, chosen_log_psd = 0, chosen_se = 0, averaged_log_psd = 0, averaged_se = 0;
};

/// The axis's spectrum at 12 log-spaced frequencies across its determinable band (f_det_lo to
/// f_det_hi); empty when it has no fit or no band.
std::vector<BandPoint> bandSpectrum(const AxisResult& a);

/// The axis note `boresight noise` writes where the candidates disagree: the frequency at which the
/// averaged standard error is largest against the chosen model's own, and the ratio, when it is over
/// 2 (points without a finite average or a chosen error are skipped); empty otherwise.
std::string uncertainChoiceNote(const std::vector<BandPoint>& band);

struct NoiseRequest {
  std::string config;               ///< platform file
  std::string overlay;              ///< a model overlay whose noise replaces the platform's (empty: none)
  std::vector<std::string> inputs;  ///< Level-1 files or LCM logs, recognised by content
  NoiseOptions options;
  double lookahead_s = 2.0;
  bool strict = false;
  std::function<void(const std::string&)> progress;
};

struct NoiseOutput {
  std::vector<AxisResult> axes;
  std::vector<std::string> inputs, notes;
  /// Per source "NAME: N read, M used, K REASON..." and its first rejected lines ("    rejected ...").
  std::vector<std::string> sources;
  stream::Counters counters;
  core::Health health;
  std::uint64_t epochs = 0, full_epochs = 0, acc_samples = 0;
  double span_s = 0;
  TimeUs t0 = 0, t1 = 0;            ///< first and last head epoch (GPS)
  std::string platform;
  std::vector<std::string> model_in_use;  ///< the configured noise per axis and where it came from
};

/// The chosen models as a noise section (heads by id: cross_x, cross_y, about_boresight in rad;
/// accelerometer x, y, z in rad/s^2, its white level and its slow part together), with the fitted
/// parameters' uncertainties and what was not determined.
model::NoiseSection fittedNoiseSection(const NoiseOutput& out);

/// Replays the inputs and fits every axis. False with *error (file:line: reason) on bad input; what
/// a short span cannot determine is in the result (notes, undetermined parameters), not an error.
bool runNoise(const NoiseRequest& req, NoiseOutput& out, std::string* error);

/// noise.json: every axis with its candidates, chosen model, parameters and uncertainties.
bool writeNoiseJson(const std::string& path, const NoiseOutput& out, std::string* error);
/// noise.yaml: the chosen models in the platform file's `noise` form (per head axis in arcsec, per
/// accelerometer axis in rad/s^2), to paste into a platform file.
bool writeNoiseYaml(const std::string& path, const NoiseOutput& out, std::string* error);
/// overlay.yaml: the same as a model overlay (io/overlay_yaml.h), valid over the data's span, for
/// `--overlay` of process, calibrate, audit and the node.
bool writeNoiseOverlay(const std::string& path, const NoiseOutput& out, const std::string& program, std::string* error);
/// report.md with a log-log plot per axis: the data's PSD against the fitted and the configured model.
bool writeNoiseReport(const std::string& dir, const NoiseOutput& out, std::string* error);

}  // namespace boresight::noise
