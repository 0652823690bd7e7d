// The state-space side of the noise library (noise.h): the Kalman whitener and its inverse, the
// exact Gaussian likelihood with regressors profiled out, and the banded whitener.
//
// State: the Gauss-Markov terms' values x (k of them); observation y = sum_j x_j + w, w white with
// variance R. Between two samples dt apart every term propagates exactly: x_j' = phi_j x_j + q_j,
// phi_j = exp(-dt / tau_j), var(q_j) = var_j (1 - phi_j^2). With P the state covariance, h = (1..1):
//   predict  x = Phi x,  P = Phi P Phi + Q
//   gain     s = P h,  F = h^T s + R,  K = s / F
//   update   e = y - h^T x,  x += K e,  P -= s s^T / F
// z = e / sqrt(F) is the standardised innovation; sum log(2 pi F) + z^2 is -2 log-likelihood.
#include <boresight/model/noise.h>

#include <Eigen/Cholesky>

#include <algorithm>
#include <cmath>

namespace boresight::model {
namespace {
constexpr double kLog2Pi = 1.8378770664093453;
}

KalmanWhitener::KalmanWhitener(const NoiseModel& m) : white_var_(m.whiteVariance()), gm_(m.markovTerms()) {
  k_ = static_cast<int>(gm_.size());
  const auto k = static_cast<std::size_t>(k_);
  phi_.assign(k, 0.0);
  q_.assign(k, 0.0);
  K_.assign(k, 0.0);
  s_.assign(k, 0.0);
  s_next_.assign(k, 0.0);
  pp_.assign(k * k, 0.0);
  reset();
}

void KalmanWhitener::reset() {
  const auto k = static_cast<std::size_t>(k_);
  P_.assign(k * k, 0.0);
  for (std::size_t j = 0; j < k; ++j) P_[j * k + j] = gm_[j].var;
  X_.clear();
  columns_ = 0;
  F_ = 1;
  logF_ = 0;
  inv_sqrt_F_ = 1;
  if (k == 0) {  // white alone: the innovation variance is the white variance at every step
    F_ = std::max(white_var_, 1e-300);
    logF_ = std::log(F_);
    inv_sqrt_F_ = 1.0 / std::sqrt(F_);
  }
  t_prev_ = 0;
  dt_prev_ = -1;
  m2ll_ = 0;
  started_ = false;
  frozen_ = false;
  pending_ = false;
  sums_ = false;
  steps_ = 0;
  settle_ = 0;
}

void KalmanWhitener::predict(double t_s) {
  if (!started_) {
    started_ = true;  // the stationary prior: x = 0, P = diag(var)
    t_prev_ = t_s;
    return;
  }
  const auto k = static_cast<std::size_t>(k_);
  const double dt = std::max(0.0, t_s - t_prev_);
  t_prev_ = t_s;
  // Steps within 1e-4 of the previous one (time-tag jitter: star-camera tags jitter by 5-20 us at 0.5-1 s)
  // reuse its transition, and the gain stays frozen: the relative error of 1 - phi is then below 1e-4,
  // zero on average over symmetric jitter, far below any noise level's uncertainty. A tolerance of
  // 1e-5 unfroze the gain at most steps of simulated and real head series (a day's fit 10x slower).
  const bool same = dt_prev_ >= 0 && std::abs(dt - dt_prev_) <= 1e-4 * std::max(dt, 1e-9);
  if (!same) {
    frozen_ = false;
    settle_ = 0;
    dt_prev_ = dt;
    for (std::size_t j = 0; j < k; ++j) {
      phi_[j] = std::exp(-dt / gm_[j].tau_s);
      q_[j] = gm_[j].var * std::max(0.0, 1.0 - phi_[j] * phi_[j]);
    }
    for (std::size_t a = 0; a < k; ++a)
      for (std::size_t b = 0; b < k; ++b) pp_[a * k + b] = phi_[a] * phi_[b];
  }
  for (std::size_t c = 0; c < static_cast<std::size_t>(columns_); ++c) {
    double* x = X_.data() + c * k;
    for (std::size_t j = 0; j < k; ++j) x[j] *= phi_[j];
  }
  if (frozen_) return;
  // One pass over P: the last update's pending subtraction (P - K s^T, the posterior), the propagation
  // (elementwise phi_a phi_b, plus Q), and the row sums P h that the next gain needs.
  for (std::size_t a = 0; a < k; ++a) {
    double* row = P_.data() + a * k;
    const double* pp = pp_.data() + a * k;
    const double ka = pending_ ? K_[a] : 0.0;
    double sum = 0;
    for (std::size_t b = 0; b < k; ++b) {
      const double v = (row[b] - ka * s_[b]) * pp[b];
      row[b] = v;
      sum += v;
    }
    row[a] += q_[a];
    s_next_[a] = sum + q_[a];
  }
  s_.swap(s_next_);
  pending_ = false;
  sums_ = true;
}

void KalmanWhitener::gainStep() {
  if (frozen_) return;
  const auto k = static_cast<std::size_t>(k_);
  if (!sums_) {  // the first step (the stationary prior)
    for (std::size_t a = 0; a < k; ++a) {
      const double* row = P_.data() + a * k;
      double v = 0;
      for (std::size_t b = 0; b < k; ++b) v += row[b];
      s_[a] = v;
    }
  }
  double F = white_var_;
  for (std::size_t a = 0; a < k; ++a) F += s_[a];
  if (!(F > 1e-300)) F = 1e-300;
  const double F_old = F_;
  F_ = F;
  logF_ = std::log(F);
  inv_sqrt_F_ = 1.0 / std::sqrt(F);
  for (std::size_t a = 0; a < k; ++a) K_[a] = s_[a] / F;
  // The update P -= K s^T waits for the next predict(), which makes it in the same pass.
  pending_ = true;
  sums_ = false;
  // On a regular grid the covariance settles: freeze the gain once F stops changing. While frozen, P_,
  // K_ and s_ stay as they are, so the update still pending is made by the pass of the next irregular
  // step (which propagates the posterior from there).
  if (k > 0 && std::abs(F - F_old) <= 1e-12 * F) {
    if (++settle_ >= 3) frozen_ = true;
  } else {
    settle_ = 0;
  }
}

void KalmanWhitener::whitenColumns(double t_s, const double* in, double* out, int columns) {
  const auto k = static_cast<std::size_t>(k_);
  if (columns_ == 0) {
    columns_ = columns;
    X_.assign(k * static_cast<std::size_t>(columns), 0.0);
  }
  predict(t_s);
  if (k > 0) gainStep();
  const double inv_sF = inv_sqrt_F_;
  for (std::size_t c = 0; c < static_cast<std::size_t>(columns_); ++c) {
    double* x = X_.data() + c * k;
    double pred = 0;
    for (std::size_t j = 0; j < k; ++j) pred += x[j];
    const double e = in[c] - pred;
    for (std::size_t j = 0; j < k; ++j) x[j] += K_[j] * e;
    out[c] = e * inv_sF;
  }
  m2ll_ += kLog2Pi + logF_ + out[0] * out[0];
  ++steps_;
}

double KalmanWhitener::whiten(double t_s, double y) {
  double z;
  whitenColumns(t_s, &y, &z, 1);
  return z;
}

double KalmanWhitener::colour(double t_s, double z) {
  const auto k = static_cast<std::size_t>(k_);
  if (columns_ == 0) {
    columns_ = 1;
    X_.assign(k, 0.0);
  }
  predict(t_s);
  if (k > 0) gainStep();
  const double e = z * std::sqrt(F_);
  double pred = 0;
  for (std::size_t j = 0; j < k; ++j) pred += X_[j];
  for (std::size_t j = 0; j < k; ++j) X_[j] += K_[j] * e;
  m2ll_ += kLog2Pi + logF_ + z * z;
  ++steps_;
  return e + pred;
}

// ---------------------------------------------------------------------------------------------

double NoiseSeries::medianInterval() const {
  if (t_s.size() < 2) return 0.0;
  std::vector<double> d(t_s.size() - 1);
  for (std::size_t i = 1; i < t_s.size(); ++i) d[i - 1] = t_s[i] - t_s[i - 1];
  std::nth_element(d.begin(), d.begin() + static_cast<std::ptrdiff_t>(d.size() / 2), d.end());
  return d[d.size() / 2];
}

namespace {

/// Whitens y and the columns of X together; returns sum log F (the determinant term).
double whitenAll(const NoiseModel& m, const NoiseSeries& s, const Eigen::MatrixXd& X, Eigen::VectorXd& zy, Eigen::MatrixXd& zX) {
  const int p = static_cast<int>(X.cols());
  const auto n = static_cast<Eigen::Index>(s.size());
  zy.resize(n);
  zX.resize(n, p);
  KalmanWhitener kf(m);
  std::vector<double> in(static_cast<std::size_t>(p + 1)), out(static_cast<std::size_t>(p + 1));
  double logdet = 0;
  for (Eigen::Index i = 0; i < n; ++i) {
    in[0] = s.y[static_cast<std::size_t>(i)];
    for (int c = 0; c < p; ++c) in[static_cast<std::size_t>(c + 1)] = X(i, c);
    kf.whitenColumns(s.t_s[static_cast<std::size_t>(i)], in.data(), out.data(), p + 1);
    logdet += kf.logInnovationVariance();
    zy[i] = out[0];
    for (int c = 0; c < p; ++c) zX(i, c) = out[static_cast<std::size_t>(c + 1)];
  }
  return logdet;
}

}  // namespace

double minusTwoLogLikelihood(const NoiseModel& m, const NoiseSeries& s, const Eigen::MatrixXd& X, bool reml,
                             Eigen::VectorXd* beta, Eigen::MatrixXd* beta_cov) {
  // One pass that keeps only the sums GLS needs (zX^T zX, zX^T zy, zy^T zy): no n-long buffers.
  const int p = static_cast<int>(X.cols());
  const auto n = static_cast<Eigen::Index>(s.size());
  KalmanWhitener kf(m);
  std::vector<double> in(static_cast<std::size_t>(p + 1)), out(static_cast<std::size_t>(p + 1));
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(p, p);
  Eigen::VectorXd c = Eigen::VectorXd::Zero(p);
  double logdet = 0, yy = 0;
  for (Eigen::Index i = 0; i < n; ++i) {
    in[0] = s.y[static_cast<std::size_t>(i)];
    for (int k = 0; k < p; ++k) in[static_cast<std::size_t>(k + 1)] = X(i, k);
    kf.whitenColumns(s.t_s[static_cast<std::size_t>(i)], in.data(), out.data(), p + 1);
    logdet += kf.logInnovationVariance();
    yy += out[0] * out[0];
    for (int a = 0; a < p; ++a) {
      const double za = out[static_cast<std::size_t>(a + 1)];
      c[a] += za * out[0];
      for (int b = 0; b <= a; ++b) A(a, b) += za * out[static_cast<std::size_t>(b + 1)];
    }
  }
  double rss = yy;
  double extra = 0;
  if (p > 0) {
    A = A.selfadjointView<Eigen::Lower>();
    const Eigen::LDLT<Eigen::MatrixXd> ldlt(A);
    const Eigen::VectorXd b = ldlt.solve(c);
    rss = std::max(0.0, yy - c.dot(b));  // |zy - zX b|^2 at the GLS solution
    if (beta) *beta = b;
    if (beta_cov) *beta_cov = ldlt.solve(Eigen::MatrixXd::Identity(p, p));
    if (reml) extra = ldlt.vectorD().array().abs().max(1e-300).log().sum();
  } else {
    if (beta) beta->resize(0);
    if (beta_cov) beta_cov->resize(0, 0);
  }
  const double nn = reml ? static_cast<double>(n - p) : static_cast<double>(n);
  return nn * kLog2Pi + logdet + rss + extra;
}

std::vector<double> whitenSeries(const NoiseModel& m, const NoiseSeries& s, const Eigen::MatrixXd& X) {
  Eigen::VectorXd zy;
  Eigen::MatrixXd zX;
  whitenAll(m, s, X, zy, zX);
  if (X.cols() > 0) {
    const Eigen::VectorXd b = (zX.transpose() * zX).ldlt().solve(zX.transpose() * zy);
    zy -= zX * b;
  }
  return std::vector<double>(zy.data(), zy.data() + zy.size());
}

// ---------------------------------------------------------------------------------------------

BandedWhitener::BandedWhitener(const std::vector<std::int64_t>& t, double D, const std::vector<double>& rho)
    : n_(t.size()), K_(static_cast<int>(rho.size()) - 1) {
  const int K = K_;
  const int W = K + 1;
  const int n = static_cast<int>(t.size());
  L_.assign(static_cast<std::size_t>(n) * static_cast<std::size_t>(W), 0.0);
  auto at = [&](int k, int m) -> double& { return L_[static_cast<std::size_t>(k * W + (K - (k - m)))]; };
  auto corr = [&](int k, int m) {
    const double dt_s = static_cast<double>(std::llabs(t[static_cast<std::size_t>(k)] - t[static_cast<std::size_t>(m)])) * 1e-6;
    const long long lag = std::llround(dt_s / D);
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
}

double BandedWhitener::factor(std::size_t k, std::size_t m) const {
  const std::size_t W = static_cast<std::size_t>(K_) + 1;
  return L_[k * W + (static_cast<std::size_t>(K_) - (k - m))];
}

std::vector<double> BandedWhitener::whiten(const std::vector<double>& x) const {
  std::vector<double> z(x.size());
  for (std::size_t k = 0; k < x.size() && k < n_; ++k) z[k] = whitenAt(k, x[k], [&](std::size_t m) { return z[m]; });
  return z;
}

}  // namespace boresight::model
