// Distribution functions of the audit's tests and the noise library's whiteness tests: upper tail
// probabilities of the chi-square, F, normal and Poisson distributions, and their quantiles by
// bisection. Regularised incomplete gamma (series and continued fraction) and beta (continued
// fraction, modified Lentz), double precision, no tables.
#pragma once

#include <cmath>
#include <limits>

namespace boresight::model::stats {

namespace detail {
/// Continued fraction of Q(a, x) for x >= a + 1 (modified Lentz), without the prefactor.
inline double gammaQCf(double a, double x) {
  const double tiny = 1e-300;
  double b = x + 1 - a, c = 1 / tiny, d = 1 / b, h = d;
  for (int i = 1; i < 1000; ++i) {
    const double an = -i * (i - a);
    b += 2;
    d = an * d + b;
    if (std::abs(d) < tiny) d = tiny;
    c = b + an / c;
    if (std::abs(c) < tiny) c = tiny;
    d = 1 / d;
    const double del = d * c;
    h *= del;
    if (std::abs(del - 1) < 1e-16) break;
  }
  return h;
}
inline double gammaPrefactor(double a, double x) { return std::exp(-x + a * std::log(x) - std::lgamma(a)); }
}  // namespace detail

/// Regularised lower incomplete gamma P(a, x), a > 0, x >= 0.
inline double gammaP(double a, double x) {
  if (x <= 0) return 0.0;
  if (x < a + 1) {  // series
    double term = 1.0 / a, sum = term;
    for (int n = 1; n < 1000; ++n) {
      term *= x / (a + n);
      sum += term;
      if (std::abs(term) < std::abs(sum) * 1e-16) break;
    }
    return std::min(1.0, sum * detail::gammaPrefactor(a, x));
  }
  return std::max(0.0, 1.0 - detail::gammaPrefactor(a, x) * detail::gammaQCf(a, x));
}

/// Regularised upper incomplete gamma Q(a, x) = 1 - P(a, x), accurate in the far tail.
inline double gammaQ(double a, double x) {
  if (x <= 0) return 1.0;
  if (x < a + 1) return 1.0 - gammaP(a, x);
  return detail::gammaPrefactor(a, x) * detail::gammaQCf(a, x);
}

namespace detail {
inline double betaCf(double a, double b, double x) {
  const double tiny = 1e-300;
  double c = 1, d = 1 - (a + b) * x / (a + 1);
  if (std::abs(d) < tiny) d = tiny;
  d = 1 / d;
  double h = d;
  for (int m = 1; m < 2000; ++m) {
    const double m2 = 2.0 * m;
    double aa = m * (b - m) * x / ((a - 1 + m2) * (a + m2));
    d = 1 + aa * d;
    if (std::abs(d) < tiny) d = tiny;
    c = 1 + aa / c;
    if (std::abs(c) < tiny) c = tiny;
    d = 1 / d;
    h *= d * c;
    aa = -(a + m) * (a + b + m) * x / ((a + m2) * (a + 1 + m2));
    d = 1 + aa * d;
    if (std::abs(d) < tiny) d = tiny;
    c = 1 + aa / c;
    if (std::abs(c) < tiny) c = tiny;
    d = 1 / d;
    const double del = d * c;
    h *= del;
    if (std::abs(del - 1) < 1e-15) break;
  }
  return h;
}
}  // namespace detail

/// Regularised incomplete beta I_x(a, b).
inline double betaI(double a, double b, double x) {
  if (x <= 0) return 0.0;
  if (x >= 1) return 1.0;
  const double lbt = std::lgamma(a + b) - std::lgamma(a) - std::lgamma(b) + a * std::log(x) + b * std::log1p(-x);
  if (x < (a + 1) / (a + b + 2)) return std::exp(lbt) * detail::betaCf(a, b, x) / a;
  return 1.0 - std::exp(lbt) * detail::betaCf(b, a, 1 - x) / b;
}

/// P(chi2_k > x).
inline double chi2Sf(double x, double k) { return gammaQ(0.5 * k, 0.5 * x); }

/// P(F(d1, d2) > f); d2 = infinity (<= 0 or huge) falls back to chi2_d1 / d1.
inline double fSf(double f, double d1, double d2) {
  if (!(f > 0)) return 1.0;
  if (d2 <= 0 || d2 > 1e7) return chi2Sf(f * d1, d1);
  return betaI(0.5 * d2, 0.5 * d1, d2 / (d2 + d1 * f));
}

/// Two-sided P(|N(0,1)| > |z|).
inline double normalSf2(double z) { return std::erfc(std::abs(z) / std::sqrt(2.0)); }

/// P(Poisson(lambda) >= k).
inline double poissonSfGe(double k, double lambda) {
  if (k <= 0) return 1.0;
  if (lambda <= 0) return 0.0;
  return gammaP(k, lambda);
}

/// x with sf(x) = p for a decreasing tail function sf on (0, inf), by bisection in log x.
template <class Sf>
double quantileUpper(Sf sf, double p) {
  double lo = -30, hi = 30;  // natural log of x
  for (int i = 0; i < 200; ++i) {
    const double mid = 0.5 * (lo + hi);
    if (sf(std::exp(mid)) > p) lo = mid;
    else hi = mid;
    if (hi - lo < 1e-10) break;
  }
  return std::exp(0.5 * (lo + hi));
}

inline double fQuantile(double p, double d1, double d2) {
  return quantileUpper([&](double f) { return fSf(f, d1, d2); }, p);
}
inline double chi2Quantile(double p, double k) {
  return quantileUpper([&](double x) { return chi2Sf(x, k); }, p);
}
inline double normalQuantile2(double p) {
  return quantileUpper([&](double z) { return normalSf2(z); }, p);
}

}  // namespace boresight::model::stats
