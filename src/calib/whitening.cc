#include "whitening.h"

#include "boresight/core/rotation.h"
#include "boresight/model/noise.h"

#include <Eigen/Cholesky>

#include <cmath>

namespace boresight::calib {

Whitened whiten(const CalibrationSpan& span, const std::array<Mat3, kMaxHeads>& C_S_A, const std::vector<double>& rho,
                const std::vector<std::uint8_t>* reject) {
  Whitened out;
  const int K = static_cast<int>(rho.size()) - 1;
  for (int h = 0; h < span.n_heads; ++h) {
    const auto hs = static_cast<std::size_t>(h);
    std::vector<std::size_t> idx;
    std::vector<TimeUs> t;
    for (std::size_t k = 0; k < span.obs.size(); ++k)
      if (span.obs[k].has_head[hs] && !(reject && ((*reject)[k] >> h) & 1u)) {
        idx.push_back(k);
        t.push_back(span.obs[k].t);
      }
    const model::BandedWhitener L(t, span.decimation_s, rho);
    auto& rows = out.rows[hs];
    rows.resize(idx.size());
    for (std::size_t k = 0; k < idx.size(); ++k) {
      const Observation& o = span.obs[idx[k]];
      WhitenedRow& r = rows[k];
      r.obs = idx[k];
      Vec3 xS = o.alpha_S[hs], xA = o.alpha_A, xJ = o.jerk_A;
      double xc = 1.0;
      const std::size_t m0 = k >= static_cast<std::size_t>(K) ? k - static_cast<std::size_t>(K) : 0;
      for (std::size_t m = m0; m < k; ++m) {
        const double l = L.factor(k, m);
        const WhitenedRow& p = rows[m];
        xS -= l * p.zS;
        xA -= l * p.zA;
        xJ -= l * p.zJ;
        xc -= l * p.zc;
      }
      const double d = L.factor(k, k);
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
