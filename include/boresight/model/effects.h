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
//     (so the data stamped t_tag describe the state at t_tag - offset).
//   acc_*: a_A = (I + diag(scale)) R(Exp(misalignment)) C_A_B a_B + bias + noise.
//   aberration (uncorrected): the apparent boresight moves towards the observer velocity v by
//     |b x v| / c: the head frame is rotated by b_I x v / c (annual: Earth about the Sun; orbital:
//     the satellite about the Earth).
#pragma once

#include <boresight/core/conventions.h>

#include <map>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace boresight::model {

enum class EffectKind : std::uint8_t {
  RelativeMisalignment, AnisotropicNoise, ThermalPeriodic, Drift, Step, TimeOffset,
  AccBias, AccScale, AccMisalignment, Aberration, Outliers, SignFlips, Gaps, HeadDropout,
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

struct RandomGaps {
  double per_s = 0;    ///< expected gap starts per second
  double mean_s = 0;   ///< mean gap duration (exponential)
};

/// Everything that acts on one head.
struct HeadEffects {
  Vec3 misalignment_rad = Vec3::Zero();
  double about_sigma_rad = -1;  ///< anisotropic_noise: noise about the boresight (<0: unchanged)
  std::vector<ThermalHarmonic> thermal;
  Vec3 drift_rad_s = Vec3::Zero();
  double drift_start_s = 0;
  std::vector<std::pair<double, Vec3>> steps;  ///< (time since start [s], rotation vector [rad])
  double time_offset_s = 0;
  bool aberration_annual = false, aberration_orbital = false;
  double outlier_prob = 0, outlier_rad = 0;
  double sign_flip_prob = 0;
  RandomGaps random_gaps;
  std::vector<Interval> gaps;      ///< explicit gaps
  std::vector<Interval> dropouts;  ///< head_dropout intervals
};

struct AccEffects {
  Vec3 bias_rad_s2 = Vec3::Zero();
  Vec3 scale = Vec3::Zero();          ///< scale error (a_meas = (1 + scale) a)
  Vec3 misalignment_rad = Vec3::Zero();
  double time_offset_s = 0;
  RandomGaps random_gaps;
  std::vector<Interval> gaps;
};

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

}  // namespace boresight::model
