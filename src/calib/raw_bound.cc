// The raw-data Cramer-Rao bound of method A (include/boresight/calib/raw_bound.h has the model).
#include <boresight/calib/raw_bound.h>

#include <boresight/core/rotation.h>
#include <boresight/core/pipeline.h>
#include <boresight/model/effects.h>
#include <boresight/model/overlay.h>
#include <boresight/model/parallel.h>
#include <boresight/model/rotation.h>
#include <boresight/model/sensors.h>

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <map>
#include <cmath>
#include <limits>
#include <string>

namespace boresight::calib {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

/// Pseudo-inverse of an information matrix after scaling it to unit diagonal (its units differ by
/// many orders of magnitude), and which parameters lie off its null space (eigenvalues of the scaled
/// matrix below 1e-12 of the largest).
struct ScaledInverse {
  Eigen::MatrixXd cov;
  std::vector<char> determined;
};

ScaledInverse scaledInverse(const Eigen::MatrixXd& info) {
  const auto m = static_cast<Eigen::Index>(info.rows());
  ScaledInverse out;
  out.cov = Eigen::MatrixXd::Zero(m, m);
  out.determined.assign(static_cast<std::size_t>(m), 0);
  if (m == 0) return out;
  Eigen::VectorXd s(m);
  for (Eigen::Index i = 0; i < m; ++i) s(i) = info(i, i) > 0 ? 1 / std::sqrt(info(i, i)) : 0.0;
  Eigen::MatrixXd a = s.asDiagonal() * info * s.asDiagonal();
  a = 0.5 * (a + a.transpose());
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(a);
  const Eigen::VectorXd& lam = es.eigenvalues();
  const double top = std::max(lam.maxCoeff(), 0.0);
  Eigen::VectorXd null_weight = Eigen::VectorXd::Zero(m);
  Eigen::VectorXd inv = Eigen::VectorXd::Zero(m);
  for (Eigen::Index k = 0; k < m; ++k) {
    if (top > 0 && lam(k) > 1e-12 * top) {
      inv(k) = 1 / lam(k);
    } else {
      null_weight += es.eigenvectors().col(k).cwiseAbs2();
    }
  }
  out.cov = s.asDiagonal() * (es.eigenvectors() * inv.asDiagonal() * es.eigenvectors().transpose()) * s.asDiagonal();
  for (Eigen::Index i = 0; i < m; ++i) out.determined[static_cast<std::size_t>(i)] = s(i) > 0 && null_weight(i) < 1e-6 ? 1 : 0;
  return out;
}

/// Information of the `keep` leading parameters with the others eliminated.
Eigen::MatrixXd schurLeading(const Eigen::MatrixXd& info, Eigen::Index keep) {
  const Eigen::Index rest = info.rows() - keep;
  if (rest == 0) return info;
  const ScaledInverse r = scaledInverse(info.bottomRightCorner(rest, rest));
  Eigen::MatrixXd out = info.topLeftCorner(keep, keep) -
                        info.topRightCorner(keep, rest) * r.cov * info.bottomLeftCorner(rest, keep);
  return 0.5 * (out + out.transpose());
}

double sigmaOf(const ScaledInverse& inv, Eigen::Index i) {
  const auto k = static_cast<std::size_t>(i);
  return inv.determined[k] ? std::sqrt(std::max(inv.cov(i, i), 0.0)) : kInf;
}

}  // namespace

std::string RawBoundConfig::validate() const {
  if (heads.empty()) return "no head";
  for (const auto& h : heads) {
    for (int j = 0; j < 3; ++j) {
      const std::string e = h.noise[static_cast<std::size_t>(j)].validate();
      if (!e.empty()) return "head " + std::to_string(h.id) + " axis " + std::to_string(j + 1) + ": " + e;
      if (!(h.noise[static_cast<std::size_t>(j)].whiteVariance() > 0))
        return "head " + std::to_string(h.id) + " axis " + std::to_string(j + 1) + ": no white noise";
    }
  }
  for (int a = 0; a < 3; ++a) {
    const std::string e = acc_noise[static_cast<std::size_t>(a)].validate();
    if (!e.empty()) return "accelerometer axis " + std::to_string(a + 1) + ": " + e;
    if (!(acc_noise[static_cast<std::size_t>(a)].whiteVariance() > 0))
      return "accelerometer axis " + std::to_string(a + 1) + ": no white noise";
  }
  if (!(acc_interval_s > 0) || !std::isfinite(acc_interval_s)) return "accelerometer sample interval is not positive";
  if (options.harmonics < 0 || options.harmonics > 8) return "harmonics outside 0..8";
  if (options.harmonics > 0 && !(options.orbit_rate_rad_s > 0)) return "harmonics need the orbit rate";
  if (!(options.gap_sigma_rad_s2 > 0)) return "gap_sigma_rad_s2 is not positive";
  if (!(options.unobservable_sigma_rad > 0)) return "unobservable_sigma_rad is not positive";
  if (!(options.scale_hold_sigma > 0)) return "scale_hold_sigma is not positive";
  return "";
}

RawBoundConfig rawBoundConfig(const std::vector<model::HeadModel>& heads, const model::AccelModel& acc,
                              const RawBoundOptions& options) {
  RawBoundConfig cfg;
  cfg.options = options;
  for (const auto& hm : heads) {
    RawBoundHead h;
    h.id = hm.config().id;
    const Mat3 C_Si_B = hm.config().q_Si_B.toRotationMatrix();
    for (int c = 0; c < 3; ++c) h.axes_Si.col(c) = hm.toHeadAxes(Vec3::Unit(c));
    h.C_Si_B = C_Si_B;
    h.R_axes_B = h.axes_Si * C_Si_B;
    const auto& e = hm.effects();
    for (int j = 0; j < 3; ++j) {
      const bool about = j == 2;
      model::NoiseModel m = model::NoiseModel::white(about ? hm.sigmaAbout() : hm.sigmaCross());
      for (const auto& t : (about ? e.coloured_about : e.coloured_cross).terms) m.add(t);
      for (const auto& t : (about ? e.wander_about : e.wander_cross).terms) m.add(t);
      h.noise[static_cast<std::size_t>(j)] = m;
    }
    cfg.heads.push_back(h);
  }
  const auto& ac = acc.config();
  cfg.C_A_B = ac.C_A_B;
  cfg.acc_interval_s = 1.0 / ac.rate_hz;
  for (int a = 0; a < 3; ++a) {
    const auto k = static_cast<std::size_t>(a);
    model::NoiseModel m = model::NoiseModel::white(ac.white_rad_s2(a));
    if (ac.lowfreq_rad_s2(a) > 0) m.add(model::NoiseTerm::gaussMarkov(ac.lowfreq_rad_s2(a), ac.lowfreq_tau_s));
    for (const auto& t : acc.effects().coloured[k].terms) m.add(t);
    for (const auto& t : acc.effects().bias_wander[k].terms) m.add(t);
    cfg.acc_noise[k] = m;
  }
  return cfg;
}

RawBoundConfig rawBoundConfig(const core::PipelineConfig& pipeline, const model::NoiseInUse& noise,
                              const RawBoundOptions& options) {
  RawBoundConfig cfg;
  cfg.options = options;
  for (int s = 0; s < pipeline.heads.n_heads; ++s) {
    const auto& hc = pipeline.heads.head[static_cast<std::size_t>(s)];
    RawBoundHead h;
    h.id = hc.id;
    h.C_Si_B = hc.q_Si_B.toRotationMatrix();
    Vec3 e1, e2, b;
    model::boresightBasis(hc.boresight_Si, e1, e2, b);
    h.axes_Si.row(0) = e1.transpose();
    h.axes_Si.row(1) = e2.transpose();
    h.axes_Si.row(2) = b.transpose();
    h.R_axes_B = h.axes_Si * h.C_Si_B;
    for (std::size_t j = 0; j < 3; ++j) h.noise[j] = noise.head[static_cast<std::size_t>(s)][j].noise.model;
    cfg.heads.push_back(h);
  }
  cfg.C_A_B = pipeline.C_B_A.transpose();
  cfg.acc_interval_s = 1.0 / pipeline.crn_acc.fs_hz;
  for (std::size_t a = 0; a < 3; ++a) cfg.acc_noise[a] = noise.acc[a].noise.model;
  return cfg;
}

RawBound::RawBound(const RawBoundConfig& cfg) : cfg_(cfg) {
  const std::size_t nh = cfg_.heads.size();
  n_ = 6;
  for (int a = 0; a < 3; ++a) {
    for (const auto& m : cfg_.acc_noise[static_cast<std::size_t>(a)].markovTerms()) {
      acc_axis_.push_back(a);
      tau_.push_back(m.tau_s);
      var_.push_back(m.var);
      ++n_;
    }
  }
  ka_ = n_ - 6;
  head_state_begin_.resize(nh);
  head_state_end_.resize(nh);
  head_white_.resize(nh);
  for (std::size_t i = 0; i < nh; ++i) {
    for (std::size_t j = 0; j < 3; ++j) {
      head_state_begin_[i][j] = n_;
      for (const auto& m : cfg_.heads[i].noise[j].markovTerms()) {
        tau_.push_back(m.tau_s);
        var_.push_back(m.var);
        ++n_;
      }
      head_state_end_[i][j] = n_;
      head_white_[i][j] = cfg_.heads[i].noise[j].whiteVariance();
    }
  }
  std::size_t c = 3 * nh;
  col_bias_ = c;
  if (cfg_.options.bias) c += 3;
  col_scale_ = c;
  if (cfg_.options.scale) c += 3;
  col_tau_ = c;
  if (cfg_.options.time_offset) c += 1;
  col_harm_ = c;
  if (nh > 1) c += (nh - 1) * 3 * 2 * static_cast<std::size_t>(std::max(cfg_.options.harmonics, 0));
  col_start_ = c;
  p_ = c;
  pt_ = c + 6;

  C_B_A_ = cfg_.C_A_B.transpose();
  for (int a = 0; a < 3; ++a) q_white_(a) = cfg_.acc_noise[static_cast<std::size_t>(a)].whiteVariance() * cfg_.acc_interval_s;

  const auto n = static_cast<Eigen::Index>(n_);
  P_ = Eigen::MatrixXd::Zero(n, n);
  for (std::size_t k = 0; k < var_.size(); ++k) P_(static_cast<Eigen::Index>(6 + k), static_cast<Eigen::Index>(6 + k)) = var_[k];
  E_ = Eigen::MatrixXd::Zero(n, static_cast<Eigen::Index>(pt_));
  E_.block(0, static_cast<Eigen::Index>(col_start_), 6, 6).setIdentity();
  info_ = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(pt_), static_cast<Eigen::Index>(pt_));
  x_ = Eigen::VectorXd::Zero(n);
  bvec_ = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(pt_));
  head_samples_.assign(nh, 0);
  Phi6_.setIdentity();
  Q6_.setZero();
  Psi3_.setZero();
  Sc3_.setZero();
  Tau1_.setZero();
}

Eigen::VectorXd RawBound::initialVariance() const {
  Eigen::VectorXd v = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(n_));
  for (std::size_t k = 0; k < var_.size(); ++k) v(static_cast<Eigen::Index>(6 + k)) = var_[k];
  return v;
}

void RawBound::accel(double t_s, const Vec3& alpha_B, const Vec3& w_B) {
  ++acc_samples_;
  if (!started_) {
    started_ = true;
    t_cur_ = t_flush_ = t_acc_ = first_t_ = last_t_ = t_s;
    alpha_ = alpha_B;
    w_ = w_B;
    return;
  }
  stepAcc(t_s, alpha_B);
  w_ = w_B;
}

void RawBound::stepAcc(double t_s, const Vec3& alpha_B) {
  if (t_s < t_cur_) t_s = t_cur_;
  advance(t_s);
  const double dt = t_s - t_acc_;
  alpha_dot_A_ = dt > 0 && dt <= 1.5 * cfg_.acc_interval_s ? Vec3(cfg_.C_A_B * (alpha_B - alpha_) / dt) : Vec3::Zero();
  alpha_ = alpha_B;
  t_acc_ = t_s;
  gap_counted_ = false;
  last_t_ = std::max(last_t_, t_s);
}

void RawBound::advance(double t_s) {
  const double T = cfg_.acc_interval_s;
  const double covered = t_acc_ + 1.5 * T;  // a sample stands for its interval, with some tag jitter
  while (t_cur_ < t_s) {
    const bool gap = t_cur_ >= covered;
    const double end = gap ? t_s : std::min(t_s, covered);
    const double h = std::min(end - t_cur_, T);
    if (gap && !gap_counted_) {
      ++acc_gaps_;
      gap_counted_ = true;
    }
    subStep(h, gap);
    if (end - t_cur_ < 1e-12) t_cur_ = end;
  }
}

void RawBound::subStep(double h, bool gap) {
  const Vec3 alpha = gap ? Vec3::Zero() : alpha_;
  const Mat3 A = core::skew(alpha), W = core::skew(w_), I = Mat3::Identity();
  Eigen::Matrix<double, 6, 6> Fs;
  Fs.block<3, 3>(0, 0) = I - 0.5 * h * h * A;
  Fs.block<3, 3>(0, 3) = h * I - 0.5 * h * h * W;
  Fs.block<3, 3>(3, 0) = -h * A;
  Fs.block<3, 3>(3, 3) = I - h * W;
  Eigen::Matrix<double, 6, 3> Bs;
  Bs.topRows<3>() = -0.5 * h * h * C_B_A_;
  Bs.bottomRows<3>() = -h * C_B_A_;
  const double g2 = cfg_.options.gap_sigma_rad_s2 * cfg_.options.gap_sigma_rad_s2 * cfg_.acc_interval_s;
  const Mat3 C = gap ? Mat3(g2 * I) : Mat3(C_B_A_ * q_white_.asDiagonal() * cfg_.C_A_B);
  Eigen::Matrix<double, 6, 6> Qs;
  Qs.block<3, 3>(0, 0) = h * h * h / 3 * C;
  Qs.block<3, 3>(0, 3) = 0.5 * h * h * C;
  Qs.block<3, 3>(3, 0) = 0.5 * h * h * C;
  Qs.block<3, 3>(3, 3) = h * C;
  Phi6_ = Fs * Phi6_;
  Q6_ = Fs * Q6_ * Fs.transpose() + Qs;
  Psi3_ = Fs * Psi3_;
  Sc3_ = Fs * Sc3_;
  Tau1_ = Fs * Tau1_;
  if (data_) {  // the reference trajectory moves with the measured angular acceleration
    q_nom_ = (q_nom_ * core::quatExp(w_ * h + 0.5 * h * h * alpha)).normalized();
    w_ += alpha * h;
  }
  if (!gap) {
    Psi3_ += Bs;
    Sc3_ += Bs * (cfg_.C_A_B * alpha).asDiagonal();
    Tau1_ += Bs * alpha_dot_A_;
  }
  t_cur_ += h;
}

void RawBound::flush(double t_s) {
  const double dt = t_s - t_flush_;
  if (!(dt > 0)) return;  // a second head at the same epoch: nothing has moved
  const auto n = static_cast<Eigen::Index>(n_), ka = static_cast<Eigen::Index>(ka_), nn = n - 6;
  Eigen::VectorXd& d = dd_;
  Eigen::VectorXd& q = qq_;
  d.resize(nn);
  q.resize(nn);
  for (Eigen::Index k = 0; k < nn; ++k) {
    const auto kk = static_cast<std::size_t>(k);
    d(k) = std::exp(-dt / tau_[kk]);
    q(k) = var_[kk] * (1 - d(k) * d(k));
  }
  Eigen::MatrixXd& Psig = psig_;
  Psig.resize(6, ka);
  for (Eigen::Index k = 0; k < ka; ++k) Psig.col(k) = Psi3_.col(acc_axis_[static_cast<std::size_t>(k)]) * (0.5 * (1 + d(k)));
  Eigen::MatrixXd& G6 = g6_;
  G6.setZero(6, static_cast<Eigen::Index>(p_));
  if (cfg_.options.bias) G6.middleCols(static_cast<Eigen::Index>(col_bias_), 3) = Psi3_;
  if (cfg_.options.scale) G6.middleCols(static_cast<Eigen::Index>(col_scale_), 3) = Sc3_;
  if (cfg_.options.time_offset) G6.col(static_cast<Eigen::Index>(col_tau_)) = Tau1_;

  if (recorder_) {
    Eigen::MatrixXd T = Eigen::MatrixXd::Zero(n, n), Q = Eigen::MatrixXd::Zero(n, n);
    Eigen::MatrixXd G = Eigen::MatrixXd::Zero(n, static_cast<Eigen::Index>(p_));
    T.topLeftCorner(6, 6) = Phi6_;
    T.block(0, 6, 6, ka) = Psig;
    T.bottomRightCorner(nn, nn) = d.asDiagonal();
    Q.topLeftCorner(6, 6) = Q6_;
    Q.bottomRightCorner(nn, nn) = q.asDiagonal();
    G.topRows(6) = G6;
    recorder_->transition(T, Q, G);
  }

  // P <- T P T^T + Q, T = [[Phi6, Psig, 0], [0, diag(d)]].
  Eigen::MatrixXd& top = top_;
  top.noalias() = Phi6_ * P_.topRows(6);
  top.noalias() += Psig * P_.middleRows(6, ka);
  P_.bottomRows(nn) = d.asDiagonal() * P_.bottomRows(nn);
  P_.topRows(6) = top;
  Eigen::MatrixXd& left = left_;
  left.noalias() = P_.leftCols(6) * Phi6_.transpose();
  left.noalias() += P_.middleCols(6, ka) * Psig.transpose();
  P_.rightCols(nn) = P_.rightCols(nn) * d.asDiagonal();
  P_.leftCols(6) = left;
  P_.topLeftCorner(6, 6) += Q6_;
  P_.bottomRightCorner(nn, nn).diagonal() += q;

  if (data_) {  // the error state: x <- T x (the filter runs with theta = 0)
    const Eigen::Matrix<double, 6, 1> xt = Phi6_ * x_.head(6) + Psig * x_.segment(6, ka);
    x_.tail(nn) = d.cwiseProduct(x_.tail(nn));
    x_.head(6) = xt;
  }
  // E <- T E + [G, 0].
  Eigen::MatrixXd& etop = etop_;
  etop.noalias() = Phi6_ * E_.topRows(6);
  etop.noalias() += Psig * E_.middleRows(6, ka);
  etop.leftCols(static_cast<Eigen::Index>(p_)) += G6;
  E_.bottomRows(nn) = d.asDiagonal() * E_.bottomRows(nn);
  E_.topRows(6) = etop;

  Phi6_.setIdentity();
  Q6_.setZero();
  Psi3_.setZero();
  Sc3_.setZero();
  Tau1_.setZero();
  t_flush_ = t_s;
}

/// The first of head `index`'s (1..n-1) axis-`j` harmonic parameters inside the harmonic block (cos, sin
/// of k = 1..K in turn): the one layout observe(), appliedMounting() and the names (result()) share.
static std::size_t harmonicOffset(std::size_t index, std::size_t j, int K) {
  return ((index - 1) * 3 + j) * 2 * static_cast<std::size_t>(K);
}

void RawBound::observe(std::size_t i, int j, double t_s, double y) {
  const auto jj = static_cast<std::size_t>(j);
  const auto b = static_cast<Eigen::Index>(head_state_begin_[i][jj]), e = static_cast<Eigen::Index>(head_state_end_[i][jj]);
  const Eigen::RowVector3d r = cfg_.heads[i].R_axes_B.row(j);
  // P h and E^T h for h = [r, 0.., 1 on this axis's noise states, 0..].
  Eigen::VectorXd& Ph = ph_;
  Ph.noalias() = P_.leftCols(3) * r.transpose();
  Eigen::RowVectorXd& u = u_;
  u.noalias() = r * E_.topRows(3);
  for (Eigen::Index s = b; s < e; ++s) {
    Ph += P_.col(s);
    u += E_.row(s);
  }
  const double rw = head_white_[i][jj];
  double F = r.dot(Ph.head<3>()) + rw;
  for (Eigen::Index s = b; s < e; ++s) F += Ph(s);
  if (recorder_) hE_ = u;  // h^T E, for the recorder
  const Eigen::RowVectorXd& hE = hE_;
  // d: the mounting error of this axis, and the harmonics of heads 2..n.
  u(static_cast<Eigen::Index>(3 * i + jj)) += 1;
  const int K = cfg_.options.harmonics;
  if (i > 0 && K > 0) {  // cos(k u), sin(k u) at t_s: setHarmonics
    const auto base = static_cast<Eigen::Index>(col_harm_ + harmonicOffset(i, jj, K));
    for (int k = 1; k <= K; ++k) {
      u(base + 2 * (k - 1)) += harm_cos_[static_cast<std::size_t>(k - 1)];
      u(base + 2 * (k - 1) + 1) += harm_sin_[static_cast<std::size_t>(k - 1)];
    }
  }
  if (recorder_) {
    Eigen::VectorXd h = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(n_));
    for (Eigen::Index s = 0; s < static_cast<Eigen::Index>(n_); ++s) h(s) = s < 3 ? r(s) : (s >= b && s < e ? 1.0 : 0.0);
    // d^T theta: u minus the filter's part h^T E, restricted to the parameters.
    const Eigen::VectorXd dvec = (u - hE).head(static_cast<Eigen::Index>(p_)).transpose();
    recorder_->observation(h, dvec, rw);
  }
  if (!data_) info_.noalias() += u.transpose() * (u / F);  // data mode: the sum of the groups' (finishData)
  if (data_) {
    // What this axis's noise is seen as: the data less the trajectory's prediction. The innovation v
    // takes the noise states' prediction off it as well; the noise fit must see the noise, not what the
    // model in use leaves of it (a fit of v under a coloured model in use finds it white).
    const double seen = y - r.dot(x_.head<3>());
    double v = seen;
    for (Eigen::Index s2 = b; s2 < e; ++s2) v -= x_(s2);
    x_.noalias() += Ph * (v / F);
    chi2_ += v * v / F;
    ++chi2_n_;
    const auto p = static_cast<Eigen::Index>(p_);
    const auto add = [&](Acc& a) {
      if (a.N.size() == 0) {
        a.N = Eigen::MatrixXd::Zero(p, p);
        a.b = Eigen::VectorXd::Zero(p);
      }
      a.b.noalias() += u.head(p).transpose() * (v / F);
      a.vv += v * v / F;
      a.n += 1;
    };
    const std::size_t g = 2 * i + (j == 2 ? 1 : 0);
    add(groups_[g]);
    std::size_t kb = 0;
    if (collect_blocks_ && cfg_.options.score_block_s > 0) {
      kb = static_cast<std::size_t>(std::max(0.0, std::floor((t_s - block_t0_) / cfg_.options.score_block_s)));
      if (kb >= blocks_.size()) blocks_.resize(kb + 1);
      add(blocks_[kb]);
    }
    // The information term u^T u / F: buffered (flushPending), one block's columns at a time.
    if (kb != pending_block_) flushPending();
    pending_block_ = kb;
    if (pending_[g].cols() == 0) pending_[g].resize(p, 32);
    pending_[g].col(pending_n_[g]++) = u.head(p).transpose() / std::sqrt(F);
    if (pending_n_[g] == pending_[g].cols()) flushPending();
    if (record_innovations_) {
      const std::size_t k = 3 * i + jj;
      auto& sr = innovations_[k];
      if ((sr.t_s.empty() || t_s > sr.t_s.back()) && innovation_seen_[k]++ % innovation_stride_[i] == 0) {
        sr.t_s.push_back(t_s);
        sr.y.push_back(seen);
      }
    }
  }
  E_.noalias() -= Ph * (u / F);
  P_.noalias() -= Ph * (Ph.transpose() / F);
}

void RawBound::head(double t_s, std::size_t index) {
  if (index >= cfg_.heads.size()) return;
  if (!started_) {
    ++head_before_;
    return;
  }
  if (t_s < t_cur_) t_s = t_cur_;
  advance(t_s);
  flush(t_s);
  setHarmonics(t_s);
  for (int j = 0; j < 3; ++j) observe(index, j, t_s, 0.0);
  ++head_samples_[index];
  last_t_ = std::max(last_t_, t_s);
}

void RawBound::enableData(const std::vector<Mat3>& C_Si_B_applied, const Vec3& bias, const Vec3& scale) {
  data_ = true;
  groups_.assign(2 * cfg_.heads.size(), Acc{});
  pending_.assign(groups_.size(), Eigen::MatrixXd());
  pending_n_.assign(groups_.size(), 0);
  pending_block_ = 0;
  innovations_.assign(3 * cfg_.heads.size(), model::NoiseSeries{});
  innovation_seen_.assign(3 * cfg_.heads.size(), 0);
  innovation_stride_.assign(cfg_.heads.size(), 1);
  C_Si_B_applied_ = C_Si_B_applied;
  bias_applied_ = bias;
  scale_applied_ = scale;
  // The trajectory's start is a wide prior of the filter (it re-anchors the reference), not a column.
  E_.block(0, static_cast<Eigen::Index>(col_start_), 6, 6).setZero();
  for (int k = 0; k < 3; ++k) {
    P_(k, k) = 1e-4;      // (0.01 rad)^2
    P_(3 + k, 3 + k) = 1e-5;  // (3e-3 rad/s)^2
  }
}

void RawBound::setHarmonics(double t_s) {
  const int K = cfg_.options.harmonics;
  if (K <= 0) return;
  harm_cos_.resize(static_cast<std::size_t>(K));
  harm_sin_.resize(static_cast<std::size_t>(K));
  const double ang = cfg_.options.orbit_phase_rad + cfg_.options.orbit_rate_rad_s * t_s;
  for (int k = 1; k <= K; ++k) {
    harm_cos_[static_cast<std::size_t>(k - 1)] = std::cos(k * ang);
    harm_sin_[static_cast<std::size_t>(k - 1)] = std::sin(k * ang);
  }
}

Mat3 RawBound::appliedMounting(std::size_t index) const {
  const int K = cfg_.options.harmonics;
  if (index == 0 || K <= 0 || harm_applied_.size() == 0) return C_Si_B_applied_[index];
  // The harmonic parameters of this head (head axes e1, e2, b) enter each axis's observation as the
  // mounting's do (parameter theta: the rotation -axes^T theta in Si), so the pass applies -axes^T H(t).
  // cos(k u), sin(k u) at the sample's time: setHarmonics, called first
  Vec3 H = Vec3::Zero();
  for (int j = 0; j < 3; ++j) {
    const auto base = static_cast<Eigen::Index>(harmonicOffset(index, static_cast<std::size_t>(j), K));
    for (int k = 1; k <= K; ++k) {
      const auto kk = static_cast<std::size_t>(k - 1);
      H(j) += harm_applied_(base + 2 * (k - 1)) * harm_cos_[kk] + harm_applied_(base + 2 * (k - 1) + 1) * harm_sin_[kk];
    }
  }
  return core::quatExp(Vec3(-cfg_.heads[index].axes_Si.transpose() * H)).toRotationMatrix() * C_Si_B_applied_[index];
}

void RawBound::accelData(double t_s, const Vec3& z_A, const Vec3& jerk_A) {
  ++acc_samples_;
  if (!started_) return;  // the reference starts at the first head sample
  stepAcc(t_s, C_B_A_ * (z_A - bias_applied_).cwiseQuotient(Vec3::Ones() + scale_applied_));
  alpha_dot_A_ = jerk_A;  // smoothed over the neighbours: a difference of two noisy samples is mostly noise
}

void RawBound::headData(double t_s, std::size_t index, const Quat& q_I_Si) {
  if (index >= cfg_.heads.size()) return;
  const Mat3 C_meas = q_I_Si.normalized().toRotationMatrix();
  setHarmonics(std::max(t_s, t_cur_));  // the time the sample is taken in at (below)
  const Mat3 C_Si_B = appliedMounting(index);
  if (!started_) {
    started_ = true;
    t_cur_ = t_flush_ = t_acc_ = first_t_ = last_t_ = t_s;
    alpha_.setZero();
    w_.setZero();
    q_nom_ = Quat(Mat3(C_meas * C_Si_B)).normalized();
    block_t0_ = t_s;
  }
  if (t_s < t_cur_) t_s = t_cur_;
  advance(t_s);
  flush(t_s);
  const Mat3 C_hat = q_nom_.toRotationMatrix() * C_Si_B.transpose();  // C_I_Si predicted
  const Vec3 y = cfg_.heads[index].axes_Si * core::so3Log(Mat3(C_hat.transpose() * C_meas));
  // Gate on the marginal innovations before any update.
  const Mat3& R = cfg_.heads[index].R_axes_B;
  for (int j = 0; j < 3 && gate_sigma_ > 0; ++j) {
    const auto jj = static_cast<std::size_t>(j);
    const auto b = static_cast<Eigen::Index>(head_state_begin_[index][jj]), e = static_cast<Eigen::Index>(head_state_end_[index][jj]);
    const Eigen::RowVector3d r = R.row(j);
    // F0 = h^T P h over the few states h touches (attitude and this axis's noise states).
    double v0 = y(j) - r.dot(x_.head<3>());
    for (Eigen::Index s2 = b; s2 < e; ++s2) v0 -= x_(s2);
    double F0 = r.dot(P_.topLeftCorner<3, 3>() * r.transpose()) + head_white_[index][jj];
    for (Eigen::Index s2 = b; s2 < e; ++s2) {
      F0 += 2 * r.dot(P_.block<3, 1>(0, s2));
      for (Eigen::Index s3 = b; s3 < e; ++s3) F0 += P_(s3, s2);
    }
    if (v0 * v0 > gate_sigma_ * gate_sigma_ * F0) {
      ++rejected_;
      return;
    }
  }
  for (int j = 0; j < 3; ++j) observe(index, j, t_s, y(j));
  // Re-anchor the reference: C_I_B <- C_I_B Exp(phi), w <- w + w x phi + phi'.
  const Vec3 phi = x_.head<3>(), v = x_.segment<3>(3);
  q_nom_ = (q_nom_ * core::quatExp(phi)).normalized();
  w_ += w_.cross(phi) + v;
  x_.head(6).setZero();
  ++head_samples_[index];
  last_t_ = std::max(last_t_, t_s);
}

void RawBound::flushPending() {
  for (std::size_t g = 0; g < pending_.size(); ++g) {
    const int n = pending_n_[g];
    if (n == 0) continue;
    // The lower triangle only (finishData() fills the upper one).
    pending_sum_.setZero(pending_[g].rows(), pending_[g].rows());
    pending_sum_.selfadjointView<Eigen::Lower>().rankUpdate(pending_[g].leftCols(n));
    groups_[g].N += pending_sum_;
    if (collect_blocks_ && cfg_.options.score_block_s > 0 && pending_block_ < blocks_.size()) blocks_[pending_block_].N += pending_sum_;
    pending_n_[g] = 0;
  }
}

void RawBound::finishData() {
  flushPending();
  for (auto* v : {&groups_, &blocks_})
    for (auto& a : *v)
      if (a.N.size() > 0) a.N = a.N.selfadjointView<Eigen::Lower>();
  // The trajectory start's columns are zero in data mode (enableData): the information and sum u^T v / F
  // are those of the parameters, summed over the variance groups.
  const auto p = static_cast<Eigen::Index>(p_);
  info_.setZero();
  bvec_.setZero();
  for (const auto& g : groups_) {
    if (g.n <= 0) continue;
    info_.topLeftCorner(p, p) += g.N;
    bvec_.head(p) += g.b;
  }
}

Eigen::VectorXd RawBound::solveParameters(const RawBoundResult& r) const {
  const auto p = static_cast<Eigen::Index>(p_);
  Eigen::VectorXd b = bvec_.head(p);
  const Eigen::Index rest = static_cast<Eigen::Index>(pt_) - p;
  if (rest > 0) {
    const ScaledInverse nn = scaledInverse(info_.bottomRightCorner(rest, rest));
    const Eigen::VectorXd tail = bvec_.tail(rest);
    const Eigen::VectorXd start = nn.cov * tail;
    const Eigen::MatrixXd cross_info = info_.topRightCorner(p, rest);
    b.noalias() -= cross_info * start;
  }
  return r.covariance * b;
}

namespace {

/// The accelerometer's angular jerk at sample m of `acc` (in time order; A, rad/s^3): the least-squares
/// slope over the samples within +-1 s (the time offset's column). lo and hi are the window's ends,
/// carried from one sample to the next (start both at 0, m increasing): computed as the pass goes, so
/// no array of a day's jerks is held.
Vec3 smoothedJerk(const std::vector<RawData::Acc>& acc, std::size_t m, std::size_t& lo, std::size_t& hi) {
  const double t = acc[m].t_s;
  while (lo < m && acc[lo].t_s < t - 1.0) ++lo;
  if (hi < m) hi = m;
  while (hi + 1 < acc.size() && acc[hi + 1].t_s <= t + 1.0) ++hi;
  double st = 0;
  Vec3 sz = Vec3::Zero();
  const double n = static_cast<double>(hi - lo + 1);
  for (std::size_t q = lo; q <= hi; ++q) {
    st += acc[q].t_s;
    sz += acc[q].z_A();
  }
  const double tm = st / n;
  const Vec3 zm = sz / n;
  double stt = 0;
  Vec3 stz = Vec3::Zero();
  for (std::size_t q = lo; q <= hi; ++q) {
    const double dt = acc[q].t_s - tm;
    stt += dt * dt;
    stz += dt * (acc[q].z_A() - zm);
  }
  return stt > 0 ? Vec3(stz / stt) : Vec3::Zero();
}

/// Each term's level times sqrt(f): the whole model's variance times f.
model::NoiseModel scaledNoise(const model::NoiseModel& m, double f) {
  model::NoiseModel out = m;
  for (auto& t : out.terms) t.sigma *= std::sqrt(f);
  return out;
}

/// The sandwich covariance C M C of the parameters from per-block scores G_b = b_b - N_b theta
/// (Bell-McCaffrey's bias-reduced form: in C's whitened coordinates each block's score is divided by
/// (1 - H_b)^(1/2), H_b the block's leverage matrix, so that under the model in use the result has
/// expectation C exactly; leverage eigenvalues are clamped at 0.95).
Eigen::MatrixXd robustCovariance(const Eigen::MatrixXd& C, const std::vector<Eigen::MatrixXd>& N,
                                 const std::vector<Eigen::VectorXd>& G) {
  const Eigen::Index p = C.rows();
  Eigen::VectorXd d(p);
  for (Eigen::Index i = 0; i < p; ++i) d(i) = C(i, i) > 0 ? std::sqrt(C(i, i)) : 0.0;
  Eigen::VectorXd dinv = d;
  for (Eigen::Index i = 0; i < p; ++i) dinv(i) = d(i) > 0 ? 1 / d(i) : 0.0;
  const Eigen::MatrixXd Cs = dinv.asDiagonal() * C * dinv.asDiagonal();
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(0.5 * (Cs + Cs.transpose()));
  const Eigen::VectorXd root = es.eigenvalues().cwiseMax(0.0).cwiseSqrt();
  const Eigen::MatrixXd W = d.asDiagonal() * es.eigenvectors() * root.asDiagonal() * es.eigenvectors().transpose();  // W W^T = C
  Eigen::MatrixXd M = Eigen::MatrixXd::Zero(p, p);
  for (std::size_t b = 0; b < N.size(); ++b) {
    const Eigen::MatrixXd H = W.transpose() * N[b] * W;
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eh(0.5 * (H + H.transpose()));
    Eigen::VectorXd f(p);
    for (Eigen::Index k = 0; k < p; ++k) f(k) = 1 / std::sqrt(1 - std::min(std::max(eh.eigenvalues()(k), 0.0), 0.95));
    const Eigen::VectorXd z = eh.eigenvectors() * f.asDiagonal() * eh.eigenvectors().transpose() * (W.transpose() * G[b]);
    M.noalias() += z * z.transpose();
  }
  const Eigen::MatrixXd out = W * M * W.transpose();
  return 0.5 * (out + out.transpose());
}

}  // namespace

RawEstimate estimateRaw(const RawBoundConfig& cfg0, const RawData& data, const Vec3& bias0, int passes) {
  const std::size_t nh = cfg0.heads.size();
  RawBoundConfig cfg = cfg0;
  std::vector<Vec3> eps(nh, Vec3::Zero());
  std::vector<Mat3> applied(nh);
  Vec3 bias = bias0, scale = Vec3::Zero();
  std::array<bool, 3> scale_held{false, false, false};  // options.scale_hold_sigma, sticky over the passes
  Eigen::VectorXd harm;  // the orbit harmonics' parameters (options.harmonics), applied from the second pass
  RawEstimate out;
  std::vector<std::array<double, 2>> factor(nh, {1.0, 1.0});
  std::vector<std::array<model::NoiseModel, 3>> base(nh);  // the noise models the factors apply to
  for (std::size_t i = 0; i < nh; ++i) base[i] = cfg0.heads[i].noise;
  out.chi2_per_dof.assign(nh, {0.0, 0.0});
  // An accelerometer sample is the mean over [t - T/2, t + T/2): it drives the trajectory from t - T/2,
  // so it is taken in before a head sample at t.
  // With a time offset tau the sample tagged t is the mean about t + tau.
  const double half = 0.5 * cfg.acc_interval_s;
  double tau = 0;
  // The head samples and the accelerometer's, each in time order (a sorted copy when the data are not);
  // a pass merges the two with the accelerometer shifted by its offset (a head sample first at a tie).
  const auto by_time = [](const auto& a, const auto& b) { return a.t_s < b.t_s; };
  RawData sorted;
  const RawData* d = &data;
  if (!std::is_sorted(data.heads.begin(), data.heads.end(), by_time) || !std::is_sorted(data.acc.begin(), data.acc.end(), by_time)) {
    sorted = data;
    std::stable_sort(sorted.heads.begin(), sorted.heads.end(), by_time);
    std::stable_sort(sorted.acc.begin(), sorted.acc.end(), by_time);
    d = &sorted;
  }
  const std::vector<RawData::Head>& heads = d->heads;
  const std::vector<RawData::Acc>& accs = d->acc;
  // The noise fit takes at most 16384 innovations per head axis (every k-th head sample's): the exact
  // likelihood's cost is linear in them, and what the fit determines (times from 20 intervals up) does
  // not need every 0.5 s sample.
  std::vector<std::size_t> head_count(nh, 0);
  for (const auto& h : heads)
    if (h.head >= 0 && static_cast<std::size_t>(h.head) < nh) ++head_count[static_cast<std::size_t>(h.head)];
  const int npass = std::max(passes, 1);
  for (int pass = 0; pass < npass; ++pass) {
    for (std::size_t i = 0; i < nh; ++i) {
      applied[i] = core::quatExp(eps[i]).toRotationMatrix() * cfg.heads[i].C_Si_B;
      for (std::size_t j = 0; j < 3; ++j) cfg.heads[i].noise[j] = scaledNoise(base[i][j], factor[i][j == 2 ? 1 : 0]);
    }
    RawBound b(cfg);
    b.enableData(applied, bias, scale);
    if (harm.size() > 0) b.harm_applied_ = harm;
    // The first pass runs with the nominal mountings: the heads disagree by their relative errors (up to
    // some 1000"), which the filter (theta = 0) cannot tell from outliers; no gate there.
    b.gate_sigma_ = pass == 0 ? 0.0 : 6.0;
    const bool fit_now = cfg.options.fit_noise && pass == 1 && npass > 2;
    b.record_innovations_ = fit_now;
    if (fit_now)
      for (std::size_t i = 0; i < nh; ++i) b.innovation_stride_[i] = head_count[i] / 16384 + 1;
    b.collect_blocks_ = pass + 1 == npass;  // the score blocks serve the last pass's covariance only
    std::size_t ih = 0, ia = 0, jlo = 0, jhi = 0;
    while (ih < heads.size() || ia < accs.size()) {
      if (ia < accs.size() && (ih == heads.size() || accs[ia].t_s + tau - half < heads[ih].t_s)) {
        const auto& ev = accs[ia];
        b.accelData(ev.t_s + tau - half, ev.z_A(), cfg.options.time_offset ? smoothedJerk(accs, ia, jlo, jhi) : Vec3::Zero());
        ++ia;
        continue;
      }
      const auto& ev = heads[ih++];
      if (ev.head < 0 || static_cast<std::size_t>(ev.head) >= nh) continue;
      if (ev.v_obs_I().isZero()) {
        b.headData(ev.t_s, static_cast<std::size_t>(ev.head), ev.q_I_Si());
      } else {
        // Remove the aberration: q_meas = q_true Exp(C_Si_I (b_I x v / c)).
        const auto hi = static_cast<std::size_t>(ev.head);
        const Mat3 C_I_Si = ev.q_I_Si().normalized().toRotationMatrix();
        const Vec3 b_I = C_I_Si * Vec3(cfg.heads[hi].axes_Si.row(2).transpose());
        const Vec3 phi = C_I_Si.transpose() * (b_I.cross(ev.v_obs_I()) / model::kSpeedOfLight);
        b.headData(ev.t_s, hi, ev.q_I_Si().normalized() * core::quatExp(-phi));
      }
    }
    b.finishData();
    out.bound = b.result();
    if (cfg.options.scale) {
      // A scale factor the span does not determine is held from here on (options.scale_hold_sigma).
      const ScaledInverse free_inv = scaledInverse(out.bound.information);
      for (std::size_t a = 0; a < 3; ++a)
        if (sigmaOf(free_inv, static_cast<Eigen::Index>(b.col_scale_ + a)) > cfg.options.scale_hold_sigma) scale_held[a] = true;
      b.held_cols_.clear();
      for (std::size_t a = 0; a < 3; ++a)
        if (scale_held[a]) b.held_cols_.push_back(b.col_scale_ + a);
      if (!b.held_cols_.empty()) out.bound = b.result();
    }
    const Eigen::VectorXd th = b.solveParameters(out.bound);
    for (std::size_t i = 0; i < nh; ++i) eps[i] -= cfg.heads[i].axes_Si.transpose() * Vec3(th.segment<3>(static_cast<Eigen::Index>(3 * i)));
    if (cfg.options.bias) bias += th.segment<3>(static_cast<Eigen::Index>(b.col_bias_));
    if (cfg.options.scale) scale += th.segment<3>(static_cast<Eigen::Index>(b.col_scale_));
    if (cfg.options.time_offset) tau += th(static_cast<Eigen::Index>(b.col_tau_));
    if (b.col_start_ > b.col_harm_) {
      const auto nk = static_cast<Eigen::Index>(b.col_start_ - b.col_harm_);
      if (harm.size() == 0) harm = Eigen::VectorXd::Zero(nk);
      harm += th.segment(static_cast<Eigen::Index>(b.col_harm_), nk);
    }
    out.chi2_per_obs = b.chi2_n_ ? b.chi2_ / static_cast<double>(b.chi2_n_) : 0;
    out.head_samples_rejected = b.rejected_;
    out.passes = pass + 1;

    // Variance components at this pass's estimate: the residual square sum of a group is
    // sum (v - u theta)^2 / F = vv - 2 theta^T b + theta^T N theta.
    std::vector<model::VarianceGroup> vg;
    std::vector<std::size_t> vg_index;
    for (std::size_t g = 0; g < b.groups_.size(); ++g) {
      const auto& a = b.groups_[g];
      if (a.n <= 0) continue;
      model::VarianceGroup x;
      x.N = a.N;
      x.ssr = std::max(0.0, a.vv - 2 * th.dot(a.b) + th.dot(a.N * th));
      x.n_obs = a.n;
      vg.push_back(std::move(x));
      vg_index.push_back(g);
    }
    const model::VarianceComponents vc = model::estimateVarianceComponents(vg);
    for (std::size_t k = 0; k < vg_index.size() && k < vc.factor.size(); ++k)
      out.chi2_per_dof[vg_index[k] / 2][vg_index[k] % 2] = vc.factor[k];
    out.variance_factor = factor;
    // The first pass's residuals hold the heads' relative mounting errors: factors from the second on.
    if (cfg.options.variance_components && pass >= 1 && pass + 1 < npass && vc.ok)
      for (std::size_t k = 0; k < vg_index.size(); ++k)
        factor[vg_index[k] / 2][vg_index[k] % 2] *= std::min(std::max(vc.factor[k], 1e-2), 1e2);

    if (fit_now) {
      // The noise as the data has it: every head axis's model fitted to this pass's innovations, in use
      // from the next pass on (at factor 1: the fit has the level).
      out.fitted_noise.assign(nh, {});
      model::NoiseFitOptions fo;
      fo.likelihood = model::NoiseLikelihood::Auto;
      fo.pl_terms = 6;  // each term is a filter state per head axis
      fo.band_lo = 3;   // a correlation time counts as determined when the span holds 3 of its periods
      const std::vector<model::NoiseStructure> st = {model::NoiseStructure::White, model::NoiseStructure::WhiteGaussMarkov,
                                                     model::NoiseStructure::WhitePowerLaw};
      // One fit per head axis, independent of the others: on options.threads threads.
      model::parallelFor(3 * nh, cfg.options.threads, [&](std::size_t ij) {
        const std::size_t i = ij / 3, j = ij % 3;
        {
          const model::NoiseSeries& sr = b.innovations_[3 * i + j];  // every k-th head sample's (above)
          if (sr.size() < 200) {
            out.fitted_noise[i][j] = cfg0.heads[i].noise[j];
            return;
          }
          const Eigen::MatrixXd X = Eigen::MatrixXd::Ones(static_cast<Eigen::Index>(sr.size()), 1);
          // The smallest BIC among the fits whose every parameter the span and sampling determine: a
          // correlation time or corner outside them (fitNoise says so) is slow content the span cannot
          // tell from a constant mounting error, and would hand the filter a wandering mounting.
          const model::NoiseSelection sel = model::selectNoise(sr, st, X, fo);
          const model::NoiseFit* best = nullptr;
          for (const auto& f : sel.fits) {
            if (f.model.empty()) continue;
            bool all = true;
            for (const auto& q : f.params) all = all && (q.derived || q.determined);
            if (all && (best == nullptr || f.bic < best->bic)) best = &f;
          }
          out.fitted_noise[i][j] = best != nullptr ? best->model : cfg0.heads[i].noise[j];
          if (best != nullptr && cfg.options.keep_slow_noise) {
            // What the span cannot determine, from the model stated beforehand: its Gauss-Markov parts
            // with a corner below the fit's band (the band of fitNoise: band_lo / span).
            const double f_band = fo.band_lo / std::max(sr.t_s.back() - sr.t_s.front(), 1.0);
            for (const auto& m : cfg0.heads[i].noise[j].markovTerms())
              if (1.0 / (2 * kPi * m.tau_s) < f_band) out.fitted_noise[i][j].add(model::NoiseTerm::gaussMarkov(std::sqrt(m.var), m.tau_s));
          }
        }
      });
      for (std::size_t i = 0; i < nh; ++i) factor[i] = {1.0, 1.0};
      for (std::size_t i = 0; i < nh; ++i)
        for (std::size_t j = 0; j < 3; ++j) base[i][j] = out.fitted_noise[i][j];
    }

    if (pass + 1 == npass && !b.blocks_.empty()) {
      std::vector<Eigen::MatrixXd> Nb;
      std::vector<Eigen::VectorXd> Gb;
      for (const auto& a : b.blocks_) {
        if (a.n <= 0) continue;
        Nb.push_back(a.N);
        Gb.push_back(a.b - a.N * th);
      }
      out.score_blocks = Nb.size();
      out.robust_covariance = robustCovariance(out.bound.covariance, Nb, Gb);
      out.robust_head_sigma_rad.assign(nh, Vec3::Zero());
      for (std::size_t i = 0; i < nh; ++i)
        for (int j = 0; j < 3; ++j) {
          const auto k = static_cast<Eigen::Index>(3 * i) + j;
          out.robust_head_sigma_rad[i](j) =
              std::isfinite(out.bound.head_sigma_rad[i](j)) ? std::sqrt(std::max(out.robust_covariance(k, k), 0.0)) : kInf;
        }
    }
  }
  out.mounting_rad = eps;
  out.harmonics = harm;
  out.bias_rad_s2 = bias;
  out.scale = scale;
  out.time_offset_s = -tau;  // tags late: the sample tagged t is the mean about t - offset
  return out;
}

RawBoundResult RawBound::result() const {
  RawBoundResult out;
  const std::size_t nh = cfg_.heads.size();
  const auto p = static_cast<Eigen::Index>(p_);
  static const char* kAxis[3] = {"e1", "e2", "b"};
  static const char* kA[3] = {"x", "y", "z"};
  for (std::size_t i = 0; i < nh; ++i)
    for (int j = 0; j < 3; ++j) out.names.push_back("head" + std::to_string(cfg_.heads[i].id) + "." + kAxis[j]);
  if (cfg_.options.bias)
    for (int a = 0; a < 3; ++a) out.names.push_back(std::string("acc_bias.") + kA[a]);
  if (cfg_.options.scale)
    for (int a = 0; a < 3; ++a) out.names.push_back(std::string("acc_scale.") + kA[a]);
  if (cfg_.options.time_offset) out.names.push_back("acc_time_offset");
  for (std::size_t i = 1; i < nh; ++i)
    for (int j = 0; j < 3; ++j)
      for (int k = 1; k <= cfg_.options.harmonics; ++k) {
        const std::string stem = "head" + std::to_string(cfg_.heads[i].id) + "." + kAxis[j] + ".h" + std::to_string(k);
        out.names.push_back(stem + "cos");
        out.names.push_back(stem + "sin");
      }

  // Eliminate the trajectory start (the last six columns).
  out.information = schurLeading(info_, p);  // the parameters lead, the start is last
  const ScaledInverse inv = scaledInverse(out.information);
  out.covariance = inv.cov;
  out.head_sigma_rad.assign(nh, Vec3::Zero());
  for (std::size_t i = 0; i < nh; ++i)
    for (int j = 0; j < 3; ++j) out.head_sigma_rad[i](j) = sigmaOf(inv, static_cast<Eigen::Index>(3 * i) + j);
  if (cfg_.options.bias)
    for (int a = 0; a < 3; ++a) out.bias_sigma_rad_s2(a) = sigmaOf(inv, static_cast<Eigen::Index>(col_bias_) + a);

  // Common rotation c (head 1's error in B) and relative errors r_i: e_1 = R_1 c, e_i = R_i c + r_i.
  Eigen::MatrixXd J = Eigen::MatrixXd::Identity(p, p);
  for (std::size_t i = 0; i < nh; ++i) {
    const auto row = static_cast<Eigen::Index>(3 * i);
    J.block(row, 0, 3, 3) = cfg_.heads[i].R_axes_B;
    if (i == 0) continue;
    J.block(row, row, 3, 3).setIdentity();
  }
  const Eigen::MatrixXd Inew = J.transpose() * out.information * J;
  const Eigen::MatrixXd Ic = schurLeading(Inew, 3);
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(Mat3(0.5 * (Ic + Ic.transpose())));
  const double top = std::max(es.eigenvalues().maxCoeff(), 0.0);
  for (int k = 0; k < 3; ++k) {
    const int src = 2 - k;  // largest information first
    const double lam = es.eigenvalues()(src);
    out.common_axes_B.col(k) = es.eigenvectors().col(src);
    out.common_sigma_rad(k) = lam > 1e-12 * top && lam > 0 ? 1 / std::sqrt(lam) : kInf;
  }
  // Directions of the common rotation above the observability threshold are held at their nominal value:
  // c = V_o c_o over the observable directions V_o only, the covariance of the head errors (and every
  // other parameter) that of the parameters (c_o, r_2.., rest) mapped back.
  {
    Eigen::MatrixXd Vo(3, 3);
    Eigen::Index ko = 0;
    for (int k = 0; k < 3; ++k) {
      if (out.common_sigma_rad(k) > cfg_.options.unobservable_sigma_rad) {
        out.unobservable_B.push_back(out.common_axes_B.col(k));
      } else {
        Vo.col(ko++) = out.common_axes_B.col(k);
      }
    }
    // Held parameters (estimateRaw's undetermined scale factors): their columns left out as well.
    std::vector<char> keep(static_cast<std::size_t>(p), 1);
    for (const std::size_t c : held_cols_)
      if (c >= 3 && static_cast<Eigen::Index>(c) < p) {
        keep[c] = 0;
        out.held.push_back(out.names[c]);
      }
    if (!out.unobservable_B.empty() || !out.held.empty()) {
      Eigen::Index nk = 0;
      for (Eigen::Index c = 3; c < p; ++c) nk += keep[static_cast<std::size_t>(c)];
      Eigen::MatrixXd Jp = Eigen::MatrixXd::Zero(p, ko + nk);
      Jp.leftCols(ko) = J.leftCols(3) * Vo.leftCols(ko);
      for (Eigen::Index c = 3, q = ko; c < p; ++c)
        if (keep[static_cast<std::size_t>(c)]) Jp.col(q++) = J.col(c);
      const ScaledInverse ci = scaledInverse(Jp.transpose() * out.information * Jp);
      out.covariance = Jp * ci.cov * Jp.transpose();
      for (std::size_t i = 0; i < nh; ++i)
        for (int j = 0; j < 3; ++j) {
          const auto k = static_cast<Eigen::Index>(3 * i) + j;
          out.head_sigma_rad[i](j) = std::sqrt(std::max(out.covariance(k, k), 0.0));
        }
      if (cfg_.options.bias)
        for (int a = 0; a < 3; ++a) {
          const auto k = static_cast<Eigen::Index>(col_bias_) + a;
          out.bias_sigma_rad_s2(a) = std::sqrt(std::max(out.covariance(k, k), 0.0));
        }
    }
  }
  const ScaledInverse inv_new = scaledInverse(Inew);
  out.relative_sigma_rad.assign(nh, Vec3::Zero());
  for (std::size_t i = 1; i < nh; ++i)
    for (int j = 0; j < 3; ++j) out.relative_sigma_rad[i](j) = sigmaOf(inv_new, static_cast<Eigen::Index>(3 * i) + j);

  out.span_s = started_ ? last_t_ - first_t_ : 0;
  out.head_samples = head_samples_;
  out.acc_samples = acc_samples_;
  out.acc_gaps = acc_gaps_;
  out.head_samples_before_acc = head_before_;
  return out;
}

RawMountings rawMountings(const RawEstimate& est, const RawBoundConfig& cfg, double not_determined_rad) {
  RawMountings out;
  const std::size_t n = cfg.heads.size();
  const auto n3 = static_cast<Eigen::Index>(3 * n);
  Eigen::MatrixXd T = Eigen::MatrixXd::Zero(n3, n3);  // head axes -> Si, per head (A^T)
  for (std::size_t i = 0; i < n; ++i)
    T.block<3, 3>(static_cast<Eigen::Index>(3 * i), static_cast<Eigen::Index>(3 * i)) = cfg.heads[i].axes_Si.transpose();
  const bool have = est.bound.covariance.rows() >= n3 && est.mounting_rad.size() >= n;
  out.covariance_Si = have ? Eigen::MatrixXd(T * est.bound.covariance.topLeftCorner(n3, n3) * T.transpose())
                           : Eigen::MatrixXd::Constant(n3, n3, std::numeric_limits<double>::quiet_NaN());
  if (have) out.covariance_Si = Eigen::MatrixXd(0.5 * (out.covariance_Si + out.covariance_Si.transpose()));  // exactly symmetric
  for (std::size_t i = 0; i < n; ++i) {
    out.r_Si.push_back(have ? est.mounting_rad[i] : Vec3::Zero());
    Vec3 sg = Vec3::Constant(std::numeric_limits<double>::quiet_NaN());
    const bool any = have && i < est.bound.head_sigma_rad.size() && std::isfinite(est.bound.head_sigma_rad[i].maxCoeff());
    for (int a = 0; a < 3; ++a) {
      const auto k = static_cast<Eigen::Index>(3 * i) + a;
      const double s = have ? std::sqrt(std::max(0.0, out.covariance_Si(k, k))) : 0.0;
      if (any && s > 0 && s < not_determined_rad) sg(a) = s;  // 0: an axis held with the common directions
    }
    out.sigma_Si.push_back(sg);
  }
  out.common_determined = have && est.bound.unobservable_B.empty();
  return out;
}

double parameterSigma(const RawBoundResult& r, const std::string& name) {
  for (std::size_t k = 0; k < r.names.size(); ++k)
    if (r.names[k] == name && static_cast<Eigen::Index>(k) < r.covariance.rows()) {
      const auto kk = static_cast<Eigen::Index>(k);
      return std::sqrt(std::max(0.0, r.covariance(kk, kk)));
    }
  return std::numeric_limits<double>::quiet_NaN();
}

std::vector<OrbitHarmonicTerm> orbitHarmonicTerms(const RawEstimate& est, const RawBoundConfig& cfg) {
  std::vector<OrbitHarmonicTerm> out;
  const int K = cfg.options.harmonics;
  if (K <= 0 || est.harmonics.size() == 0 || cfg.heads.size() < 2) return out;
  std::map<std::string, Eigen::Index> col;
  for (std::size_t q = 0; q < est.bound.names.size(); ++q) col[est.bound.names[q]] = static_cast<Eigen::Index>(q);
  static const char* kAxName[3] = {"e1", "e2", "b"};
  const auto colOf = [&](std::size_t i, int ax, int k, const char* cs) -> Eigen::Index {
    const auto it = col.find("head" + std::to_string(cfg.heads[i].id) + "." + kAxName[ax] + ".h" + std::to_string(k) + cs);
    return it == col.end() ? -1 : it->second;
  };
  const Eigen::Index hb = colOf(1, 0, 1, "cos");  // est.harmonics holds the terms from the first one on
  if (hb < 0) return out;
  for (std::size_t i = 1; i < cfg.heads.size(); ++i) {
    const Mat3& A = cfg.heads[i].axes_Si;
    for (int k = 1; k <= K; ++k) {
      OrbitHarmonicTerm t;
      t.head = i;
      t.harmonic = k;
      for (int c = 0; c < 2; ++c) {
        const char* cs = c == 0 ? "cos" : "sin";
        Vec3 hv;
        Mat3 C;
        Eigen::Index idx[3];
        for (int ax = 0; ax < 3; ++ax) {
          idx[ax] = colOf(i, ax, k, cs);
          if (idx[ax] < 0 || idx[ax] - hb >= est.harmonics.size()) return {};
          hv(ax) = est.harmonics(idx[ax] - hb);
        }
        for (int a = 0; a < 3; ++a)
          for (int b = 0; b < 3; ++b) C(a, b) = est.bound.covariance(idx[a], idx[b]);
        (c == 0 ? t.cos_Si : t.sin_Si) = -A.transpose() * hv;
        (c == 0 ? t.cov_cos_Si : t.cov_sin_Si) = A.transpose() * C * A;
      }
      out.push_back(t);
    }
  }
  return out;
}

}  // namespace boresight::calib
