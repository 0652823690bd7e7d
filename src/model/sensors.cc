#include <boresight/model/rotation.h>
#include <boresight/model/sensors.h>

#include <algorithm>
#include <cmath>

namespace boresight::model {

HeadModel::HeadModel(const HeadConfig& cfg, const HeadEffects& eff) : cfg_(cfg), eff_(eff) {
  q_Si_B_true_ = (quatExp(cfg_.mounting_error_rad) * cfg_.q_Si_B).normalized();
  boresightBasis(cfg_.boresight_Si, e1_, e2_, b_);
}

Quat HeadModel::qSiB(const OrbitContext& ctx) const {
  const Vec3 phi = headSystematicRotVec(eff_, ctx);
  if (phi.isZero()) return q_Si_B_true_;
  return (quatExp(phi) * q_Si_B_true_).normalized();
}

Quat HeadModel::predict(const Quat& q_I_B, const OrbitContext& ctx) const {
  Quat q_I_Si = q_I_B * qSiB(ctx).conjugate();
  if (eff_.aberration_annual || eff_.aberration_orbital) {
    const Mat3 C_I_Si = q_I_Si.toRotationMatrix();
    const Vec3 phi = aberrationRotVec(eff_, C_I_Si * b_, C_I_Si.transpose(), ctx);
    q_I_Si = q_I_Si * quatExp(phi);
  }
  return q_I_Si.normalized();
}

Mat3 HeadModel::noiseCovariance() const {
  const double sc = sigmaCross(), sa = sigmaAbout();
  return sc * sc * (e1_ * e1_.transpose() + e2_ * e2_.transpose()) + sa * sa * (b_ * b_.transpose());
}

Vec3 HeadModel::noiseRotVec(const CounterRng& rng, std::uint64_t n) const {
  double n0, n1;
  rng.normal2(n, 0, n0, n1);
  return sigmaCross() * (n0 * e1_ + n1 * e2_) + sigmaAbout() * rng.normal(n, 2) * b_;
}

Vec3 HeadModel::noisyStar(const Vec3& s_true, const CounterRng& rng, std::uint64_t n, std::uint64_t k) const {
  if (sigmaStar() <= 0) return s_true;
  const Vec3 e1 = s_true.unitOrthogonal();
  const Vec3 e2 = s_true.cross(e1);
  double n0, n1;
  rng.normal2(n, k, n0, n1);
  return (s_true + sigmaStar() * (n0 * e1 + n1 * e2)).normalized();
}

std::uint8_t blindMask(const HeadConfig& hc, const Vec3& b_I, const Vec3& sun_I, const Vec3& moon_I, const Vec3& r_I) {
  std::uint8_t m = 0;
  const double rn = r_I.norm();
  const double earth_radius_angle = std::asin(std::min(1.0, kEarthEquatorialRadius_m / rn));
  if (b_I.dot(sun_I) > std::cos(hc.sun_exclusion_rad)) m |= kBlindBitSun;
  if (std::acos(std::clamp(b_I.dot(-r_I / rn), -1.0, 1.0)) < earth_radius_angle + hc.earth_exclusion_rad)
    m |= kBlindBitEarth;
  if (b_I.dot((moon_I - r_I).normalized()) > std::cos(hc.moon_exclusion_rad)) m |= kBlindBitMoon;
  return m;
}

AccelModel::AccelModel(const AccelConfig& cfg, const AccEffects& eff) : cfg_(cfg), eff_(eff) {
  C_A_B_true_ = quatExp(eff_.misalignment_rad).toRotationMatrix() * cfg_.C_A_B;
}

Vec3 AccelModel::predict(const Vec3& a_B) const {
  const Vec3 a = C_A_B_true_ * a_B;
  return (Vec3::Ones() + eff_.scale).cwiseProduct(a) + cfg_.bias_rad_s2 + eff_.bias_rad_s2;
}

}  // namespace boresight::model
