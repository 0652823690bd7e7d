#include "boresight/core/thermal.h"

#include "boresight/core/fixed_ldlt.h"
#include "boresight/core/clones.h"
#include "boresight/core/rotation.h"

#include <algorithm>
#include <cmath>

namespace boresight::core {

namespace {
double angle(const Vec3& a, const Vec3& b) { return std::atan2(a.cross(b).norm(), a.dot(b)); }

}  // namespace

Status BoresightMonitor::configure(const HeadSetConfig& cfg, const DeformationFilterConfig& filter) {
  configured_ = false;
  const Status s = validate(cfg);
  if (s != Status::kOk) return s;
  if (!(filter.tau_s > 0) || !std::isfinite(filter.tau_s) || !(filter.hold_drift_rad_per_s >= 0) ||
      !std::isfinite(filter.hold_drift_rad_per_s))
    return Status::kInvalidConfig;
  fcfg_ = filter;
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
      cos0_[p] = std::cos(alpha0_[p]);
      sin0_[p] = std::sin(alpha0_[p]);
      sigma_iba2_nom_[p] = n_[p].dot(cov_[p] * n_[p]);
    }
  configured_ = true;
  reset();
  return Status::kOk;
}

void BoresightMonitor::reset() {
  dev_last_.fill(0.0);
  cur_.fill(PairDeformation{});
  acc_.fill(Acc{});
  filt_.fill(Filt{});
  have_anchor_ = false;
  anchor_ = 0;
  sigma_iba2_.fill(0.0);
  have_last_ = false;
  last_t_ = 0;
  health_.clear();
}

namespace {
/// Weighted time moments m_k = sum w s^k x about a time origin, moved to an origin d seconds later
/// (s -> s - d) with every weight scaled by c: m2 -> c (m2 - 2 d m1 + d^2 m0), m1 -> c (m1 - d m0).
template <typename T>
void shiftMoments(T& m0, T& m1, T& m2, double d, double c) {
  m2 = c * (m2 - 2.0 * d * m1 + d * d * m0);
  m1 = c * (m1 - d * m0);
  m0 = c * m0;
}
template <typename T>
void shiftMoments(T& m0, T& m1, double d, double c) {
  m1 = c * (m1 - d * m0);
  m0 = c * m0;
}
}  // namespace

void BoresightMonitor::reanchor(TimeUs t) {
  // move the time origin of every pair's sums from anchor_ to t (s -> s - d) and scale the weights
  // by exp(-d / tau) (its square for the squared weights): the estimates do not change
  const double d = toSeconds(t - anchor_);
  const double c = std::exp(-d / fcfg_.tau_s), c2 = c * c;
  for (Filt& F : filt_) {
    if (!F.seen) continue;
    shiftMoments(F.a0, F.a1, F.a2, d, c);
    shiftMoments(F.b0, F.b1, F.b2, d, c2);
    shiftMoments(F.z0, F.z1, d, c);
    F.wsum *= c;
    F.w2sum *= c2;
    if (!F.general) continue;
    shiftMoments(F.S0, F.S1, F.S2, d, c);
    shiftMoments(F.N0, F.N1, F.N2, d, c2);
    shiftMoments(F.y0, F.y1, d, c);
  }
  anchor_ = t;
}

BoresightMonitor::EpochWeights BoresightMonitor::epochWeights(TimeUs t) const {
  // growing weights g = exp((t - anchor) / tau) instead of decaying every sum each epoch (same
  // estimate, less work); s = t - anchor is the time in the sums. The same for every pair of the epoch.
  EpochWeights w;
  const double sa = toSeconds(t - anchor_);
  w.g = std::exp(sa / fcfg_.tau_s);
  w.g2 = w.g * w.g;
  w.sa = sa;
  w.gs = w.g * sa;
  w.gss = w.gs * sa;
  w.g2s = w.g2 * sa;
  w.g2ss = w.g2s * sa;
  return w;
}

void BoresightMonitor::updateFilter(Filt& F, TimeUs t, const EpochWeights& w, bool nominal, const Mat3& W,
                                    const Vec3& delta) {
  if (nominal) {  // W = W1: scalar and vector sums only
    F.a0 += w.g;
    F.a1 += w.gs;
    F.a2 += w.gss;
    F.b0 += w.g2;
    F.b1 += w.g2s;
    F.b2 += w.g2ss;
    F.z0 += w.g * delta;
    F.z1 += w.gs * delta;
  } else {
    const double sa = w.sa;
    const Mat3 gW = w.g * W;
    const Mat3 g2W = w.g2 * W;
    F.S0 += gW;
    F.S1 += sa * gW;
    F.S2 += (sa * sa) * gW;
    F.N0 += g2W;
    F.N1 += sa * g2W;
    F.N2 += (sa * sa) * g2W;
    const Vec3 gWd = gW * delta;
    F.y0 += gWd;
    F.y1 += sa * gWd;
    F.general = true;
  }
  F.wsum += w.g;
  F.w2sum += w.g2;
  F.seen = true;
  F.t = t;
  F.predicted = false;
  F.dirty = true;  // solved when asked (filtered(), relativeFor()): the sums are cheap, the solve is not
}

void BoresightMonitor::solveFilter(const Filt& F, const Mat3& W1) const {
  if (!F.dirty) return;
  F.dirty = false;
  bool ok = false;
  // the full sums: nominal part (scalars times W1) plus the general part
  Mat3 S0 = F.a0 * W1, S1 = F.a1 * W1, S2 = F.a2 * W1, N0 = F.b0 * W1, N1 = F.b1 * W1, N2 = F.b2 * W1;
  Vec3 y0 = W1 * F.z0, y1 = W1 * F.z1;
  if (F.general) {
    S0 += F.S0;
    S1 += F.S1;
    S2 += F.S2;
    N0 += F.N0;
    N1 += F.N1;
    N2 += F.N2;
    y0 += F.y0;
    y1 += F.y1;
  }
  if (fcfg_.model == DeformationModel::kLinear && F.wsum * F.wsum / F.w2sum > 8.0) {
    // times relative to the pair's last epoch: s -> s - d (the level is then the estimate at F.t)
    const double d = toSeconds(F.t - anchor_);
    const Mat3 T1 = S1 - d * S0, T2 = S2 - 2.0 * d * S1 + d * d * S0;
    const Mat3 U1 = N1 - d * N0, U2 = N2 - 2.0 * d * N1 + d * d * N0;
    // [S0 S1; S1 S2] [level; rate] = [y0; y1], covariance M^-1 N M^-1 (top-left block: the level)
    Mat6 M, N;
    M << S0, T1, T1, T2;
    N << N0, U1, U1, U2;
    Mat6 L;
    Vec6 D;
    if (ldltFactor<6>(M, L, D)) {
      Vec6 x;
      x << y0, y1 - d * y0;
      ldltSolveInPlace<6>(L, D, x);
      // the level's rows of M^-1 (M symmetric: its first three columns) and R N R^T
      Eigen::Matrix<double, 6, 3> Rt;
      for (int c = 0; c < 3; ++c) {
        Vec6 e = Vec6::Zero();
        e[c] = 1.0;
        ldltSolveInPlace<6>(L, D, e);
        Rt.col(c) = e;
      }
      const Mat3 C = Rt.transpose() * N * Rt;
      if (x.allFinite() && C.allFinite()) {
        F.delta = x.head<3>();
        F.cov = 0.5 * (C + C.transpose());
        ok = true;
      }
    }
  } else {
    Mat3 P;
    if (invertSpd3(S0, P)) {
      F.delta = P * y0;
      F.cov = P * N0 * P;
      F.cov = 0.5 * (F.cov + F.cov.transpose()).eval();
      ok = true;
    }
  }
  if (!ok) {
    ++F.solve_failures;
    health_.record(Status::kNumericalFailure);
  }
}

Status BoresightMonitor::step(const ValidHeads& in) {
  PairRelatives rel;
  if (configured_) formPairRelatives(in, cfg_.n_heads, rel);
  return step(in, rel);
}

BORESIGHT_CLONES Status BoresightMonitor::step(const ValidHeads& in, const PairRelatives& rel_in) {
  if (const Status g = admitStep(configured_, have_last_, last_t_, in.t, health_); g != Status::kOk) return g;
  const PairRelatives* relp = &rel_in;
  PairRelatives own;
  if (rel_in.t != in.t || rel_in.mask != in.mask) {  // not this epoch's: form them
    formPairRelatives(in, cfg_.n_heads, own);
    relp = &own;
  }
  const PairRelatives& rel = *relp;
  have_last_ = true;
  last_t_ = in.t;
  // the filters' time origin: re-anchored every kReanchorS (or 40 tau) so the weights stay below e^40
  if (!have_anchor_ || toSeconds(in.t - anchor_) > std::min(kReanchorS, 40.0 * fcfg_.tau_s)) {
    if (have_anchor_) {
      reanchor(in.t);
    } else {
      anchor_ = in.t;
      have_anchor_ = true;
    }
  }
  const EpochWeights w = epochWeights(in.t);
  for (int a = 0; a < cfg_.n_heads; ++a)
    for (int b = a + 1; b < cfg_.n_heads; ++b) {
      const auto p = static_cast<std::size_t>(pairIndex(a, b));
      PairDeformation& r = cur_[p];
      r.valid = false;
      if (!in.has(a) || !in.has(b)) continue;
      const auto ua = static_cast<std::size_t>(a), ub = static_cast<std::size_t>(b);
      const Quat& q_Sa_Sb = rel.q_Sa_Sb[p];
      const Vec3& ba = cfg_.head[ua].boresight_Si;
      const Vec3 v = q_Sa_Sb * cfg_.head[ub].boresight_Si;
      // deviation d = alpha - alpha0 from cos(alpha) = ba.v, sin(alpha) = |ba x v| (|ba| = |v| = 1):
      // sin d = sin(alpha) cos(alpha0) - cos(alpha) sin(alpha0), cos d = ... + ...; for |sin d| < 0.01
      // d = asin(sin d) by its series (first omitted term 35 x^9/1152 < 1e-19 rad), else atan2
      const double c = ba.dot(v), sn = ba.cross(v).norm();
      const double sd = sn * cos0_[p] - c * sin0_[p], cd = c * cos0_[p] + sn * sin0_[p];
      double dev;
      if (cd > 0 && std::abs(sd) < 1e-2) {
        const double x2 = sd * sd;
        dev = sd * (1.0 + x2 * (1.0 / 6.0 + x2 * (3.0 / 40.0 + x2 * (5.0 / 112.0))));
      } else {
        dev = std::atan2(sd, cd);
      }
      r.iba_dev_rad = dev;
      r.iba_rad = alpha0_[p] + dev;
      r.iba_ground_rad = alpha0_[p];
      r.delta_Si = quatLogNearIdentity(q_Sa_Sb * q0_[p].conjugate());
      const double sa = in.sigma_scale[ua], sb = in.sigma_scale[ub];
      const bool nominal = sa == 1.0 && sb == 1.0;
      r.n_iba_Si = n_[p];
      r.valid = true;
      dev_last_[p] = dev;
      Acc& A = acc_[p];
      if (nominal) {
        r.cov_delta_Si = cov_[p];
        sigma_iba2_[p] = sigma_iba2_nom_[p];
        ++A.n;
        ++A.n_nom;
        A.delta_nom += r.delta_Si;
        A.dev_sum += dev;
        updateFilter(filt_[p], in.t, w, true, W1_[p], r.delta_Si);
        continue;
      }
      const Mat3 Sa = headCovariance(cfg_.head[ua].sigma_cross_rad, cfg_.head[ua].sigma_roll_rad, ba);
      const Mat3 Sb = headCovariance(cfg_.head[ub].sigma_cross_rad, cfg_.head[ub].sigma_roll_rad, cfg_.head[ub].boresight_Si);
      r.cov_delta_Si = sa * sa * Sa + sb * sb * C0_[p] * Sb * C0_[p].transpose();
      Mat3 W;
      if (!invertSpd3(r.cov_delta_Si, W)) {
        health_.record(Status::kNumericalFailure);
        continue;
      }
      ++A.n;
      A.W_sum += W;
      A.W_delta += W * r.delta_Si;
      A.dev_sum += dev;
      sigma_iba2_[p] = n_[p].dot(r.cov_delta_Si * n_[p]);
      // filtered deformation: information-weighted fit with exponential forgetting
      updateFilter(filt_[p], in.t, w, false, W, r.delta_Si);
    }
  health_.record(Status::kOk);
  return Status::kOk;
}

DeformationMean BoresightMonitor::mean(int a, int b) const {
  DeformationMean m;
  if (!configured_ || a < 0 || b <= a || b >= cfg_.n_heads) return m;
  const Acc& A = acc_[static_cast<std::size_t>(pairIndex(a, b))];
  if (A.n == 0) return m;
  const auto p = static_cast<std::size_t>(pairIndex(a, b));
  const Mat3 W_sum = static_cast<double>(A.n_nom) * W1_[p] + A.W_sum;
  Mat3 P;
  if (!invertSpd3(W_sum, P)) return m;
  m.valid = true;
  m.n = A.n;
  m.cov_Si = P;
  m.delta_Si = P * (W1_[p] * A.delta_nom + A.W_delta);
  m.iba_dev_mean_rad = A.dev_sum / static_cast<double>(A.n);
  return m;
}

FilteredDeformation BoresightMonitor::filtered(int a, int b) const {
  FilteredDeformation d;
  if (!configured_ || a < 0 || b <= a || b >= cfg_.n_heads) return d;
  const Filt& F = filt_[static_cast<std::size_t>(pairIndex(a, b))];
  if (F.predicted) {
    d.valid = true;
    d.predicted = true;
    d.t = F.t_pred;
    d.delta_Si = F.delta_pred;
    d.cov_Si = F.cov_pred;
    return d;
  }
  if (!F.seen) return d;
  solveFilter(F, W1_[static_cast<std::size_t>(pairIndex(a, b))]);
  d.valid = true;
  d.t = F.t;
  d.delta_Si = F.delta;
  d.cov_Si = F.cov;
  d.n_eff = F.w2sum > 0 ? F.wsum * F.wsum / F.w2sum : 0;
  d.solve_failures = F.solve_failures;
  return d;
}

Status BoresightMonitor::setPredictedDeformation(int a, int b, TimeUs t, const Vec3& delta_Si, const Mat3& cov_Si) {
  if (!configured_) return Status::kNotConfigured;
  if (a < 0 || b <= a || b >= cfg_.n_heads) return Status::kInvalidConfig;
  if (!allFinite(delta_Si) || !cov_Si.allFinite()) return Status::kNonFinite;
  Filt& F = filt_[static_cast<std::size_t>(pairIndex(a, b))];
  F.predicted = true;
  F.t_pred = t;
  F.delta_pred = delta_Si;
  F.cov_pred = 0.5 * (cov_Si + cov_Si.transpose());
  return Status::kOk;
}

Status BoresightMonitor::relativeFor(int a, int b, RelativeCorrection mode, TimeUs t, Mat3& C, Mat3& cov) const {
  cov.setZero();
  if (!configured_ || a < 0 || b < 0 || a >= cfg_.n_heads || b >= cfg_.n_heads) return Status::kInvalidConfig;
  if (a == b) {
    C.setIdentity();
    return Status::kOk;
  }
  const int lo = a < b ? a : b, hi = a < b ? b : a;
  const auto p = static_cast<std::size_t>(pairIndex(lo, hi));
  // C_lo_hi and the covariance of its error in S_lo
  Mat3 C_lh = C0_[p];
  Mat3 P = Mat3::Zero();
  switch (mode) {
    case RelativeCorrection::kNone:
      break;
    case RelativeCorrection::kIbaOneAxis:
      C_lh = so3Exp(dev_last_[p] * n_[p]) * C0_[p];
      if (filt_[p].seen) P = sigma_iba2_[p] * n_[p] * n_[p].transpose();
      break;
    case RelativeCorrection::kFilteredThreeAxis: {
      const Filt& F = filt_[p];
      TimeUs t_value = t;  // when the value in use was last set: it is held since
      if (F.predicted) {
        C_lh = so3Exp(F.delta_pred) * C0_[p];
        P = F.cov_pred;
        t_value = F.t_pred;
      } else if (F.seen) {
        solveFilter(F, W1_[p]);
        C_lh = so3Exp(F.delta) * C0_[p];
        P = F.cov;
        t_value = F.t;
      }
      // A held value - the filter's while the pair is not seen, or a prediction no longer renewed (no
      // orbit input) - grows by the hold drift with its age.
      const double age = t > t_value ? toSeconds(t - t_value) : 0.0;
      const double g = fcfg_.hold_drift_rad_per_s * age;
      P.diagonal().array() += g * g;
      break;
    }
  }
  if (a < b) {
    C = C_lh;
    cov = P;
  } else {  // C_hi_lo = C_lh^T: its error e_hi = -C_lh^T e_lo
    C = C_lh.transpose();
    cov = C_lh.transpose() * P * C_lh;
  }
  return Status::kOk;
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
    return so3Exp(dev_last_[p] * n_[p]) * C0_[p];
  }
  const auto p = static_cast<std::size_t>(pairIndex(b, a));
  return (so3Exp(dev_last_[p] * n_[p]) * C0_[p]).transpose();
}

}  // namespace boresight::core
