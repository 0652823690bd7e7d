// Angular rate and acceleration of an attitude stream (METHODS 1.5) and the CRN low-pass of the
// accelerometer's angular acceleration (METHODS 1.6), on the same time tags and in the same frame.
//
// AttitudeRates takes q_I_X (X: the body B for the fused attitude, or a head Si) at its own rate,
// makes the sign continuous, and runs the CRN on the four components (orders 0, 1, 2). At an output
// epoch (centre tap) with q, q', q'' the filtered components (|q| slightly below 1 after low-pass):
//   w_X     = 2 vec(q* q') / |q|^2
//   alpha_X = (2 vec(q* q'') - 2 (q . q') w_X) / |q|^2
// (exact for q = n u with u unit: vec(u* u') = w/2 and d/dt vec(u* u') = vec(u* u'') since u'* u' is real).
//
// AccAngularFilter takes a_A (rad/s^2, accelerometer frame) at its rate (GRACE-FO 10 Hz), runs the
// same CRN low-pass in A and rotates the result to X with the configured C_X_A (the filter is linear:
// the same as rotating every sample, at one rotation per output) (order 0; order 1 only for the
// first-order Taylor step to a requested tag). evaluateAt(t) puts it on the attitude stream's output tags.
#pragma once

#include "boresight/core/crn.h"

namespace boresight::core {

struct RateOutput {
  TimeUs t = 0;                   ///< centre tag
  Quat q_I_X = Quat::Identity();  ///< low-passed attitude (normalised)
  Vec3 w_X = Vec3::Zero();        ///< angular rate of X relative to I, in X, rad/s
  Vec3 alpha_X = Vec3::Zero();    ///< angular acceleration, in X, rad/s^2
  /// Bridged samples in the filter window (0: every sample real; the two sigmas below are then 0).
  int bridged = 0;
  /// Bound on the bridged samples' contribution per axis, first order in the kernel sums e_k = |sum_j
  /// |g_k[j]| sigma_j| over the four components (CrnStream::Output::sigma_bridge): w_sigma_bridge =
  /// 2 (e1 + e0 |q'|) / |q|^2 + 2 |w| e0 / |q| (rad/s), alpha_sigma_bridge likewise with q'' and the
  /// (q . q') w term (rad/s^2); NaN with linear bridging.
  double w_sigma_bridge = 0;
  double alpha_sigma_bridge = 0;
};

class AttitudeRates {
 public:
  /// cfg.max_order is forced to 2 (rate and acceleration need q, q' and q'').
  Status configure(const CrnConfig& cfg);
  void reset();
  /// One attitude sample; outputs (centre-stamped, on cfg.output_period_us) via output(i).
  Status step(TimeUs t, const Quat& q_I_X);
  int numOutputs() const { return n_out_; }
  const RateOutput& output(int i) const { return out_[static_cast<std::size_t>(i)]; }
  /// Rate and acceleration at any covered tag (second-order Taylor step from the nearest sample).
  Status evaluateAt(TimeUs t, RateOutput& out) const;
  const Health& health() const { return crn_.health(); }
  const CrnStream<4>& stream() const { return crn_; }
  /// White attitude noise of sigma rad per axis gives sigma * noiseGain(1) rad/s on the rate and sigma *
  /// noiseGain(2) rad/s^2 on the acceleration per axis: sqrt(sum_j g_k[j]^2).
  double noiseGain(int order) const;

 private:
  static RateOutput fromFiltered(const CrnStream<4>::Output& o);
  CrnStream<4> crn_{};
  bool configured_ = false;
  bool have_prev_ = false;
  Quat prev_ = Quat::Identity();
  std::array<RateOutput, kMaxCrnOutputsPerStep> out_{};
  int n_out_ = 0;
};

struct AccOutput {
  TimeUs t = 0;
  Vec3 a_X = Vec3::Zero();  ///< CRN low-passed angular acceleration in X, rad/s^2
  int bridged = 0;          ///< bridged accelerometer samples in the window (0: all real)
  /// bound on their contribution per axis, |sum_j |g0[j]| sigma_j| over the three axes, rad/s^2 (a
  /// rotation keeps the norm); 0 without bridged samples, NaN under linear bridging
  double sigma_bridge = 0;
};

class AccAngularFilter {
 public:
  /// C_X_A: accelerometer frame to the output frame X (e.g. accToBodyDefault() for GRACE SRF).
  Status configure(const CrnConfig& cfg, const Mat3& C_X_A);
  void reset();
  /// One accelerometer sample a_A (rad/s^2 in A). Grid outputs (if cfg.output_period_us > 0).
  Status step(TimeUs t, const Vec3& a_A) {  // inline: called at the accelerometer rate
    if (!configured_) return crn_.step(t, Vec3::Constant(std::nan("")));  // counted by the stream
    return crn_.step(t, a_A);  // filtered in A (linear): rotated to X once per output, not per sample
  }
  int numOutputs() const { return crn_.numOutputs(); }
  AccOutput output(int i) const;
  Status evaluateAt(TimeUs t, AccOutput& out) const;
  const Health& health() const { return crn_.health(); }
  /// The stream (values in the accelerometer frame A).
  const CrnStream<3>& stream() const { return crn_; }

 private:
  CrnStream<3> crn_{};
  Mat3 C_X_A_ = Mat3::Identity();
  bool configured_ = false;
};

}  // namespace boresight::core
