#include "boresight/core/relative_attitude.h"

#include "boresight/core/clones.h"
#include "boresight/core/fixed_ldlt.h"
#include "boresight/core/rotation.h"

#include <cmath>

namespace boresight::core {

Status RelativeAttitudeMeans::configure(const HeadSetConfig& cfg) {
  configured_ = false;
  const Status s = validate(cfg);
  if (s != Status::kOk) return s;
  cfg_ = cfg;
  for (int a = 0; a < cfg.n_heads; ++a) {
    const HeadConfig& h = cfg.head[static_cast<std::size_t>(a)];
    Sigma_[static_cast<std::size_t>(a)] = headCovariance(h.sigma_cross_rad, h.sigma_roll_rad, h.boresight_Si);
    const Mat3 C_B_Si = h.q_Si_B.normalized().toRotationMatrix().transpose();
    Mat3 W_Si;
    if (!invertSpd3(Sigma_[static_cast<std::size_t>(a)], W_Si)) return Status::kInvalidConfig;
    W_B_[static_cast<std::size_t>(a)] = C_B_Si * W_Si * C_B_Si.transpose();
  }
  for (int a = 0; a < cfg.n_heads; ++a)
    for (int b = a + 1; b < cfg.n_heads; ++b) {
      const auto p = static_cast<std::size_t>(pairIndex(a, b));
      C_Sj_Si0_[p] = groundRelative(cfg, b, a);
      const Mat3 S = Sigma_[static_cast<std::size_t>(b)] + C_Sj_Si0_[p] * Sigma_[static_cast<std::size_t>(a)] * C_Sj_Si0_[p].transpose();
      if (!invertSpd3(S, W1_[p])) return Status::kInvalidConfig;
    }
  // the datum of the alignment: (sum W)^-1 and the term (sum W_k d_k)^T (sum W)^-1 (sum W_k d_k) of
  // its normal equations (constant: the configured information); unused slots get identity blocks
  Mat3 W_all = Mat3::Zero();
  for (int k = 0; k < cfg.n_heads; ++k) W_all += W_B_[static_cast<std::size_t>(k)];
  if (!invertSpd3(W_all, P_all_)) return Status::kInvalidConfig;
  H_datum_.setZero();
  for (int i = 0; i < cfg.n_heads; ++i)
    for (int j = 0; j < cfg.n_heads; ++j)
      H_datum_.block<3, 3>(3 * i, 3 * j) = W_B_[static_cast<std::size_t>(i)] * P_all_ * W_B_[static_cast<std::size_t>(j)];
  for (int k = cfg.n_heads; k < kMaxHeads; ++k) H_datum_.block<3, 3>(3 * k, 3 * k) = Mat3::Identity();
  configured_ = true;
  reset();
  return Status::kOk;
}

void RelativeAttitudeMeans::reset() {
  acc_.fill(Acc{});
  reanchors_ = 0;
  have_last_ = false;
  last_t_ = 0;
  health_.clear();
}

Status RelativeAttitudeMeans::step(const ValidHeads& in) {
  PairRelatives rel;
  if (configured_) formPairRelatives(in, cfg_.n_heads, rel);
  return step(in, rel);
}

BORESIGHT_CLONES Status RelativeAttitudeMeans::step(const ValidHeads& in, const PairRelatives& rel_in) {
  if (const Status g = admitStep(configured_, have_last_, last_t_, in.t, health_); g != Status::kOk) return g;
  const PairRelatives* relp = &rel_in;
  PairRelatives own;
  if (rel_in.t != in.t || rel_in.mask != in.mask) {  // not this epoch's: form them
    formPairRelatives(in, cfg_.n_heads, own);
    relp = &own;
  }
  have_last_ = true;
  last_t_ = in.t;
  const double tau = cfg_.relative_time_constant_s;
  for (int a = 0; a < cfg_.n_heads; ++a) {
    if (!in.has(a)) continue;
    const auto ua = static_cast<std::size_t>(a);
    for (int b = a + 1; b < cfg_.n_heads; ++b) {
      if (!in.has(b)) continue;
      const auto ub = static_cast<std::size_t>(b);
      const auto p = static_cast<std::size_t>(pairIndex(a, b));
      const Quat& B = relp->q_Sa_Sb[p];
      const double sa = in.sigma_scale[ua], sb = in.sigma_scale[ub];
      const bool nominal = sa == 1.0 && sb == 1.0;
      Mat3 W;
      if (!nominal) {
        const Mat3& C = C_Sj_Si0_[p];
        const Mat3 S = sb * sb * Sigma_[ub] + sa * sa * C * Sigma_[ua] * C.transpose();
        if (!invertSpd3(S, W)) {
          health_.record(Status::kNumericalFailure);
          continue;
        }
      }
      Acc& A = acc_[p];
      if (A.n == 0) A.q_ref = B;
      // exponential forgetting, applied in blocks: the sums are multiplied by exp(-(t - t_last)/tau)
      // once the elapsed time reaches kForgetBlockS (or tau/1000), so the epochs inside one block
      // share one weight (relative weight error below 1e-3 for the default tau; exact at block ends)
      if (A.n == 0) {
        A.t_last = in.t;
      } else if (tau > 0) {
        const double x = toSeconds(in.t - A.t_last) / tau;
        if (x >= 1e-3 || toSeconds(in.t - A.t_last) >= kForgetBlockS) {
          const double lambda = x < 1e-3 ? 1.0 - x * (1.0 - 0.5 * x * (1.0 - x / 3.0)) : std::exp(-x);
          A.n_w *= lambda;
          A.w_nom *= lambda;
          A.eta_nom *= lambda;
          A.W_sum *= lambda;
          A.W_eta *= lambda;
          A.eta_sum *= lambda;
          A.eta_eta *= lambda;
          A.t_last = in.t;
        }
      }
      const Vec3 eta = quatLogNearIdentity(A.q_ref.conjugate() * B);
      ++A.n;
      A.n_w += 1.0;
      if (nominal) {
        A.w_nom += 1.0;
        A.eta_nom += eta;
      } else {
        A.W_sum += W;
        A.W_eta.noalias() += W * eta;
      }
      A.eta_sum += eta;
      A.eta_eta.noalias() += eta * eta.transpose();
      if ((A.n & 63u) != 1u) continue;  // re-anchoring check every 64 epochs
      const Mat3 W_all = infoSum(A, p);
      Mat3 P;
      if (!invertSpd3(W_all, P)) continue;
      const Vec3 m = P * infoEtaSum(A, p);
      if (m.norm() > kReanchorRad) {  // move the anchor to the mean (first order in m)
        const double n = A.n_w;
        A.q_ref = (A.q_ref * quatExp(m)).normalized();
        A.eta_nom -= A.w_nom * m;  // W1 eta_nom + W_eta -= (w_nom W1 + W_sum) m
        A.W_eta -= A.W_sum * m;
        A.eta_eta += -m * A.eta_sum.transpose() - A.eta_sum * m.transpose() + n * m * m.transpose();
        A.eta_sum -= n * m;
        ++reanchors_;
      }
    }
  }
  health_.record(Status::kOk);
  return Status::kOk;
}

PairMean RelativeAttitudeMeans::mean(int a, int b) const {
  PairMean r;
  if (!configured_ || a < 0 || b <= a || b >= cfg_.n_heads) return r;
  const auto p = static_cast<std::size_t>(pairIndex(a, b));
  const Acc& A = acc_[p];
  if (A.n == 0) return r;
  Mat3 P;
  if (!invertSpd3(infoSum(A, p), P)) return r;
  const Vec3 m = P * infoEtaSum(A, p);
  const double n = A.n_w;
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

bool RelativeAttitudeMeans::datumProject(HeadAlignment& a) const {
  // subtract the information-weighted mean: c_k -= (sum W)^-1 sum W_k c_k (pair differences unchanged)
  Vec3 Wc = Vec3::Zero();
  for (int k = 0; k < cfg_.n_heads; ++k) {
    const auto u = static_cast<std::size_t>(k);
    Wc += W_B_[u] * a.c_B[u];
  }
  const Vec3 mean = P_all_ * Wc;
  for (int k = 0; k < cfg_.n_heads; ++k) a.c_B[static_cast<std::size_t>(k)] -= mean;
  a.mask = (1u << cfg_.n_heads) - 1u;
  return true;
}

bool RelativeAttitudeMeans::alignment(HeadAlignment& out) const {
  out = HeadAlignment{};
  if (!configured_ || cfg_.n_heads < 2) return false;
  constexpr int kN = 3 * kMaxHeads;
  // the datum term first (configure), then the pairs
  Eigen::Matrix<double, kN, kN> H = H_datum_;
  Eigen::Matrix<double, kN, 1> g = Eigen::Matrix<double, kN, 1>::Zero();
  std::array<int, kMaxHeads> root{};  // union-find over the usable pairs: every head must be linked
  for (int k = 0; k < kMaxHeads; ++k) root[static_cast<std::size_t>(k)] = k;
  auto find = [&root](int k) {
    while (root[static_cast<std::size_t>(k)] != k) k = root[static_cast<std::size_t>(k)];
    return k;
  };
  for (int a = 0; a < cfg_.n_heads; ++a)
    for (int b = a + 1; b < cfg_.n_heads; ++b) {
      const auto p = static_cast<std::size_t>(pairIndex(a, b));
      const Acc& A = acc_[p];
      if (A.n < static_cast<std::uint64_t>(cfg_.relative_min_epochs)) continue;
      const Mat3 W_all_ab = infoSum(A, p);
      Mat3 P;
      if (!invertSpd3(W_all_ab, P)) continue;
      const Quat q_ab = A.q_ref * quatExp(P * infoEtaSum(A, p));  // mean C_Sa_Sb
      const Quat& q_Sa_B = cfg_.head[static_cast<std::size_t>(a)].q_Si_B;
      const Quat& q_Sb_B = cfg_.head[static_cast<std::size_t>(b)].q_Si_B;
      const Vec3 r = quatLog(q_Sa_B.conjugate() * q_ab * q_Sb_B);  // d_b - d_a, in B
      const Mat3 C_B_Sb = q_Sb_B.toRotationMatrix().transpose();
      const Mat3 Wr = C_B_Sb * W_all_ab * C_B_Sb.transpose();     // information of r in B
      H.block<3, 3>(3 * a, 3 * a) += Wr;
      H.block<3, 3>(3 * b, 3 * b) += Wr;
      H.block<3, 3>(3 * a, 3 * b) -= Wr;
      H.block<3, 3>(3 * b, 3 * a) -= Wr;
      g.segment<3>(3 * b) += Wr * r;
      g.segment<3>(3 * a) -= Wr * r;
      root[static_cast<std::size_t>(find(a))] = find(b);
    }
  for (int k = 1; k < cfg_.n_heads; ++k)
    if (find(k) != find(0)) return false;
  // gauge: the pair terms see only differences; the datum term in H (H_datum_: (sum W_k d_k)^T M
  // (sum W_k d_k), M = (sum W)^-1) fixes the common part at zero without changing the differences.
  // H is then positive definite: a fixed-size LDL^T without pivoting (fixed_ldlt.h; Eigen's pivoted
  // LDLT gives the same to rounding, at 1.8 times the cost of the whole update)
  Eigen::Matrix<double, kN, kN> L;
  Eigen::Matrix<double, kN, 1> D;
  if (!ldltFactor<kN>(H, L, D)) return false;
  Eigen::Matrix<double, kN, 1> d = g;
  ldltSolveInPlace<kN>(L, D, d);
  if (!d.allFinite()) return false;
  for (int k = 0; k < cfg_.n_heads; ++k) out.c_B[static_cast<std::size_t>(k)] = d.segment<3>(3 * k);
  return datumProject(out);  // exact datum (removes the solver's rounding)
}

bool RelativeAttitudeMeans::alignmentFromMountings(const std::array<Quat, kMaxHeads>& q_Si_B, HeadAlignment& out) const {
  out = HeadAlignment{};
  if (!configured_) return false;
  for (int k = 0; k < cfg_.n_heads; ++k) {
    const auto u = static_cast<std::size_t>(k);
    if (!allFinite(q_Si_B[u]) || std::abs(q_Si_B[u].norm() - 1.0) > 1e-6) return false;
    // Exp(d_k) = C_B_Sk C_Sk_B^0: the rotation, in B, from the nominal to the handed mounting
    out.c_B[u] = quatLog(q_Si_B[u].conjugate() * cfg_.head[u].q_Si_B.normalized());
  }
  return datumProject(out);
}

}  // namespace boresight::core
