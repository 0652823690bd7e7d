#include "boresight/core/head_fusion.h"

#include "boresight/core/rotation.h"

namespace boresight::core {

Status HeadFusion::configure(const HeadSetConfig& cfg) {
  configured_ = false;
  const Status s = validate(cfg);
  if (s != Status::kOk) return s;
  cfg_ = cfg;
  for (int k = 0; k < cfg.n_heads; ++k) {
    const auto u = static_cast<std::size_t>(k);
    const HeadConfig& h = cfg.head[u];
    q_Si_B_[u] = h.q_Si_B.normalized();
    const Mat3 C_B_Si = q_Si_B_[u].toRotationMatrix().transpose();
    const Mat3 Sigma_B = C_B_Si * headCovariance(h.sigma_cross_rad, h.sigma_roll_rad, h.boresight_Si) * C_B_Si.transpose();
    if (!invertSpd3(Sigma_B, W_B_[u])) return Status::kInvalidConfig;
  }
  configured_ = true;
  reset();
  return Status::kOk;
}

Status HeadFusion::setRelativeAlignment(const HeadAlignment& a) {
  if (!configured_) return Status::kNotConfigured;
  const std::uint32_t all = (1u << cfg_.n_heads) - 1u;
  if (a.mask != 0 && a.mask != all) return Status::kInvalidConfig;
  for (int k = 0; k < cfg_.n_heads; ++k)
    if (!allFinite(a.c_B[static_cast<std::size_t>(k)])) return Status::kInvalidConfig;
  align_ = a;
  for (int k = 0; k < cfg_.n_heads; ++k) {
    const auto u = static_cast<std::size_t>(k);
    q_fuse_[u] = a.mask ? Quat(q_Si_B_[u] * quatExp(-a.c_B[u])) : q_Si_B_[u];
  }
  return Status::kOk;
}

void HeadFusion::reset() {
  align_ = HeadAlignment{};
  q_fuse_ = q_Si_B_;
  have_last_ = false;
  last_t_ = 0;
  out_ = FusedAttitude{};
  health_.clear();
}

Status HeadFusion::step(const ValidHeads& in) {
  if (const Status g = admitStep(configured_, have_last_, last_t_, in.t, health_); g != Status::kOk) return g;
  auto q_I_B = filled<Quat, kMaxHeads>(Quat::Identity());
  auto W = filled<Mat3, kMaxHeads>(Mat3::Zero());
  int ref = -1;
  int used = 0;
  Mat3 W_sum = Mat3::Zero();
  for (int k = 0; k < cfg_.n_heads; ++k) {
    if (!in.has(k)) continue;
    const auto u = static_cast<std::size_t>(k);
    q_I_B[u] = in.q_I_Si[u] * q_fuse_[u];
    const double sc = in.sigma_scale[u];
    W[u] = (sc == 1.0) ? W_B_[u] : Mat3(W_B_[u] / (sc * sc));
    W_sum += W[u];
    if (ref < 0) ref = k;
    ++used;
  }
  if (used == 0) {
    health_.record(Status::kNoValidInput);
    return Status::kNoValidInput;
  }
  Mat3 P;
  if (!invertSpd3(W_sum, P)) {
    health_.record(Status::kNumericalFailure);
    return Status::kNumericalFailure;
  }
  // Weighted least squares on sum_i |Log(Exp(-x) q^-1 q_i)|^2_{W_i}, started at the first head:
  // step 1 with the first-order Jacobian (identity: H = sum W_i, already inverted in P), step 2 a
  // Gauss-Newton step with the exact SO(3) Jacobian; the result is the optimum to third order in the
  // head errors.
  Quat q = q_I_B[static_cast<std::size_t>(ref)];
  {
    Vec3 rhs = Vec3::Zero();
    const Quat q_inv = q.conjugate();
    for (int k = 0; k < cfg_.n_heads; ++k) {
      if (!in.has(k)) continue;
      const auto u = static_cast<std::size_t>(k);
      rhs += W[u] * quatLog(q_inv * q_I_B[u]);
    }
    q = (q * quatExp(P * rhs)).normalized();
  }
  {
    Mat3 H = Mat3::Zero();
    Vec3 g = Vec3::Zero();
    const Quat q_inv = q.conjugate();
    for (int k = 0; k < cfg_.n_heads; ++k) {
      if (!in.has(k)) continue;
      const auto u = static_cast<std::size_t>(k);
      const Vec3 r = quatLog(q_inv * q_I_B[u]);
      const Mat3 A = jacobianLeftInverse(r);
      const Mat3 AtW = A.transpose() * W[u];
      H.noalias() += AtW * A;
      g.noalias() += AtW * r;
    }
    Mat3 Hinv;
    if (!invertSpd3(H, Hinv)) {
      health_.record(Status::kNumericalFailure);
      return Status::kNumericalFailure;
    }
    q = (q * quatExp(Hinv * g)).normalized();
  }
  if (have_last_) q = continuous(q, out_.q_I_B);
  out_.t = in.t;
  out_.q_I_B = q;
  out_.P_B = P;
  out_.heads_used = used;
  out_.mask = in.mask;
  have_last_ = true;
  last_t_ = in.t;
  health_.record(Status::kOk);
  return Status::kOk;
}

}  // namespace boresight::core
