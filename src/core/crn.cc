#include "boresight/core/crn.h"

#include <cmath>
#include <cstring>

// Run-time dispatch of the inner loops (GCC on x86-64 Linux): an x86-64-v3 (AVX2 + FMA) clone and the
// baseline, chosen once at load time (ifunc, no allocation). Same lanes and summation order in both;
// the v3 clone fuses multiply-adds (crn.cc is compiled with -ffp-contract=fast), so its results can
// differ from the baseline's in the last bits (a few 1e-16 relative), never between runs on one machine.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && defined(__linux__) && \
    !defined(BORESIGHT_NO_TARGET_CLONES)
#define BORESIGHT_CLONES __attribute__((target_clones("arch=x86-64-v3", "default")))
#else
#define BORESIGHT_CLONES
#endif

namespace boresight::core {

// Four-lane vectors (GCC/clang vector extension: AVX registers in the v3 clone, SSE2 pairs in the
// baseline); loads through memcpy (unaligned, no aliasing issue). Every sum below is lane-wise and
// then reduced in a fixed order.
// (-Wpsabi: the helpers pass V4 by value; they are internal and inlined, no ABI crosses a boundary.)
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic ignored "-Wpsabi"
#endif
typedef double V4 __attribute__((vector_size(32)));

namespace {
__attribute__((always_inline)) inline V4 load4(const double* p) {
  V4 v;
  std::memcpy(&v, p, sizeof v);
  return v;
}
__attribute__((always_inline)) inline double hsum(V4 v) { return (v[0] + v[2]) + (v[1] + v[3]); }
}  // namespace

BORESIGHT_CLONES double crnDot(const double* a, const double* b, int n) {
  V4 s0 = {0, 0, 0, 0}, s1 = {0, 0, 0, 0};
  int j = 0;
  for (; j + 8 <= n; j += 8) {
    s0 += load4(a + j) * load4(b + j);
    s1 += load4(a + j + 4) * load4(b + j + 4);
  }
  double r = 0;
  for (; j < n; ++j) r += a[j] * b[j];
  return hsum(s0 + s1) + r;
}

BORESIGHT_CLONES void crnDotTaylor3(const double* g0, const double* g1, double s, const double* x0, const double* x1,
                                    const double* x2, int n, double out[3]) {
  const V4 sv = {s, s, s, s};
  V4 a0 = {0, 0, 0, 0}, a1 = a0, a2 = a0, b0 = a0, b1 = a0, b2 = a0;
  int j = 0;
  // one block of 8 taps: a* take its first four, b* its last four
  auto block = [&](int i) __attribute__((always_inline)) {
    const V4 k = load4(g0 + i) + sv * load4(g1 + i);
    const V4 kk = load4(g0 + i + 4) + sv * load4(g1 + i + 4);
    a0 += k * load4(x0 + i);
    a1 += k * load4(x1 + i);
    a2 += k * load4(x2 + i);
    b0 += kk * load4(x0 + i + 4);
    b1 += kk * load4(x1 + i + 4);
    b2 += kk * load4(x2 + i + 4);
  };
  for (; j + 16 <= n; j += 16) {  // two blocks per pass (less loop overhead; the same sums in the same order)
    block(j);
    block(j + 8);
  }
  for (; j + 8 <= n; j += 8) block(j);
  double r0 = 0, r1 = 0, r2 = 0;
  for (; j < n; ++j) {
    const double k = g0[j] + s * g1[j];
    r0 += k * x0[j];
    r1 += k * x1[j];
    r2 += k * x2[j];
  }
  out[0] = hsum(a0 + b0) + r0;
  out[1] = hsum(a1 + b1) + r1;
  out[2] = hsum(a2 + b2) + r2;
}

BORESIGHT_CLONES void crnDot4x3(const double* g0, const double* g1, const double* g2, const double* x0, const double* x1,
                                const double* x2, const double* x3, int n, double out[12]) {
  V4 a[12];
  for (auto& v : a) v = V4{0, 0, 0, 0};
  int j = 0;
  for (; j + 4 <= n; j += 4) {
    const V4 k0 = load4(g0 + j), k1 = load4(g1 + j), k2 = load4(g2 + j);
    const V4 y0 = load4(x0 + j), y1 = load4(x1 + j), y2 = load4(x2 + j), y3 = load4(x3 + j);
    a[0] += k0 * y0;
    a[1] += k1 * y0;
    a[2] += k2 * y0;
    a[3] += k0 * y1;
    a[4] += k1 * y1;
    a[5] += k2 * y1;
    a[6] += k0 * y2;
    a[7] += k1 * y2;
    a[8] += k2 * y2;
    a[9] += k0 * y3;
    a[10] += k1 * y3;
    a[11] += k2 * y3;
  }
  for (int i = 0; i < 12; ++i) out[i] = hsum(a[i]);
  if (j == n) return;  // the streams call with n a multiple of 8 (crnPaddedTaps): no scalar tail
  const double* g[3] = {g0, g1, g2};
  const double* x[4] = {x0, x1, x2, x3};
  for (int c = 0; c < 4; ++c)
    for (int o = 0; o < 3; ++o) {
      double r = 0;
      for (int jj = j; jj < n; ++jj) r += g[o][jj] * x[c][jj];
      out[3 * c + o] += r;
    }
}

BORESIGHT_CLONES void crnDotFolded4x3(const double* h0, const double* h1, const double* h2, const double centre[3],
                                      const double* const xp[4], const double* const xm[4], const double xc[4], int m,
                                      double out[12]) {
  // per channel the sum and the difference of the mirrored samples, then the even kernels on the sum
  // and the odd one on the difference: 2 loads, an add, a subtraction and 3 multiply-adds per 4 tap
  // pairs and channel (12 accumulators; the kernels are read from memory)
  V4 a[12];
  for (auto& v : a) v = V4{0, 0, 0, 0};
  int i = 0;
  for (; i + 4 <= m; i += 4) {
    for (int c = 0; c < 4; ++c) {
      const V4 p = load4(xp[c] + i), q = load4(xm[c] + i);
      const V4 sum = p + q, dif = p - q;
      a[3 * c] += load4(h0 + i) * sum;
      a[3 * c + 1] += load4(h1 + i) * dif;
      a[3 * c + 2] += load4(h2 + i) * sum;
    }
  }
  for (int c = 0; c < 4; ++c)
    for (int o = 0; o < 3; ++o) out[3 * c + o] = hsum(a[3 * c + o]) + centre[o] * xc[c];
  if (i == m) return;  // the stream calls with m a multiple of 4: no scalar tail
  for (int c = 0; c < 4; ++c)
    for (int j = i; j < m; ++j) {
      const double sum = xp[c][j] + xm[c][j], dif = xp[c][j] - xm[c][j];
      out[3 * c] += h0[j] * sum;
      out[3 * c + 1] += h1[j] * dif;
      out[3 * c + 2] += h2[j] * sum;
    }
}

BORESIGHT_CLONES void crnAxpy(const double* a, const double* b, double s, double* out, int n) {
  for (int j = 0; j < n; ++j) out[j] = a[j] + s * b[j];
}

namespace {
double ipow(double x, int n) {
  double r = 1.0;
  for (int i = 0; i < n; ++i) r *= x;
  return r;
}
}  // namespace

Status designCrn(const CrnConfig& cfg, CrnKernel& out) {
  if (!(cfg.fs_hz > 0) || !std::isfinite(cfg.fs_hz) || !(cfg.length_s > 0) || !std::isfinite(cfg.length_s) ||
      !(cfg.bandwidth_hz > 0) || !std::isfinite(cfg.bandwidth_hz) || cfg.nc < 1 || cfg.nc > 64)
    return Status::kInvalidConfig;
  const double nf_real = cfg.fs_hz * cfg.length_s;
  if (!(nf_real >= 3) || nf_real > kMaxCrnTaps) return Status::kInvalidConfig;
  int nf = static_cast<int>(std::lround(nf_real));
  if (nf % 2 == 0) nf += (nf + 1 <= kMaxCrnTaps) ? 1 : -1;
  const int M = (nf - 1) / 2;
  const double tf = nf / cfg.fs_hz;
  const int nb = static_cast<int>(std::lround(cfg.bandwidth_hz * tf));
  if (nb < 0 || nb > M || cfg.bandwidth_hz >= 0.5 * cfg.fs_hz) return Status::kInvalidConfig;

  // F_k, k = 0..M
  std::array<double, kMaxCrnTaps> F{};
  const double dnf = static_cast<double>(nf);
  for (int k = 0; k <= M; ++k) {
    double sum = 0;
    for (int m = -nb; m <= nb; ++m) {
      const int j = k - m;
      const double d = (j == 0) ? dnf / cfg.nc : std::sin(kPi * j / cfg.nc) / std::sin(kPi * j / dnf);
      sum += ipow(d, cfg.nc);
    }
    F[static_cast<std::size_t>(k)] = sum;
  }
  const double F0 = F[0];
  if (!(std::abs(F0) > 0) || !std::isfinite(F0)) return Status::kInvalidConfig;
  for (int k = 0; k <= M; ++k) F[static_cast<std::size_t>(k)] /= F0;

  // exact angles 2 pi (k n mod Nf) / Nf from tables
  std::array<double, kMaxCrnTaps> cosT{}, sinT{};
  for (int i = 0; i < nf; ++i) {
    cosT[static_cast<std::size_t>(i)] = std::cos(2.0 * kPi * i / dnf);
    sinT[static_cast<std::size_t>(i)] = std::sin(2.0 * kPi * i / dnf);
  }
  out = CrnKernel{};
  out.nf = nf;
  out.half = M;
  out.nb = nb;
  out.fs_hz = cfg.fs_hz;
  out.tf_s = tf;
  auto& g0 = out.g[0];
  auto& g1 = out.g[1];
  auto& g2 = out.g[2];
  for (int n = 0; n <= M; ++n) {
    double c0 = F[0], s1 = 0, c2 = 0;
    for (int k = 1; k <= M; ++k) {
      const auto idx = static_cast<std::size_t>((static_cast<long>(k) * n) % nf);
      const double wk = 2.0 * kPi * k / tf;
      const double Fk = F[static_cast<std::size_t>(k)];
      c0 += 2.0 * Fk * cosT[idx];
      s1 += 2.0 * wk * Fk * sinT[idx];
      c2 -= 2.0 * wk * wk * Fk * cosT[idx];
    }
    const auto ip = static_cast<std::size_t>(M + n), im = static_cast<std::size_t>(M - n);
    g0[ip] = g0[im] = c0 / dnf;
    g1[ip] = s1 / dnf;
    g1[im] = -s1 / dnf;
    g2[ip] = g2[im] = c2 / dnf;
  }
  // exact unit gain at zero frequency
  double m0 = 0, m1 = 0, m2 = 0;
  for (int n = -M; n <= M; ++n) {
    const auto i = static_cast<std::size_t>(n + M);
    m0 += g0[i];
    m1 += n * g1[i];
    m2 += static_cast<double>(n) * n * g2[i];
  }
  if (!(std::abs(m0) > 0) || !(std::abs(m1) > 0) || !(std::abs(m2) > 0)) return Status::kInvalidConfig;
  const double s0 = 1.0 / m0, s1 = cfg.fs_hz / m1, s2 = 2.0 * cfg.fs_hz * cfg.fs_hz / m2;
  double mean2 = 0;
  for (int i = 0; i < nf; ++i) {
    const auto u = static_cast<std::size_t>(i);
    g0[u] *= s0;
    g1[u] *= s1;
    g2[u] *= s2;
    mean2 += g2[u];
  }
  mean2 /= dnf;  // remove the rounding residue so that a constant gives exactly no second derivative
  for (int i = 0; i < nf; ++i) g2[static_cast<std::size_t>(i)] -= mean2;
  return Status::kOk;
}

double CrnKernel::response(int order, double f_hz) const {
  if (order < 0 || order > 2 || nf == 0) return 0;
  const auto& k = g[static_cast<std::size_t>(order)];
  double r = 0;
  for (int n = -half; n <= half; ++n) {
    const double ph = 2.0 * kPi * f_hz * n / fs_hz;
    r += k[static_cast<std::size_t>(n + half)] * (order == 1 ? std::sin(ph) : std::cos(ph));
  }
  return r;
}

}  // namespace boresight::core
