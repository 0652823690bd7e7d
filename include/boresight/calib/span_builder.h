// boresight::calib - builds a CalibrationSpan from the same epochs the core sees: per-head CRN angular
// accelerations in each head's frame (core::AttitudeRates per head, on q_I_Si), the accelerometer's
// through the same CRN low-pass on the same tags (core::AccAngularFilter, kept in the frame A), the pair
// means (core::RelativeAttitudeMeans, no forgetting: the whole span counts).
//
// Decimation: the head filters produce outputs only on a grid of decimation_s (the CRN cost follows the
// output rate), so a span holds one Observation per decimation_s: 10 s by default, about the CRN's
// correlation length (the noise of epochs 10 s apart still correlates by +0.40, 20 s by +0.06, 30 s by
// +0.005: CalibrationSpan::noise_correlation, which the solver uses to whiten).
// Noise model of an observation: the head's attitude noise (HeadConfig sigmas, anisotropic, times the
// sample's sigma_scale), white at the head rate, through the CRN second-derivative kernel:
// cov_alpha_S = sum g2^2 Sigma_S; the accelerometer's white noise through the low-pass:
// cov_alpha_A = sum g0^2 diag(sigma_acc^2). The accelerometer's low-frequency (Gauss-Markov) noise is
// not modelled (about 1e-2 of the head term in rad/s^2; the bias absorbs its mean over the span).
//
// Inputs in time order per stream, the two streams merged by time (the engine does): an epoch waits
// until the accelerometer filter covers it (35 s later) and is dropped (dropped_no_acc) when the
// accelerometer data does not cover it. Memory: the observations (about 0.7 kB each, 6 MB per day at
// 10 s) plus the filters' fixed rings; max_observations bounds them. Every epoch also goes into the
// per-head sufficient statistics (CalibrationSpan::moments, streaming whitening): with
// keep_observations = false that is all the span holds, and its memory is constant.
//
// Producers: the replay engine (Level-1 files, LCM logs) via `boresight calibrate`, the node's worker,
// the Monte Carlo bench. Owned by the solver's author; the CLI only calls it.
#pragma once

#include "boresight/calib/problem.h"
#include "boresight/core/pipeline.h"

#include <deque>
#include <vector>
#include <string>

namespace boresight::calib {

struct SpanOptions {
  double decimation_s = 10.0;          ///< one observation per this interval, s (>= the head interval)
  std::size_t max_observations = 0;    ///< 0 = no limit; else the oldest are dropped (1/16 of it at a time)
  /// White noise of the accelerometer's angular acceleration per sample and A axis, rad/s^2
  /// (GRACE-FO ACC1A at 10 Hz, as config/sim_gracefo.yaml).
  Vec3 acc_white_noise_radps2 = Vec3(1.5e-7, 3.0e-8, 5.0e-8);
  /// A calibration CRN for both filters (heads and accelerometer) instead of the pipeline's, when > 0:
  /// the acceleration noise grows as B^5 while 100 s manoeuvres pass any B above ~0.02 Hz, so a
  /// narrower filter bounds the angles far better (Monte Carlo, three 1-deg 100 s manoeuvres: CRLB
  /// 710" at the core's 0.1 Hz / 70.7 s, 160" at 0.05 Hz / 100 s with decimation_s 20). The
  /// accelerometer's filter must fit kMaxCrnTaps: length_s * its rate <= 1023.
  double crn_bandwidth_hz = 0.0;
  double crn_length_s = 0.0;
  /// false: observations are not stored, only the sufficient statistics (CalibrationSpan::moments):
  /// memory constant in the span; the solver then works from the moments (no robust loss, no outlier
  /// rounds: see SolveOptions::from_moments).
  bool keep_observations = true;
};

class SpanBuilder {
 public:
  /// The core configuration gives heads, nominal mountings, C_B_A and the CRNs (crn_attitude at the
  /// head rate, crn_acc at the accelerometer rate). False with *error.
  bool configure(const core::PipelineConfig& cfg, const SpanOptions& opt, std::string* error);
  /// One head epoch (ids as in the telemetry). Rejected samples are counted, never fatal.
  void pushHeads(const core::HeadEpoch& e);
  /// One accelerometer sample a_A (rad/s^2, frame A, as measured: bias and all).
  void pushAcc(TimeUs t, const Vec3& a_A);
  /// End of data: epochs still waiting for the accelerometer are dropped (counted), the pair means
  /// are written into the span.
  void finish();
  const CalibrationSpan& span() const { return span_; }
  /// Health of the head validator and filters (diagnostics).
  core::Health health() const;

 private:
  void addHeadOutput(int slot, const core::RateOutput& o);
  void relativeStep(const core::ValidHeads& v);
  void resolve();
  void emit(Observation&& ob);
  void accumulate(const Observation& ob);
  struct WhitenState {  ///< the streaming banded Cholesky of one head: the last K epochs
    std::deque<TimeUs> t;
    std::deque<std::vector<double>> L;                    ///< L(k, k-K..k) of those epochs
    std::deque<Eigen::Matrix<double, 10, 1>> z;           ///< their whitened data vectors
  };
  std::array<WhitenState, kMaxHeads> wstate_{};
  bool configured_ = false;
  core::PipelineConfig cfg_{};
  SpanOptions opt_{};
  core::HeadInputValidator validator_{};
  std::array<core::AttitudeRates, kMaxHeads> rates_{};
  core::AccAngularFilter acc_{};
  core::RelativeAttitudeMeans means_{};
  std::array<Mat3, kMaxHeads> cov_head_unit_{};  ///< CRN acceleration noise per head at sigma_scale 1
  std::array<Mat3, kMaxHeads> W_B_{};            ///< head attitude information in B at sigma_scale 1
  Mat3 cov_acc_ = Mat3::Zero();
  std::deque<Observation> pending_;               ///< head outputs waiting for the accelerometer
  bool have_head_ = false;
  bool have_emitted_ = false;   ///< an observation went to the span
  TimeUs last_emitted_t_ = 0;   ///< its tag (later head outputs of that tag are left out)
  CalibrationSpan span_{};
};

}  // namespace boresight::calib
