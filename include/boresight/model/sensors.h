// Forward models of the star-sensor heads and the accelerometer, with the effect catalogue applied.
//
// These are the models the simulator draws data from and the audit predicts data with: given the
// true body attitude q_I_B, body angular acceleration a_B and the orbit context, they return what a
// configured sensor is expected to deliver (no noise), and the noise it adds.
//
//   head i:  q_I_Si_meas = q_I_B (x) q_Si_B(t)^-1 (x) Exp(phi_aberration) (x) Exp(n)
//            q_Si_B(t)   = Exp(phi_eff(t)) (x) Exp(phi_mount) (x) q_Si_B (nominal)      (see effects.h)
//            n ~ N(0, sigma_cross^2 (e1 e1^T + e2 e2^T) + sigma_about^2 b b^T)  (head frame, per sample)
//            the simulator adds to n the coloured_noise process and the fov_error rotation (measurement
//            errors) and to phi_eff the thermal_wander process (a rotation of the mounting)
//   head axes: (e1, e2, b) of boresightBasis(boresight); "cross" = e1 and e2, "about" = b.
//   acc:     a_A = (I + diag(scale)) R(Exp(m)) C_A_B a_B + bias + white + low-frequency noise
#pragma once

#include <boresight/core/conventions.h>
#include <boresight/core/heads.h>
#include <boresight/model/effects.h>
#include <boresight/model/random.h>

#include <Eigen/Core>

#include <cstddef>
#include <utility>
#include <vector>

namespace boresight::model {

/// One fov_error field of a head: the displacement of a star on the detector as a smooth function of
/// its normalised focal-plane position (u, v) = (s.e1, s.e2) / (s.b tan(FOV half-angle)), in tangent-
/// plane radians along (e1, e2):
///   d_x(u, v) = sum_k cx[k] L_i(u) L_j(v),   d_y(u, v) = sum_k cy[k] L_i(u) L_j(v),
/// k over the terms (i, j) of fovTerms(order) (1 <= i + j <= order: degree 0, a uniform shift, is a
/// mounting error), L_n = sqrt(2n + 1) P_n (Legendre polynomials scaled to unit mean square on
/// [-1, 1]). The terms are orthonormal over the square [-1, 1]^2, so the mean square displacement over
/// the square is |cx|^2 along e1 and |cy|^2 along e2; drawFovErrorField sets the RMS per axis (the
/// root of their mean, (|cx|^2 + |cy|^2) / 2) to rms_rad exactly.
struct FovErrorField {
  int order = 3;
  double rms_rad = 0;
  std::vector<double> cx, cy;  ///< rad, one per fovTerms(order) entry
  Eigen::Vector2d displacement(double u, double v) const;
  bool operator==(const FovErrorField& o) const { return order == o.order && rms_rad == o.rms_rad && cx == o.cx && cy == o.cy; }
};

/// The (i, j) degrees of the field's terms: by total degree 1..order, then i from high to low.
std::vector<std::pair<int, int>> fovTerms(int order);

/// A field with the spec's order and RMS: coefficient k is (normal(k, 0), normal(k, 1)) of `rng`; the
/// uniform rotation about the boresight that the degree-1 terms can hold (dx = -t v, dy = t u: a
/// mounting error) is taken out; both axes are then scaled by one factor to an RMS per axis of
/// spec.rms_rad (random shape, exact size). The attitude error can still have a mean over a day (the field's average over the stars
/// seen): truth.yaml reports it (fov_error.realised_mean_arcsec); it acts as a relative misalignment.
FovErrorField drawFovErrorField(const FovErrorSpec& spec, const CounterRng& rng);

/// One head. The common fields are the core's HeadConfig, the one definition of a head (core/heads.h):
///   id, q_Si_B (the NOMINAL / ground mounting, as in QSA1B), boresight_Si, sigma_cross_rad /
///   sigma_roll_rad (for the simulator: the true per-sample attitude noise, cross-boresight per axis
///   and about the boresight), sigma_star_rad (true noise of one star direction, per axis).
/// A core configuration of the simulated heads is `HeadSetConfig::head[k] = model_head` (slicing to
/// the base is the intended conversion). The fields below are the simulator's own.
struct HeadConfig : core::HeadConfig {
  HeadConfig() { id = 1; }
  Vec3 mounting_error_rad = Vec3::Zero();  ///< truth: the in-orbit mounting differs by Exp(this)
  double rate_hz = 2.0;
  std::int64_t tag_offset_us = 0;          ///< fractional-second offset of the time tags
  double tag_jitter_us = 0;                ///< uniform +- jitter of the tags (shared by heads with equal rate/offset)
  double tag_drift_ppm = 0;                ///< linear drift of the tags relative to the truth (receiver clock)
  double fov_half_angle_rad = 10 * kRadPerDeg;
  double limiting_mag = 6.0;               ///< faintest Hp counted as a tracked star
  // the blinding cones (sun/earth/moon_exclusion_rad) are the core's: one definition for the simulator,
  // the platform file and the audit
  char desig = 'P';
  const core::HeadConfig& core() const { return *this; }
};

class HeadModel {
 public:
  HeadModel() = default;
  HeadModel(const HeadConfig& cfg, const HeadEffects& eff);

  const HeadConfig& config() const { return cfg_; }
  const HeadEffects& effects() const { return eff_; }

  /// True constant mounting q_Si_B (nominal with the mounting error, no time-varying effects).
  Quat qSiBTrue() const { return q_Si_B_true_; }
  /// Mounting at an epoch, with relative_misalignment, thermal_periodic, drift and step.
  Quat qSiB(const OrbitContext& ctx) const;
  /// The same with a further rotation (Si, rad) added to phi_eff: the thermal_wander process.
  Quat qSiB(const OrbitContext& ctx, const Vec3& extra_rad) const;
  /// Expected measurement (noise-free) for a true body attitude q_I_B at the TRUE time of ctx.
  Quat predict(const Quat& q_I_B, const OrbitContext& ctx) const;
  /// The same through qSiB(ctx, extra_rad).
  Quat predict(const Quat& q_I_B, const OrbitContext& ctx, const Vec3& extra_rad) const;
  /// A vector given in head axes (components along e1, e2, b) in Si coordinates.
  Vec3 fromHeadAxes(const Vec3& c) const { return c.x() * e1_ + c.y() * e2_ + c.z() * b_; }
  /// Si coordinates to head axes (e1, e2, b).
  Vec3 toHeadAxes(const Vec3& v) const { return Vec3(v.dot(e1_), v.dot(e2_), v.dot(b_)); }

  /// fov_error: the head's fields (the simulator draws them from the seed; empty: none).
  void setFovFields(std::vector<FovErrorField> f) { fov_ = std::move(f); }
  const std::vector<FovErrorField>& fovFields() const { return fov_; }
  bool hasFovError() const { return !fov_.empty(); }
  /// Normalised focal-plane position (u, v) of a head-frame direction (FovErrorField).
  Eigen::Vector2d focalPlane(const Vec3& s_Si) const;
  /// The displacement (e1, e2 tangent-plane rad) of a star at s_Si: the sum of the fields.
  Eigen::Vector2d fovDisplacement(const Vec3& s_Si) const;
  /// The star's direction as the head measures it: s_Si moved by fovDisplacement on the tangent plane.
  Vec3 fovDisplacedStar(const Vec3& s_Si) const;
  /// The attitude error (Si rotation vector) of a head whose stars at s_Si[0..n) are displaced by
  /// d[0..n) (tangent-plane rad along e1, e2): the least-squares phi of d_k = J(s_k) phi, J the tangent-
  /// plane displacement a rotation of the head frame by phi makes (the stars move by -phi x s); the
  /// delivered attitude is q_I_Si Exp(phi). Zero with fewer than two stars (no attitude).
  Vec3 rotationFromDisplacements(const Vec3* s_Si, const Eigen::Vector2d* d, std::size_t n) const;
  /// rotationFromDisplacements of the stars' fovDisplacement: the fov_error attitude error.
  Vec3 fovAttitudeError(const Vec3* s_Si, std::size_t n) const;
  /// Boresight direction in I for an attitude q_I_Si.
  Vec3 boresightInertial(const Quat& q_I_Si) const { return q_I_Si * b_; }

  /// cross_noise / anisotropic_noise replace the configured levels (quadrature sum of the specs).
  double sigmaCross() const { return eff_.cross_sigma_rad >= 0 ? eff_.cross_sigma_rad : cfg_.sigma_cross_rad; }
  double sigmaAbout() const { return eff_.about_sigma_rad >= 0 ? eff_.about_sigma_rad : cfg_.sigma_roll_rad; }
  double sigmaStar() const { return cfg_.sigma_star_rad; }
  /// A measured star direction: unit s_true (head frame) with noise of sigmaStar() per perpendicular
  /// axis, draw number `k` of sample `n` of this head (counter-based: independent of other draws).
  Vec3 noisyStar(const Vec3& s_true, const CounterRng& rng, std::uint64_t n, std::uint64_t k) const;
  /// Per-sample attitude noise covariance in Si (rad^2).
  Mat3 noiseCovariance() const;
  /// The noise rotation vector (Si) of sample number n of this head.
  Vec3 noiseRotVec(const CounterRng& rng, std::uint64_t n) const;

 private:
  HeadConfig cfg_;
  HeadEffects eff_;
  Quat q_Si_B_true_ = Quat::Identity();
  Vec3 e1_ = Vec3::UnitX(), e2_ = Vec3::UnitY(), b_ = Vec3::UnitZ();
  std::vector<FovErrorField> fov_;
  double tan_half_fov_ = 0;
};

/// Exclusion-cone bits (the simulator's BlindReason values).
enum BlindBit : std::uint8_t { kBlindBitSun = 1, kBlindBitEarth = 2, kBlindBitMoon = 4 };
constexpr double kEarthEquatorialRadius_m = 6378137.0;

/// Which exclusion cones of a head contain its boresight b_I (unit, inertial): the Sun (sun_I, unit
/// geocentric direction), the Earth's limb seen from r_I (satellite position, m; Earth a sphere of
/// the equatorial radius) and the Moon (moon_I, geocentric position, m). A blinded head delivers nothing.
std::uint8_t blindMask(const HeadConfig& hc, const Vec3& b_I, const Vec3& sun_I, const Vec3& moon_I, const Vec3& r_I);

struct AccelConfig {
  double rate_hz = 10.0;
  std::int64_t tag_offset_us = 0;
  double tag_jitter_us = 0;
  double tag_drift_ppm = 0;
  Mat3 C_A_B = accToBodyDefault().transpose();  ///< nominal body -> accelerometer frame
  Vec3 white_rad_s2 = Vec3::Zero();     ///< white noise, 1-sigma per sample, per A axis
  Vec3 lowfreq_rad_s2 = Vec3::Zero();   ///< first-order Gauss-Markov noise, stationary 1-sigma, per A axis
  double lowfreq_tau_s = 1000.0;        ///< its correlation time
  Vec3 bias_rad_s2 = Vec3::Zero();      ///< nominal (known) bias, part of the scenario
  Vec3 lin_bias_m_s2 = Vec3::Zero();    ///< linear acceleration (drag-like constant), frame A
  Vec3 lin_white_m_s2 = Vec3::Zero();   ///< linear acceleration white noise
};

class AccelModel {
 public:
  AccelModel() = default;
  AccelModel(const AccelConfig& cfg, const AccEffects& eff);
  const AccelConfig& config() const { return cfg_; }
  const AccEffects& effects() const { return eff_; }
  /// True body -> A rotation including acc_misalignment.
  Mat3 C_A_B_true() const { return C_A_B_true_; }
  /// Expected angular acceleration in A (noise-free), including bias, scale and misalignment.
  Vec3 predict(const Vec3& a_B) const;

 private:
  AccelConfig cfg_;
  AccEffects eff_;
  Mat3 C_A_B_true_ = Mat3::Identity();
};

}  // namespace boresight::model
