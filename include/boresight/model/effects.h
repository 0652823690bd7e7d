// The effect catalogue: named, parametrised ways in which sensor data deviate from the nominal model.
//
// The simulator injects effects; the audit (issue: model audit) tests for them with the SAME code, so
// every effect is (1) a canonical name with documented parameters, units and defaults
// (effectCatalogue()), (2) a parsed, validated EffectSpec, and (3) a typed per-sensor set
// (HeadEffects, AccEffects) whose evaluation functions are pure functions of time and orbit context.
//
// Sign conventions (all rotation vectors are small, radians inside, arcseconds in parameters):
//   Head errors are rotations of the head frame in its own components: the true mounting at time t is
//     C_Si_B(t) = R(Exp(phi_eff(t))) R(Exp(phi_mount)) C_Si_B_nominal,
//   phi_mount being the constant per-head mounting error (truth) and phi_eff the sum of
//   relative_misalignment + thermal_periodic + drift + step.
//   time_offset: a sensor's time tag runs AHEAD of the truth by offset: t_tag = t_true + offset
//     (so the data stamped t_tag describe the state at t_tag - offset). sensor 'all': every head
//     shares the offset (the accelerometer does not: target it with 'acc').
//   clock_drift: a tag RATE error: t_tag = t_true + offset + rate_ppm 1e-6 (t_true - start_s), for all
//     t (start_s is the epoch at which the clock error equals offset); 'all' = every head, as above.
//   cross_noise: the head's white noise per cross-boresight axis (real GRACE-FO heads are about 2.5x
//     quieter than the 6" GROOPS value); anisotropic_noise: the same about the boresight.
//   acc_*: a_A = (I + diag(scale)) R(Exp(misalignment)) C_A_B a_B + bias + noise.
//   coloured_noise: a coloured MEASUREMENT error of a head (the attitude it reports, not its mounting),
//     per head axis: each cross-boresight axis (e1, e2 of boresightBasis) draws its own process of
//     the cross model, the boresight axis the about model; noise.h's Gauss-Markov or power-law term.
//   thermal_wander: a random ROTATION of a head's mounting (like thermal_periodic, so it moves the
//     star vectors' geometric attitude too), per head axis with the same forms.
//   fov_error: every star the head tracks is displaced on the detector by a smooth random field of its
//     focal-plane position (model/sensors.h FovErrorField); the head's attitude error is the
//     least-squares rotation of its stars' displacements, so it follows the stars across the detector.
//   acc_coloured_noise, acc_bias_wander: coloured angular-acceleration noise and a slowly varying bias
//     per A axis (noise.h terms), added to the configured white and Gauss-Markov noise.
//   aberration (uncorrected): the apparent boresight moves towards the observer velocity v by
//     |b x v| / c: the head frame is rotated by b_I x v / c (annual: Earth about the Sun; orbital:
//     the satellite about the Earth).
//
// Composition: every spec is its own term; two specs of one kind never overwrite each other.
//   Rotations (relative_misalignment, thermal_periodic, drift, step) add as rotation vectors; each
//     drift keeps its own start. time_offset specs add; clock_drift terms add.
//   Noise levels (anisotropic_noise about the boresight, cross_noise per cross axis) are independent
//     white sources: variances add, sigma = sqrt(sum sigma_j^2), and that sum REPLACES the head's
//     configured level on its axes (one spec sets the level, as it always did).
//   coloured_noise, thermal_wander, acc_coloured_noise, acc_bias_wander: each spec is one more
//     independent term of its axis's noise.h model (variances add; the configured white noise stays);
//     a term's draws do not change when later specs are added. fov_error: each spec is its own field
//     (own random coefficients); displacements add, and so do the attitude errors (linear).
//   outliers, sign_flips and random gaps (gaps with per_day > 0): independent processes, each with its
//     own rate (size, mean length) and its own random stream (model/stochastic.h); a sample is hit
//     when any process fires (the rotations of the outlier processes that fire compose; a sign flip
//     is applied once). Explicit gaps and head_dropout intervals add. aberration: on when any spec
//     turns it on.
// Linearity: headSystematicRotVec and aberrationRotVec are linear in the effect parameters
// (amplitudes, rates, step sizes; the audit evaluates them with unit parameters);
// headRotationFromParams (below) is the same sum from a parameter vector, templated for Ceres.
#pragma once

#include <boresight/core/conventions.h>
#include <boresight/model/noise.h>

#include <array>
#include <cmath>
#include <cstddef>
#include <map>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace boresight::model {

enum class EffectKind : std::uint8_t {
  RelativeMisalignment, AnisotropicNoise, ThermalPeriodic, Drift, Step, TimeOffset,
  AccBias, AccScale, AccMisalignment, Aberration, Outliers, SignFlips, Gaps, HeadDropout,
  CrossNoise, ClockDrift,  // appended: the catalogue order of the older entries is unchanged
  ColouredNoise, FovError, ThermalWander, AccColouredNoise, AccBiasWander,  // appended (noise as the data has it)
};

/// Which sensors an effect may target.
enum class EffectTarget : std::uint8_t { Head, Acc, Any };

struct EffectParamInfo {
  const char* key;
  const char* unit;
  double def;       ///< default value (ignored when required)
  bool required;
  const char* doc;
};

struct EffectInfo {
  EffectKind kind;
  const char* name;  ///< canonical name, e.g. "thermal_periodic"
  EffectTarget target;
  const char* doc;
  std::vector<EffectParamInfo> params;  ///< besides "sensor"
};

/// Every effect, in a fixed order.
const std::vector<EffectInfo>& effectCatalogue();
const EffectInfo* findEffect(std::string_view name);
const char* effectName(EffectKind k);

/// One configured effect. `sensor` is "all", "acc" or a head id ("1", "2", ...).
struct EffectSpec {
  EffectKind kind = EffectKind::RelativeMisalignment;
  std::string name;
  std::string sensor = "all";
  std::map<std::string, double> values;  ///< every parameter of the effect, defaults filled in
  std::string origin;                    ///< where it came from, for messages ("--effect", "x.yaml: effects[1]")
  double get(const std::string& key) const;
  bool appliesToHead(int head_id) const;
  bool appliesToAcc() const { return sensor == "acc" || sensor == "all"; }
};

/// Builds a spec from key/value strings, validating names, numbers and targets. On failure returns
/// false with *error = "<origin>: effect NAME: key 'k': reason".
bool makeEffect(std::string_view name, const std::vector<std::pair<std::string, std::string>>& kv,
                const std::string& origin, EffectSpec& out, std::string* error);

/// The command-line form "NAME:key=value,key=value" (also "NAME" alone when nothing is required).
bool parseEffectArg(std::string_view arg, EffectSpec& out, std::string* error);

/// A text table of the catalogue (for --help and documentation).
std::string effectCatalogueText();

struct Interval {
  double start_s = 0;  ///< seconds since the simulation start
  double end_s = 0;
  bool contains(double t) const { return t >= start_s && t < end_s; }
};

struct ThermalHarmonic {
  int n = 1;                        ///< cycles per revolution (harmonic of the argument of latitude)
  Vec3 amp_rad = Vec3::Zero();      ///< amplitude per head axis
  double phase_rad = 0;
  double beta_gain = 0;             ///< amplitude multiplier 1 + beta_gain * (cos(beta) - cos(beta_ref))
  double beta_ref_rad = 0;
};

/// One random-gap process (one `gaps` spec with per_day > 0): gap starts on 1 s slots with
/// probability per_s each, lengths exponential with mean mean_s. Several processes are independent.
struct RandomGaps {
  double per_s = 0;    ///< expected gap starts per second
  double mean_s = 0;   ///< mean gap duration (exponential)
};

/// One `drift` spec: rate_rad_s * (t - start_s) for t > start_s.
struct DriftTerm {
  Vec3 rate_rad_s = Vec3::Zero();
  double start_s = 0;
};

/// One `outliers` spec: per sample, with probability `prob`, the attitude is rotated by `rad` about a
/// random axis. Several specs are independent processes; a sample is an outlier when any fires (each
/// process that fires applies its rotation).
struct OutlierProcess {
  double prob = 0;
  double rad = 0;
};

/// One `clock_drift` spec: the tag clock runs off by offset_s + rate_ppm 1e-6 (t_true - start_s).
struct ClockDriftTerm {
  double offset_s = 0;
  double rate_ppm = 0;
  double start_s = 0;
};

/// One fov_error spec: a random smooth field of star displacements over the detector (its coefficients
/// are drawn per head and spec from the seed: model/sensors.h drawFovErrorField).
struct FovErrorSpec {
  int order = 3;       ///< highest total degree of the 2-D Legendre terms (1..6; degree 0, a shift, is a mounting error)
  double rms_rad = 0;  ///< RMS displacement per focal-plane axis (both axes' mean square) over the square [-1, 1]^2
};

/// The noise.h term of a coloured_noise / thermal_wander / acc_* spec with stationary 1-sigma `sigma`
/// (rad or rad/s^2): Gauss-Markov when tau_s > 0, else the power law (alpha, f_lo_hz, f_hi_hz).
NoiseTerm effectNoiseTerm(const EffectSpec& s, double sigma);

/// Everything that acts on one head. Each spec is its own term (see the composition rules above).
struct HeadEffects {
  Vec3 misalignment_rad = Vec3::Zero();
  /// anisotropic_noise: white noise about the boresight, quadrature sum of the specs (<0: none given,
  /// the head's configured level applies).
  double about_sigma_rad = -1;
  /// cross_noise: white noise per cross-boresight axis, quadrature sum of the specs (<0: configured).
  double cross_sigma_rad = -1;
  std::vector<ThermalHarmonic> thermal;
  std::vector<DriftTerm> drifts;  ///< one per drift spec
  /// One more drift term, drift_rad_s (t - drift_start_s) after drift_start_s, for code that builds a
  /// HeadEffects by hand (the audit's unit signatures); headEffectsFor never sets it (it fills `drifts`).
  Vec3 drift_rad_s = Vec3::Zero();
  double drift_start_s = 0;
  std::vector<std::pair<double, Vec3>> steps;  ///< (time since start [s], rotation vector [rad])
  double time_offset_s = 0;                    ///< sum of the time_offset specs (head id or 'all')
  std::vector<ClockDriftTerm> clock_drifts;
  bool aberration_annual = false, aberration_orbital = false;
  std::vector<OutlierProcess> outliers;
  std::vector<double> sign_flip_probs;  ///< one independent process per sign_flips spec
  std::vector<RandomGaps> random_gaps;  ///< one independent process per gaps spec with per_day > 0
  std::vector<Interval> gaps;      ///< explicit gaps
  std::vector<Interval> dropouts;  ///< head_dropout intervals
  /// coloured_noise: the measurement error's model per cross-boresight axis (each axis its own
  /// process) and about the boresight, rad; one term per spec with a nonzero level.
  NoiseModel coloured_cross, coloured_about;
  /// thermal_wander: the mounting's random rotation per head axis, rad (as coloured_*).
  NoiseModel wander_cross, wander_about;
  std::vector<FovErrorSpec> fov;  ///< one per fov_error spec
  bool hasColoured() const { return !coloured_cross.empty() || !coloured_about.empty(); }
  bool hasWander() const { return !wander_cross.empty() || !wander_about.empty(); }
};

struct AccEffects {
  Vec3 bias_rad_s2 = Vec3::Zero();
  Vec3 scale = Vec3::Zero();          ///< scale error (a_meas = (1 + scale) a)
  Vec3 misalignment_rad = Vec3::Zero();
  double time_offset_s = 0;           ///< sum of the time_offset specs with sensor 'acc'
  std::vector<ClockDriftTerm> clock_drifts;
  std::vector<RandomGaps> random_gaps;
  std::vector<Interval> gaps;
  std::array<NoiseModel, 3> coloured;     ///< acc_coloured_noise per A axis, rad/s^2 (one term per spec)
  std::array<NoiseModel, 3> bias_wander;  ///< acc_bias_wander per A axis, rad/s^2
  bool hasColoured() const { return !coloured[0].empty() || !coloured[1].empty() || !coloured[2].empty(); }
  bool hasBiasWander() const { return !bias_wander[0].empty() || !bias_wander[1].empty() || !bias_wander[2].empty(); }
};

/// t_tag - t_true (s) at true time t_true_s (since the start): time_offset plus the clock drifts.
double tagMinusTrue(double time_offset_s, const std::vector<ClockDriftTerm>& clock, double t_true_s);
/// The true time (s since the start) that a sample tagged t_tag_s describes: the exact inverse of
/// tagMinusTrue (it is linear). Without clock drifts exactly t_tag_s - time_offset_s.
double trueTimeOfTag(double time_offset_s, const std::vector<ClockDriftTerm>& clock, double t_tag_s);

/// Collects the specs that apply to a head / to the accelerometer.
HeadEffects headEffectsFor(const std::vector<EffectSpec>& specs, int head_id);
AccEffects accEffectsFor(const std::vector<EffectSpec>& specs);

/// What the deterministic effects need to know at an epoch.
struct OrbitContext {
  double t_s = 0;          ///< seconds since the simulation start
  double arg_lat_rad = 0;  ///< argument of latitude u of the satellite
  double beta_rad = 0;     ///< Sun elevation above the orbit plane
  Vec3 v_sat_I = Vec3::Zero();    ///< satellite velocity relative to the Earth centre, inertial, m/s
  Vec3 v_earth_I = Vec3::Zero();  ///< Earth velocity about the solar-system barycentre, inertial, m/s
};

/// Sum of relative_misalignment, thermal_periodic, drift and step at an epoch: rotation vector in Si.
Vec3 headSystematicRotVec(const HeadEffects& e, const OrbitContext& ctx);

/// Uncorrected aberration as a head-frame rotation vector; b_I is the head's boresight in I and
/// C_Si_I the head attitude.
Vec3 aberrationRotVec(const HeadEffects& e, const Vec3& b_I, const Mat3& C_Si_I, const OrbitContext& ctx);

constexpr double kSpeedOfLight = 299792458.0;

/// The structure of a head's deterministic rotation: which terms it has (harmonic numbers, beta
/// modulation, drift starts, step times); their sizes are the parameter vector of
/// headRotationFromParams. Layout (3 components each, head axes):
///   [0,3)                       misalignment (relative_misalignment), rad
///   per harmonic: C then S      phi += m(beta) (C cos(n u) + S sin(n u)), rad; the catalogue's
///                               amp cos(n u + phase) is C = amp cos(phase), S = -amp sin(phase)
///   per drift                   rate, rad/s (after its start); a nonzero HeadEffects::drift_rad_s
///                               is one more drift term after the list
///   per step                    rotation, rad (from its time on)
struct HeadParamLayout {
  struct Harmonic {
    int n = 1;
    double beta_gain = 0, beta_ref_rad = 0;
  };
  std::vector<Harmonic> harmonics;
  std::vector<double> drift_starts_s;
  std::vector<double> step_times_s;
  std::size_t size() const { return 3 * (1 + 2 * harmonics.size() + drift_starts_s.size() + step_times_s.size()); }
};

HeadParamLayout headParamLayout(const HeadEffects& e);
/// The parameter values of e in the layout's order (size() numbers).
std::vector<double> headParams(const HeadEffects& e);

/// headSystematicRotVec from a parameter vector (double or a Ceres Jet): out = phi_eff in head axes.
template <typename T>
void headRotationFromParams(const HeadParamLayout& L, const T* p, const OrbitContext& ctx, T out[3]) {
  for (int k = 0; k < 3; ++k) out[k] = p[k];
  std::size_t i = 3;
  for (const auto& h : L.harmonics) {
    const double m = 1.0 + h.beta_gain * (std::cos(ctx.beta_rad) - std::cos(h.beta_ref_rad));
    const double c = m * std::cos(h.n * ctx.arg_lat_rad), s = m * std::sin(h.n * ctx.arg_lat_rad);
    for (std::size_t k = 0; k < 3; ++k) out[k] += p[i + k] * c + p[i + 3 + k] * s;
    i += 6;
  }
  for (double start : L.drift_starts_s) {
    if (ctx.t_s > start)
      for (std::size_t k = 0; k < 3; ++k) out[k] += p[i + k] * (ctx.t_s - start);
    i += 3;
  }
  for (double at : L.step_times_s) {
    if (ctx.t_s >= at)
      for (std::size_t k = 0; k < 3; ++k) out[k] += p[i + k];
    i += 3;
  }
}

}  // namespace boresight::model
