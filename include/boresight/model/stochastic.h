// The stochastic parts of the sensor models, as functions a simulator composes and an estimator
// evaluates: time tags (pattern, jitter, clock drift), missing samples (random gap processes,
// explicit gaps, dropouts), outliers and sign flips (independent per-sample processes) and the
// accelerometer noise (white + first-order Gauss-Markov). Every draw is counter-based
// (model/random.h): a pure function of (seed, stream, sensor key, sample index), so an estimator can
// replay the simulator's draws and a simulator's output does not depend on which other effects are on.
//
// Random streams. Process j of a sensor (the j-th `outliers`, `sign_flips` or random `gaps` spec that
// applies to it, in spec order) draws from CounterRng(seed, stream, processKey(sensor, j)); j = 0 uses
// the sensor's own key (head id, 0 for the accelerometer), which keeps single-spec output identical
// to what the simulator produced before effects composed.
//
// Statistics (for likelihoods and detection thresholds):
//   outliers:  P(sample hit) = 1 - prod_j (1 - p_j); sign flips likewise.
//   gaps:      a process starts a gap at each 1 s slot with probability p = per_s, of length
//              -mean_s ln(u) (exponential) from the slot start; a time t is missing when any earlier
//              gap still covers it. P(t free) = prod_k (1 - p exp(-(k + f)/mean_s)), f the fraction
//              of t in its slot, averaged over f (expectedMissingFraction); processes multiply.
//   acc noise: per A axis, x_n = w_n + g_n, w white (sigma_w), g an AR(1) g_{n+1} = phi g_n +
//              sqrt(1 - phi^2) sigma_g e_n, phi = exp(-T / tau), stationary from the first sample:
//              the noise.h model white(sigma_w) + GaussMarkov(sigma_g, tau) sampled every T, whose
//              autocovariance and PSD (noise.h) AccNoiseModel returns.
//   coloured processes (coloured_noise, thermal_wander, acc_coloured_noise, acc_bias_wander): one
//              noise.h model per axis drawn with noise.h's NoiseSimulator at the sensor's true sample
//              times, every tag (a missing or blinded sample advances the process too), so irregular
//              sampling and gaps are exact; stream and keys in NoiseProcess.
#pragma once

#include <boresight/core/conventions.h>
#include <boresight/model/effects.h>
#include <boresight/model/random.h>
#include <boresight/model/sensors.h>

#include <boresight/model/noise.h>

#include <array>
#include <cstdint>
#include <vector>

namespace boresight::model {

/// Sensor key of process j (see the header comment): j = 0 is the sensor itself.
constexpr std::uint64_t processKey(std::uint64_t sensor, std::size_t j) {
  return sensor + 0x10000ULL * static_cast<std::uint64_t>(j);
}

// ---------------------------------------------------------------------------------------------
// Time tags

/// A sensor's time-tag pattern (receiver time, integer microseconds):
///   tag(k) = start + k period + round(drift_ppm 1e-6 k period) + round(jitter_us (2 u_k - 1)),
/// u_k uniform in (0, 1) from `jitter_rng` (so the jitter is uniform in +-jitter_us, sigma
/// jitter_us / sqrt(3)). Heads with equal rate and offset share the jitter draws (one electronics
/// unit stamps them). The true time a sample describes is trueTimeOfTag(time offset, clock drifts,
/// tag) (effects.h).
struct TagModel {
  TimeUs start = 0, period = 1;
  double drift_ppm = 0, jitter_us = 0;
  CounterRng jitter_rng{0, Stream::HeadTagJitter, 0};
  TimeUs tag(std::uint64_t k) const;
  /// E[tag(k)] without the rounding of the jitter, us (the jitter has mean zero).
  double expectedTag(std::uint64_t k) const;
  /// The jitter draw of sample k, us, before rounding (0 without jitter).
  double jitter(std::uint64_t k) const;
  double jitterSigmaUs() const;
};

/// The simulator's pattern for a sensor: the first tag at the first whole second at or after
/// `start` plus `offset_us`, moved back by whole periods while it stays at or after `start`.
/// period = round(1e6 / rate_hz) us. The jitter stream is (seed, stream, period * 1000003 + offset).
TagModel makeTagModel(TimeUs start, double rate_hz, TimeUs offset_us, double drift_ppm, double jitter_us,
                      std::uint64_t seed, Stream stream);

// ---------------------------------------------------------------------------------------------
// Missing samples

/// Expected long-run fraction of time one random gap process leaves missing (header comment).
double expectedMissingFraction(const RandomGaps& g);
/// Several independent processes: 1 - prod (1 - f_j).
double expectedMissingFraction(const std::vector<RandomGaps>& g);

/// The missing-sample process of one sensor: its random gap processes, explicit gaps and dropouts.
/// missing(t) must be called with non-decreasing t (the simulator's time order); memory O(processes).
class GapProcess {
 public:
  GapProcess() = default;
  /// `stream` is HeadGap (sensor = head id) or AccGap (sensor = 0).
  GapProcess(const std::vector<RandomGaps>& random, std::vector<Interval> fixed, std::vector<Interval> dropouts,
             std::uint64_t seed, Stream stream, std::uint64_t sensor);
  /// True when a sample at t (s since the start) is missing.
  bool missing(double t_s);
  /// Only the random processes (a draw; same state rules as missing()).
  bool randomMissing(double t_s);
  /// Only the explicit gaps and dropouts (deterministic).
  bool fixedMissing(double t_s) const;
  double expectedRandomFraction() const;

 private:
  struct Proc {
    RandomGaps g;
    CounterRng rng{0, Stream::HeadGap, 0};
    std::int64_t next_slot = 0;
    double until = -1;
  };
  std::vector<Proc> procs_;
  std::vector<Interval> fixed_;  ///< explicit gaps and dropouts: their union, disjoint, in time order
};

// ---------------------------------------------------------------------------------------------
// Outliers and sign flips

/// The outlier processes of a head (one per `outliers` spec). Process j fires at sample n when
/// uniform(n, 0) < p_j on its stream (HeadOutlier, processKey(head, j)); it then rotates the head
/// attitude by p.rad about the unit axis (normal(n, 1), normal(n, 2), normal(n, 3)), head frame.
class OutlierSampler {
 public:
  OutlierSampler() = default;
  OutlierSampler(const std::vector<OutlierProcess>& p, std::uint64_t seed, std::uint64_t head_id);
  std::size_t size() const { return procs_.size(); }
  /// P(sample hit by at least one process).
  double probability() const;
  bool fires(std::size_t j, std::uint64_t n) const;
  /// The rotation vector (head frame, rad) process j applies when it fires at sample n.
  Vec3 rotation(std::size_t j, std::uint64_t n) const;
  /// Applies every process that fires at sample n: q = q Exp(rot_j) in process order. True when any fired.
  bool apply(std::uint64_t n, Quat& q) const;

 private:
  std::vector<OutlierProcess> procs_;
  std::vector<CounterRng> rng_;
};

/// The sign-flip processes of a head: process j fires at sample n when uniform(n, 0) < p_j on
/// (HeadSignFlip, processKey(head, j)); a sample is delivered as -q when any fires.
class SignFlipSampler {
 public:
  SignFlipSampler() = default;
  SignFlipSampler(const std::vector<double>& probs, std::uint64_t seed, std::uint64_t head_id);
  double probability() const;
  bool fires(std::uint64_t n) const;

 private:
  std::vector<double> p_;
  std::vector<CounterRng> rng_;
};

// ---------------------------------------------------------------------------------------------
// Coloured processes (noise.h models drawn at the sensor's sample times)

/// Sensor key of a coloured process on its stream: sensor (head id, 0 for the accelerometer), axis
/// (0, 1: cross-boresight e1, e2 or A x, y; 2: about the boresight or A z); chunk 0 (a chunk > 0 was
/// a work-around of a simulator limit that no longer exists).
constexpr std::uint64_t colouredProcessKey(std::uint64_t sensor, int axis, std::size_t chunk) {
  return sensor + 0x100ULL * static_cast<std::uint64_t>(axis) + 0x1000ULL * static_cast<std::uint64_t>(chunk);
}

/// One axis of a noise.h model drawn by noise.h's NoiseSimulator on CounterRng(seed, stream,
/// colouredProcessKey(sensor, axis, 0)) (any number of terms: the simulator spreads them over as many
/// counter indices per sample as it needs).
class NoiseProcess {
 public:
  NoiseProcess() = default;
  NoiseProcess(const NoiseModel& m, std::uint64_t seed, Stream stream, std::uint64_t sensor, int axis);
  bool empty() const { return empty_; }
  /// The value at t_s (non-decreasing over calls; the first call starts from the stationary state).
  double next(double t_s) { return empty_ ? 0.0 : sim_.next(t_s); }

 private:
  NoiseSimulator sim_;
  bool empty_ = true;
};

/// Three axes of NoiseProcess: models[0..2] on axes 0..2 (see colouredProcessKey).
class NoiseProcess3 {
 public:
  NoiseProcess3() = default;
  NoiseProcess3(const std::array<NoiseModel, 3>& models, std::uint64_t seed, Stream stream, std::uint64_t sensor);
  bool empty() const { return empty_; }
  Vec3 next(double t_s);

 private:
  std::array<NoiseProcess, 3> axis_;
  bool empty_ = true;
};

/// A head's coloured_noise or thermal_wander models on its three axes: (cross, cross, about).
inline std::array<NoiseModel, 3> headAxisModels(const NoiseModel& cross, const NoiseModel& about) {
  return {cross, cross, about};
}

// ---------------------------------------------------------------------------------------------
// Accelerometer noise

/// White + first-order Gauss-Markov angular-acceleration noise per A axis, and white linear noise
/// (header comment). Sample n's low-frequency value is the AR(1) state after n steps from the
/// stationary draw lowFreqInitial(); the state advances once per sample, delivered or missing.
/// model(k) is the angular noise of axis k as a noise.h model; variances, autocovariance and PSD are
/// the library's.
class AccNoiseModel {
 public:
  AccNoiseModel() = default;
  AccNoiseModel(const AccelConfig& c, std::uint64_t seed);
  double phi() const { return phi_; }
  double sampleInterval() const { return T_; }
  /// The angular noise of A axis k (0..2): white(sigma_w) + GaussMarkov(sigma_g, tau), rad/s^2.
  const NoiseModel& model(int k) const { return models_[static_cast<std::size_t>(k)]; }
  Vec3 lowFreqInitial() const;
  /// The state of sample n + 1 from that of sample n.
  Vec3 lowFreqNext(const Vec3& lf_n, std::uint64_t n) const;
  /// White angular (rad/s^2) and linear (m/s^2) noise of sample n.
  void white(std::uint64_t n, Vec3& ang, Vec3& lin) const;
  Vec3 whiteVariance() const;
  Vec3 lowFreqVariance() const;
  /// Autocovariance of the angular noise at a lag of k samples, per axis.
  Vec3 autocovariance(std::uint64_t k) const;
  /// One-sided power spectral density of the angular noise at f (0 <= f <= rate/2), (rad/s^2)^2/Hz.
  Vec3 psdOneSided(double f_hz) const;

 private:
  Vec3 white_ = Vec3::Zero(), lin_white_ = Vec3::Zero(), lf_ = Vec3::Zero();
  double T_ = 0.1, phi_ = 0;
  std::array<NoiseModel, 3> models_;
  CounterRng white_rng_{0, Stream::AccNoise, 0}, lf_rng_{0, Stream::AccLowFreq, 0};
};

}  // namespace boresight::model
