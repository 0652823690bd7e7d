#include <boresight/model/random.h>
#include <boresight/model/rotation.h>
#include <boresight/sim/attitude.h>

#include <algorithm>
#include <cmath>

namespace boresight::sim {
namespace {

Mat3 skew(const Vec3& v) {
  Mat3 m;
  m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return m;
}

/// Right Jacobian of Exp: body rate of Exp(phi(t)) is Jr(phi) phi'.
Mat3 rightJacobian(const Vec3& phi) {
  const double th = phi.norm();
  const Mat3 K = skew(phi);
  if (th < 1e-6) return Mat3::Identity() - 0.5 * K + K * K / 6.0;
  return Mat3::Identity() - (1 - std::cos(th)) / (th * th) * K + (th - std::sin(th)) / (th * th * th) * K * K;
}

/// Reference frame R: x along track (sign), z to nadir, y = z x x; then the pitch offset about y.
Quat referenceAttitude(const Vec3& r, const Vec3& v, int sign, double pitch) {
  const Vec3 z = -r.normalized();
  const Vec3 y = z.cross(sign * v).normalized();
  const Vec3 x = y.cross(z);
  Mat3 C_I_O;
  C_I_O.col(0) = x;
  C_I_O.col(1) = y;
  C_I_O.col(2) = z;
  return Quat(C_I_O) * Quat(Eigen::AngleAxisd(pitch, Vec3::UnitY()));
}

}  // namespace

AttitudeSim::AttitudeSim(const AttitudeConfig& cfg, const Orbit& orbit, double t0_gps_s, std::uint64_t seed)
    : cfg_(cfg), orbit_(orbit), t0_gps_(t0_gps_s), ring_(kHistory) {
  const model::CounterRng rng(seed, model::Stream::Magnetic, 0);
  Vec3 r, v;
  orbit_.posVel(t0_gps_s, r, v);
  const double n_orb = v.norm() / r.norm();  // rad/s
  for (int j = 0; j < 3; ++j)
    for (int k = 0; k < 3; ++k) {
      // Random frequencies between 0.5 and 6 cycles per revolution, random phases.
      mtq_freq_[j][k] = n_orb * (0.5 + 5.5 * rng.uniform(static_cast<std::uint64_t>(j * 3 + k), 0));
      mtq_phase_[j][k] = 2 * kPi * rng.uniform(static_cast<std::uint64_t>(j * 3 + k), 1);
    }
  for (int j = 0; j < 3; ++j) {
    dist_phase1_[j] = 2 * kPi * rng.uniform(100 + static_cast<std::uint64_t>(j), 0);
    dist_phase2_[j] = 2 * kPi * rng.uniform(100 + static_cast<std::uint64_t>(j), 1);
  }
  Step s{0.0, cfg_.initial_deviation_rad, cfg_.initial_rate_rad_s, Vec3::Zero(), Vec3::Zero()};
  finishStep(s, nullptr);
  ring_[0] = s;
  count_ = 1;
}

void AttitudeSim::finishStep(Step& s, int* fired) {
  Vec3 r, v;
  orbit_.posVel(t0_gps_ + s.t0, r, v);
  const Quat q_I_R = referenceAttitude(r, v, cfg_.along_track_sign, cfg_.pitch_offset_rad);
  s.w_R = q_I_R.conjugate() * (r.cross(v) / r.squaredNorm());
  s.alpha = controlAlpha(s, r, v, fired);
}

Vec3 AttitudeSim::controlAlpha(const Step& s, const Vec3& r, const Vec3& v, int* fired) const {
  const double t = s.t0;
  // Argument of latitude from the node line (no Sun needed here).
  const Vec3 h = r.cross(v).normalized();
  Vec3 node = Vec3::UnitZ().cross(h);
  if (node.norm() < 1e-12) node = Vec3::UnitX();
  node.normalize();
  const double u = std::atan2(h.dot(node.cross(r)), node.dot(r));
  Vec3 alpha;
  for (int j = 0; j < 3; ++j) {
    const double I = cfg_.inertia_kg_m2[j];
    double torque = -I * (cfg_.mtq_kp_s2 * s.d0[j] + cfg_.mtq_kd_s * s.dd0[j]);
    torque = std::clamp(torque, -cfg_.mtq_max_torque_Nm[j], cfg_.mtq_max_torque_Nm[j]);
    double bg = 0;
    for (int k = 0; k < 3; ++k) bg += std::sin(mtq_freq_[j][k] * t + mtq_phase_[j][k]);
    torque += cfg_.mtq_background_torque_Nm[j] * bg / std::sqrt(3.0);
    torque += cfg_.disturbance_torque_Nm[j] *
              (std::cos(u + dist_phase1_[j]) + 0.5 * std::cos(2 * u + dist_phase2_[j]));
    alpha[j] = torque / I;
    // Thrusters: leave the deadband moving outwards -> one pulse back towards the centre.
    if (std::abs(s.d0[j]) > cfg_.deadband_rad[j] && s.d0[j] * s.dd0[j] >= 0) {
      const double a_thr = cfg_.thruster_torque_Nm[j] / I;
      const double dw = -std::copysign(cfg_.target_rate_rad_s[j], s.d0[j]) - s.dd0[j];
      const double on = std::clamp(std::abs(dw) / a_thr, cfg_.min_on_s, std::min(cfg_.max_on_s, cfg_.step_s));
      alpha[j] += std::copysign(a_thr * on / cfg_.step_s, dw);
      if (fired) ++*fired;
    }
  }
  return alpha;
}

void AttitudeSim::advanceTo(double t) {
  while (ring_[static_cast<std::size_t>((count_ - 1) % static_cast<std::int64_t>(kHistory))].t0 + cfg_.step_s <= t) {
    const Step& p = ring_[static_cast<std::size_t>((count_ - 1) % static_cast<std::int64_t>(kHistory))];
    const double h = cfg_.step_s;
    Step s{static_cast<double>(count_) * h, p.d0 + p.dd0 * h + 0.5 * p.alpha * h * h, p.dd0 + p.alpha * h, Vec3::Zero(),
           Vec3::Zero()};
    int fired = 0;
    finishStep(s, &fired);
    pulses_ += static_cast<std::uint64_t>(fired);
    ring_[static_cast<std::size_t>(count_ % static_cast<std::int64_t>(kHistory))] = s;
    ++count_;
  }
}

double AttitudeSim::earliestValid() const {
  const std::int64_t first = std::max<std::int64_t>(0, count_ - static_cast<std::int64_t>(kHistory));
  return static_cast<double>(first) * cfg_.step_s;
}

const AttitudeSim::Step& AttitudeSim::stepAt(double t) const {
  std::int64_t k = static_cast<std::int64_t>(std::floor(t / cfg_.step_s));
  const std::int64_t first = std::max<std::int64_t>(0, count_ - static_cast<std::int64_t>(kHistory));
  k = std::clamp(k, first, count_ - 1);  // before the start: extrapolate step 0; callers stay in range
  return ring_[static_cast<std::size_t>(k % static_cast<std::int64_t>(kHistory))];
}

Vec3 AttitudeSim::stepAlpha(double t) const { return stepAt(t).alpha; }

void AttitudeSim::manoeuvre(double t, Vec3& d, Vec3& dd) const {
  d.setZero();
  dd.setZero();
  for (const auto& m : cfg_.manoeuvres) {
    const double periods = std::floor(m.duration_s / m.period_s);
    const double tau = t - m.start_s;
    if (tau <= 0 || tau >= periods * m.period_s) continue;
    const double w = 2 * kPi / m.period_s;
    // A sinusoid under a sin^2 envelope over the whole manoeuvre: angle and rate start and end at 0.
    const double D = periods * m.period_s, e = std::sin(kPi * tau / D);
    d += m.amplitude_rad * (std::sin(w * tau) * e * e);
    dd += m.amplitude_rad * (w * std::cos(w * tau) * e * e + std::sin(w * tau) * (kPi / D) * std::sin(2 * kPi * tau / D));
  }
}

void AttitudeSim::eval(double t, Quat& q_I_B, Vec3& w_B) const {
  const Step& s = stepAt(t);
  const double tau = t - s.t0;
  Vec3 d = s.d0 + s.dd0 * tau + 0.5 * s.alpha * tau * tau;
  Vec3 dd = s.dd0 + s.alpha * tau;
  Vec3 dm, ddm;
  manoeuvre(t, dm, ddm);
  d += dm;
  dd += ddm;
  Vec3 r, v;
  orbit_.posVel(t0_gps_ + t, r, v);
  const Quat q_I_R = referenceAttitude(r, v, cfg_.along_track_sign, cfg_.pitch_offset_rad);
  const Quat q_R_B = model::quatExp(d);
  q_I_B = (q_I_R * q_R_B).normalized();
  const Vec3 w_orbit_I = r.cross(v) / r.squaredNorm();
  w_B = q_I_B.conjugate() * w_orbit_I + rightJacobian(d) * dd;
}

Vec3 AttitudeSim::rate(double t) const {
  const Step& s = stepAt(t);
  const double tau = t - s.t0;
  Vec3 d = s.d0 + s.dd0 * tau + 0.5 * s.alpha * tau * tau;
  Vec3 dd = s.dd0 + s.alpha * tau;
  if (!cfg_.manoeuvres.empty()) {
    Vec3 dm, ddm;
    manoeuvre(t, dm, ddm);
    d += dm;
    dd += ddm;
  }
  // The orbit rate seen in R is constant for a circular orbit (up to the nodal drift, ~1e-8 rad/s);
  // it is taken from the start of the step.
  return model::quatExp(d).conjugate() * s.w_R + rightJacobian(d) * dd;
}

Vec3 AttitudeSim::meanAngularAcceleration(std::int64_t t_us, std::int64_t T_us) const {
  // Consecutive samples share an end point: reuse the rate computed at the previous call's end.
  const std::int64_t ta = t_us - T_us / 2, tb = ta + T_us;
  const Vec3 wa = ta == cache_t_ ? cache_w_ : rate(static_cast<double>(ta) * 1e-6);
  const Vec3 wb = rate(static_cast<double>(tb) * 1e-6);
  cache_t_ = tb;
  cache_w_ = wb;
  return (wb - wa) / (static_cast<double>(T_us) * 1e-6);
}

}  // namespace boresight::sim
