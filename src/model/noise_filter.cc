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
  // One pass over the upper triangle of P (it is symmetric; the lower triangle is not kept): the last
  // update's pending subtraction (P - K s^T = P - s s^T / F, the posterior), the propagation
  // (elementwise phi_a phi_b, plus Q), and the row sums P h that the next gain needs (each
  // off-diagonal element counts in its row and in its column). Half the work of the full matrix.
  std::fill(s_next_.begin(), s_next_.end(), 0.0);
  for (std::size_t a = 0; a < k; ++a) {
    double* row = P_.data() + a * k;
    const double* pp = pp_.data() + a * k;
    const double ka = pending_ ? K_[a] : 0.0;
    const double diag = (row[a] - ka * s_[a]) * pp[a] + q_[a];
    row[a] = diag;
    for (std::size_t b = a + 1; b < k; ++b) {
      const double v = (row[b] - ka * s_[b]) * pp[b];
      row[b] = v;
      s_next_[b] += v;
    }
    double sum = diag;
    for (std::size_t b = a + 1; b < k; ++b) sum += row[b];
    s_next_[a] += sum;
  }
  s_.swap(s_next_);
  pending_ = false;
  sums_ = true;
}

void KalmanWhitener::gainStep() {
  if (frozen_) return;
  const auto k = static_cast<std::size_t>(k_);
  if (!sums_) {  // the first step (the stationary prior: P is diagonal)
    for (std::size_t a = 0; a < k; ++a) s_[a] = P_[a * k + a];
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
  // step (which propagates the posterior from there). "Stops": a relative change of at most 1e-9 on
  // three steps running (1e-12 kept slow terms' gains unfrozen for thousands of steps: calibrate's 6 h
  // attitude-domain estimate spent 0.25 s more in its noise fits, for changes under 0.1 % of a sigma).
  if (k > 0 && std::abs(F - F_old) <= 1e-9 * F) {
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

namespace {

/// The sums generalised least squares needs from whitened columns (y first, then X's columns): zX^T zX,
/// zX^T zy, zy^T zy and sum log F. No n-long buffers.
class GlsSums {
 public:
  explicit GlsSums(int p) : p_(p), A_(Eigen::MatrixXd::Zero(p, p)), c_(Eigen::VectorXd::Zero(p)) {}
  void add(const double* out, double logF) {
    logdet_ += logF;
    yy_ += out[0] * out[0];
    for (int a = 0; a < p_; ++a) {
      const double za = out[a + 1];
      c_[a] += za * out[0];
      for (int b = 0; b <= a; ++b) A_(a, b) += za * out[b + 1];
    }
    ++n_;
  }
  /// -2 log L with the columns profiled out (and the GLS solution, its covariance, when asked for).
  double m2ll(bool reml, Eigen::VectorXd* beta, Eigen::MatrixXd* beta_cov) const {
    double rss = yy_, extra = 0;
    if (p_ > 0) {
      const Eigen::MatrixXd A = A_.selfadjointView<Eigen::Lower>();
      const Eigen::LDLT<Eigen::MatrixXd> ldlt(A);
      const Eigen::VectorXd b = ldlt.solve(c_);
      rss = std::max(0.0, yy_ - c_.dot(b));  // |zy - zX b|^2 at the GLS solution
      if (beta) *beta = b;
      if (beta_cov) *beta_cov = ldlt.solve(Eigen::MatrixXd::Identity(p_, p_));
      if (reml) extra = ldlt.vectorD().array().abs().max(1e-300).log().sum();
    } else {
      if (beta) beta->resize(0);
      if (beta_cov) beta_cov->resize(0, 0);
    }
    const double nn = reml ? static_cast<double>(n_ - p_) : static_cast<double>(n_);
    return nn * kLog2Pi + logdet_ + rss + extra;
  }

 private:
  int p_;
  Eigen::MatrixXd A_;
  Eigen::VectorXd c_;
  double logdet_ = 0, yy_ = 0;
  Eigen::Index n_ = 0;
};

}  // namespace

double minusTwoLogLikelihood(const NoiseModel& m, const NoiseSeries& s, const Eigen::MatrixXd& X, bool reml,
                             Eigen::VectorXd* beta, Eigen::MatrixXd* beta_cov) {
  const int p = static_cast<int>(X.cols());
  const auto n = static_cast<Eigen::Index>(s.size());
  KalmanWhitener kf(m);
  GlsSums gls(p);
  std::vector<double> in(static_cast<std::size_t>(p + 1)), out(static_cast<std::size_t>(p + 1));
  for (Eigen::Index i = 0; i < n; ++i) {
    in[0] = s.y[static_cast<std::size_t>(i)];
    for (int k = 0; k < p; ++k) in[static_cast<std::size_t>(k + 1)] = X(i, k);
    kf.whitenColumns(s.t_s[static_cast<std::size_t>(i)], in.data(), out.data(), p + 1);
    gls.add(out.data(), kf.logInnovationVariance());
  }
  return gls.m2ll(reml, beta, beta_cov);
}

LikelihoodScore scoreLikelihood(const std::function<NoiseModel(const Eigen::VectorXd&)>& model, const Eigen::VectorXd& x,
                                double h, const NoiseSeries& s, const Eigen::MatrixXd& X, bool reml, bool central) {
  const auto np = x.size();
  const auto P = static_cast<std::size_t>(np);
  const int p = static_cast<int>(X.cols());
  const auto cols = static_cast<std::size_t>(p + 1);
  // Filter 0 at x, 2i + 1 at x + h e_i, 2i + 2 at x - h e_i (forward differences: x itself stands in
  // for x - h e_i, and the differences are over h).
  const std::size_t nf = central ? 2 * P + 1 : P + 1;
  auto hi = [&](std::size_t a) { return central ? 2 * a + 1 : a + 1; };
  auto lo = [&](std::size_t a) { return central ? 2 * a + 2 : std::size_t{0}; };
  std::vector<KalmanWhitener> kf;
  kf.reserve(nf);
  kf.emplace_back(model(x));
  for (Eigen::Index i = 0; i < np; ++i) {
    Eigen::VectorXd a = x, b = x;
    a[i] += h;
    b[i] -= h;
    kf.emplace_back(model(a));
    if (central) kf.emplace_back(model(b));
  }
  std::vector<GlsSums> gls(nf, GlsSums(p));
  std::vector<double> in(cols), out(nf * cols), e(nf * cols), logF(nf), de(P * cols), dl(P);
  // D[(a P + b) cols^2 + c cols + d] = sum de_a[c] de_b[d] / F over the samples (b <= a): the columns'
  // innovation derivatives, combined with the GLS coefficients at the end.
  std::vector<double> D(P * P * cols * cols, 0.0);
  Eigen::MatrixXd G = Eigen::MatrixXd::Zero(np, np);
  const double inv2h = central ? 1.0 / (2 * h) : 1.0 / h;  // over the differences' step
  for (std::size_t i = 0; i < s.size(); ++i) {
    in[0] = s.y[i];
    for (int k = 0; k < p; ++k) in[static_cast<std::size_t>(k + 1)] = X(static_cast<Eigen::Index>(i), k);
    for (std::size_t f = 0; f < nf; ++f) {
      double* o = out.data() + f * cols;
      kf[f].whitenColumns(s.t_s[i], in.data(), o, p + 1);
      logF[f] = kf[f].logInnovationVariance();
      gls[f].add(o, logF[f]);
      const double sF = std::sqrt(kf[f].innovationVariance());
      for (std::size_t c = 0; c < cols; ++c) e[f * cols + c] = o[c] * sF;
    }
    const double invF = 1.0 / kf[0].innovationVariance();
    for (std::size_t a = 0; a < P; ++a) {
      dl[a] = (logF[hi(a)] - logF[lo(a)]) * inv2h;
      for (std::size_t c = 0; c < cols; ++c) de[a * cols + c] = (e[hi(a) * cols + c] - e[lo(a) * cols + c]) * inv2h;
    }
    for (std::size_t a = 0; a < P; ++a)
      for (std::size_t b = 0; b <= a; ++b) {
        G(static_cast<Eigen::Index>(a), static_cast<Eigen::Index>(b)) += dl[a] * dl[b];
        double* Dab = D.data() + (a * P + b) * cols * cols;
        for (std::size_t c = 0; c < cols; ++c) {
          const double u = de[a * cols + c] * invF;
          for (std::size_t d = 0; d < cols; ++d) Dab[c * cols + d] += u * de[b * cols + d];
        }
      }
  }
  LikelihoodScore r;
  Eigen::VectorXd beta;
  r.m2ll = gls[0].m2ll(reml, &beta, nullptr);
  r.gradient.resize(np);
  for (std::size_t a = 0; a < P; ++a)
    r.gradient[static_cast<Eigen::Index>(a)] = (gls[hi(a)].m2ll(reml, nullptr, nullptr) - gls[lo(a)].m2ll(reml, nullptr, nullptr)) * inv2h;
  // The innovation of the residual y - X beta is e_y - e_X beta (beta at x: its own change with x does not
  // enter the expected Hessian of the profile to first order).
  std::vector<double> w(cols, 1.0);
  for (int k = 0; k < p; ++k) w[static_cast<std::size_t>(k + 1)] = -beta[k];
  r.information.resize(np, np);
  for (std::size_t a = 0; a < P; ++a)
    for (std::size_t b = 0; b <= a; ++b) {
      const double* Dab = D.data() + (a * P + b) * cols * cols;
      double q = 0;
      for (std::size_t c = 0; c < cols; ++c)
        for (std::size_t d = 0; d < cols; ++d) q += w[c] * Dab[c * cols + d] * w[d];
      const auto A = static_cast<Eigen::Index>(a), B = static_cast<Eigen::Index>(b);
      r.information(A, B) = r.information(B, A) = G(A, B) + 2 * q;
    }
  return r;
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
