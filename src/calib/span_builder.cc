#include "boresight/calib/span_builder.h"

#include "boresight/core/rotation.h"

#include <algorithm>
#include <cmath>

namespace boresight::calib {

namespace {

double sumSquares(const core::CrnKernel& k, int order) {
  double s = 0;
  for (int j = 0; j < k.nf; ++j) s += k.g[static_cast<std::size_t>(order)][static_cast<std::size_t>(j)] *
                                      k.g[static_cast<std::size_t>(order)][static_cast<std::size_t>(j)];
  return s;
}

// Correlation of white noise through kernel `order` between outputs `lag` samples apart.
double kernelCorrelation(const core::CrnKernel& k, int order, int lag) {
  const auto& g = k.g[static_cast<std::size_t>(order)];
  double s = 0;
  for (int j = 0; j + lag < k.nf; ++j) s += g[static_cast<std::size_t>(j)] * g[static_cast<std::size_t>(j + lag)];
  return s / sumSquares(k, order);
}

}  // namespace

bool SpanBuilder::configure(const core::PipelineConfig& cfg, const SpanOptions& opt, std::string* error) {
  configured_ = false;
  auto fail = [&](const std::string& m) {
    if (error) *error = m;
    return false;
  };
  if (core::validate(cfg.heads) != core::Status::kOk) return fail("span builder: invalid head configuration");
  const double head_dt = 1.0 / cfg.crn_attitude.fs_hz;
  if (!(opt.decimation_s >= head_dt) || !std::isfinite(opt.decimation_s))
    return fail("span builder: decimation_s must be at least the head sampling interval");
  if (!opt.acc_white_noise_radps2.allFinite() || (opt.acc_white_noise_radps2.array() < 0).any())
    return fail("span builder: acc_white_noise_radps2 must be finite and >= 0");
  cfg_ = cfg;
  cfg_.heads.relative_time_constant_s = 0.0;  // the batch mean keeps every epoch of the span
  opt_ = opt;
  if (validator_.configure(cfg_.heads) != core::Status::kOk) return fail("span builder: head validator refused");
  if (means_.configure(cfg_.heads) != core::Status::kOk) return fail("span builder: pair means refused");
  core::CrnConfig ch = cfg.crn_attitude;
  core::CrnConfig ca = cfg.crn_acc;
  if (opt.crn_bandwidth_hz > 0) ch.bandwidth_hz = ca.bandwidth_hz = opt.crn_bandwidth_hz;
  if (opt.crn_length_s > 0) ch.length_s = ca.length_s = opt.crn_length_s;
  ch.output_period_us = static_cast<TimeUs>(std::llround(opt.decimation_s * 1e6));
  for (int s = 0; s < cfg.heads.n_heads; ++s)
    if (rates_[static_cast<std::size_t>(s)].configure(ch) != core::Status::kOk)
      return fail("span builder: crn_attitude refused (rate, length or taps out of range)");
  ca.output_period_us = 0;  // evaluated on the heads' tags only
  if (acc_.configure(ca, Mat3::Identity()) != core::Status::kOk)
    return fail("span builder: crn_acc refused (rate, length or taps out of range)");

  const core::CrnKernel& kh = rates_[0].stream().kernel();
  const core::CrnKernel& ka = acc_.stream().kernel();
  const double g2 = sumSquares(kh, 2), g0 = sumSquares(ka, 0);
  for (int s = 0; s < cfg.heads.n_heads; ++s) {
    const auto& h = cfg.heads.head[static_cast<std::size_t>(s)];
    const Mat3 Sig = core::headCovariance(h.sigma_cross_rad, h.sigma_roll_rad, h.boresight_Si.normalized());
    cov_head_unit_[static_cast<std::size_t>(s)] = g2 * Sig;
    const Mat3 M = h.q_Si_B.normalized().toRotationMatrix();
    Mat3 W;
    if (!core::invertSpd3(M.transpose() * Sig * M, W)) return fail("span builder: head covariance not invertible");
    W_B_[static_cast<std::size_t>(s)] = W;
  }
  cov_acc_ = g0 * opt.acc_white_noise_radps2.cwiseAbs2().asDiagonal();

  span_ = CalibrationSpan{};
  span_.n_heads = cfg.heads.n_heads;
  for (int s = 0; s < cfg.heads.n_heads; ++s) {
    span_.head_ids[static_cast<std::size_t>(s)] = cfg.heads.head[static_cast<std::size_t>(s)].id;
    span_.q_S_B_nominal[static_cast<std::size_t>(s)] = cfg.heads.head[static_cast<std::size_t>(s)].q_Si_B.normalized();
  }
  span_.C_B_A = cfg.C_B_A;
  span_.decimation_s = opt.decimation_s;
  span_.crn_half_length_s = std::max(kh.half / kh.fs_hz, ka.half / ka.fs_hz);
  const int lag = static_cast<int>(std::llround(opt.decimation_s * kh.fs_hz));
  span_.noise_correlation.push_back(1.0);
  for (int k = 1; k * lag < kh.nf; ++k) {
    const double r = kernelCorrelation(kh, 2, k * lag);
    if (std::abs(r) < 1e-4) break;
    span_.noise_correlation.push_back(r);
  }
  // The second-derivative kernel passes no power at zero frequency and little above its band, so at a
  // decimation finer than about 1/B the epochs' correlation spectrum S(f) = 1 + 2 sum rho_k cos(2 pi f k)
  // nearly vanishes (and, cut at |rho| < 1e-4, goes negative: at 0.5, 1, 2, 4 and 5 s the whitening of
  // the bias column divided by ~0 and the residuals came out NaN). Its minimum is held at
  // kMinNoiseSpectrum by a white part (rho_k / (1 + eps), k > 0): the whitening then amplifies by at most
  // 1/sqrt(kMinNoiseSpectrum), and the weights err on the safe side (less information claimed in the
  // directions the kernel does not excite). Decimations of 8 s and more (S_min >= 0.3) are untouched.
  {
    constexpr double kMinNoiseSpectrum = 0.05;
    std::vector<double>& rho = span_.noise_correlation;
    double s_min = 1.0;
    for (int i = 0; i <= 4096 && rho.size() > 1; ++i) {
      const double f = 0.5 * i / 4096.0;
      double S = 1.0;
      for (std::size_t k = 1; k < rho.size(); ++k) S += 2.0 * rho[k] * std::cos(2.0 * kPi * f * static_cast<double>(k));
      s_min = std::min(s_min, S);
    }
    if (s_min < kMinNoiseSpectrum) {
      const double eps = (kMinNoiseSpectrum - s_min) / (1.0 - kMinNoiseSpectrum);
      for (std::size_t k = 1; k < rho.size(); ++k) rho[k] /= 1.0 + eps;
      span_.noise_white_fraction = eps / (1.0 + eps);
    }
  }
  pending_.clear();
  for (auto& w : wstate_) w = WhitenState{};
  have_head_ = false;
  have_emitted_ = false;
  last_emitted_t_ = 0;
  configured_ = true;
  return true;
}

core::Health SpanBuilder::health() const {
  core::Health h = validator_.health();
  for (int s = 0; s < cfg_.heads.n_heads; ++s) h.add(rates_[static_cast<std::size_t>(s)].health());
  h.add(acc_.health());
  h.add(means_.health());
  return h;
}

void SpanBuilder::pushHeads(const core::HeadEpoch& e) {
  if (!configured_) return;
  const core::Status st = validator_.step(e);
  if (st != core::Status::kOk) {
    ++span_.head_epochs_rejected;
    return;
  }
  const core::ValidHeads& v = validator_.output();
  if (!have_head_) span_.t_first = v.t;
  have_head_ = true;
  span_.t_last = v.t;
  ++span_.head_epochs;
  means_.step(v);
  relativeStep(v);
  for (int s = 0; s < cfg_.heads.n_heads; ++s) {
    if (!v.has(s)) continue;
    core::AttitudeRates& r = rates_[static_cast<std::size_t>(s)];
    r.step(v.t, v.q_I_Si[static_cast<std::size_t>(s)]);
    for (int i = 0; i < r.numOutputs(); ++i) addHeadOutput(s, r.output(i));
  }
  resolve();
}

void SpanBuilder::relativeStep(const core::ValidHeads& v) {
  RelativeNormal& rn = span_.relative_normal;
  const int n = cfg_.heads.n_heads;
  // reference: the first anchored head present
  int ref = -1;
  for (int h = 0; h < n && ref < 0; ++h)
    if (v.has(h) && rn.anchored[static_cast<std::size_t>(h)]) ref = h;
  if (ref < 0) {  // nobody anchored is here: anchor the first present head at its nominal mounting
    for (int h = 0; h < n && ref < 0; ++h)
      if (v.has(h)) ref = h;
    if (ref < 0) return;
    rn.anchored[static_cast<std::size_t>(ref)] = true;
    rn.q_S_B_anchor[static_cast<std::size_t>(ref)] = cfg_.heads.head[static_cast<std::size_t>(ref)].q_Si_B.normalized();
  }
  const auto rs = static_cast<std::size_t>(ref);
  const Quat R_ref = v.q_I_Si[rs] * rn.q_S_B_anchor[rs];  // q_I_B implied by the reference head
  int present[kMaxHeads];
  int m = 0;
  for (int h = 0; h < n; ++h) {
    if (!v.has(h)) continue;
    const auto hs = static_cast<std::size_t>(h);
    if (!rn.anchored[hs]) {  // first seen with an anchored head: anchor so that R_h = R_ref now
      rn.anchored[hs] = true;
      rn.q_S_B_anchor[hs] = (v.q_I_Si[hs].conjugate() * R_ref).normalized();
    }
    present[m++] = h;
  }
  if (m < 2) return;
  for (int a = 0; a < m; ++a)
    for (int b = 0; b < m; ++b)
      rn.together[static_cast<std::size_t>(present[a])][static_cast<std::size_t>(present[b])] = true;
  // x_h, W_h; eliminate the epoch's common offset: P^T W P = W - W 1 (sum W)^-1 1^T W
  std::array<Vec3, kMaxHeads> x{};
  std::array<Mat3, kMaxHeads> W{};
  Mat3 Ws = Mat3::Zero();
  Vec3 Wx = Vec3::Zero();
  for (int a = 0; a < m; ++a) {
    const auto hs = static_cast<std::size_t>(present[a]);
    const Quat R_h = v.q_I_Si[hs] * rn.q_S_B_anchor[hs];
    x[hs] = core::quatLog(R_ref.conjugate() * R_h);
    const double sc = v.sigma_scale[hs] > 0 ? v.sigma_scale[hs] : 1.0;
    W[hs] = W_B_[hs] / (sc * sc);
    Ws += W[hs];
    Wx += W[hs] * x[hs];
  }
  Mat3 Wsi;
  if (!core::invertSpd3(Ws, Wsi)) return;
  const Vec3 theta = Wsi * Wx;
  for (int a = 0; a < m; ++a) {
    const int ha = present[a];
    const auto as = static_cast<std::size_t>(ha);
    rn.info_x.segment<3>(3 * ha) += W[as] * (x[as] - theta);
    for (int b = 0; b < m; ++b) {
      const int hb = present[b];
      const auto bs = static_cast<std::size_t>(hb);
      Mat3 blk = -W[as] * Wsi * W[bs];
      if (a == b) blk += W[as];
      rn.info.block<3, 3>(3 * ha, 3 * hb) += blk;
    }
  }
  ++rn.epochs;
}

void SpanBuilder::addHeadOutput(int slot, const core::RateOutput& o) {
  if (!o.alpha_X.allFinite()) return;
  if (o.bridged > 0 && !std::isfinite(o.alpha_sigma_bridge)) return;  // linear bridging: no uncertainty
  if (have_emitted_ && o.t <= last_emitted_t_) {  // its observation is in the span already: one left out
    ++span_.late_head_outputs;
    return;
  }
  // pending_ is in time order; heads of one epoch share the tag, so the match is at the back
  auto it = pending_.end();
  while (it != pending_.begin() && std::prev(it)->t > o.t) --it;
  if (it == pending_.begin() || std::prev(it)->t != o.t) {
    Observation ob;
    ob.t = o.t;
    it = pending_.insert(it, ob);
  } else {
    --it;
  }
  const auto s = static_cast<std::size_t>(slot);
  it->has_head[s] = true;
  it->alpha_S[s] = o.alpha_X;
  it->cov_alpha_S[s] = cov_head_unit_[s];
  // a window with bridged samples adds their bound (per axis, in quadrature)
  if (o.bridged > 0) it->cov_alpha_S[s] += o.alpha_sigma_bridge * o.alpha_sigma_bridge * Mat3::Identity();
  // fused context rate: the first head's rate rotated to B with its nominal mounting
  if (it->w_B.isZero()) it->w_B = span_.q_S_B_nominal[s].conjugate() * o.w_X;
}

void SpanBuilder::pushAcc(TimeUs t, const Vec3& a_A) {
  if (!configured_) return;
  if (core::accepted(acc_.step(t, a_A))) ++span_.acc_samples;
  resolve();
}

void SpanBuilder::resolve() {
  while (!pending_.empty()) {
    Observation& ob = pending_.front();
    core::CrnStream<3>::Output o;
    const core::Status s = acc_.stream().evaluateAt(ob.t, o);
    if (s == core::Status::kNotReady) return;
    const bool bound_ok = o.bridged == 0 || o.sigma_bridge[0].allFinite();  // linear bridging: none
    if (s == core::Status::kOk && o.y[0].allFinite() && o.y[1].allFinite() && bound_ok) {
      ob.alpha_A = o.y[0];
      ob.jerk_A = o.y[1];
      ob.cov_alpha_A = cov_acc_;
      if (o.bridged > 0) {  // the bridged samples' bound
        const double b = o.sigma_bridge[0].norm();
        ob.cov_alpha_A += b * b * Mat3::Identity();
      }
      emit(std::move(ob));
    } else {
      ++span_.dropped_no_acc;
    }
    pending_.pop_front();
  }
}

// Streaming version of whitening.cc's banded Cholesky (same recurrences, epoch by epoch): row k of L
// from the last K rows, then z_k = (d_k - sum_m L(k,m) z_m) / L(k,k); moments of z and of d.
void SpanBuilder::accumulate(const Observation& ob) {
  const std::vector<double>& rho = span_.noise_correlation;
  const int K = static_cast<int>(rho.size()) - 1;
  ++span_.epochs_total;
  Eigen::Vector4d a4;
  a4 << ob.alpha_A, 1.0;
  span_.acc_moments += a4 * a4.transpose();
  for (int h = 0; h < cfg_.heads.n_heads; ++h) {
    const auto hs = static_cast<std::size_t>(h);
    if (!ob.has_head[hs]) continue;
    WhitenState& w = wstate_[hs];
    Eigen::Matrix<double, 10, 1> d;
    d << ob.alpha_S[hs], ob.alpha_A, ob.jerk_A, 1.0;
    const int m0 = static_cast<int>(w.t.size());  // previous epochs in the window: indices 0..m0-1
    auto corr = [&](TimeUs ta, TimeUs tb) {
      const long long lag = std::llround(std::abs(toSeconds(ta - tb)) / span_.decimation_s);
      return lag < static_cast<long long>(rho.size()) ? rho[static_cast<std::size_t>(lag)] : 0.0;
    };
    // Lk[j] = L(k, k - m0 + j) for j < m0; L(k,k) last. Window row r holds L(r, r-K..r) (K+1 entries).
    std::vector<double> Lk(static_cast<std::size_t>(K + 1), 0.0);
    auto Lwin = [&](int r, int c) -> double {  // L(r, c) for window rows r, c (window indices, c <= r)
      const int back = r - c;
      if (back > K) return 0.0;
      return w.L[static_cast<std::size_t>(r)][static_cast<std::size_t>(K - back)];
    };
    const int off = K + 1 - (m0 + 1);  // Lk index of window column j: off + j; of k itself: K
    for (int j = 0; j < m0; ++j) {
      double sum = corr(ob.t, w.t[static_cast<std::size_t>(j)]);
      for (int p = 0; p < j; ++p) sum -= Lk[static_cast<std::size_t>(off + p)] * Lwin(j, p);
      Lk[static_cast<std::size_t>(off + j)] = sum / Lwin(j, j);
    }
    double diag = 1.0;
    for (int j = 0; j < m0; ++j) diag -= Lk[static_cast<std::size_t>(off + j)] * Lk[static_cast<std::size_t>(off + j)];
    Lk[static_cast<std::size_t>(K)] = std::sqrt(std::max(diag, 1e-6));
    Eigen::Matrix<double, 10, 1> z = d;
    for (int j = 0; j < m0; ++j) z -= Lk[static_cast<std::size_t>(off + j)] * w.z[static_cast<std::size_t>(j)];
    z /= Lk[static_cast<std::size_t>(K)];
    HeadMoments& hm = span_.moments[hs];
    ++hm.n;
    hm.whitened += z * z.transpose();
    hm.raw += d * d.transpose();
    hm.cov = ob.cov_alpha_S[hs] + (span_.q_S_B_nominal[hs].toRotationMatrix() * span_.C_B_A) * ob.cov_alpha_A *
                                      (span_.q_S_B_nominal[hs].toRotationMatrix() * span_.C_B_A).transpose();
    // the window: rows re-indexed so that the newest is last; a row's entries refer to absolute lags
    w.t.push_back(ob.t);
    w.L.push_back(Lk);
    w.z.push_back(z);
    while (static_cast<int>(w.t.size()) > K) {
      w.t.pop_front();
      w.L.pop_front();
      w.z.pop_front();
    }
  }
}

void SpanBuilder::emit(Observation&& ob) {
  have_emitted_ = true;
  last_emitted_t_ = ob.t;
  accumulate(ob);
  if (!opt_.keep_observations) return;
  if (opt_.max_observations > 0 && span_.obs.size() >= opt_.max_observations) {
    // drop the oldest in blocks of 1/16 of the limit (one move of the vector per block, not per epoch)
    const std::size_t n = std::min(span_.obs.size(), std::max<std::size_t>(1, opt_.max_observations / 16));
    span_.obs.erase(span_.obs.begin(), span_.obs.begin() + static_cast<std::ptrdiff_t>(n));
  }
  span_.obs.push_back(std::move(ob));
}

void SpanBuilder::finish() {
  if (!configured_) return;
  resolve();
  span_.dropped_no_acc += pending_.size();
  pending_.clear();
  span_.relative.clear();
  for (int a = 0; a < cfg_.heads.n_heads; ++a)
    for (int b = a + 1; b < cfg_.heads.n_heads; ++b) {
      const core::PairMean m = means_.mean(a, b);
      if (!m.valid) continue;
      RelativeMean r;
      r.slot_i = a;
      r.slot_j = b;
      r.q_Si_Sj = m.q_Si_Sj;
      r.cov_Sj = m.cov_mean_Sj;
      r.epochs = m.n;
      span_.relative.push_back(r);
    }
}

}  // namespace boresight::calib
