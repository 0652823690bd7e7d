#include "boresight/core/crn.h"

#include <cmath>

namespace boresight::core {

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
