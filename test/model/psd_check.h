// Spectrum checks for simulated noise: a Welch periodogram of a regularly sampled series, its exact
// expectation under a model with a closed-form autocovariance, and a band test whose tolerance follows
// from the number of averaged segments (no tuned factors).
//
// Estimate. Segments of L samples, Hann window w_n = sin^2(pi n / L), overlapping by L/2; per bin
// k = 1..L/2-1 the one-sided estimate 2 T |sum_n w_n x_n e^(-2 pi i k n / L)|^2 / sum_n w_n^2, averaged
// over the M segments (no mean removed: the processes tested have mean zero).
// Expectation. For a stationary process with autocovariance R, the expected windowed periodogram is
//   E_k = (2 T / sum w^2) sum_{|m| < L} R(m T) c_m cos(2 pi k m / L),  c_m = sum_n w_n w_{n+|m|},
// exact (leakage and aliasing included), so the comparison needs no allowance for window bias. R is
// the model's closed form (noise.h NoiseModel::autocovariance, the Fourier pair of psdSampled).
// Spread. For a Gaussian process each segment's estimate is E_k chi^2_2 / 2 away from bin 0 and
// Nyquist; with 50 % overlapped Hann segments the average has variance E_k^2 (1 + 2 (1 - 1/M) rho^2) / M,
// rho = sum w_n w_{n+L/2} / sum w^2 (Percival and Walden 1993, eq. 292b), i.e. nu = 2 M / (1 + 2 (1 -
// 1/M) rho^2) equivalent degrees of freedom. Hann periodogram bins three apart are uncorrelated, so the
// bins k0, k0 + 3, ... of a band give K independent ratios r = estimate / E_k, whose mean has standard
// deviation sqrt(2 / (nu K)). bandCheck() returns, per band, that mean and its z; a test requires
// |z| < the two-sided normal quantile at a family-wise level split over all bands (Bonferroni).
#pragma once

#include <cmath>
#include <complex>
#include <cstddef>
#include <functional>
#include <string>
#include <vector>

namespace boresight::testpsd {

inline std::vector<double> hann(std::size_t L) {
  std::vector<double> w(L);
  for (std::size_t n = 0; n < L; ++n) {
    const double s = std::sin(3.141592653589793 * static_cast<double>(n) / static_cast<double>(L));
    w[n] = s * s;
  }
  return w;
}

struct Welch {
  std::size_t L = 0;
  double T = 1;
  int segments = 0;
  double nu = 0;                ///< equivalent chi-square degrees of freedom of each averaged bin
  std::vector<double> psd;      ///< bins 0..L/2 (0 and L/2 not meaningful for the test)
  double f(std::size_t k) const { return static_cast<double>(k) / (static_cast<double>(L) * T); }
};

inline Welch welch(const std::vector<double>& x, double T, std::size_t L) {
  Welch out;
  out.L = L;
  out.T = T;
  const std::vector<double> w = hann(L);
  double sw2 = 0, overlap = 0;
  for (std::size_t n = 0; n < L; ++n) sw2 += w[n] * w[n];
  for (std::size_t n = 0; n + L / 2 < L; ++n) overlap += w[n] * w[n + L / 2];
  const double rho = overlap / sw2;
  out.psd.assign(L / 2 + 1, 0.0);
  // radix-2 FFT (L a power of two)
  std::vector<std::complex<double>> buf(L);
  const auto fft = [](std::vector<std::complex<double>>& a) {
    const std::size_t n = a.size();
    for (std::size_t i = 1, j = 0; i < n; ++i) {
      std::size_t bit = n >> 1;
      for (; j & bit; bit >>= 1) j ^= bit;
      j ^= bit;
      if (i < j) std::swap(a[i], a[j]);
    }
    for (std::size_t len = 2; len <= n; len <<= 1) {
      const double ang = -2 * 3.141592653589793 / static_cast<double>(len);
      const std::complex<double> wl(std::cos(ang), std::sin(ang));
      for (std::size_t i = 0; i < n; i += len) {
        std::complex<double> wk(1);
        for (std::size_t j = 0; j < len / 2; ++j) {
          const auto u = a[i + j], v = a[i + j + len / 2] * wk;
          a[i + j] = u + v;
          a[i + j + len / 2] = u - v;
          wk *= wl;
        }
      }
    }
  };
  for (std::size_t start = 0; start + L <= x.size(); start += L / 2) {
    for (std::size_t n = 0; n < L; ++n) buf[n] = w[n] * x[start + n];
    fft(buf);
    for (std::size_t k = 0; k <= L / 2; ++k) out.psd[k] += 2 * T * std::norm(buf[k]) / sw2;
    ++out.segments;
  }
  for (auto& p : out.psd) p /= out.segments;
  const double M = out.segments;
  out.nu = 2 * M / (1 + 2 * (1 - 1 / M) * rho * rho);
  return out;
}

/// E_k of the header comment for an autocovariance R(lag_s), all bins k = 0..L/2.
inline std::vector<double> expectedWelch(const std::function<double(double)>& R, double T, std::size_t L) {
  const std::vector<double> w = hann(L);
  double sw2 = 0;
  for (double v : w) sw2 += v * v;
  std::vector<double> a(L);  // R(m T) c_m, doubled for m > 0
  for (std::size_t m = 0; m < L; ++m) {
    double c = 0;
    for (std::size_t n = 0; n + m < L; ++n) c += w[n] * w[n + m];
    a[m] = (m == 0 ? 1.0 : 2.0) * R(static_cast<double>(m) * T) * c;
  }
  std::vector<double> e(L / 2 + 1, 0.0);
  for (std::size_t k = 0; k <= L / 2; ++k) {
    double s = 0;
    for (std::size_t m = 0; m < L; ++m)
      s += a[m] * std::cos(2 * 3.141592653589793 * static_cast<double>((k * m) % L) / static_cast<double>(L));
    e[k] = 2 * T * s / sw2;
  }
  return e;
}

struct Band {
  double f_lo = 0, f_hi = 0;
  int bins = 0;
  double mean_ratio = 0, z = 0;
  std::string describe() const {
    return "band " + std::to_string(f_lo) + "-" + std::to_string(f_hi) + " Hz (" + std::to_string(bins) +
           " bins): mean ratio " + std::to_string(mean_ratio) + ", z " + std::to_string(z);
  }
};

/// The bins k = k_first, k_first + 3, ... below L/2 cut into `nbands` bands of equal log width.
inline std::vector<Band> bandCheck(const Welch& W, const std::function<double(double)>& R, std::size_t k_first, int nbands) {
  const std::vector<double> E = expectedWelch(R, W.T, W.L);
  std::vector<std::size_t> ks;
  for (std::size_t k = k_first; k < W.L / 2; k += 3) ks.push_back(k);
  std::vector<Band> out;
  const double l0 = std::log(static_cast<double>(ks.front())), l1 = std::log(static_cast<double>(ks.back()) + 1);
  for (int b = 0; b < nbands; ++b) {
    const double lo = std::exp(l0 + (l1 - l0) * b / nbands), hi = std::exp(l0 + (l1 - l0) * (b + 1) / nbands);
    Band band;
    band.f_lo = lo / (static_cast<double>(W.L) * W.T);
    band.f_hi = hi / (static_cast<double>(W.L) * W.T);
    double sum = 0;
    for (std::size_t k : ks)
      if (static_cast<double>(k) >= lo && static_cast<double>(k) < hi) {
        sum += W.psd[k] / E[k];
        ++band.bins;
      }
    if (band.bins == 0) continue;
    band.mean_ratio = sum / band.bins;
    band.z = (band.mean_ratio - 1) / std::sqrt(2 / (W.nu * band.bins));
    out.push_back(band);
  }
  return out;
}

/// Two-sided standard normal quantile for a family-wise level alpha over n tests: |z| < zCrit(alpha, n).
inline double zCrit(double alpha, int n) {
  // Invert the normal tail 2 (1 - Phi(z)) = alpha / n by bisection on erfc.
  const double p = alpha / n;
  double lo = 0, hi = 10;
  for (int i = 0; i < 200; ++i) {
    const double mid = 0.5 * (lo + hi);
    if (std::erfc(mid / std::sqrt(2.0)) > p) lo = mid;
    else hi = mid;
  }
  return 0.5 * (lo + hi);
}

}  // namespace boresight::testpsd
