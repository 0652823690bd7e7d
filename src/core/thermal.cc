#include "boresight/core/thermal.h"

#include "boresight/core/rotation.h"

#include <cmath>

namespace boresight::core {

namespace {
double angle(const Vec3& a, const Vec3& b) { return std::atan2(a.cross(b).norm(), a.dot(b)); }
}  // namespace

Status BoresightMonitor::configure(const HeadSetConfig& cfg) {
  configured_ = false;
  const Status s = validate(cfg);
  if (s != Status::kOk) return s;
  cfg_ = cfg;
  for (int a = 0; a < cfg.n_heads; ++a)
    for (int b = a + 1; b < cfg.n_heads; ++b) {
      const auto p = static_cast<std::size_t>(pairIndex(a, b));
      const HeadConfig& ha = cfg.head[static_cast<std::size_t>(a)];
      const HeadConfig& hb = cfg.head[static_cast<std::size_t>(b)];
      C0_[p] = core::groundRelative(cfg, a, b);
      const Vec3 v0 = C0_[p] * hb.boresight_Si;
      alpha0_[p] = angle(ha.boresight_Si, v0);
      const Vec3 nn = ha.boresight_Si.cross(v0);
      if (nn.norm() < 1e-9) return Status::kInvalidConfig;  // parallel boresights: no IBA plane
      n_[p] = nn.normalized();
      cov_[p] = headCovariance(ha.sigma_cross_rad, ha.sigma_roll_rad, ha.boresight_Si) +
                C0_[p] * headCovariance(hb.sigma_cross_rad, hb.sigma_roll_rad, hb.boresight_Si) * C0_[p].transpose();
      if (!invertSpd3(cov_[p], W1_[p])) return Status::kInvalidConfig;
      q0_[p] = Quat(C0_[p]).normalized();
    }
  configured_ = true;
  reset();
  return Status::kOk;
}

void BoresightMonitor::reset() {
  for (auto& T : T_last_) T.setIdentity();
  cur_.fill(PairDeformation{});
  acc_.fill(Acc{});
  have_last_ = false;
  last_t_ = 0;
  health_.clear();
}

Status BoresightMonitor::step(const ValidHeads& in) {
  if (const Status g = admitStep(configured_, have_last_, last_t_, in.t, health_); g != Status::kOk) return g;
  have_last_ = true;
  last_t_ = in.t;
  for (int a = 0; a < cfg_.n_heads; ++a)
    for (int b = a + 1; b < cfg_.n_heads; ++b) {
      const auto p = static_cast<std::size_t>(pairIndex(a, b));
      PairDeformation& r = cur_[p];
      r.valid = false;
      if (!in.has(a) || !in.has(b)) continue;
      const auto ua = static_cast<std::size_t>(a), ub = static_cast<std::size_t>(b);
      const Quat q_Sa_Sb = in.q_I_Si[ua].conjugate() * in.q_I_Si[ub];
      const Vec3& ba = cfg_.head[ua].boresight_Si;
      const Vec3 v = q_Sa_Sb * cfg_.head[ub].boresight_Si;
      r.iba_rad = angle(ba, v);
      r.iba_ground_rad = alpha0_[p];
      r.iba_dev_rad = r.iba_rad - alpha0_[p];
      r.T_Si = so3Exp(r.iba_dev_rad * n_[p]);
      r.delta_Si = quatLog(q_Sa_Sb * q0_[p].conjugate());
      const double sa = in.sigma_scale[ua], sb = in.sigma_scale[ub];
      r.n_iba_Si = n_[p];
      r.valid = true;
      T_last_[p] = r.T_Si;
      Mat3 W = W1_[p];
      if (sa == 1.0 && sb == 1.0) {
        r.cov_delta_Si = cov_[p];
      } else {
        const Mat3 Sa = headCovariance(cfg_.head[ua].sigma_cross_rad, cfg_.head[ua].sigma_roll_rad, ba);
        const Mat3 Sb = headCovariance(cfg_.head[ub].sigma_cross_rad, cfg_.head[ub].sigma_roll_rad, cfg_.head[ub].boresight_Si);
        r.cov_delta_Si = sa * sa * Sa + sb * sb * C0_[p] * Sb * C0_[p].transpose();
        if (!invertSpd3(r.cov_delta_Si, W)) {
          health_.record(Status::kNumericalFailure);
          continue;
        }
      }
      Acc& A = acc_[p];
      ++A.n;
      A.W_sum += W;
      A.W_delta += W * r.delta_Si;
      A.dev_sum += r.iba_dev_rad;
    }
  health_.record(Status::kOk);
  return Status::kOk;
}

DeformationMean BoresightMonitor::mean(int a, int b) const {
  DeformationMean m;
  if (!configured_ || a < 0 || b <= a || b >= cfg_.n_heads) return m;
  const Acc& A = acc_[static_cast<std::size_t>(pairIndex(a, b))];
  if (A.n == 0) return m;
  Mat3 P;
  if (!invertSpd3(A.W_sum, P)) return m;
  m.valid = true;
  m.n = A.n;
  m.cov_Si = P;
  m.delta_Si = P * A.W_delta;
  m.iba_dev_mean_rad = A.dev_sum / static_cast<double>(A.n);
  return m;
}

Mat3 BoresightMonitor::groundRelative(int a, int b) const {
  if (a == b) return Mat3::Identity();
  if (a < b) return C0_[static_cast<std::size_t>(pairIndex(a, b))];
  return C0_[static_cast<std::size_t>(pairIndex(b, a))].transpose();
}

Mat3 BoresightMonitor::correctedRelative(int a, int b) const {
  if (a == b) return Mat3::Identity();
  if (a < b) {
    const auto p = static_cast<std::size_t>(pairIndex(a, b));
    return T_last_[p] * C0_[p];
  }
  const auto p = static_cast<std::size_t>(pairIndex(b, a));
  return (T_last_[p] * C0_[p]).transpose();
}

}  // namespace boresight::core
