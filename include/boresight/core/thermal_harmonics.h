// Orbit-periodic thermal model of the relative head deformations (METHODS 2.5), evaluated in the core
// to predict the relative corrections while a head is blind.
//
// The batch fit (calib/thermal_fit.h) estimates, for every head k other than the datum head d (slot 0,
// head 1), the deformation of k relative to d as a function of the argument of latitude u, in S_d:
//   C_Sd_Sk(true) = Exp(delta_dk) C_Sd_Sk^0,
//   delta_dk(u, beta) = c_k + sum_n [ a_kn cos(m_n u) + b_kn sin(m_n u) ]
//                           + x(beta) sum_n [ a'_kn cos(m_n u) + b'_kn sin(m_n u) ]    (beta_terms only)
//   m_n = order[n] cycles per revolution, x(beta) = cos(beta) - cos_beta_ref.
// The deformation of any other pair a < b follows exactly (da = 0 and C0_dd = I for the datum): with
// C_Sa_Sb = (Exp(da) C0_da)^T Exp(db) C0_db and C0_ab = C0_da^T C0_db,
//   C_Sa_Sb C0_ab^T = C0_da^T Exp(-da) Exp(db) C0_da,   so   delta_ab (in Sa) = C0_da^T Log(Exp(-da) Exp(db)).
//
// ThermalPredictor: configure(heads, model) once (fixed-size arrays, no allocation), stepOrbit(t, u, du/dt,
// beta) at any rate (the argument of latitude is an input: the core has no ephemeris), predictPair() at
// a head epoch, with u extrapolated linearly from the last orbit input (at most max_orbit_age_s).
// Pipeline::setThermalModel() / stepOrbit() wire it to BoresightMonitor::setPredictedDeformation for every
// pair a head epoch does not see.
#pragma once

#include "boresight/core/heads.h"

namespace boresight::core {

/// What the pipeline hands to the monitor for a pair that is not seen.
/// Measured (test/calib/thermal_fit_test.cc, three 20-minute blindings of head 3, RMS error of the pair
/// correction): model still valid: hold 12.4", absolute 1.4", anchored 3.6"; the constant moved by 33"
/// since the fit: hold 12.4", absolute 32.6", anchored 3.6". Default: anchored (bounded by the filter's
/// noise whatever happened to the constant since the fit).
enum class ThermalPredictionMode : std::uint8_t {
  kAbsolute = 0,  ///< the model's deformation at u (the fit's constant included)
  kAnchored = 1,  ///< the filter's last value plus the model's change since that epoch (robust to a
                  ///< change of the constant since the fit; carries the filter's noise at the anchor);
                  ///< the absolute value while the filter has no value yet
};

/// One head's model relative to the datum head, rotation vectors in S_datum, rad.
struct ThermalHeadModel {
  bool valid = false;                    ///< a model for this slot (the datum slot has none: zero)
  Vec3 constant_rad = Vec3::Zero();      ///< c_k
  std::array<Vec3, kMaxThermalHarmonics> cos_rad = filled<Vec3, kMaxThermalHarmonics>(Vec3::Zero());  ///< a_kn
  std::array<Vec3, kMaxThermalHarmonics> sin_rad = filled<Vec3, kMaxThermalHarmonics>(Vec3::Zero());  ///< b_kn
  /// Beta modulation a'_kn, b'_kn per unit of x(beta) (used when ThermalHarmonicModel::beta_terms).
  std::array<Vec3, kMaxThermalHarmonics> beta_cos_rad = filled<Vec3, kMaxThermalHarmonics>(Vec3::Zero());
  std::array<Vec3, kMaxThermalHarmonics> beta_sin_rad = filled<Vec3, kMaxThermalHarmonics>(Vec3::Zero());
  /// Covariance of the predicted deformation (fit uncertainty averaged over u plus the variance the
  /// model leaves unexplained beyond the head noise), rad^2, in S_datum.
  Mat3 cov_rad2 = Mat3::Zero();
};

struct ThermalHarmonicModel {
  int datum_slot = 0;       ///< the datum head's slot (the fit uses head 1 = slot 0)
  int n_harmonics = 0;      ///< 0..kMaxThermalHarmonics
  std::array<int, kMaxThermalHarmonics> order{};  ///< cycles per revolution of each harmonic, >= 1
  bool beta_terms = false;  ///< the beta modulation was determined (span of weeks) and is applied
  double cos_beta_ref = 1.0;  ///< x(beta) = cos(beta) - cos_beta_ref
  std::array<ThermalHeadModel, kMaxHeads> head{};  ///< by slot
  ThermalPredictionMode mode = ThermalPredictionMode::kAnchored;
  /// Longest extrapolation of u from the last orbit input, s (beyond it: no prediction, kUnavailable).
  double max_orbit_age_s = 60.0;
};

/// Checks a model against a head set (datum in range, orders >= 1, finite coefficients, SPD-or-zero covariances).
Status validate(const ThermalHarmonicModel& m, const HeadSetConfig& heads);

class ThermalPredictor {
 public:
  /// Copies the model and forms the ground relatives to the datum. kInvalidConfig on a bad model.
  Status configure(const HeadSetConfig& heads, const ThermalHarmonicModel& model);
  /// Forgets the orbit input (the model stays).
  void reset();
  bool configured() const { return configured_; }
  const ThermalHarmonicModel& model() const { return m_; }
  /// Orbit input: argument of latitude u (rad), its rate (rad/s) and the beta angle (rad) at t.
  /// kNonFinite, kTimeBackwards / kDuplicateTime, kNotConfigured; kOk otherwise.
  Status stepOrbit(TimeUs t, double u_rad, double u_rate_rad_s, double beta_rad);
  /// u and cos(beta) at t from the last orbit input; false when none within max_orbit_age_s.
  bool orbitAt(TimeUs t, double& u_rad, double& cos_beta) const;
  /// Model deformation of slot k relative to the datum, in S_datum, rad (zero for the datum slot).
  Vec3 relativeToDatum(int slot, double u_rad, double cos_beta) const;
  /// Predicted deformation of the pair a < b in Sa (C_Sa_Sb = Exp(delta) C0_ab) and its covariance.
  /// kInvalidConfig for bad slots or a slot without a model.
  Status predictPair(int a, int b, double u_rad, double cos_beta, Vec3& delta_Sa, Mat3& cov_Sa) const;
  const Health& health() const { return health_; }

 private:
  HeadSetConfig heads_{};
  ThermalHarmonicModel m_{};
  bool configured_ = false;
  std::array<Mat3, kMaxHeads> C0_d_ = filled<Mat3, kMaxHeads>(Mat3::Identity());  ///< C_Sd_Sk^0 by slot k
  bool have_orbit_ = false;
  TimeUs t_orbit_ = 0;
  double u_ = 0, u_rate_ = 0, cos_beta_ = 1;
  Health health_{};
};

}  // namespace boresight::core
