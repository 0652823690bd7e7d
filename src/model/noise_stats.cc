// Spectra (Welch), the Ljung-Box whiteness test and variance-component estimation (noise.h).
#include <boresight/model/noise.h>
#include <boresight/model/stats.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <unsupported/Eigen/FFT>

#include <algorithm>
#include <cmath>
#include <complex>

namespace boresight::model {

LjungBox ljungBox(const std::vector<double>& z, int lags, int dof_used) {
  LjungBox r;
  const auto n = static_cast<int>(z.size());
  r.lags = std::max(1, std::min(lags, n - 1));
  r.dof = std::max(1, r.lags - dof_used);
  if (n < 3) return r;
  double mean = 0;
  for (double v : z) mean += v;
  mean /= n;
  double c0 = 0;
  for (double v : z) c0 += (v - mean) * (v - mean);
  if (!(c0 > 0)) return r;
  double q = 0;
  for (int k = 1; k <= r.lags; ++k) {
    double ck = 0;
    for (int i = k; i < n; ++i) ck += (z[static_cast<std::size_t>(i)] - mean) * (z[static_cast<std::size_t>(i - k)] - mean);
    const double rk = ck / c0;
    q += rk * rk / (n - k);
  }
  r.Q = static_cast<double>(n) * (n + 2.0) * q;
  r.p_value = stats::chi2Sf(r.Q, r.dof);
  return r;
}

namespace {

/// Accumulates Hann-windowed periodograms of segments (one-sided, u^2/Hz).
struct WelchAccumulator {
  std::size_t seg;
  double T;
  std::vector<double> win, acc;
  double win_power = 0;
  int count = 0;
  Eigen::FFT<double> fft;
  std::vector<double> buf;
  std::vector<std::complex<double>> spec;
  WelchAccumulator(std::size_t segment, double T_s) : seg(segment), T(T_s), win(segment), acc(segment / 2 + 1, 0.0), buf(segment) {
    for (std::size_t i = 0; i < seg; ++i) {
      win[i] = 0.5 - 0.5 * std::cos(6.283185307179586 * static_cast<double>(i) / static_cast<double>(seg));
      win_power += win[i] * win[i];
    }
  }
  void add(const double* y) {
    double mean = 0;
    for (std::size_t i = 0; i < seg; ++i) mean += y[i];
    mean /= static_cast<double>(seg);
    for (std::size_t i = 0; i < seg; ++i) buf[i] = (y[i] - mean) * win[i];
    fft.fwd(spec, buf);
    for (std::size_t k = 0; k <= seg / 2; ++k) {
      const double p = std::norm(spec[k]) * T / win_power;
      acc[k] += (k == 0 || (seg % 2 == 0 && k == seg / 2)) ? p : 2.0 * p;
    }
    ++count;
  }
  /// Adds every half-overlapped segment of a run.
  void addRun(const double* y, std::size_t n) {
    if (n < seg) return;
    const std::size_t step = seg / 2;
    for (std::size_t s = 0; s + seg <= n; s += step) add(y + s);
  }
  Spectrum result() const {
    Spectrum out;
    out.segments = count;
    if (count == 0) return out;
    // bin 0 is the mean's (removed per segment): left out
    for (std::size_t k = 1; k <= seg / 2; ++k) {
      out.f_hz.push_back(static_cast<double>(k) / (static_cast<double>(seg) * T));
      out.psd.push_back(acc[k] / count);
    }
    return out;
  }
};

}  // namespace

Spectrum welchPsd(const std::vector<double>& y, double T_s, std::size_t segment) {
  WelchAccumulator w(std::max<std::size_t>(segment, 4), T_s);
  w.addRun(y.data(), y.size());
  return w.result();
}

Spectrum welchPsdGapped(const NoiseSeries& s, double T_s, std::size_t segment) {
  WelchAccumulator w(std::max<std::size_t>(segment, 4), T_s);
  std::vector<double> run;
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (!run.empty()) {
      const double dt = s.t_s[i] - s.t_s[i - 1];
      if (std::abs(dt - T_s) > 0.1 * T_s) {
        w.addRun(run.data(), run.size());
        run.clear();
      }
    }
    run.push_back(s.y[i]);
  }
  w.addRun(run.data(), run.size());
  return w.result();
}

VarianceComponents estimateVarianceComponents(const std::vector<VarianceGroup>& groups) {
  VarianceComponents r;
  if (groups.empty()) {
    r.message = "no groups";
    return r;
  }
  const Eigen::Index p = groups.front().N.rows();
  Eigen::MatrixXd N = Eigen::MatrixXd::Zero(p, p);
  for (const auto& g : groups) {
    if (g.N.rows() != p || g.N.cols() != p) {
      r.message = "group '" + g.name + "': normal block of another size";
      return r;
    }
    N += g.N;
  }
  // N^+ on the unit-diagonal scaling (the parameters' units differ by orders of magnitude): a direction
  // the groups together do not determine (eigenvalue below 1e-12 of the largest) carries no parameter
  // and takes no redundancy, so a rank-deficient problem has its variance components too.
  Eigen::VectorXd sc(p);
  for (Eigen::Index i = 0; i < p; ++i) sc(i) = N(i, i) > 0 ? 1 / std::sqrt(N(i, i)) : 0.0;
  Eigen::MatrixXd Ns = sc.asDiagonal() * N * sc.asDiagonal();
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(0.5 * (Ns + Ns.transpose()));
  const double top = p > 0 ? es.eigenvalues().maxCoeff() : 0.0;
  if (!(top > 0)) {
    r.message = "the normal matrix is zero: no parameter is determined";
    return r;
  }
  Eigen::VectorXd inv = Eigen::VectorXd::Zero(p);
  for (Eigen::Index k = 0; k < p; ++k)
    if (es.eigenvalues()(k) > 1e-12 * top) inv(k) = 1 / es.eigenvalues()(k);
  const Eigen::MatrixXd Ninv = sc.asDiagonal() * (es.eigenvectors() * inv.asDiagonal() * es.eigenvectors().transpose()) * sc.asDiagonal();
  r.ok = true;
  for (const auto& g : groups) {
    const double red = g.n_obs - (g.N.cwiseProduct(Ninv.transpose())).sum();  // tr(N_g N^-1)
    r.redundancy.push_back(red);
    if (!(red > 1e-9)) {
      r.factor.push_back(1.0);
      r.ok = false;
      r.message = "group '" + g.name + "' has no redundancy (its observations only determine parameters)";
    } else {
      r.factor.push_back(g.ssr / red);
    }
  }
  return r;
}

}  // namespace boresight::model
