// truth.yaml: writer and reader (keys in sim/truth.h).
#include <boresight/io/time_format.h>
#include <boresight/io/yaml_file.h>
#include <boresight/model/stochastic.h>
#include <boresight/sim/simulator.h>
#include <boresight/sim/truth.h>

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <fstream>
#include <sstream>
#include <utility>

namespace boresight::sim {
namespace {

// ------------------------------------------------------------------------------------------ writer

void emitVec(YAML::Emitter& y, const Vec3& v, double scale = 1.0) {
  y << YAML::Flow << YAML::BeginSeq << v.x() * scale << v.y() * scale << v.z() * scale << YAML::EndSeq;
}
void emitQuat(YAML::Emitter& y, const Quat& q) {
  double a[4];
  quatToScalarFirst(q, a);
  y << YAML::Flow << YAML::BeginSeq << a[0] << a[1] << a[2] << a[3] << YAML::EndSeq;
}
void emitMat(YAML::Emitter& y, const Mat3& m) {
  y << YAML::BeginSeq;
  for (int i = 0; i < 3; ++i) y << YAML::Flow << YAML::BeginSeq << m(i, 0) << m(i, 1) << m(i, 2) << YAML::EndSeq;
  y << YAML::EndSeq;
}
template <typename V>
void kv(YAML::Emitter& y, const char* k, const V& v) {
  y << YAML::Key << k << YAML::Value << v;
}
void kvVec(YAML::Emitter& y, const char* k, const Vec3& v, double scale = 1.0) {
  y << YAML::Key << k << YAML::Value;
  emitVec(y, v, scale);
}

void emitTags(YAML::Emitter& y, std::int64_t offset_us, double jitter_us, double drift_ppm) {
  y << YAML::Key << "tags" << YAML::Value << YAML::BeginMap;
  kv(y, "offset_us", offset_us);
  kv(y, "jitter_us", jitter_us);
  kv(y, "drift_ppm", drift_ppm);
  y << YAML::EndMap;
}

void emitClock(YAML::Emitter& y, const std::vector<model::ClockDriftTerm>& c) {
  y << YAML::Key << "clock_drifts" << YAML::Value << YAML::BeginSeq;
  for (const auto& d : c) {
    y << YAML::Flow << YAML::BeginMap;
    kv(y, "offset_s", d.offset_s);
    kv(y, "rate_ppm", d.rate_ppm);
    kv(y, "start_s", d.start_s);
    y << YAML::EndMap;
  }
  y << YAML::EndSeq;
}

void emitRuns(YAML::Emitter& y, std::uint64_t count, const std::vector<model::Interval>& runs) {
  kv(y, "missing_runs", count);
  if (count <= kMaxRecordedMissingRuns) {
    y << YAML::Key << "missing_intervals_s" << YAML::Value << YAML::BeginSeq;
    for (const auto& r : runs) y << YAML::Flow << YAML::BeginSeq << r.start_s << r.end_s << YAML::EndSeq;
    y << YAML::EndSeq;
  }
}

/// A noise.h model as a list of terms, levels times `scale` under the key `sigma_key`.
void emitModel(YAML::Emitter& y, const char* k, const model::NoiseModel& m, double scale, const char* sigma_key) {
  y << YAML::Key << k << YAML::Value << YAML::BeginSeq;
  for (const auto& t : m.terms) {
    y << YAML::Flow << YAML::BeginMap;
    kv(y, "kind", std::string(model::noiseKindName(t.kind)));
    kv(y, sigma_key, t.sigma * scale);
    if (t.kind == model::NoiseKind::GaussMarkov) kv(y, "tau_s", t.tau_s);
    if (t.kind == model::NoiseKind::PowerLaw) {
      kv(y, "alpha", t.alpha);
      kv(y, "f_lo_hz", t.f_lo_hz);
      kv(y, "f_hi_hz", t.f_hi_hz);
    }
    y << YAML::EndMap;
  }
  y << YAML::EndSeq;
}

Vec3 rms(const Vec3& ss, std::uint64_t n) { return n ? Vec3((ss / static_cast<double>(n)).cwiseSqrt()) : Vec3::Zero(); }

void emitHeadNoise(YAML::Emitter& y, const char* k, const model::NoiseModel& cross, const model::NoiseModel& about,
                   const Vec3& ss, std::uint64_t n) {
  y << YAML::Key << k << YAML::Value << YAML::BeginMap;
  emitModel(y, "cross", cross, kArcsecPerRad, "sigma_arcsec");
  emitModel(y, "about", about, kArcsecPerRad, "sigma_arcsec");
  kvVec(y, "realised_rms_arcsec", rms(ss, n), kArcsecPerRad);
  y << YAML::EndMap;
}

void emitAccNoise(YAML::Emitter& y, const char* k, const std::array<model::NoiseModel, 3>& m, const Vec3& ss, std::uint64_t n) {
  y << YAML::Key << k << YAML::Value << YAML::BeginMap;
  emitModel(y, "x", m[0], 1.0, "sigma_rad_s2");
  emitModel(y, "y", m[1], 1.0, "sigma_rad_s2");
  emitModel(y, "z", m[2], 1.0, "sigma_rad_s2");
  kvVec(y, "realised_rms_rad_s2", rms(ss, n));
  y << YAML::EndMap;
}

void emitAttitude(YAML::Emitter& y, const AttitudeConfig& a) {
  kv(y, "step_s", a.step_s);
  kv(y, "along_track_sign", a.along_track_sign);
  kv(y, "pitch_offset_deg", a.pitch_offset_rad / kRadPerDeg);
  kvVec(y, "inertia_kg_m2", a.inertia_kg_m2);
  kvVec(y, "deadband_arcsec", a.deadband_rad, kArcsecPerRad);
  kvVec(y, "target_rate_rad_s", a.target_rate_rad_s);
  kvVec(y, "thruster_torque_Nm", a.thruster_torque_Nm);
  kv(y, "min_on_ms", a.min_on_s * 1e3);
  kv(y, "max_on_ms", a.max_on_s * 1e3);
  kv(y, "mtq_kp_s2", a.mtq_kp_s2);
  kv(y, "mtq_kd_s", a.mtq_kd_s);
  kvVec(y, "mtq_max_torque_Nm", a.mtq_max_torque_Nm);
  kvVec(y, "mtq_background_torque_Nm", a.mtq_background_torque_Nm);
  kvVec(y, "disturbance_torque_Nm", a.disturbance_torque_Nm);
  kvVec(y, "initial_deviation_arcsec", a.initial_deviation_rad, kArcsecPerRad);
  kvVec(y, "initial_rate_rad_s", a.initial_rate_rad_s);
  y << YAML::Key << "manoeuvres" << YAML::Value << YAML::BeginSeq;
  for (const auto& m : a.manoeuvres) {
    y << YAML::Flow << YAML::BeginMap;
    kvVec(y, "amplitude_deg", m.amplitude_rad, 1.0 / kRadPerDeg);
    kv(y, "period_s", m.period_s);
    kv(y, "start_s", m.start_s);
    kv(y, "duration_s", m.duration_s);
    y << YAML::EndMap;
  }
  y << YAML::EndSeq;
}

}  // namespace

bool writeTruthYaml(const std::string& path, const Simulator& sim, const std::vector<std::string>& effect_args,
                    const std::vector<std::string>& files, std::string* error) {
  const Scenario& sc = sim.scenario();
  const SimStats& st = sim.stats();
  YAML::Emitter y;
  y.SetDoublePrecision(17);
  y << YAML::Comment(
      "boresight simulate: the truth behind the simulated files (keys: include/boresight/sim/truth.h). Angles in "
      "arcseconds unless named; quaternions scalar first; q_Si_B maps body (SRF) to head; C_B_A maps "
      "accelerometer-frame vectors to the body (as in the configuration files); times in s since the start.");
  y << YAML::BeginMap;
  kv(y, "scenario", sc.file);
  kv(y, "seed", sim.seed());
  kv(y, "satellite", std::string(1, sc.satellite));
  kv(y, "start_gps_us", sc.start);
  kv(y, "start_date_gps", io::formatDate(sc.start));
  kv(y, "duration_s", sim.duration());
  y << YAML::Key << "effect_args" << YAML::Value << YAML::Flow << effect_args;
  y << YAML::Key << "effects" << YAML::Value << YAML::BeginSeq;
  for (const auto& e : sc.effects) {
    y << YAML::BeginMap;
    kv(y, "name", e.name);
    kv(y, "sensor", e.sensor);
    kv(y, "origin", e.origin);
    for (const auto& [k, v] : e.values) kv(y, k.c_str(), v);
    y << YAML::EndMap;
  }
  y << YAML::EndSeq;

  y << YAML::Key << "orbit" << YAML::Value << YAML::BeginMap;
  kv(y, "type", std::string(sc.orbit.type == OrbitConfig::Type::Gnv1b ? "gnv1b" : "circular"));
  kv(y, "altitude_km", sc.orbit.altitude_m * 1e-3);
  kv(y, "inclination_deg", sc.orbit.inclination_rad / kRadPerDeg);
  kv(y, "raan_deg", sc.orbit.raan_rad / kRadPerDeg);
  kv(y, "arg_latitude_deg", sc.orbit.arg_lat0_rad / kRadPerDeg);
  kv(y, "j2_nodal_precession", sc.orbit.j2_nodal_precession);
  kv(y, "gnv1b_file", sc.orbit.gnv1b_file);
  y << YAML::EndMap;
  kv(y, "mounting_error_sigma_arcsec", sc.mounting_error_sigma_rad * kArcsecPerRad);

  y << YAML::Key << "heads" << YAML::Value << YAML::BeginSeq;
  for (std::size_t i = 0; i < sim.heads().size(); ++i) {
    const auto& h = sim.heads()[i];
    const auto& c = h.config();
    const auto& e = h.effects();
    y << YAML::BeginMap;
    kv(y, "id", c.id);
    y << YAML::Key << "q_Si_B_nominal" << YAML::Value;
    emitQuat(y, c.q_Si_B);
    y << YAML::Key << "q_Si_B_true" << YAML::Value;
    emitQuat(y, h.qSiBTrue());
    y << YAML::Comment("constant mounting; time-varying effects below come on top");
    kvVec(y, "mounting_error_arcsec", c.mounting_error_rad, kArcsecPerRad);
    kvVec(y, "relative_misalignment_arcsec", e.misalignment_rad, kArcsecPerRad);
    kvVec(y, "boresight", c.boresight_Si);
    kv(y, "noise_cross_arcsec", h.sigmaCross() * kArcsecPerRad);
    kv(y, "noise_about_arcsec", h.sigmaAbout() * kArcsecPerRad);
    y << YAML::Key << "noise" << YAML::Value << YAML::BeginMap;
    kv(y, "configured_cross_arcsec", c.sigma_cross_rad * kArcsecPerRad);
    kv(y, "configured_about_arcsec", c.sigma_roll_rad * kArcsecPerRad);
    kv(y, "star_arcsec", c.sigma_star_rad * kArcsecPerRad);
    y << YAML::EndMap;
    kv(y, "time_offset_s", e.time_offset_s);
    emitClock(y, e.clock_drifts);
    kv(y, "rate_hz", c.rate_hz);
    emitTags(y, c.tag_offset_us, c.tag_jitter_us, c.tag_drift_ppm);
    y << YAML::Key << "geometry" << YAML::Value << YAML::BeginMap;
    kv(y, "fov_half_angle_deg", c.fov_half_angle_rad / kRadPerDeg);
    kv(y, "limiting_magnitude", c.limiting_mag);
    kv(y, "sun_exclusion_deg", c.sun_exclusion_rad / kRadPerDeg);
    kv(y, "earth_exclusion_deg", c.earth_exclusion_rad / kRadPerDeg);
    kv(y, "moon_exclusion_deg", c.moon_exclusion_rad / kRadPerDeg);
    kv(y, "designation", std::string(1, c.desig));
    y << YAML::EndMap;
    kv(y, "samples_written", st.head_samples[i]);
    kv(y, "blinded_sun", st.head_blinded_sun[i]);
    kv(y, "blinded_earth", st.head_blinded_earth[i]);
    kv(y, "blinded_moon", st.head_blinded_moon[i]);
    kv(y, "missing_gaps_dropouts", st.head_missing[i]);
    kv(y, "outliers", st.head_outliers[i]);
    kv(y, "sign_flips", st.head_sign_flips[i]);
    y << YAML::Key << "events" << YAML::Value << YAML::BeginMap;
    kv(y, "outlier_probability", model::OutlierSampler(e.outliers, 0, 0).probability());
    kv(y, "sign_flip_probability", model::SignFlipSampler(e.sign_flip_probs, 0, 0).probability());
    kv(y, "expected_random_missing_fraction", model::expectedMissingFraction(e.random_gaps));
    emitRuns(y, st.head_missing_run_count[i], st.head_missing_runs[i]);
    y << YAML::EndMap;
    if (e.hasColoured())
      emitHeadNoise(y, "coloured_noise", e.coloured_cross, e.coloured_about, st.head_coloured_ss[i], st.head_samples[i]);
    if (e.hasWander())
      emitHeadNoise(y, "thermal_wander", e.wander_cross, e.wander_about, st.head_wander_ss[i], st.head_samples[i]);
    if (h.hasFovError()) {
      y << YAML::Key << "fov_error" << YAML::Value << YAML::BeginMap;
      y << YAML::Key << "fields" << YAML::Value << YAML::BeginSeq;
      for (const auto& f : h.fovFields()) {
        y << YAML::BeginMap;
        kv(y, "order", f.order);
        kv(y, "rms_arcsec", f.rms_rad * kArcsecPerRad);
        y << YAML::Key << "cx_arcsec" << YAML::Value << YAML::Flow << YAML::BeginSeq;
        for (double v : f.cx) y << v * kArcsecPerRad;
        y << YAML::EndSeq;
        y << YAML::Key << "cy_arcsec" << YAML::Value << YAML::Flow << YAML::BeginSeq;
        for (double v : f.cy) y << v * kArcsecPerRad;
        y << YAML::EndSeq;
        y << YAML::EndMap;
      }
      y << YAML::EndSeq;
      kvVec(y, "realised_rms_arcsec", rms(st.head_fov_ss[i], st.head_samples[i]), kArcsecPerRad);
      kvVec(y, "realised_mean_arcsec", st.head_samples[i] ? Vec3(st.head_fov_sum[i] / static_cast<double>(st.head_samples[i])) : Vec3::Zero(),
            kArcsecPerRad);
      y << YAML::EndMap;
    }
    y << YAML::EndMap;
  }
  y << YAML::EndSeq;

  const auto& a = sim.accel();
  const auto& ac = a.config();
  y << YAML::Key << "accelerometer" << YAML::Value << YAML::BeginMap;
  y << YAML::Key << "C_B_A_nominal" << YAML::Value;
  emitMat(y, ac.C_A_B.transpose());
  y << YAML::Key << "C_B_A_true" << YAML::Value;
  emitMat(y, a.C_A_B_true().transpose());
  kvVec(y, "misalignment_arcsec", a.effects().misalignment_rad, kArcsecPerRad);
  kvVec(y, "bias_rad_s2", ac.bias_rad_s2 + a.effects().bias_rad_s2);
  kvVec(y, "nominal_bias_rad_s2", ac.bias_rad_s2);
  kvVec(y, "injected_bias_rad_s2", a.effects().bias_rad_s2);
  kvVec(y, "scale_error", a.effects().scale);
  kvVec(y, "white_noise_rad_s2", ac.white_rad_s2);
  kvVec(y, "lowfreq_noise_rad_s2", ac.lowfreq_rad_s2);
  kv(y, "lowfreq_tau_s", ac.lowfreq_tau_s);
  kvVec(y, "lin_bias_m_s2", ac.lin_bias_m_s2);
  kvVec(y, "lin_white_noise_m_s2", ac.lin_white_m_s2);
  kv(y, "rate_hz", ac.rate_hz);
  emitTags(y, ac.tag_offset_us, ac.tag_jitter_us, ac.tag_drift_ppm);
  kv(y, "time_offset_s", a.effects().time_offset_s);
  emitClock(y, a.effects().clock_drifts);
  kv(y, "samples_written", st.acc_samples);
  kv(y, "missing_gaps", st.acc_missing);
  y << YAML::Key << "events" << YAML::Value << YAML::BeginMap;
  kv(y, "expected_random_missing_fraction", model::expectedMissingFraction(a.effects().random_gaps));
  emitRuns(y, st.acc_missing_run_count, st.acc_missing_runs);
  y << YAML::EndMap;
  if (a.effects().hasColoured()) emitAccNoise(y, "coloured_noise", a.effects().coloured, st.acc_coloured_ss, st.acc_samples);
  if (a.effects().hasBiasWander())
    emitAccNoise(y, "bias_wander", a.effects().bias_wander, st.acc_bias_wander_ss, st.acc_samples);
  y << YAML::EndMap;

  y << YAML::Key << "attitude" << YAML::Value << YAML::BeginMap;
  emitAttitude(y, sc.attitude);
  kv(y, "thruster_pulses", st.thruster_pulses);
  kv(y, "max_abs_angular_acceleration_rad_s2", st.max_abs_alpha);
  y << YAML::EndMap;
  y << YAML::Key << "files" << YAML::Value << files;
  y << YAML::EndMap;
  return io::writeFileAtomic(path, std::string(y.c_str()) + "\n", error);
}

// ------------------------------------------------------------------------------------------ reader

namespace {

/// Thrown inside the reader only; readTruthYaml turns it into its error string.
struct TruthError {
  std::string message;
};

/// Typed access to the keys of one map with "PATH:LINE: key 'a.b[1].c': reason" errors.
class Node {
 public:
  Node(const YAML::Node& n, std::string key, const std::string* path) : n_(n), key_(std::move(key)), path_(path) {}
  [[noreturn]] void fail(const std::string& reason) const {
    const int line = n_.IsDefined() ? n_.Mark().line + 1 : 0;
    throw TruthError{*path_ + ":" + std::to_string(line < 0 ? 0 : line) + ": key '" + key_ + "': " + reason};
  }
  Node operator[](const char* k) const {
    if (!n_.IsMap()) fail("expected a map");
    const YAML::Node c = n_[k];
    if (!c.IsDefined() || c.IsNull()) {
      Node missing(n_, key_.empty() ? k : key_ + "." + k, path_);
      missing.fail("missing");
    }
    return Node(c, key_.empty() ? k : key_ + "." + k, path_);
  }
  Node at(std::size_t i) const { return Node(n_[i], key_ + "[" + std::to_string(i) + "]", path_); }
  std::size_t seqSize() const {
    if (!n_.IsSequence()) fail("expected a list");
    return n_.size();
  }
  bool has(const char* k) const { return n_.IsMap() && n_[k].IsDefined() && !n_[k].IsNull(); }
  const YAML::Node& raw() const { return n_; }
  std::string str() const {
    if (!n_.IsScalar()) fail("expected a scalar");
    return n_.Scalar();
  }
  double num() const {
    const std::string s = str();
    std::istringstream is(s);
    is.imbue(std::locale::classic());
    double v;
    is >> v;
    if (is.fail() || !is.eof() || !std::isfinite(v)) fail("'" + s + "' is not a finite number");
    return v;
  }
  std::uint64_t u64() const {
    const std::string s = str();
    if (s.empty() || s.find_first_not_of("0123456789") != std::string::npos || s.size() > 19)
      fail("'" + s + "' is not an unsigned integer below 10^19");
    return std::stoull(s);
  }
  std::int64_t i64() const {
    const std::string s = str();
    std::size_t pos = 0;
    long long v = 0;
    try {
      v = std::stoll(s, &pos);
    } catch (const std::exception&) {
      fail("'" + s + "' is not an integer");
    }
    if (pos != s.size()) fail("'" + s + "' is not an integer");
    return v;
  }
  bool boolean() const {
    try {
      return n_.as<bool>();
    } catch (const YAML::Exception&) {
      fail("expected true or false");
    }
  }
  void nums(double* out, std::size_t n) const {
    if (!n_.IsSequence() || n_.size() != n) fail("expected a list of " + std::to_string(n) + " numbers");
    for (std::size_t i = 0; i < n; ++i) out[i] = at(i).num();
  }
  Vec3 vec(double scale = 1.0) const {
    double v[3];
    nums(v, 3);
    return Vec3(v[0], v[1], v[2]) * scale;
  }
  Quat quat() const {
    double q[4];
    nums(q, 4);
    const double norm = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    if (std::abs(norm - 1) > 1e-6) fail("not a unit quaternion");
    return quatFromScalarFirst(q[0], q[1], q[2], q[3]);
  }
  Mat3 mat() const {
    if (!n_.IsSequence() || n_.size() != 3) fail("expected 3 rows of 3 numbers");
    Mat3 m;
    for (std::size_t i = 0; i < 3; ++i) {
      double r[3];
      at(i).nums(r, 3);
      for (std::size_t j = 0; j < 3; ++j) m(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j)) = r[j];
    }
    return m;
  }
  std::vector<std::string> strings() const {
    std::vector<std::string> v;
    for (std::size_t i = 0; i < seqSize(); ++i) v.push_back(at(i).str());
    return v;
  }

 private:
  YAML::Node n_;
  std::string key_;
  const std::string* path_;
};

std::vector<model::ClockDriftTerm> readClock(const Node& n) {
  std::vector<model::ClockDriftTerm> v;
  for (std::size_t i = 0; i < n.seqSize(); ++i) {
    const Node d = n.at(i);
    v.push_back({d["offset_s"].num(), d["rate_ppm"].num(), d["start_s"].num()});
  }
  return v;
}

void readRuns(const Node& ev, std::uint64_t& count, std::vector<model::Interval>& runs) {
  count = ev["missing_runs"].u64();
  runs.clear();
  if (count > kMaxRecordedMissingRuns) return;
  const Node r = ev["missing_intervals_s"];
  for (std::size_t i = 0; i < r.seqSize(); ++i) {
    double se[2];
    r.at(i).nums(se, 2);
    runs.push_back({se[0], se[1]});
  }
  if (runs.size() != count) r.fail("lists " + std::to_string(runs.size()) + " intervals, missing_runs says " + std::to_string(count));
}

void readTags(const Node& t, std::int64_t& offset_us, double& jitter_us, double& drift_ppm) {
  offset_us = t["offset_us"].i64();
  jitter_us = t["jitter_us"].num();
  drift_ppm = t["drift_ppm"].num();
}

void readAttitude(const Node& n, AttitudeConfig& a) {
  a.step_s = n["step_s"].num();
  a.along_track_sign = static_cast<int>(n["along_track_sign"].i64());
  a.pitch_offset_rad = n["pitch_offset_deg"].num() * kRadPerDeg;
  a.inertia_kg_m2 = n["inertia_kg_m2"].vec();
  a.deadband_rad = n["deadband_arcsec"].vec(kRadPerArcsec);
  a.target_rate_rad_s = n["target_rate_rad_s"].vec();
  a.thruster_torque_Nm = n["thruster_torque_Nm"].vec();
  a.min_on_s = n["min_on_ms"].num() * 1e-3;
  a.max_on_s = n["max_on_ms"].num() * 1e-3;
  a.mtq_kp_s2 = n["mtq_kp_s2"].num();
  a.mtq_kd_s = n["mtq_kd_s"].num();
  a.mtq_max_torque_Nm = n["mtq_max_torque_Nm"].vec();
  a.mtq_background_torque_Nm = n["mtq_background_torque_Nm"].vec();
  a.disturbance_torque_Nm = n["disturbance_torque_Nm"].vec();
  a.initial_deviation_rad = n["initial_deviation_arcsec"].vec(kRadPerArcsec);
  a.initial_rate_rad_s = n["initial_rate_rad_s"].vec();
  a.manoeuvres.clear();
  const Node m = n["manoeuvres"];
  for (std::size_t i = 0; i < m.seqSize(); ++i) {
    Manoeuvre x;
    x.amplitude_rad = m.at(i)["amplitude_deg"].vec(kRadPerDeg);
    x.period_s = m.at(i)["period_s"].num();
    x.start_s = m.at(i)["start_s"].num();
    x.duration_s = m.at(i)["duration_s"].num();
    a.manoeuvres.push_back(x);
  }
}

model::NoiseModel readModel(const Node& n, double scale, const char* sigma_key) {
  model::NoiseModel m;
  for (std::size_t i = 0; i < n.seqSize(); ++i) {
    const Node t = n.at(i);
    const std::string kind = t["kind"].str();
    const double sigma = t[sigma_key].num() * scale;
    if (kind == "gauss_markov") m.add(model::NoiseTerm::gaussMarkov(sigma, t["tau_s"].num()));
    else if (kind == "power_law")
      m.add(model::NoiseTerm::powerLaw(sigma, t["alpha"].num(), t["f_lo_hz"].num(), t["f_hi_hz"].num()));
    else if (kind == "white") m.add(model::NoiseTerm::white(sigma));
    else t["kind"].fail("expected gauss_markov, power_law or white");
  }
  const std::string why = m.validate();
  if (!why.empty()) n.fail(why);
  return m;
}

std::vector<double> readList(const Node& n, double scale) {
  std::vector<double> v(n.seqSize());
  for (std::size_t i = 0; i < v.size(); ++i) v[i] = n.at(i).num() * scale;
  return v;
}

void readHead(const Node& n, TruthHead& h) {
  auto& c = h.config;
  const std::int64_t id = n["id"].i64();
  if (id < 1 || id > 9) n["id"].fail("a head id is 1..9");
  c.id = static_cast<int>(id);
  c.q_Si_B = n["q_Si_B_nominal"].quat();
  h.q_Si_B_true = n["q_Si_B_true"].quat();
  c.mounting_error_rad = n["mounting_error_arcsec"].vec(kRadPerArcsec);
  h.relative_misalignment_rad = n["relative_misalignment_arcsec"].vec(kRadPerArcsec);
  c.boresight_Si = n["boresight"].vec();
  h.sigma_cross_rad = n["noise_cross_arcsec"].num() * kRadPerArcsec;
  h.sigma_about_rad = n["noise_about_arcsec"].num() * kRadPerArcsec;
  const Node noise = n["noise"];
  c.sigma_cross_rad = noise["configured_cross_arcsec"].num() * kRadPerArcsec;
  c.sigma_roll_rad = noise["configured_about_arcsec"].num() * kRadPerArcsec;
  c.sigma_star_rad = noise["star_arcsec"].num() * kRadPerArcsec;
  h.time_offset_s = n["time_offset_s"].num();
  h.clock_drifts = readClock(n["clock_drifts"]);
  c.rate_hz = n["rate_hz"].num();
  readTags(n["tags"], c.tag_offset_us, c.tag_jitter_us, c.tag_drift_ppm);
  const Node g = n["geometry"];
  c.fov_half_angle_rad = g["fov_half_angle_deg"].num() * kRadPerDeg;
  c.limiting_mag = g["limiting_magnitude"].num();
  c.sun_exclusion_rad = g["sun_exclusion_deg"].num() * kRadPerDeg;
  c.earth_exclusion_rad = g["earth_exclusion_deg"].num() * kRadPerDeg;
  c.moon_exclusion_rad = g["moon_exclusion_deg"].num() * kRadPerDeg;
  const std::string d = g["designation"].str();
  c.desig = d.empty() ? 'P' : d[0];
  h.samples = n["samples_written"].u64();
  h.blinded_sun = n["blinded_sun"].u64();
  h.blinded_earth = n["blinded_earth"].u64();
  h.blinded_moon = n["blinded_moon"].u64();
  h.missing = n["missing_gaps_dropouts"].u64();
  h.outliers = n["outliers"].u64();
  h.sign_flips = n["sign_flips"].u64();
  const Node ev = n["events"];
  h.outlier_probability = ev["outlier_probability"].num();
  h.sign_flip_probability = ev["sign_flip_probability"].num();
  h.expected_random_missing_fraction = ev["expected_random_missing_fraction"].num();
  readRuns(ev, h.missing_runs, h.missing_intervals);
  if (n.has("coloured_noise")) {
    const Node cn = n["coloured_noise"];
    h.coloured_cross = readModel(cn["cross"], kRadPerArcsec, "sigma_arcsec");
    h.coloured_about = readModel(cn["about"], kRadPerArcsec, "sigma_arcsec");
    h.coloured_rms_rad = cn["realised_rms_arcsec"].vec(kRadPerArcsec);
  }
  if (n.has("thermal_wander")) {
    const Node tw = n["thermal_wander"];
    h.wander_cross = readModel(tw["cross"], kRadPerArcsec, "sigma_arcsec");
    h.wander_about = readModel(tw["about"], kRadPerArcsec, "sigma_arcsec");
    h.wander_rms_rad = tw["realised_rms_arcsec"].vec(kRadPerArcsec);
  }
  if (n.has("fov_error")) {
    const Node f = n["fov_error"];
    const Node fs = f["fields"];
    for (std::size_t i = 0; i < fs.seqSize(); ++i) {
      const Node x = fs.at(i);
      model::FovErrorField fld;
      const std::int64_t order = x["order"].i64();
      if (order < 1 || order > 6) x["order"].fail("must be 1..6");
      fld.order = static_cast<int>(order);
      fld.rms_rad = x["rms_arcsec"].num() * kRadPerArcsec;
      fld.cx = readList(x["cx_arcsec"], kRadPerArcsec);
      fld.cy = readList(x["cy_arcsec"], kRadPerArcsec);
      const std::size_t nt = model::fovTerms(fld.order).size();
      if (fld.cx.size() != nt) x["cx_arcsec"].fail("expected " + std::to_string(nt) + " coefficients for order " + std::to_string(order));
      if (fld.cy.size() != nt) x["cy_arcsec"].fail("expected " + std::to_string(nt) + " coefficients for order " + std::to_string(order));
      h.fov_fields.push_back(std::move(fld));
    }
    h.fov_rms_rad = f["realised_rms_arcsec"].vec(kRadPerArcsec);
    h.fov_mean_rad = f["realised_mean_arcsec"].vec(kRadPerArcsec);
  }
}

void readAccel(const Node& n, TruthAccel& a) {
  auto& c = a.config;
  c.C_A_B = n["C_B_A_nominal"].mat().transpose();
  a.C_B_A_true = n["C_B_A_true"].mat();
  a.misalignment_rad = n["misalignment_arcsec"].vec(kRadPerArcsec);
  c.bias_rad_s2 = n["nominal_bias_rad_s2"].vec();
  a.injected_bias_rad_s2 = n["injected_bias_rad_s2"].vec();
  a.scale = n["scale_error"].vec();
  c.white_rad_s2 = n["white_noise_rad_s2"].vec();
  c.lowfreq_rad_s2 = n["lowfreq_noise_rad_s2"].vec();
  c.lowfreq_tau_s = n["lowfreq_tau_s"].num();
  c.lin_bias_m_s2 = n["lin_bias_m_s2"].vec();
  c.lin_white_m_s2 = n["lin_white_noise_m_s2"].vec();
  c.rate_hz = n["rate_hz"].num();
  readTags(n["tags"], c.tag_offset_us, c.tag_jitter_us, c.tag_drift_ppm);
  a.time_offset_s = n["time_offset_s"].num();
  a.clock_drifts = readClock(n["clock_drifts"]);
  a.samples = n["samples_written"].u64();
  a.missing = n["missing_gaps"].u64();
  const Node ev = n["events"];
  a.expected_random_missing_fraction = ev["expected_random_missing_fraction"].num();
  readRuns(ev, a.missing_runs, a.missing_intervals);
  const auto axes = [](const Node& an, std::array<model::NoiseModel, 3>& m, Vec3& rms_v) {
    m[0] = readModel(an["x"], 1.0, "sigma_rad_s2");
    m[1] = readModel(an["y"], 1.0, "sigma_rad_s2");
    m[2] = readModel(an["z"], 1.0, "sigma_rad_s2");
    rms_v = an["realised_rms_rad_s2"].vec();
  };
  if (n.has("coloured_noise")) axes(n["coloured_noise"], a.coloured, a.coloured_rms_rad_s2);
  if (n.has("bias_wander")) axes(n["bias_wander"], a.bias_wander, a.bias_wander_rms_rad_s2);
}

void readEffects(const Node& n, std::vector<model::EffectSpec>& out) {
  out.clear();
  for (std::size_t i = 0; i < n.seqSize(); ++i) {
    const Node e = n.at(i);
    if (!e.raw().IsMap()) e.fail("expected a map with name, sensor, origin and the parameters");
    const std::string name = e["name"].str();
    const std::string origin = e["origin"].str();
    std::vector<std::pair<std::string, std::string>> kv;
    for (const auto& p : e.raw()) {
      const std::string k = p.first.Scalar();
      if (k == "name" || k == "origin") continue;
      kv.emplace_back(k, e[k.c_str()].str());
    }
    model::EffectSpec s;
    std::string err;
    if (!model::makeEffect(name, kv, origin, s, &err)) e.fail(err);
    out.push_back(std::move(s));
  }
}

}  // namespace

const TruthHead* TruthFile::head(int id) const {
  for (const auto& h : heads)
    if (h.config.id == id) return &h;
  return nullptr;
}

bool readTruthYaml(const std::string& path, TruthFile& out, std::string* error) {
  YAML::Node root;
  if (!io::loadYamlFile(path, root, error, "truth file")) return false;
  TruthFile t;
  try {
    const Node top(root, "", &path);
    if (!root.IsMap()) top.fail("truth.yaml must be a map");
    t.scenario = top["scenario"].str();
    t.seed = top["seed"].u64();
    const std::string sat = top["satellite"].str();
    if (sat.size() != 1) top["satellite"].fail("expected one letter");
    t.satellite = sat[0];
    t.start = top["start_gps_us"].i64();
    t.duration_s = top["duration_s"].num();
    if (top.has("effect_args")) t.effect_args = top["effect_args"].strings();
    readEffects(top["effects"], t.effects);
    const Node o = top["orbit"];
    const std::string type = o["type"].str();
    if (type == "circular") t.orbit.type = OrbitConfig::Type::Circular;
    else if (type == "gnv1b") t.orbit.type = OrbitConfig::Type::Gnv1b;
    else o["type"].fail("expected 'circular' or 'gnv1b'");
    t.orbit.altitude_m = o["altitude_km"].num() * 1e3;
    t.orbit.inclination_rad = o["inclination_deg"].num() * kRadPerDeg;
    t.orbit.raan_rad = o["raan_deg"].num() * kRadPerDeg;
    t.orbit.arg_lat0_rad = o["arg_latitude_deg"].num() * kRadPerDeg;
    t.orbit.j2_nodal_precession = o["j2_nodal_precession"].boolean();
    t.orbit.gnv1b_file = o.has("gnv1b_file") ? o["gnv1b_file"].str() : std::string();
    t.mounting_error_sigma_rad = top["mounting_error_sigma_arcsec"].num() * kRadPerArcsec;
    const Node hs = top["heads"];
    for (std::size_t i = 0; i < hs.seqSize(); ++i) {
      TruthHead h;
      readHead(hs.at(i), h);
      t.heads.push_back(std::move(h));
    }
    readAccel(top["accelerometer"], t.acc);
    const Node att = top["attitude"];
    readAttitude(att, t.attitude);
    t.thruster_pulses = att["thruster_pulses"].u64();
    t.max_abs_alpha = att["max_abs_angular_acceleration_rad_s2"].num();
    if (top.has("files")) t.files = top["files"].strings();
  } catch (const TruthError& e) {
    if (error) *error = e.message;
    return false;
  }
  out = std::move(t);
  return true;
}

}  // namespace boresight::sim
