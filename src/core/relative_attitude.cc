#include "boresight/core/relative_attitude.h"

#include "boresight/core/rotation.h"

namespace boresight::core {

Status RelativeAttitudeMeans::configure(const HeadSetConfig& cfg) {
  configured_ = false;
  const Status s = validate(cfg);
  if (s != Status::kOk) return s;
  cfg_ = cfg;
  for (int a = 0; a < cfg.n_heads; ++a) {
    const HeadConfig& h = cfg.head[static_cast<std::size_t>(a)];
    Sigma_[static_cast<std::size_t>(a)] = headCovariance(h.sigma_cross_rad, h.sigma_roll_rad, h.boresight_Si);
  }
  for (int a = 0; a < cfg.n_heads; ++a)
    for (int b = a + 1; b < cfg.n_heads; ++b) {
      const auto p = static_cast<std::size_t>(pairIndex(a, b));
      C_Sj_Si0_[p] = groundRelative(cfg, b, a);
      const Mat3 S = Sigma_[static_cast<std::size_t>(b)] + C_Sj_Si0_[p] * Sigma_[static_cast<std::size_t>(a)] * C_Sj_Si0_[p].transpose();
      if (!invertSpd3(S, W1_[p])) return Status::kInvalidConfig;
    }
  configured_ = true;
  reset();
  return Status::kOk;
}

void RelativeAttitudeMeans::reset() {
  acc_.fill(Acc{});
  have_last_ = false;
  last_t_ = 0;
  health_.clear();
}

Status RelativeAttitudeMeans::step(const ValidHeads& in) {
  if (const Status g = admitStep(configured_, have_last_, last_t_, in.t, health_); g != Status::kOk) return g;
  have_last_ = true;
  last_t_ = in.t;
  for (int a = 0; a < cfg_.n_heads; ++a) {
    if (!in.has(a)) continue;
    const auto ua = static_cast<std::size_t>(a);
    const Quat q_Sa_I = in.q_I_Si[ua].conjugate();
    for (int b = a + 1; b < cfg_.n_heads; ++b) {
      if (!in.has(b)) continue;
      const auto ub = static_cast<std::size_t>(b);
      const auto p = static_cast<std::size_t>(pairIndex(a, b));
      const Quat B = q_Sa_I * in.q_I_Si[ub];
      const double sa = in.sigma_scale[ua], sb = in.sigma_scale[ub];
      Mat3 W = W1_[p];
      if (sa != 1.0 || sb != 1.0) {
        const Mat3& C = C_Sj_Si0_[p];
        const Mat3 S = sb * sb * Sigma_[ub] + sa * sa * C * Sigma_[ua] * C.transpose();
        if (!invertSpd3(S, W)) {
          health_.record(Status::kNumericalFailure);
          continue;
        }
      }
      Acc& A = acc_[p];
      if (A.n == 0) A.q_ref = B;
      const Vec3 eta = quatLog(A.q_ref.conjugate() * B);
      ++A.n;
      A.W_sum += W;
      A.W_eta += W * eta;
      A.eta_sum += eta;
      A.eta_eta += eta * eta.transpose();
      if ((A.n & 63u) != 1u) continue;  // re-anchoring check every 64 epochs
      Mat3 P;
      if (!invertSpd3(A.W_sum, P)) continue;
      const Vec3 m = P * A.W_eta;
      if (m.norm() > kReanchorRad) {  // move the anchor to the mean (first order in m)
        const double n = static_cast<double>(A.n);
        A.q_ref = (A.q_ref * quatExp(m)).normalized();
        A.W_eta -= A.W_sum * m;
        A.eta_eta += -m * A.eta_sum.transpose() - A.eta_sum * m.transpose() + n * m * m.transpose();
        A.eta_sum -= n * m;
      }
    }
  }
  health_.record(Status::kOk);
  return Status::kOk;
}

PairMean RelativeAttitudeMeans::mean(int a, int b) const {
  PairMean r;
  if (!configured_ || a < 0 || b <= a || b >= cfg_.n_heads) return r;
  const Acc& A = acc_[static_cast<std::size_t>(pairIndex(a, b))];
  if (A.n == 0) return r;
  Mat3 P;
  if (!invertSpd3(A.W_sum, P)) return r;
  const Vec3 m = P * A.W_eta;
  const double n = static_cast<double>(A.n);
  const Vec3 eta_mean = A.eta_sum / n;
  r.valid = true;
  r.n = A.n;
  r.q_Si_Sj = (A.q_ref * quatExp(m)).normalized();
  r.cov_mean_Sj = P;
  r.spread_Sj = A.eta_eta / n - eta_mean * eta_mean.transpose();
  return r;
}

ClosureCheck RelativeAttitudeMeans::closure(int i, int j, int k) const {
  ClosureCheck c;
  c.i = i;
  c.j = j;
  c.k = k;
  const PairMean ij = mean(i, j), jk = mean(j, k), ik = mean(i, k);
  if (!ij.valid || !jk.valid || !ik.valid) return c;
  // E = B_ik^T B_ij B_jk, a rotation of Sk. With B = B_true Exp(e): first order
  // e_E = e_jk + C_Sk_Sj e_ij - e_ik, all in Sk.
  const Quat E = ik.q_Si_Sj.conjugate() * ij.q_Si_Sj * jk.q_Si_Sj;
  const Vec3 e_Sk = quatLog(E);
  const Mat3 C_Sk_Sj = jk.q_Si_Sj.toRotationMatrix().transpose();
  const Mat3 cov = jk.cov_mean_Sj + C_Sk_Sj * ij.cov_mean_Sj * C_Sk_Sj.transpose() + ik.cov_mean_Sj;
  Mat3 W;
  if (!invertSpd3(cov, W)) return c;
  const Mat3 C_Si_Sk = ik.q_Si_Sj.toRotationMatrix();
  c.valid = true;
  c.error_Si = C_Si_Sk * e_Sk;
  c.angle_rad = e_Sk.norm();
  c.chi2 = e_Sk.dot(W * e_Sk);
  return c;
}

}  // namespace boresight::core
