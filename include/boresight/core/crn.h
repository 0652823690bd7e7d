// CRN digital filter and differentiator (METHODS 1.4): design at configure, streaming FIR at step.
//
// Design: Nf = fs Tf rounded to an odd number of taps, M = (Nf-1)/2, NB = round(B Tf'), Tf' = Nf/fs.
//   F_k = sum_{m=-NB..NB} D(k-m)^Nc,  D(j) = sin(pi j/Nc) / sin(pi j/Nf),  D(0) = Nf/Nc,  k = 0..M
// (a rectangle of half-width B convolved with the Nc-fold self-convolution of a rectangular window),
// then, with w_k = 2 pi k / Tf' and the kernel g applied as y(t_c) = sum_{n=-M..M} g[n] x(t_c + n/fs):
//   g0[n] = (F_0 + 2 sum_k F_k cos(2 pi k n/Nf)) / Nf          (low-pass, even)
//   g1[n] = 2/Nf sum_k w_k F_k sin(2 pi k n/Nf)                (first derivative, odd)
//   g2[n] = -2/Nf sum_k w_k^2 F_k cos(2 pi k n/Nf)             (second derivative, even)
// normalised to exact unit gain at zero frequency: sum g0 = 1, sum n g1 = fs, sum n^2 g2 = 2 fs^2
// (the limit of "unit gain at a low reference frequency").
//
// Streaming: a ring of the last kCrnRing samples (each written twice so that any window is
// contiguous) and, only at output epochs, one folded dot product per channel and order: the
// cost follows the output rate, not the input rate. The output is stamped at the centre tap, M/fs
// after the newest input (35.3 s for GRACE), which keeps the kernel zero-phase.
// Output epochs (grid mode): a centre sample whose time tag is within half a sampling interval of a
// multiple of output_period_us (the first such sample per grid point). evaluateAt(tau) evaluates the
// filter at any tag tau inside the history, from the nearest centre sample with a second-order
// Taylor step (tau - t_c, at most half a sampling interval) using the derivative kernels.
// Time: samples are taken as uniform at fs; tags may jitter by up to jitter_tolerance_us (tol). A step
// d is rounded to the nearest whole number n of intervals. n = 1 within tol: a normal sample. n <= 1
// outside tol (early, or late by more than tol but less than half an interval): kIrregularTime, the
// sample is dropped (a late sample's slot is then bridged by the next one). n >= 2: a gap of n-1
// missing samples; bridged (kGapBridged) when configured, n-1 <= max_bridge_samples and d is within
// n tol of n intervals: the missing samples get the tags t_last + d k/n (evenly spaced between the two
// real samples). Otherwise the filter restarts (kGapRestarted: history dropped, the new sample is the
// first of a new window).
// Bridged values (BridgeFit): kLinear - on the line between the two real neighbours (no uncertainty:
// NaN sigmas). kLocalFit (default) - a least-squares cubic in time through the real samples on both
// sides, so that the values follow the motion (a line through the neighbours misses the curvature by
// alpha T^2 / 8 over a gap of T). Samples per side: 4, 8, 16, 32 or 64 up to S = max(4, missing + 1)
// (S <= kMaxBridgeSamples + 1), the one with the smallest summed variance over the gap (short spans
// where the motion's curvature changes fast, long ones where noise dominates). At the gap only the
// sample after it is known: the values are then fitted from the samples before and that one, and
// fitted again at each of the next S - 1 real samples (before any output is evaluated), so the rows
// whose window centre is near the gap - emitted M samples later - use the two-sided fit. Each bridged
// value carries a 1-sigma per channel: the cubic's prediction variance scaled by its residual variance
// (noise and misfit of the span) plus the square of the quartic-minus-cubic difference (an estimate of
// the cubic's truncation error), and at least the largest difference to another span's values (where
// the spans disagree, the motion does what no cubic over one of them captures). Fewer than 5 real
// points (start of a window): linear values with NaN sigmas.
// Flagged outputs: an output (grid or evaluateAt) whose window holds bridged samples reports their
// number (Output::bridged) and per order and channel sum_j |g_o[j]| sigma_j over them (sigma_bridge:
// a bound on the bridged values' contribution that holds for any correlation between them, as the
// errors of one fit are strongly correlated). Outputs whose window holds only real samples are
// unchanged by the gap: bridged = 0, sigma_bridge = 0.
#pragma once

#include "boresight/core/capacities.h"
#include "boresight/core/conventions.h"
#include "boresight/core/fixed_ldlt.h"
#include "boresight/core/status.h"

#include <Eigen/Core>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>

namespace boresight::core {

enum class GapPolicy : std::uint8_t { kRestart = 0, kBridge = 1 };
/// How bridged samples get their values (see the header comment).
enum class BridgeFit : std::uint8_t { kLinear = 0, kLocalFit = 1 };

struct CrnConfig {
  double fs_hz = 10.0;       ///< input sampling rate, Hz
  int nc = 7;                ///< Nc, order of the self-convolution (-)
  double bandwidth_hz = 0.1; ///< B, half-width of the rectangle, Hz
  double length_s = 70.7;    ///< Tf, filter length, s (Nf = fs Tf rounded to odd <= kMaxCrnTaps)
  int max_order = 2;         ///< highest derivative order produced (0, 1 or 2)
  TimeUs output_period_us = kUsPerSecond;  ///< grid of output epochs, us (0: no grid outputs)
  TimeUs jitter_tolerance_us = 0;          ///< accepted |dt - 1/fs|, us (0: a quarter interval)
  GapPolicy gap_policy = GapPolicy::kRestart;
  int max_bridge_samples = 20;             ///< longest bridged gap, missing samples (<= kMaxBridgeSamples)
  BridgeFit bridge_fit = BridgeFit::kLocalFit;  ///< values of bridged samples

  /// Named construction (the defaults above, then these): CrnConfig::at(2.0).outputEvery(kUsPerSecond)
  /// .bridging(20) instead of a positional list that silently shifts when a field is added.
  static CrnConfig at(double fs) {
    CrnConfig c;
    c.fs_hz = fs;
    return c;
  }
  CrnConfig& outputEvery(TimeUs period_us) {
    output_period_us = period_us;
    return *this;
  }
  CrnConfig& bridging(int max_samples, BridgeFit fit = BridgeFit::kLocalFit) {
    gap_policy = GapPolicy::kBridge;
    max_bridge_samples = max_samples;
    bridge_fit = fit;
    return *this;
  }
};

/// Designed CRN kernels (full length, index j = n + M).
struct CrnKernel {
  int nf = 0;          ///< taps (odd)
  int half = 0;        ///< M = (nf-1)/2
  int nb = 0;          ///< NB, bins of half-width B
  double fs_hz = 0;
  double tf_s = 0;     ///< Nf / fs
  /// g[order][n + M]; zero beyond nf (up to kCrnKernelStride), so that a dot product may run over
  /// crnPaddedTaps(nf) taps: the padding adds exact zeros (the stream's ring holds only finite values)
  std::array<std::array<double, kCrnKernelStride>, 3> g{};

  /// Frequency response of the designed kernel of `order` at f (Hz): the real gain for order 0 and 2,
  /// the gain of the quadrature part for order 1 (ideal: 1, 2 pi f, -(2 pi f)^2 times the low-pass).
  double response(int order, double f_hz) const;
};

/// nf rounded up to a multiple of 8 (the vector loops of crnDot* then have no scalar tail).
constexpr int crnPaddedTaps(int nf) { return (nf + 7) & ~7; }

/// Designs the kernels; kInvalidConfig when the parameters are out of range.
Status designCrn(const CrnConfig& cfg, CrnKernel& out);

/// sum_j a[j] b[j], j < n, in eight interleaved partial sums added in a fixed order (vectorised; an
/// AVX2+FMA clone is picked at load time where the CPU has it: same order, fused multiply-adds).
double crnDot(const double* a, const double* b, int n);
/// Three channels at once with the kernel g0 + s g1 formed on the fly (value with a Taylor step).
void crnDotTaylor3(const double* g0, const double* g1, double s, const double* x0, const double* x1,
                   const double* x2, int n, double out[3]);
/// Four channels times three kernels: out[3 c + o] = sum_j g_o[j] x_c[j] (the rate filter's q, q', q'').
void crnDot4x3(const double* g0, const double* g1, const double* g2, const double* x0, const double* x1,
               const double* x2, const double* x3, int n, double out[12]);
/// The same folded about the centre tap for kernels that are even (orders 0, 2) or odd (order 1):
/// out[3 c + o] = centre[o] xc[c] + sum_{i < m} h_o[i] (xp_c[i] +- xm_c[i]) (+ for o = 0, 2; - for o = 1),
/// with h_o[i] = g_o at tap M+1+i, xp_c[i] = x_c at the centre + 1 + i, xm_c[i] = x_c at the centre - 1 - i.
/// Half the multiplies and kernel loads of crnDot4x3 (the stream keeps a reversed copy of its ring so
/// that xm is contiguous).
void crnDotFolded4x3(const double* h0, const double* h1, const double* h2, const double centre[3],
                     const double* const xp[4], const double* const xm[4], const double xc[4], int m, double out[12]);
/// out[j] = a[j] + s b[j], j < n.
void crnAxpy(const double* a, const double* b, double s, double* out, int n);

/// Streaming CRN filter of N channels.
template <int N>
class CrnStream {
 public:
  using VecN = Eigen::Matrix<double, N, 1>;
  struct Output {
    TimeUs t = 0;              ///< centre tag (grid mode) or requested tag (evaluateAt)
    std::array<VecN, 3> y{};   ///< y[0] low-passed value, y[1] first, y[2] second derivative (per s^k)
    int bridged = 0;           ///< bridged samples in the window (0: every sample real)
    /// per order: sum over the bridged samples of |g_o| times their sigma, per channel (0 when bridged
    /// is 0; NaN when a bridged value has no sigma: linear bridging)
    std::array<VecN, 3> sigma_bridge{};
  };

  Status configure(const CrnConfig& cfg) {
    configured_ = false;
    if (N < 1) return Status::kInvalidConfig;
    if (cfg.max_order < 0 || cfg.max_order > 2) return Status::kInvalidConfig;
    if (cfg.output_period_us < 0 || cfg.jitter_tolerance_us < 0) return Status::kInvalidConfig;
    if (cfg.max_bridge_samples < 0 || cfg.max_bridge_samples > kMaxBridgeSamples) return Status::kInvalidConfig;
    const Status s = designCrn(cfg, kernel_);
    if (s != Status::kOk) return s;
    cfg_ = cfg;
    if constexpr (kFolded) {  // the half kernels of the folded evaluation (zero beyond M)
      for (auto& h : half_) h.fill(0.0);
      for (int o = 0; o < 3; ++o)
        for (int i = 0; i < kernel_.half; ++i)
          half_[static_cast<std::size_t>(o)][static_cast<std::size_t>(i)] =
              kernel_.g[static_cast<std::size_t>(o)][static_cast<std::size_t>(kernel_.half + 1 + i)];
    }
    dt_us_ = static_cast<TimeUs>(std::llround(1e6 / cfg.fs_hz));
    tol_us_ = cfg.jitter_tolerance_us > 0 ? cfg.jitter_tolerance_us : dt_us_ / 4;
    if (tol_us_ >= dt_us_ / 2) return Status::kInvalidConfig;
    configured_ = true;
    reset();
    return Status::kOk;
  }

  void reset() {
    count_ = 0;
    pos_ = 0;
    have_last_ = false;
    last_t_ = 0;
    last_grid_ = INT64_MIN;
    n_out_ = 0;
    seq_ = 0;
    last_bridged_seq_ = INT64_MIN / 2;
    refit_ = Refit{};
    health_.clear();
  }

  /// Pushes one sample. Outputs completed by it are output(0..numOutputs()-1) until the next step.
  Status step(TimeUs t, const VecN& x) {
    n_out_ = 0;
    // the usual case first (small, inlined): the next slot, within the jitter tolerance (d > 0)
    const TimeUs d = t - last_t_;
    if (have_last_ && d >= dt_us_ - tol_us_ && d <= dt_us_ + tol_us_ && configured_ && finite(x)) {
      push(t, x, true);
      health_.record(Status::kOk);
      return Status::kOk;
    }
    return stepGeneral(t, x);
  }

 private:
  static bool finite(const VecN& x) {
    bool ok = true;
    for (int ch = 0; ch < N; ++ch) ok = ok && std::isfinite(x[ch]);
    return ok;
  }

  // Every other case: first sample, bad input, time errors, gaps (bridged or restarting).
  __attribute__((noinline)) Status stepGeneral(TimeUs t, const VecN& x) {
    if (!configured_) return record(Status::kNotConfigured);
    if (!finite(x)) return record(Status::kNonFinite);
    Status result = Status::kOk;
    if (have_last_) {
      const TimeUs d = t - last_t_;
      if (d < 0) return record(Status::kTimeBackwards);
      if (d == 0) return record(Status::kDuplicateTime);
      // The step in whole sampling intervals, rounded to the nearest; it is on the grid when its
      // intervals deviate from dt by at most the tolerance each (n intervals: n * tol in all).
      const TimeUs n = (d + dt_us_ / 2) / dt_us_;
      const TimeUs dev = d - n * dt_us_;
      const bool on_grid = n >= 1 && dev <= n * tol_us_ && -dev <= n * tol_us_;
      if (n <= 1 && !on_grid) return record(Status::kIrregularTime);  // too early or too late for its slot
      if (n > 1) {
        const TimeUs missing = n - 1;
        if (cfg_.gap_policy == GapPolicy::kBridge && on_grid && missing <= cfg_.max_bridge_samples && count_ > 0) {
          // missing samples evenly spaced between the last real sample and this one
          refit_.active = false;  // a gap ends the refinement of the previous one
          const TimeUs t0 = last_t_;
          const VecN x0 = last_x_;
          const int m = static_cast<int>(missing);
          const std::int64_t first = seq_ + 1;
          bool fitted = false;
          if (cfg_.bridge_fit == BridgeFit::kLocalFit) {
            refit_.first_seq = first;
            refit_.missing = m;
            refit_.side = std::min(kMaxBridgeSamples + 1, std::max(4, m + 1));
            refit_.after = 0;
            for (int k = 1; k <= m; ++k) gap_t_[static_cast<std::size_t>(k - 1)] = t0 + (d * k) / n;
            fitted = fitGap(&t, &x);
          }
          for (int k = 1; k <= m; ++k) {
            const auto u = static_cast<std::size_t>(k - 1);
            if (!fitted) {
              const double f = static_cast<double>(k) / static_cast<double>(n);
              gap_x_[u] = x0 + f * (x - x0);
              gap_s_[u] = VecN::Constant(std::numeric_limits<double>::quiet_NaN());
            }
            push(t0 + (d * k) / n, gap_x_[u], false, &gap_s_[u]);
          }
          refit_.active = fitted;
          refit_.after = 0;
          result = Status::kGapBridged;
        } else {
          count_ = 0;
          refit_.active = false;
          result = Status::kGapRestarted;
        }
      }
    }
    push(t, x, true);
    return record(result);
  }

 public:
  /// Evaluates the filter at tag tau from the current history (no allocation).
  /// kNotReady: not enough samples after tau yet; kUnavailable: tau is not covered (too old, in a
  /// restarted gap, or before the first sample).
  Status evaluateAt(TimeUs tau, Output& out) const {
    int c = 0;
    double dts = 0;
    const Status s = locate(tau, c, dts);
    if (s != Status::kOk) return s;
    Output o;
    const int top = cfg_.max_order;
    evaluate(c, top, o);
    // second-order Taylor step from the centre tag to tau (|dts| <= half an interval)
    if (top >= 1) o.y[0] += o.y[1] * dts;
    if (top >= 2) {
      o.y[0] += 0.5 * dts * dts * o.y[2];
      o.y[1] += o.y[2] * dts;
    }
    o.t = tau;
    out = o;
    return Status::kOk;
  }

  /// The low-passed value only at tag tau (statuses as evaluateAt): with max_order >= 1 the
  /// first-order Taylor step is folded into one kernel, g0 + (tau - t_c) g1, so one pass per channel
  /// (the accelerometer path: order 2 ignored, |dts| <= half an interval).
  /// With `bridged` given: the bridged samples in the window and, in `sigma0`, their order-0 bound per
  /// channel (Output::bridged, sigma_bridge[0]; 0 when none).
  Status evaluateValueAt(TimeUs tau, VecN& y, int* bridged = nullptr, VecN* sigma0 = nullptr) const {
    int c = 0;
    double dts = 0;
    const Status s = locate(tau, c, dts);
    if (s != Status::kOk) return s;
    if (bridged != nullptr) {
      Output b;
      bridgeTerms(c, 0, b);
      *bridged = b.bridged;
      if (sigma0 != nullptr) *sigma0 = b.sigma_bridge[0];
    }
    const int M = kernel_.half, L = 2 * M + 1;
    if constexpr (N == 3) {
      if (cfg_.max_order >= 1) {
        double r[3];
        crnDotTaylor3(kernel_.g[0].data(), kernel_.g[1].data(), dts, &buf_[0][static_cast<std::size_t>(c - M)],
                      &buf_[1][static_cast<std::size_t>(c - M)], &buf_[2][static_cast<std::size_t>(c - M)],
                      crnPaddedTaps(L), r);
        y = VecN(r[0], r[1], r[2]);
        return Status::kOk;
      }
    }
    const double* g = kernel_.g[0].data();
    std::array<double, kMaxCrnTaps> k;  // the combined kernel (stack, no heap)
    if (cfg_.max_order >= 1) {
      crnAxpy(kernel_.g[0].data(), kernel_.g[1].data(), dts, k.data(), L);
      g = k.data();
    }
    for (int ch = 0; ch < N; ++ch)
      y[ch] = crnDot(g, &buf_[static_cast<std::size_t>(ch)][static_cast<std::size_t>(c - M)], L);
    return Status::kOk;
  }

  int numOutputs() const { return n_out_; }
  const Output& output(int i) const { return outputs_[static_cast<std::size_t>(i)]; }
  const CrnKernel& kernel() const { return kernel_; }
  const Health& health() const { return health_; }
  /// Delay of the centre tap behind the newest input, us.
  TimeUs delayUs() const { return static_cast<TimeUs>(kernel_.half) * dt_us_; }
  TimeUs samplingIntervalUs() const { return dt_us_; }
  TimeUs newestTime() const { return last_t_; }
  bool hasSamples() const { return count_ > 0; }

 private:
  Status record(Status s) {
    health_.record(s);
    return s;
  }

  // Doubled ring: sample p lives at p and p + kCrnRing of buf_[ch]; the newest is at pos_ + kCrnRing.
  int centreIndex(int k_back) const { return pos_ + kCrnRing - k_back; }

  void writeSlot(int slot, const VecN& x) {
    for (int ch = 0; ch < N; ++ch) {
      buf_[static_cast<std::size_t>(ch)][static_cast<std::size_t>(slot)] = x[ch];
      buf_[static_cast<std::size_t>(ch)][static_cast<std::size_t>(slot + kCrnRing)] = x[ch];
      if constexpr (kFolded) {  // slot s also at kCrnRing-1-s and 2 kCrnRing-1-s: older samples follow
        rev_[static_cast<std::size_t>(ch)][static_cast<std::size_t>(kCrnRing - 1 - slot)] = x[ch];
        rev_[static_cast<std::size_t>(ch)][static_cast<std::size_t>(2 * kCrnRing - 1 - slot)] = x[ch];
      }
    }
  }

  // Ring slot of the sample `back` pushes before the newest.
  int slotBack(std::int64_t back) const { return static_cast<int>((pos_ - back) & (kCrnRing - 1)); }

  // A real sample (sigma null) or a bridged one with its 1-sigma per channel.
  void push(TimeUs t, const VecN& x, bool real, const VecN* sigma = nullptr) {
    pos_ = (pos_ + 1) & (kCrnRing - 1);
    ++seq_;
    writeSlot(pos_, x);
    bridged_[static_cast<std::size_t>(pos_)] = real ? 0 : 1;
    if (!real) {
      bsig_[static_cast<std::size_t>(pos_)] = *sigma;
      last_bridged_seq_ = seq_;
    }
    times_[static_cast<std::size_t>(pos_)] = t;
    if (count_ < kCrnRing) ++count_;
    have_last_ = true;
    last_t_ = t;
    if (real) last_x_ = x;
    if (real && refit_.active) refine();  // before any output reads the bridged values
    if (cfg_.output_period_us <= 0) return;
    const int M = kernel_.half;
    if (count_ < 2 * M + 1) return;
    const int c = centreIndex(M);
    const TimeUs tc = times_[static_cast<std::size_t>(c & (kCrnRing - 1))];
    const TimeUs P = cfg_.output_period_us;
    const TimeUs g = (tc >= 0 ? (tc + P / 2) / P : -((-tc + P / 2) / P));
    const TimeUs off = tc - g * P;
    if (off > dt_us_ / 2 || off < -dt_us_ / 2 || g <= last_grid_) return;
    if (n_out_ >= kMaxCrnOutputsPerStep) return;
    last_grid_ = g;
    Output& o = outputs_[static_cast<std::size_t>(n_out_++)];
    evaluate(c, cfg_.max_order, o);
    o.t = tc;
  }

  // One more real sample after the gap under refinement: fit again and rewrite the bridged slots.
  void refine() {
    ++refit_.after;
    if (!fitGap(nullptr, nullptr)) {
      refit_.active = false;
      return;
    }
    for (int k = 0; k < refit_.missing; ++k) {
      const std::int64_t back = seq_ - (refit_.first_seq + k);
      if (back >= count_) continue;  // already out of the ring (not for gaps <= kMaxBridgeSamples)
      const int slot = slotBack(back);
      writeSlot(slot, gap_x_[static_cast<std::size_t>(k)]);
      bsig_[static_cast<std::size_t>(slot)] = gap_s_[static_cast<std::size_t>(k)];
    }
    if (refit_.after >= refit_.side) refit_.active = false;
  }

  // The local fit of the gap in refit_ (tags gap_t_) into gap_x_ / gap_s_, with the samples per side
  // chosen among 4, 8, 16, 32, 64 up to refit_.side by the smallest summed variance over the gap (a
  // short span where the motion's curvature changes fast, a long one where noise dominates). Per
  // candidate: the real samples before the gap (back to a restart or an earlier bridged sample), the
  // real samples after it in the ring (refit_.after at most), and the one sample (extra_t, extra_x) when
  // given (the sample that closes the gap, not pushed yet). false (nothing written) when no candidate
  // has 5 points and a regular fit. A candidate of 5 points (its quartic exactly determined, so its
  // truncation estimate is unreliable) is taken only when no candidate has 6.
  bool fitGap(const TimeUs* extra_t, const VecN* extra_x) {
    double best = std::numeric_limits<double>::infinity();
    int n_cand = 0;
    // candidates whose quartic (the truncation estimate) keeps a degree of freedom; only when there is
    // none (a short gap closed by one sample: 4 + 1 points), the exactly determined quartic
    for (int min_points = 6; min_points >= 5 && n_cand == 0; --min_points)
      for (int side = 4;; side *= 2) {
        const int sd = std::min(side, refit_.side);
        double score = 0;
        if (fitGapSide(sd, min_points, extra_t, extra_x, score)) {
          for (int k = 0; k < refit_.missing; ++k) {
            const auto uk = static_cast<std::size_t>(k);
            alt_x_[static_cast<std::size_t>(n_cand)][uk] = cand_x_[uk];
            alt_s_[static_cast<std::size_t>(n_cand)][uk] = cand_s_[uk];
          }
          ++n_cand;
          if (score < best) {
            best = score;
            for (int k = 0; k < refit_.missing; ++k) {
              gap_x_[static_cast<std::size_t>(k)] = cand_x_[static_cast<std::size_t>(k)];
              gap_s_[static_cast<std::size_t>(k)] = cand_s_[static_cast<std::size_t>(k)];
            }
          }
        }
        if (sd >= refit_.side) break;
      }
    // the spans disagree where the motion does what no cubic over one of them captures: the sigma is at
    // least the largest disagreement with the chosen values (and, while only the closing sample follows
    // the gap, the values are extrapolated from one side: there the largest sigma of any span, too)
    for (int c = 0; c < n_cand; ++c)
      for (int k = 0; k < refit_.missing; ++k) {
        const auto uk = static_cast<std::size_t>(k), uc = static_cast<std::size_t>(c);
        gap_s_[uk] = gap_s_[uk].cwiseMax((alt_x_[uc][uk] - gap_x_[uk]).cwiseAbs());
        if (extra_t != nullptr) gap_s_[uk] = gap_s_[uk].cwiseMax(alt_s_[uc][uk]);
      }
    return n_cand > 0;
  }

  // One candidate of fitGap with `side` samples per side into cand_x_ / cand_s_; score: the sum of the
  // variances over the gap and channels.
  bool fitGapSide(int side, int min_points, const TimeUs* extra_t, const VecN* extra_x, double& score) {
    const int m = refit_.missing;
    const TimeUs tc = gap_t_[0] + (gap_t_[static_cast<std::size_t>(m - 1)] - gap_t_[0]) / 2;
    const double h = (side + 0.5 * (m + 1)) * toSeconds(dt_us_);  // tau = (t - tc) / h in about [-1, 1]
    int n = 0;
    auto add = [&](TimeUs t, const VecN& x) {
      fit_tau_[static_cast<std::size_t>(n)] = toSeconds(t - tc) / h;
      fit_x_[static_cast<std::size_t>(n)] = x;
      ++n;
    };
    for (int i = 1; i <= side; ++i) {
      const std::int64_t back = seq_ - (refit_.first_seq - i);
      if (back < 0 || back >= count_) break;
      const int slot = slotBack(back);
      if (bridged_[static_cast<std::size_t>(slot)]) break;
      add(times_[static_cast<std::size_t>(slot)], ringValue(slot));
    }
    for (int i = 0; i < std::min(refit_.after, side); ++i) {
      const std::int64_t back = seq_ - (refit_.first_seq + m + i);
      if (back < 0 || back >= count_) break;
      const int slot = slotBack(back);
      if (bridged_[static_cast<std::size_t>(slot)]) break;
      add(times_[static_cast<std::size_t>(slot)], ringValue(slot));
    }
    if (extra_t != nullptr) add(*extra_t, *extra_x);
    if (n < min_points) return false;
    // normal equations of the quartic in tau (the cubic's are their leading 4 x 4 block)
    Eigen::Matrix<double, 5, 5> A = Eigen::Matrix<double, 5, 5>::Zero();
    Eigen::Matrix<double, 5, N> B = Eigen::Matrix<double, 5, N>::Zero();
    for (int i = 0; i < n; ++i) {
      const double u = fit_tau_[static_cast<std::size_t>(i)];
      const Eigen::Matrix<double, 5, 1> p(1.0, u, u * u, u * u * u, u * u * u * u);
      A.noalias() += p * p.transpose();
      B.noalias() += p * fit_x_[static_cast<std::size_t>(i)].transpose();
    }
    Eigen::Matrix<double, 4, 4> L3;
    Eigen::Matrix<double, 4, 1> D3;
    Eigen::Matrix<double, 5, 5> L4;
    Eigen::Matrix<double, 5, 1> D4;
    const Eigen::Matrix<double, 4, 4> A3 = A.template topLeftCorner<4, 4>();
    if (!ldltFactor<4>(A3, L3, D3) || !ldltFactor<5>(A, L4, D4)) return false;
    Eigen::Matrix<double, 4, N> c3;
    Eigen::Matrix<double, 5, N> c4;
    for (int ch = 0; ch < N; ++ch) {
      Eigen::Matrix<double, 4, 1> b3 = B.template block<4, 1>(0, ch);
      Eigen::Matrix<double, 5, 1> b4 = B.col(ch);
      ldltSolveInPlace<4>(L3, D3, b3);
      ldltSolveInPlace<5>(L4, D4, b4);
      c3.col(ch) = b3;
      c4.col(ch) = b4;
    }
    VecN rss = VecN::Zero();  // the cubic's residuals
    for (int i = 0; i < n; ++i) {
      const double u = fit_tau_[static_cast<std::size_t>(i)];
      const Eigen::Matrix<double, 4, 1> p(1.0, u, u * u, u * u * u);
      rss += (fit_x_[static_cast<std::size_t>(i)].transpose() - p.transpose() * c3).transpose().cwiseAbs2();
    }
    const VecN s2 = rss / static_cast<double>(n - 4);
    score = 0;
    for (int k = 0; k < m; ++k) {
      const auto uk = static_cast<std::size_t>(k);
      const double u = toSeconds(gap_t_[uk] - tc) / h;
      const Eigen::Matrix<double, 4, 1> p3(1.0, u, u * u, u * u * u);
      const Eigen::Matrix<double, 5, 1> p4(1.0, u, u * u, u * u * u, u * u * u * u);
      Eigen::Matrix<double, 4, 1> y = p3;
      ldltSolveInPlace<4>(L3, D3, y);
      const double lever = p3.dot(y);  // p^T (X^T X)^-1 p
      const VecN v3 = (p3.transpose() * c3).transpose();
      const VecN v4 = (p4.transpose() * c4).transpose();
      const VecN var = s2 * lever + (v4 - v3).cwiseAbs2();
      if (!v3.allFinite() || !var.allFinite()) return false;
      cand_x_[uk] = v3;
      cand_s_[uk] = var.cwiseSqrt();
      score += var.sum();
    }
    return true;
  }

  VecN ringValue(int slot) const {
    VecN v;
    for (int ch = 0; ch < N; ++ch) v[ch] = buf_[static_cast<std::size_t>(ch)][static_cast<std::size_t>(slot)];
    return v;
  }

  // Output::bridged and sigma_bridge of the window centred at doubled-ring index c (see the header).
  void bridgeTerms(int c, int top, Output& o) const {
    o.bridged = 0;
    for (auto& v : o.sigma_bridge) v.setZero();
    const int M = kernel_.half;
    const std::int64_t oldest_back = static_cast<std::int64_t>(pos_ + kCrnRing - c) + M;
    if (seq_ - last_bridged_seq_ > oldest_back) return;  // the newest bridged sample is older than the window
    for (int j = 0; j <= 2 * M; ++j) {
      const int slot = (c - M + j) & (kCrnRing - 1);
      if (!bridged_[static_cast<std::size_t>(slot)]) continue;
      ++o.bridged;
      const VecN& sg = bsig_[static_cast<std::size_t>(slot)];
      for (int order = 0; order <= top; ++order)
        o.sigma_bridge[static_cast<std::size_t>(order)] +=
            std::abs(kernel_.g[static_cast<std::size_t>(order)][static_cast<std::size_t>(j)]) * sg;
    }
  }

  // The centre sample c (doubled-ring index) nearest to tau and tau - t_c (s).
  Status locate(TimeUs tau, int& c, double& dts) const {
    if (!configured_ || count_ == 0) return Status::kNotReady;
    const TimeUs ahead = last_t_ - tau;  // newest minus tau
    const int M = kernel_.half;
    if (ahead < 0) return Status::kNotReady;
    TimeUs k = (ahead + dt_us_ / 2) / dt_us_;
    if (k > kCrnRing) return Status::kUnavailable;
    for (int it = 0; it < 4; ++it) {  // tags jitter: move to the sample nearest to tau
      if (k >= count_) break;
      const TimeUs tk = times_[static_cast<std::size_t>((pos_ - static_cast<int>(k)) & (kCrnRing - 1))];
      if (tau - tk > dt_us_ / 2 && k > 0) {
        --k;
      } else if (tk - tau > dt_us_ / 2) {
        ++k;
      } else {
        break;
      }
    }
    if (k < M) return Status::kNotReady;
    if (k + M > count_ - 1 || k + M > kCrnRing - 1) return Status::kUnavailable;
    c = centreIndex(static_cast<int>(k));
    const TimeUs tc = times_[static_cast<std::size_t>(c & (kCrnRing - 1))];
    if (std::abs(tau - tc) > dt_us_ / 2 + tol_us_) return Status::kUnavailable;
    dts = toSeconds(tau - tc);
    return Status::kOk;
  }

  // Per channel and order one contiguous dot product over the 2M+1 taps (crnDot: fixed summation
  // order, vectorised; the doubled ring makes every window contiguous).
  void evaluate(int c, int top, Output& o) const {
    const int M = kernel_.half, L = 2 * M + 1;
    if constexpr (kFolded) {
      if (top == 2) {
        double r[12];
        // x at the centre + 1 + i (forward ring) and at the centre - 1 - i (reversed ring, slot s at
        // kCrnRing - 1 - s: the sample before the centre's slot sc is at kCrnRing - sc)
        const auto f = static_cast<std::size_t>(c + 1);
        const auto b = static_cast<std::size_t>(kCrnRing - (c & (kCrnRing - 1)));
        const double* xp[4] = {&buf_[0][f], &buf_[1][f], &buf_[2][f], &buf_[3][f]};
        const double* xm[4] = {&rev_[0][b], &rev_[1][b], &rev_[2][b], &rev_[3][b]};
        const auto uc = static_cast<std::size_t>(c);
        const double xc[4] = {buf_[0][uc], buf_[1][uc], buf_[2][uc], buf_[3][uc]};
        const auto um = static_cast<std::size_t>(M);
        const double centre[3] = {kernel_.g[0][um], kernel_.g[1][um], kernel_.g[2][um]};
        crnDotFolded4x3(half_[0].data(), half_[1].data(), half_[2].data(), centre, xp, xm, xc, (M + 3) & ~3, r);
        for (int ch = 0; ch < 4; ++ch)
          for (int order = 0; order < 3; ++order) o.y[static_cast<std::size_t>(order)][ch] = r[3 * ch + order];
        bridgeTerms(c, top, o);
        return;
      }
    }
    for (int ch = 0; ch < N; ++ch) {
      const double* x = &buf_[static_cast<std::size_t>(ch)][static_cast<std::size_t>(c - M)];
      for (int order = 0; order < 3; ++order)
        o.y[static_cast<std::size_t>(order)][ch] =
            order <= top ? crnDot(kernel_.g[static_cast<std::size_t>(order)].data(), x, L) : 0.0;
    }
    bridgeTerms(c, top, o);
  }

  CrnConfig cfg_{};
  CrnKernel kernel_{};
  bool configured_ = false;
  TimeUs dt_us_ = 0, tol_us_ = 0;
  // + 8: a window ending at the newest sample may be read on to its padded length (crnPaddedTaps;
  // the kernel's padding taps are zero and every value here is finite, so they add exact zeros)
  std::array<std::array<double, 2 * kCrnRing + 8>, static_cast<std::size_t>(N)> buf_{};
  // The rate filter (4 channels, orders 0-2) evaluates folded about the centre tap: its kernels are
  // even, odd, even (half the multiplies and kernel loads) with a reversed copy of the ring.
  static constexpr bool kFolded = N == 4;
  std::array<std::array<double, kFolded ? 2 * kCrnRing + 8 : 1>, static_cast<std::size_t>(N)> rev_{};
  std::array<std::array<double, kFolded ? kCrnKernelStride / 2 + 8 : 1>, 3> half_{};  ///< g_o at M+1+i
  std::array<TimeUs, kCrnRing> times_{};
  int pos_ = 0;
  int count_ = 0;
  bool have_last_ = false;
  TimeUs last_t_ = 0;
  VecN last_x_ = VecN::Zero();
  TimeUs last_grid_ = INT64_MIN;
  std::array<Output, kMaxCrnOutputsPerStep> outputs_{};
  int n_out_ = 0;
  Health health_{};
  // Bridging: per slot whether the sample is bridged and its 1-sigma; the sequence number (pushes since
  // reset) of the newest sample and of the newest bridged one; the gap under refinement.
  std::int64_t seq_ = 0;
  std::int64_t last_bridged_seq_ = INT64_MIN / 2;
  std::array<std::uint8_t, kCrnRing> bridged_{};
  std::array<VecN, kCrnRing> bsig_{};
  struct Refit {
    bool active = false;
    std::int64_t first_seq = 0;  ///< sequence number of the first bridged sample
    int missing = 0, side = 0;   ///< bridged samples; real samples used per side
    int after = 0;               ///< real samples after the gap seen so far
  };
  Refit refit_{};
  static constexpr int kFitMax = 2 * (kMaxBridgeSamples + 1) + 1;
  std::array<TimeUs, kMaxBridgeSamples> gap_t_{};
  std::array<VecN, kMaxBridgeSamples> gap_x_{}, gap_s_{}, cand_x_{}, cand_s_{};
  std::array<std::array<VecN, kMaxBridgeSamples>, 5> alt_x_{}, alt_s_{};  ///< every candidate's values, sigmas
  std::array<double, kFitMax> fit_tau_{};
  std::array<VecN, kFitMax> fit_x_{};
};

}  // namespace boresight::core
