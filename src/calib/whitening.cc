#include "whitening.h"

#include "boresight/core/rotation.h"

#include <Eigen/Cholesky>

#include <cmath>

namespace boresight::calib {

std::vector<double> bandedCholesky(const std::vector<TimeUs>& t, double D, const std::vector<double>& rho) {
  const int K = static_cast<int>(rho.size()) - 1;
  const int W = K + 1;
  const int n = static_cast<int>(t.size());
  std::vector<double> L(static_cast<std::size_t>(n) * static_cast<std::size_t>(W), 0.0);
  auto at = [&](int k, int m) -> double& { return L[static_cast<std::size_t>(k * W + (K - (k - m)))]; };
  auto corr = [&](int k, int m) {
    const long long lag = std::llround(std::abs(toSeconds(t[static_cast<std::size_t>(k)] - t[static_cast<std::size_t>(m)])) / D);
    return lag < static_cast<long long>(rho.size()) ? rho[static_cast<std::size_t>(lag)] : 0.0;
  };
  for (int k = 0; k < n; ++k) {
    const int m0 = std::max(0, k - K);
    for (int m = m0; m <= k; ++m) {
      double s = corr(k, m);
      for (int p = std::max(m0, m - K); p < m; ++p) s -= at(k, p) * at(m, p);
      if (m < k) {
        at(k, m) = s / at(m, m);
      } else {
        // a non-positive pivot cannot happen for a true correlation matrix; guard against rounding
        at(k, k) = std::sqrt(std::max(s, 1e-6));
      }
    }
  }
  return L;
}

Whitened whiten(const CalibrationSpan& span, const std::array<Mat3, kMaxHeads>& C_S_A, const std::vector<double>& rho,
                const std::vector<std::uint8_t>* reject) {
  Whitened out;
  const int K = static_cast<int>(rho.size()) - 1;
  const int W = K + 1;
  for (int h = 0; h < span.n_heads; ++h) {
    const auto hs = static_cast<std::size_t>(h);
    std::vector<std::size_t> idx;
    std::vector<TimeUs> t;
    for (std::size_t k = 0; k < span.obs.size(); ++k)
      if (span.obs[k].has_head[hs] && !(reject && ((*reject)[k] >> h) & 1u)) {
        idx.push_back(k);
        t.push_back(span.obs[k].t);
      }
    const std::vector<double> L = bandedCholesky(t, span.decimation_s, rho);
    auto& rows = out.rows[hs];
    rows.resize(idx.size());
    for (std::size_t k = 0; k < idx.size(); ++k) {
      const Observation& o = span.obs[idx[k]];
      WhitenedRow& r = rows[k];
      r.obs = idx[k];
      Vec3 xS = o.alpha_S[hs], xA = o.alpha_A, xJ = o.jerk_A;
      double xc = 1.0;
      const int ki = static_cast<int>(k);
      for (int m = std::max(0, ki - K); m < ki; ++m) {
        const double l = L[static_cast<std::size_t>(ki * W + (K - (ki - m)))];
        const WhitenedRow& p = rows[static_cast<std::size_t>(m)];
        xS -= l * p.zS;
        xA -= l * p.zA;
        xJ -= l * p.zJ;
        xc -= l * p.zc;
      }
      const double d = L[static_cast<std::size_t>(ki * W + K)];
      r.zS = xS / d;
      r.zA = xA / d;
      r.zJ = xJ / d;
      r.zc = xc / d;
      const Mat3 cov = o.cov_alpha_S[hs] + C_S_A[hs] * o.cov_alpha_A * C_S_A[hs].transpose();
      Mat3 Winv;
      if (core::invertSpd3(cov, Winv)) {
        Eigen::LLT<Mat3> llt(Winv);
        r.sqrt_info = llt.matrixU();
      } else {
        r.sqrt_info = Mat3::Zero();  // checked before: cannot happen for a span that passed checkSpan
      }
    }
  }
  return out;
}

}  // namespace boresight::calib
