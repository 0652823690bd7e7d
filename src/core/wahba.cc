#include "boresight/core/wahba.h"

#include "boresight/core/rotation.h"

#include <Eigen/Eigenvalues>
#include <Eigen/SVD>

#include <cmath>

namespace boresight::core {

Status MultiHeadWahba::configure(const WahbaConfig& cfg) {
  configured_ = false;
  const Status s = validate(cfg.heads);
  if (s != Status::kOk) return s;
  if (cfg.reference_slot < 0 || cfg.reference_slot >= cfg.heads.n_heads) return Status::kInvalidConfig;
  if (!(cfg.min_information >= 0) || !(cfg.unit_tolerance > 0)) return Status::kInvalidConfig;
  cfg_ = cfg;
  const auto R = static_cast<std::size_t>(cfg.reference_slot);
  q_SR_B_ = cfg.heads.head[R].q_Si_B.normalized();
  for (int k = 0; k < cfg.heads.n_heads; ++k) {
    const auto u = static_cast<std::size_t>(k);
    C_SR_Sk0_[u] = groundRelative(cfg.heads, cfg.reference_slot, k);
  }
  configured_ = true;
  reset();
  return Status::kOk;
}

void MultiHeadWahba::reset() {
  C_SR_Sk_ = C_SR_Sk0_;
  Q_SR_.fill(Mat3::Zero());
  have_last_ = false;
  last_t_ = 0;
  out_ = WahbaSolution{};
  health_.clear();
}

Status MultiHeadWahba::setRelative(int slot, const Mat3& C_SR_Sk) { return setRelative(slot, C_SR_Sk, Mat3::Zero()); }

Status MultiHeadWahba::setRelative(int slot, const Mat3& C_SR_Sk, const Mat3& cov_SR) {
  if (!configured_) return Status::kNotConfigured;
  if (slot < 0 || slot >= cfg_.heads.n_heads) return Status::kUnknownHead;
  if (!C_SR_Sk.allFinite() || !(C_SR_Sk * C_SR_Sk.transpose()).isApprox(Mat3::Identity(), 1e-6))
    return Status::kNonFinite;
  if (!cov_SR.allFinite() || cov_SR.diagonal().minCoeff() < 0) return Status::kNonFinite;
  C_SR_Sk_[static_cast<std::size_t>(slot)] = C_SR_Sk;
  Q_SR_[static_cast<std::size_t>(slot)] = 0.5 * (cov_SR + cov_SR.transpose());
  return Status::kOk;
}

Status MultiHeadWahba::step(const StarEpoch& in) {
  if (const Status g = admitStep(configured_, have_last_, last_t_, in.t, health_); g != Status::kOk) return g;
  int n = in.n < 0 ? 0 : in.n;
  if (n > kMaxStarInputs) {
    health_.record(Status::kCapacityExceeded);
    n = kMaxStarInputs;
  }
  // validate and project into SR
  int m = 0;
  for (int j = 0; j < n; ++j) {
    const StarObservation& so = in.star[static_cast<std::size_t>(j)];
    const int slot = slotOf(cfg_.heads, so.head_id);
    Status r = Status::kOk;
    if (slot < 0) {
      r = Status::kUnknownHead;
    } else if (!allFinite(so.s_Sk) || !allFinite(so.r_I) || !std::isfinite(so.sigma_rad) || so.sigma_rad < 0) {
      r = Status::kNonFinite;
    } else if (std::abs(so.s_Sk.norm() - 1.0) > cfg_.unit_tolerance || std::abs(so.r_I.norm() - 1.0) > cfg_.unit_tolerance) {
      r = Status::kNonUnitQuaternion;  // a non-unit direction: same family as a non-unit quaternion
    }
    if (r != Status::kOk) {
      health_.record(r);
      continue;
    }
    const auto us = static_cast<std::size_t>(slot);
    const double sig = so.sigma_rad > 0 ? so.sigma_rad : cfg_.heads.head[us].sigma_star_rad;
    const auto um = static_cast<std::size_t>(m);
    u_[um] = C_SR_Sk_[us] * so.s_Sk.normalized();
    w_[um] = 1.0 / (sig * sig);
    idx_[um] = static_cast<std::int16_t>(j);
    slot_[um] = static_cast<std::int8_t>(slot);
    ++m;
  }
  if (m < 2) {
    health_.record(Status::kTooFewStars);
    return Status::kTooFewStars;
  }
  // greedy well-distributed selection (moves the picks to the front of u_, w_, idx_)
  const int k_max = m < kMaxStars ? m : kMaxStars;
  Mat3 info = Mat3::Zero();
  if (m > kMaxStars) {
    for (int pick = 0; pick < k_max; ++pick) {
      int best = pick;
      if (pick == 0) {
        for (int j = 1; j < m; ++j)
          if (w_[static_cast<std::size_t>(j)] > w_[static_cast<std::size_t>(best)]) best = j;
      } else {
        Eigen::SelfAdjointEigenSolver<Mat3> es;
        es.computeDirect(info);
        const Vec3 weak = es.eigenvectors().col(0);
        double best_gain = -1;
        for (int j = pick; j < m; ++j) {
          const auto uj = static_cast<std::size_t>(j);
          const double c = u_[uj].dot(weak);
          const double gain = w_[uj] * (1.0 - c * c);
          if (gain > best_gain) {
            best_gain = gain;
            best = j;
          }
        }
      }
      const auto up = static_cast<std::size_t>(pick), ub = static_cast<std::size_t>(best);
      std::swap(u_[up], u_[ub]);
      std::swap(w_[up], w_[ub]);
      std::swap(idx_[up], idx_[ub]);
      std::swap(slot_[up], slot_[ub]);
      info += w_[up] * (Mat3::Identity() - u_[up] * u_[up].transpose());
    }
  } else {
    for (int j = 0; j < m; ++j) {
      const auto uj = static_cast<std::size_t>(j);
      info += w_[uj] * (Mat3::Identity() - u_[uj] * u_[uj].transpose());
    }
  }
  // observability: smallest eigenvalue of the information
  double w_best = 0;
  for (int j = 0; j < k_max; ++j) w_best = std::max(w_best, w_[static_cast<std::size_t>(j)]);
  const double min_info = cfg_.min_information > 0 ? cfg_.min_information : 0.01 * w_best;
  Eigen::SelfAdjointEigenSolver<Mat3> es;
  es.computeDirect(info, Eigen::EigenvaluesOnly);
  if (!(es.eigenvalues()(0) >= min_info)) {
    health_.record(Status::kTooFewStars);
    return Status::kTooFewStars;
  }
  // SVD of the attitude profile matrix; need one B = sum w r u^T for C_I_SR directly
  Mat3 Bm = Mat3::Zero();
  for (int j = 0; j < k_max; ++j) {
    const auto uj = static_cast<std::size_t>(j);
    Bm += w_[uj] * in.star[static_cast<std::size_t>(idx_[uj])].r_I.normalized() * u_[uj].transpose();
  }
  // minimise sum w |r - C_I_SR u|^2: C_I_SR = U diag(1, 1, det U det V) V^T with Bm = U S V^T
  Eigen::JacobiSVD<Mat3> svd(Bm, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Mat3& U = svd.matrixU();
  const Mat3& V = svd.matrixV();
  const double d = U.determinant() * V.determinant();
  const Mat3 C_I_SR = U * Eigen::Vector3d(1.0, 1.0, d).asDiagonal() * V.transpose();
  Mat3 P;
  if (!C_I_SR.allFinite() || !invertSpd3(info, P)) {
    health_.record(Status::kNumericalFailure);
    return Status::kNumericalFailure;
  }
  // relative-matrix uncertainty: common to all stars of a head (see the header)
  Mat3 P_total = P;
  for (int k = 0; k < cfg_.heads.n_heads; ++k) {
    const Mat3& Q = Q_SR_[static_cast<std::size_t>(k)];
    if (Q.isZero(0.0)) continue;
    Mat3 A = Mat3::Zero();
    for (int j = 0; j < k_max; ++j) {
      const auto uj = static_cast<std::size_t>(j);
      if (slot_[uj] == k) A += w_[uj] * (Mat3::Identity() - u_[uj] * u_[uj].transpose());
    }
    const Mat3 G = P * A;
    P_total += G * Q * G.transpose();
  }
  P_total = 0.5 * (P_total + P_total.transpose()).eval();
  WahbaSolution s;
  s.t = in.t;
  s.q_I_SR = Quat(C_I_SR).normalized();
  if (have_last_) s.q_I_SR = continuous(s.q_I_SR, out_.q_I_SR);
  s.q_I_B = (s.q_I_SR * q_SR_B_).normalized();
  s.P_SR = P_total;
  s.P_stars_SR = P;
  s.stars_in = m;
  s.stars_used = k_max;
  double ss = 0;
  for (int j = 0; j < k_max; ++j) {
    const auto uj = static_cast<std::size_t>(j);
    s.used[uj] = idx_[uj];
    ss += (in.star[static_cast<std::size_t>(idx_[uj])].r_I.normalized() - C_I_SR * u_[uj]).squaredNorm();
  }
  s.residual_rms_rad = std::sqrt(ss / k_max);
  out_ = s;
  have_last_ = true;
  last_t_ = in.t;
  health_.record(Status::kOk);
  return Status::kOk;
}

}  // namespace boresight::core
