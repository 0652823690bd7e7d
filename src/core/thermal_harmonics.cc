#include "boresight/core/thermal_harmonics.h"

#include <cmath>

namespace boresight::core {

namespace {
bool finiteMat(const Mat3& m) { return m.allFinite(); }
}  // namespace

Status validate(const ThermalHarmonicModel& m, const HeadSetConfig& heads) {
  if (validate(heads) != Status::kOk) return Status::kInvalidConfig;
  if (m.datum_slot < 0 || m.datum_slot >= heads.n_heads) return Status::kInvalidConfig;
  if (m.n_harmonics < 0 || m.n_harmonics > kMaxThermalHarmonics) return Status::kInvalidConfig;
  for (int n = 0; n < m.n_harmonics; ++n)
    if (m.order[static_cast<std::size_t>(n)] < 1) return Status::kInvalidConfig;
  if (!std::isfinite(m.cos_beta_ref) || !(m.max_orbit_age_s >= 0) || !std::isfinite(m.max_orbit_age_s))
    return Status::kInvalidConfig;
  if (m.mode != ThermalPredictionMode::kAbsolute && m.mode != ThermalPredictionMode::kAnchored)
    return Status::kInvalidConfig;
  for (int k = 0; k < heads.n_heads; ++k) {
    const ThermalHeadModel& h = m.head[static_cast<std::size_t>(k)];
    if (!h.valid) continue;
    if (k == m.datum_slot) return Status::kInvalidConfig;  // the datum is the reference: no model
    bool ok = allFinite(h.constant_rad) && finiteMat(h.cov_rad2);
    for (int n = 0; n < m.n_harmonics; ++n) {
      const auto i = static_cast<std::size_t>(n);
      ok = ok && allFinite(h.cos_rad[i]) && allFinite(h.sin_rad[i]) && allFinite(h.beta_cos_rad[i]) &&
           allFinite(h.beta_sin_rad[i]);
    }
    if (!ok) return Status::kInvalidConfig;
    // symmetric with no negative eigenvalue beyond rounding (a zero covariance is allowed)
    if ((h.cov_rad2 - h.cov_rad2.transpose()).cwiseAbs().maxCoeff() > 1e-9 * (1e-30 + h.cov_rad2.cwiseAbs().maxCoeff()))
      return Status::kInvalidConfig;
    if (h.cov_rad2.trace() < 0 || h.cov_rad2(0, 0) < 0 || h.cov_rad2(1, 1) < 0 || h.cov_rad2(2, 2) < 0)
      return Status::kInvalidConfig;
  }
  return Status::kOk;
}

Status ThermalPredictor::configure(const HeadSetConfig& heads, const ThermalHarmonicModel& model) {
  configured_ = false;
  if (validate(model, heads) != Status::kOk) return Status::kInvalidConfig;
  heads_ = heads;
  m_ = model;
  for (int k = 0; k < heads.n_heads; ++k) C0_d_[static_cast<std::size_t>(k)] = groundRelative(heads, model.datum_slot, k);
  configured_ = true;
  reset();
  return Status::kOk;
}

void ThermalPredictor::reset() {
  have_orbit_ = false;
  t_orbit_ = 0;
  u_ = u_rate_ = 0;
  cos_beta_ = 1;
  health_.clear();
}

Status ThermalPredictor::stepOrbit(TimeUs t, double u, double u_rate, double beta) {
  const Status s = admitStep(configured_, have_orbit_, t_orbit_, t, health_);
  if (s != Status::kOk) return s;
  if (!std::isfinite(u) || !std::isfinite(u_rate) || !std::isfinite(beta)) {
    health_.record(Status::kNonFinite);
    return Status::kNonFinite;
  }
  have_orbit_ = true;
  t_orbit_ = t;
  u_ = u;
  u_rate_ = u_rate;
  cos_beta_ = std::cos(beta);
  health_.record(Status::kOk);
  return Status::kOk;
}

bool ThermalPredictor::orbitAt(TimeUs t, double& u, double& cos_beta) const {
  if (!configured_ || !have_orbit_) return false;
  const double dt = toSeconds(t - t_orbit_);
  if (!(std::fabs(dt) <= m_.max_orbit_age_s)) return false;
  u = u_ + u_rate_ * dt;
  cos_beta = cos_beta_;
  return true;
}

Vec3 ThermalPredictor::relativeToDatum(int slot, double u, double cos_beta) const {
  if (!configured_ || slot < 0 || slot >= heads_.n_heads || slot == m_.datum_slot) return Vec3::Zero();
  const ThermalHeadModel& h = m_.head[static_cast<std::size_t>(slot)];
  if (!h.valid) return Vec3::Zero();
  Vec3 d = h.constant_rad;
  const double x = cos_beta - m_.cos_beta_ref;
  for (int n = 0; n < m_.n_harmonics; ++n) {
    const auto i = static_cast<std::size_t>(n);
    const double a = static_cast<double>(m_.order[i]) * u;
    const double c = std::cos(a), s = std::sin(a);
    d += c * h.cos_rad[i] + s * h.sin_rad[i];
    if (m_.beta_terms) d += x * (c * h.beta_cos_rad[i] + s * h.beta_sin_rad[i]);
  }
  return d;
}

Status ThermalPredictor::predictPair(int a, int b, double u, double cos_beta, Vec3& delta, Mat3& cov) const {
  delta.setZero();
  cov.setZero();
  if (!configured_ || a < 0 || b <= a || b >= heads_.n_heads) return Status::kInvalidConfig;
  const int d = m_.datum_slot;
  const ThermalHeadModel& ha = m_.head[static_cast<std::size_t>(a)];
  const ThermalHeadModel& hb = m_.head[static_cast<std::size_t>(b)];
  if ((a != d && !ha.valid) || (b != d && !hb.valid)) return Status::kInvalidConfig;
  if (!std::isfinite(u) || !std::isfinite(cos_beta)) return Status::kNonFinite;
  const Vec3 da = relativeToDatum(a, u, cos_beta), db = relativeToDatum(b, u, cos_beta);
  const Mat3& C0_da = C0_d_[static_cast<std::size_t>(a)];  // identity when a is the datum
  delta = C0_da.transpose() * quatLog(quatExp(-da) * quatExp(db));
  // the two heads' model errors taken as independent, first order
  Mat3 P = Mat3::Zero();
  if (a != d) P += ha.cov_rad2;
  if (b != d) P += hb.cov_rad2;
  cov = C0_da.transpose() * P * C0_da;
  return Status::kOk;
}

}  // namespace boresight::core
