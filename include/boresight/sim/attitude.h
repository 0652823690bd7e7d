// GRACE-FO-like attitude: the body frame B follows a local orbital reference R (x along track,
// z to nadir, optional pitch offset) with a small deviation delta (rotation vector, B):
//     q_I_B(t) = q_I_O(t) (x) q_pitch (x) Exp(delta_ctrl(t) + delta_man(t))
// delta_ctrl obeys delta'' = alpha per axis (diagonal inertia, gyroscopic terms neglected: |w| ~ 1e-3
// rad/s), with alpha piecewise constant on a fixed step (0.1 s by default):
//   - cold-gas attitude thrusters: when |delta_j| leaves the deadband and still moves outwards, a pulse
//     of on-time clamp(|dw| / alpha_thr, min_on, max_on) reverses the rate to the target rate; its
//     impulse is spread over the step (a 10 Hz accelerometer sees the same step mean);
//   - magnetic torquers: a weak PD law, saturated, plus a background of random sinusoids;
//   - disturbances at 1 and 2 cycles per revolution (gravity gradient, drag residuals).
// delta_man are the optional calibration manoeuvres: sinusoidal oscillations added to the reference.
// The angular rate is exact for this attitude law (right Jacobian of Exp), and the accelerometer's
// angular acceleration is the mean over its sample interval, (w(t+T/2) - w(t-T/2)) / T.
#pragma once

#include <boresight/core/conventions.h>
#include <boresight/sim/orbit.h>

#include <climits>
#include <cstdint>
#include <vector>

namespace boresight::sim {

struct Manoeuvre {
  Vec3 amplitude_rad = Vec3::Zero();  ///< per body axis
  double period_s = 100;
  double start_s = 0;                 ///< since the simulation start
  double duration_s = 0;              ///< whole periods are flown (rounded down)
};

struct AttitudeConfig {
  double step_s = 0.1;
  int along_track_sign = +1;           ///< +1: x_B along the velocity; -1: against it
  double pitch_offset_rad = 0;         ///< rotation of B about y_R
  Vec3 inertia_kg_m2 = Vec3(120, 600, 650);
  Vec3 deadband_rad = Vec3::Constant(1e-3);
  Vec3 target_rate_rad_s = Vec3::Constant(3e-6);
  Vec3 thruster_torque_Nm = Vec3(0.0127, 0.0127, 0.0127);
  double min_on_s = 0.01, max_on_s = 0.1;
  double mtq_kp_s2 = 1e-4, mtq_kd_s = 0.02;  ///< PD gains on delta (1/s^2, 1/s)
  Vec3 mtq_max_torque_Nm = Vec3::Constant(1e-3);
  Vec3 mtq_background_torque_Nm = Vec3::Constant(5e-5);
  Vec3 disturbance_torque_Nm = Vec3::Constant(2e-5);
  Vec3 initial_deviation_rad = Vec3::Zero();
  Vec3 initial_rate_rad_s = Vec3::Zero();
  std::vector<Manoeuvre> manoeuvres;
};

class AttitudeSim {
 public:
  /// t0: GPS seconds of the simulation start; times below are seconds since t0.
  AttitudeSim(const AttitudeConfig& cfg, const Orbit& orbit, double t0_gps_s, std::uint64_t seed);

  /// Propagates the dynamics so that eval() is valid up to t (s since start).
  void advanceTo(double t);
  /// Body attitude q_I_B and rate w_B (rad/s, B) at t; valid for t in the last kHistory steps.
  void eval(double t, Quat& q_I_B, Vec3& w_B) const;
  /// Mean angular acceleration over [t - T/2, t + T/2] (rad/s^2, B); times in integer microseconds
  /// since the start, so that the rate at a shared end point is the same number whether it is
  /// computed or reused (bitwise reproducible with or without gaps).
  Vec3 meanAngularAcceleration(std::int64_t t_us, std::int64_t T_us) const;
  /// Body rate w_B at t (rad/s, B), as eval() gives it, without evaluating the orbit.
  Vec3 bodyRate(double t) const { return rate(t); }
  /// The commanded deviation alpha of the step containing t (rad/s^2, B; diagnostics and tests).
  Vec3 stepAlpha(double t) const;
  double earliestValid() const;
  std::uint64_t thrusterPulses() const { return pulses_; }

  static constexpr std::size_t kHistory = 512;  ///< steps kept (51.2 s at 0.1 s)

 private:
  struct Step {
    double t0;
    Vec3 d0, dd0, alpha;
    Vec3 w_R = Vec3::Zero();  ///< orbit angular velocity in the reference frame R at t0 (rad/s)
  };
  /// Body rate only (no orbit evaluation): w_B = R(Exp(d))^T w_R + Jr(d) d'.
  Vec3 rate(double t) const;
  const Step& stepAt(double t) const;
  Vec3 controlAlpha(const Step& s, const Vec3& r, const Vec3& v, int* fired) const;
  void finishStep(Step& s, int* fired);
  void manoeuvre(double t, Vec3& d, Vec3& dd) const;

  AttitudeConfig cfg_;
  const Orbit& orbit_;
  double t0_gps_;
  std::vector<Step> ring_;
  std::int64_t count_ = 0;  ///< steps computed (the ring keeps the last kHistory)
  Vec3 mtq_freq_[3], mtq_phase_[3];
  Vec3 dist_phase1_, dist_phase2_;
  std::uint64_t pulses_ = 0;
  mutable std::int64_t cache_t_ = INT64_MIN;  ///< meanAngularAcceleration: last end point (us) and its rate
  mutable Vec3 cache_w_ = Vec3::Zero();
};

}  // namespace boresight::sim
