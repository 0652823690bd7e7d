// Synthetic method A data with known truth for the calibration tests, the Monte Carlo bench and the
// benchmarks: a body attitude with known angular acceleration (constant orbital rate about -y_B plus
// sinusoidal calibration manoeuvres under a sin^2 envelope, as config/sim_gracefo_calibration.yaml),
// heads at head_rate_hz with anisotropic white attitude noise in their own frames, an accelerometer at
// acc_rate_hz with scale, non-orthogonality, bias, time offset and white noise - pushed in time order
// through a SpanBuilder (the full CRN chain), so that everything from attitudes onward is the real code.
//
// Truth convention (solver.h): C_Sh_B(true) = Exp([r_h]x) M_h with B the datum frame that the configured
// C_B_A puts A into; a_meas(tag t) = K C_A_B a_B(t - tau) + b + noise, K = I + diag(s) + N(n).
#pragma once

#include "boresight/calib/solver.h"
#include "boresight/calib/span_builder.h"
#include "boresight/core/rotation.h"

#include <cmath>
#include <random>
#include <vector>

namespace boresight::calib::synth {

struct Manoeuvre {
  Vec3 amplitude_rad = Vec3::Zero();  ///< per body axis
  double period_s = 100.0;
  double start_s = 0.0;               ///< since the start of the data
  double duration_s = 1000.0;
};

struct Blind {  ///< a head delivering nothing over [start_s, end_s)
  int slot = 0;
  double start_s = 0, end_s = 0;
};

struct Config {
  int n_heads = 3;
  std::array<Quat, kMaxHeads> q_S_B_nominal{};   ///< nominal mountings (M_h)
  ModelParameters truth{};
  std::vector<Manoeuvre> manoeuvres;
  std::vector<Blind> blind;
  double duration_s = 3600.0;
  double head_rate_hz = 2.0, acc_rate_hz = 10.0;
  double sigma_cross_arcsec = 6.0, sigma_roll_arcsec = 48.0;
  Vec3 acc_white = Vec3(1.5e-7, 3.0e-8, 5.0e-8);
  double orbit_period_s = 5650.0;
  /// Thruster-like transients in the accelerometer only (robust loss test): every this many s a
  /// 1 s pulse of this size on A x (0: none).
  double acc_transient_every_s = 0.0, acc_transient_radps2 = 0.0;
  std::uint64_t seed = 1;
  TimeUs t0 = 738849600LL * kUsPerSecond;  ///< 2023-06-01 00:00 GPS
  Mat3 C_B_A = accToBodyDefault();
  double decimation_s = 10.0;
  double crn_bandwidth_hz = 0.0, crn_length_s = 0.0;  ///< SpanOptions' calibration CRN (0: the pipeline's)
};

/// GRACE-FO-like head geometry (config/sim_gracefo.yaml).
inline std::array<Quat, kMaxHeads> gracefoMountings() {
  std::array<Quat, kMaxHeads> q{};
  q[0] = Quat(-0.1843610150, 0.6881349921, 0.6762283734, 0.1876071319).normalized();
  q[1] = Quat(0.2495963317, -0.0402839151, 0.8505722893, 0.4610918109).normalized();
  q[2] = Quat(-0.4611496071, 0.8536225615, -0.0423220733, -0.2384919381).normalized();
  q[3] = Quat(0.5, 0.5, 0.5, 0.5);
  return q;
}

/// Three manoeuvres about x, y, z (1 deg, 100 s period, 1000 s each), starting at `start_s`, `gap_s` apart.
inline std::vector<Manoeuvre> threeAxisManoeuvres(double start_s, double gap_s = 1200.0, double amp_deg = 1.0) {
  std::vector<Manoeuvre> m;
  for (int a = 0; a < 3; ++a) {
    Manoeuvre x;
    x.amplitude_rad = Vec3::Zero();
    x.amplitude_rad[a] = amp_deg * kRadPerDeg;
    x.start_s = start_s + a * gap_s;
    m.push_back(x);
  }
  return m;
}

/// The calibration tests' span: three heads of GRACE-FO geometry, 3900 s with three one-axis manoeuvres,
/// mounting errors of 100-600" and an accelerometer bias.
inline Config manoeuvreCase(std::uint64_t seed) {
  Config c;
  c.seed = seed;
  c.q_S_B_nominal = gracefoMountings();
  c.duration_s = 3900;
  c.manoeuvres = threeAxisManoeuvres(150.0, 1200.0);
  c.truth.r_S[0] = Vec3(300, -200, 500) * kRadPerArcsec;
  c.truth.r_S[1] = Vec3(-250, 400, -300) * kRadPerArcsec;
  c.truth.r_S[2] = Vec3(100, 350, 600) * kRadPerArcsec;
  c.truth.acc_bias = Vec3(1.31e-5, 1.19e-4, -7.81e-4);
  return c;
}

class Attitude {
 public:
  explicit Attitude(const Config& c) : c_(c) {}
  /// q_I_B at s seconds after the start.
  Quat q(double s) const {
    Vec3 d = Vec3::Zero();
    for (const Manoeuvre& m : c_.manoeuvres) {
      const double x = s - m.start_s;
      if (x <= 0 || x >= m.duration_s) continue;
      const double env = std::sin(kPi * x / m.duration_s);
      d += m.amplitude_rad * std::sin(2 * kPi * x / m.period_s) * env * env;
    }
    const double wo = 2 * kPi / c_.orbit_period_s;
    return core::quatExp(Vec3(0, -wo * s, 0)) * core::quatExp(d);
  }
  /// Angular acceleration of B in B (central differences of q; error ~1e-11 rad/s^2).
  Vec3 alpha(double s) const {
    const double h = 0.01;
    const Quat a = q(s - h), b = q(s), c = continuousTo(q(s + h), b);
    const Quat a2 = continuousTo(a, b);
    const Eigen::Vector4d qdd = (a2.coeffs() + c.coeffs() - 2.0 * b.coeffs()) / (h * h);
    const Quat qq(qdd[3], qdd[0], qdd[1], qdd[2]);
    return 2.0 * (b.conjugate() * qq).vec();
  }

 private:
  static Quat continuousTo(const Quat& x, const Quat& ref) { return core::continuous(x, ref); }
  const Config& c_;
};

inline core::PipelineConfig pipelineConfig(const Config& c) {
  core::PipelineConfig p;
  p.heads.n_heads = c.n_heads;
  for (int h = 0; h < c.n_heads; ++h) {
    auto& hc = p.heads.head[static_cast<std::size_t>(h)];
    hc.id = h + 1;
    hc.q_Si_B = c.q_S_B_nominal[static_cast<std::size_t>(h)];
    hc.sigma_cross_rad = c.sigma_cross_arcsec * kRadPerArcsec;
    hc.sigma_roll_rad = c.sigma_roll_arcsec * kRadPerArcsec;
  }
  p.crn_attitude.fs_hz = c.head_rate_hz;
  p.crn_acc.fs_hz = c.acc_rate_hz;
  p.C_B_A = c.C_B_A;
  return p;
}

inline Mat3 accK(const ModelParameters& t) {
  Mat3 K;
  K << 1 + t.acc_scale[0], t.acc_nonorth[2], t.acc_nonorth[1],  //
      t.acc_nonorth[2], 1 + t.acc_scale[1], t.acc_nonorth[0],   //
      t.acc_nonorth[1], t.acc_nonorth[0], 1 + t.acc_scale[2];
  return K;
}

/// Pushes the synthetic data in time order into `sink` (pushHeads(core::HeadEpoch), pushAcc(TimeUs, Vec3)).
template <class Sink>
void stream(const Config& c, Sink& sink) {
  Attitude att(c);
  std::mt19937_64 rng(c.seed);
  std::normal_distribution<double> N01(0.0, 1.0);
  std::array<Quat, kMaxHeads> q_S_B_true{};
  for (int h = 0; h < c.n_heads; ++h)
    q_S_B_true[static_cast<std::size_t>(h)] =
        core::quatExp(c.truth.r_S[static_cast<std::size_t>(h)]) * c.q_S_B_nominal[static_cast<std::size_t>(h)];
  const Mat3 K = accK(c.truth);
  const Mat3 C_A_B = c.C_B_A.transpose();
  const double sc = c.sigma_cross_arcsec * kRadPerArcsec, sr = c.sigma_roll_arcsec * kRadPerArcsec;
  const auto nh = static_cast<long long>(std::floor(c.duration_s * c.head_rate_hz));
  const auto na = static_cast<long long>(std::floor(c.duration_s * c.acc_rate_hz));
  long long ih = 0, ia = 0;
  while (ih < nh || ia < na) {
    const double th = static_cast<double>(ih) / c.head_rate_hz, ta = static_cast<double>(ia) / c.acc_rate_hz;
    if (ih < nh && (ia >= na || th <= ta)) {
      core::HeadEpoch e;
      e.t = c.t0 + static_cast<TimeUs>(std::llround(th * 1e6));
      const Quat qb = att.q(th);
      for (int h = 0; h < c.n_heads; ++h) {
        bool blinded = false;
        for (const Blind& b : c.blind) blinded = blinded || (b.slot == h && th >= b.start_s && th < b.end_s);
        const Vec3 n(sc * N01(rng), sc * N01(rng), sr * N01(rng));
        if (blinded) continue;
        core::HeadSample& s = e.sample[static_cast<std::size_t>(e.n++)];
        s.head_id = h + 1;
        s.q_I_Si = (qb * q_S_B_true[static_cast<std::size_t>(h)].conjugate() * core::quatExp(n)).normalized();
      }
      if (e.n > 0) sink.pushHeads(e);
      ++ih;
    } else {
      const double t_true = ta - c.truth.time_offset_s;
      Vec3 a = K * (C_A_B * att.alpha(t_true)) + c.truth.acc_bias;
      for (int i = 0; i < 3; ++i) a[i] += c.acc_white[i] * N01(rng);
      if (c.acc_transient_every_s > 0 && std::fmod(ta, c.acc_transient_every_s) < 1.0) a[0] += c.acc_transient_radps2;
      sink.pushAcc(c.t0 + static_cast<TimeUs>(std::llround(ta * 1e6)), a);
      ++ia;
    }
  }
}

/// Runs the synthetic data through `builder` (configured here, finished at the end). false with *error.
inline bool generate(const Config& c, SpanBuilder& builder, std::string* error, const SpanOptions* span_opt = nullptr) {
  SpanOptions so;
  if (span_opt) so = *span_opt;
  so.decimation_s = c.decimation_s;
  so.acc_white_noise_radps2 = c.acc_white;
  so.crn_bandwidth_hz = c.crn_bandwidth_hz;
  so.crn_length_s = c.crn_length_s;
  if (!builder.configure(pipelineConfig(c), so, error)) return false;
  stream(c, builder);
  builder.finish();
  return true;
}

}  // namespace boresight::calib::synth
