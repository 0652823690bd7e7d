#include <boresight/model/rotation.h>
#include <boresight/model/sensors.h>

#include <algorithm>
#include <cmath>

namespace boresight::model {

namespace {

/// L_n(x) = sqrt(2n + 1) P_n(x), n = 0..order (Bonnet's recursion).
void scaledLegendre(double x, int order, double* L) {
  double p0 = 1, p1 = x;
  L[0] = 1;
  if (order >= 1) L[1] = std::sqrt(3.0) * x;
  for (int n = 1; n < order; ++n) {
    const double p2 = ((2 * n + 1) * x * p1 - n * p0) / (n + 1);
    L[n + 1] = std::sqrt(2.0 * (n + 1) + 1.0) * p2;
    p0 = p1;
    p1 = p2;
  }
}

}  // namespace

std::vector<std::pair<int, int>> fovTerms(int order) {
  std::vector<std::pair<int, int>> t;
  for (int d = 1; d <= order; ++d)
    for (int i = d; i >= 0; --i) t.emplace_back(i, d - i);
  return t;
}

Eigen::Vector2d FovErrorField::displacement(double u, double v) const {
  double Lu[8], Lv[8];
  scaledLegendre(u, order, Lu);
  scaledLegendre(v, order, Lv);
  Eigen::Vector2d d = Eigen::Vector2d::Zero();
  std::size_t k = 0;
  for (int deg = 1; deg <= order; ++deg)
    for (int i = deg; i >= 0; --i, ++k) {
      const double b = Lu[i] * Lv[deg - i];
      d.x() += cx[k] * b;
      d.y() += cy[k] * b;
    }
  return d;
}

FovErrorField drawFovErrorField(const FovErrorSpec& spec, const CounterRng& rng) {
  FovErrorField f;
  f.order = std::clamp(spec.order, 1, 6);
  f.rms_rad = spec.rms_rad;
  const std::size_t n = fovTerms(f.order).size();
  f.cx.resize(n);
  f.cy.resize(n);
  double sx = 0, sy = 0;
  for (std::size_t k = 0; k < n; ++k) rng.normal2(k, 0, f.cx[k], f.cy[k]);
  // The degree-1 terms (u: k = 0, v: k = 1) hold a uniform rotation about the boresight, dx = -t v,
  // dy = t u: a mounting error, not a field-of-view error. Its part t = (cy[0] - cx[1]) / 2 is removed.
  const double t = 0.5 * (f.cy[0] - f.cx[1]);
  f.cy[0] -= t;
  f.cx[1] += t;
  for (std::size_t k = 0; k < n; ++k) {
    sx += f.cx[k] * f.cx[k];
    sy += f.cy[k] * f.cy[k];
  }
  const double scale = spec.rms_rad / std::sqrt(0.5 * (sx + sy));  // one factor: the rotation stays out
  for (std::size_t k = 0; k < n; ++k) {
    f.cx[k] *= scale;
    f.cy[k] *= scale;
  }
  return f;
}

HeadModel::HeadModel(const HeadConfig& cfg, const HeadEffects& eff) : cfg_(cfg), eff_(eff) {
  q_Si_B_true_ = (quatExp(cfg_.mounting_error_rad) * cfg_.q_Si_B).normalized();
  boresightBasis(cfg_.boresight_Si, e1_, e2_, b_);
  tan_half_fov_ = std::tan(cfg_.fov_half_angle_rad);
}

Quat HeadModel::qSiB(const OrbitContext& ctx) const {
  const Vec3 phi = headSystematicRotVec(eff_, ctx);
  if (phi.isZero()) return q_Si_B_true_;
  return (quatExp(phi) * q_Si_B_true_).normalized();
}

Quat HeadModel::qSiB(const OrbitContext& ctx, const Vec3& extra_rad) const {
  const Vec3 phi = headSystematicRotVec(eff_, ctx) + extra_rad;
  if (phi.isZero()) return q_Si_B_true_;
  return (quatExp(phi) * q_Si_B_true_).normalized();
}

Quat HeadModel::predict(const Quat& q_I_B, const OrbitContext& ctx, const Vec3& extra_rad) const {
  Quat q_I_Si = q_I_B * qSiB(ctx, extra_rad).conjugate();
  if (eff_.aberration_annual || eff_.aberration_orbital) {
    const Mat3 C_I_Si = q_I_Si.toRotationMatrix();
    const Vec3 phi = aberrationRotVec(eff_, C_I_Si * b_, C_I_Si.transpose(), ctx);
    q_I_Si = q_I_Si * quatExp(phi);
  }
  return q_I_Si.normalized();
}

Eigen::Vector2d HeadModel::focalPlane(const Vec3& s) const {
  const double z = s.dot(b_) * tan_half_fov_;
  return Eigen::Vector2d(s.dot(e1_) / z, s.dot(e2_) / z);
}

Eigen::Vector2d HeadModel::fovDisplacement(const Vec3& s) const {
  const Eigen::Vector2d uv = focalPlane(s);
  Eigen::Vector2d d = Eigen::Vector2d::Zero();
  for (const auto& f : fov_) d += f.displacement(uv.x(), uv.y());
  return d;
}

Vec3 HeadModel::fovDisplacedStar(const Vec3& s) const {
  if (fov_.empty()) return s;
  const double z = s.dot(b_);
  const Eigen::Vector2d d = fovDisplacement(s);
  // tangent-plane point (x, y, 1) moved by d, back to a unit vector
  const double x = s.dot(e1_) / z + d.x(), y = s.dot(e2_) / z + d.y();
  return (x * e1_ + y * e2_ + b_).normalized() * (z < 0 ? -1.0 : 1.0);
}

namespace {

/// Normal equations of the tangent-plane displacement d of a star at (x, y) when the head frame turns
/// by phi (head axes): dx = x y phi1 - (1 + x^2) phi2 + y phi3, dy = (1 + y^2) phi1 - x y phi2 - x phi3.
inline void addStar(double x, double y, const Eigen::Vector2d& d, Mat3& N, Vec3& r) {
  const Vec3 ax(x * y, -(1 + x * x), y), ay(1 + y * y, -x * y, -x);
  N.noalias() += ax * ax.transpose() + ay * ay.transpose();
  r += ax * d.x() + ay * d.y();
}

}  // namespace

Vec3 HeadModel::rotationFromDisplacements(const Vec3* s, const Eigen::Vector2d* d, std::size_t n) const {
  if (n < 2) return Vec3::Zero();
  Mat3 N = Mat3::Zero();
  Vec3 r = Vec3::Zero();
  for (std::size_t k = 0; k < n; ++k) {
    const double z = s[k].dot(b_);
    addStar(s[k].dot(e1_) / z, s[k].dot(e2_) / z, d[k], N, r);
  }
  return fromHeadAxes(N.ldlt().solve(r));
}

Vec3 HeadModel::fovAttitudeError(const Vec3* s, std::size_t n) const {
  if (fov_.empty() || n < 2) return Vec3::Zero();
  Mat3 N = Mat3::Zero();
  Vec3 r = Vec3::Zero();
  for (std::size_t k = 0; k < n; ++k) {
    const double z = s[k].dot(b_), x = s[k].dot(e1_) / z, y = s[k].dot(e2_) / z;
    Eigen::Vector2d d = Eigen::Vector2d::Zero();
    for (const auto& f : fov_) d += f.displacement(x / tan_half_fov_, y / tan_half_fov_);
    addStar(x, y, d, N, r);
  }
  return fromHeadAxes(N.ldlt().solve(r));
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
