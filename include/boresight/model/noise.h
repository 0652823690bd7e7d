// Noise as the data has it: the one noise library of the project. Models of one sensor axis (white,
// first-order Gauss-Markov, a band-limited power law, and sums of them), their power spectral
// densities and autocovariances in closed form, seeded simulation, whitening and its inverse on
// irregular sampling across gaps, the exact Gaussian likelihood, fitting with uncertainties and
// model choice, a portmanteau whiteness test, and variance-component estimation. The simulator,
// the method A solver and the audit all use this header; nothing else models noise.
//
// Definitions (one axis, values in the sensor's unit u, e.g. rad or rad/s^2; time in seconds):
//   White        w_n ~ N(0, sigma^2) independent per SAMPLE (so its level does not depend on the
//                sampling interval; its one-sided PSD at sampling interval T is 2 sigma^2 T).
//   Gauss-Markov x(t), stationary, variance sigma^2, autocovariance sigma^2 exp(-|lag| / tau);
//                continuous one-sided PSD 4 sigma^2 tau / (1 + (2 pi f tau)^2) (a Lorentzian with
//                corner frequency f_c = 1 / (2 pi tau)). Exact discretisation between any two times
//                dt apart: x' = phi x + sqrt(1 - phi^2) sigma e, phi = exp(-dt / tau).
//   Power law    a band-limited 1/f^alpha: the PSD follows f^-alpha between f_lo and f_hi, is flat
//                below f_lo and falls as f^-2 above f_hi. It IS a sum of K Gauss-Markov terms (it is
//                not approximated by them: the sum is the model, so its PSD and autocovariance are
//                exact): corner frequencies f_k = f_lo r^k, k = 0..K-1, r = (f_hi/f_lo)^(1/(K-1)),
//                variances sigma^2 w_k with w_k proportional to f_k^(1 - alpha), sum w_k = 1 (sigma is
//                the stationary standard deviation of the whole term). K is part of the term
//                (`pl_terms`); 0 means three per decade, K = max(2, round(3 log10(f_hi/f_lo)) + 1). For a
//                fixed K the model is smooth in every parameter, which the fit needs.
//                0 < alpha < 2 keeps the sum meaningful. The sum has soft corners: in the middle two
//                decades of a five-decade band its local log-log slope is -alpha within 0.08 (for
//                alpha = 1 within 0.015, ripple under 2 %), and for alpha = 1 the PSD is 14 % below
//                the power law a third of a decade inside a corner (test/model/noise_test.cc).
//                alpha, f_lo and f_hi are parameters of this exact model, not of an ideal power law.
//   A model is a sum of independent terms: its canonical form is one white variance plus a list of
//   Gauss-Markov terms (markovTerms()).
//
// Why a state-space form (and not AR): the state of the Gauss-Markov terms propagates exactly over
// any time step, so irregular sampling and gaps of any length are exact, without resampling or
// interpolated samples; the Kalman filter's innovations are the whitened series (their prediction-
// error decomposition is the exact Gaussian likelihood), and running the same filter backwards from
// innovations re-colours a white series (the inverse). An AR form needs a regular grid. Cost: O(K^2)
// per sample while the filter's covariance changes (one pass over P makes the last step's update, the
// propagation and the next gain's P h), O(K) once it has settled on a regular grid (the gain is frozen
// when the covariance stops changing by more than 1e-12 relative and thawed at the next irregular
// step).
//
// Banded whitening (BandedWhitener): for noise that is a moving average of white noise (the CRN
// filter's output), the correlation is zero beyond a finite lag; there the banded Cholesky factor of
// the correlation matrix is the exact whitener on a grid with gaps (method A's CRN rows).
#pragma once

#include <boresight/model/random.h>

#include <Eigen/Core>

#include <cmath>

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <utility>
#include <vector>

namespace boresight::model {

enum class NoiseKind : std::uint8_t { White, GaussMarkov, PowerLaw };
const char* noiseKindName(NoiseKind k);  ///< "white", "gauss_markov", "power_law"

/// One independent term of an axis's noise (see the header comment for the definitions).
struct NoiseTerm {
  NoiseKind kind = NoiseKind::White;
  double sigma = 0;   ///< white: per-sample 1-sigma; Gauss-Markov and power law: stationary 1-sigma
  double tau_s = 0;   ///< Gauss-Markov correlation time, s
  double alpha = 1;   ///< power law: PSD about proportional to f^-alpha inside [f_lo, f_hi], 0 < alpha < 2
  double f_lo_hz = 0, f_hi_hz = 0;  ///< power law band, Hz (0 < f_lo < f_hi)
  int pl_terms = 0;   ///< power law: number of Gauss-Markov terms K (0: three per decade)

  static NoiseTerm white(double sigma);
  static NoiseTerm gaussMarkov(double sigma, double tau_s);
  static NoiseTerm powerLaw(double sigma, double alpha, double f_lo_hz, double f_hi_hz, int terms = 0);
  /// K of a power law: `terms`, or three per decade when 0.
  int powerLawTermCount() const;
  bool operator==(const NoiseTerm& o) const;
};

/// A Gauss-Markov term of the canonical form.
struct MarkovTerm {
  double var = 0;    ///< stationary variance
  double tau_s = 1;  ///< correlation time
};

/// The noise of one sensor axis: a sum of independent terms.
struct NoiseModel {
  std::vector<NoiseTerm> terms;

  static NoiseModel white(double sigma);
  NoiseModel& add(const NoiseTerm& t);
  bool empty() const { return terms.empty(); }
  bool operator==(const NoiseModel& o) const { return terms == o.terms; }

  /// Checks every term (finite, positive levels and times, 0 < alpha < 2, f_lo < f_hi); "" when valid.
  std::string validate() const;
  /// Sum of the white terms' per-sample variances.
  double whiteVariance() const;
  /// Every Gauss-Markov term, power laws expanded (header comment), in term order.
  std::vector<MarkovTerm> markovTerms() const;
  /// Total stationary variance of one sample (white plus coloured).
  double variance() const;
  /// Autocovariance at a lag in seconds; lag 0 includes the white variance.
  double autocovariance(double lag_s) const;
  /// One-sided PSD (u^2/Hz) of the process sampled every T seconds, at 0 <= f <= 1/(2T), aliasing
  /// included (exact for the sampled Gauss-Markov terms). Integrates to variance() over [0, 1/(2T)].
  double psdSampled(double f_hz, double T_s) const;
  /// One-sided PSD of the continuous coloured part (no aliasing) plus the white part's 2 sigma^2 T.
  double psdContinuous(double f_hz, double T_s) const;
  /// A short human-readable form, e.g. "white 2.1 + GM(0.8, 600 s)" with values scaled by `scale`
  /// and `unit` appended to levels.
  std::string describe(double scale = 1.0, const std::string& unit = "") const;
};

/// Power-law term expansion used by markovTerms() (exposed for tests and plots).
std::vector<MarkovTerm> powerLawTerms(const NoiseTerm& p);

// ---------------------------------------------------------------------------------------------
// Simulation

/// The exact Gauss-Markov step over dt: x' = phi x + sqrt(1 - phi^2) (sigma e), phi = exp(-dt / tau),
/// e standard normal. Written once, in this order of operations (the simulator's existing output of
/// the accelerometer's Gauss-Markov noise depends on it bit for bit).
inline double gaussMarkovStep(double x, double phi, double sigma, double e) {
  return phi * x + std::sqrt(1 - phi * phi) * (sigma * e);
}

/// Draws one axis of a model at non-decreasing times (any spacing, gaps allowed). Sample n (the n-th
/// call of next(), counted from 0) uses normals of `rng` at index n only (and of rng.derived(c) for
/// the terms beyond the seventh, eight per stream): draws are a pure function of (seed, stream,
/// sensor key, n) and of the term's place, so switching other effects on or off, or adding terms after
/// a term, does not change them. The
/// Gauss-Markov states start from their stationary distribution at the first call.
class NoiseSimulator {
 public:
  NoiseSimulator() = default;
  NoiseSimulator(const NoiseModel& m, const CounterRng& rng);
  /// The noise value at time t_s (>= the previous call's time).
  double next(double t_s);
  std::uint64_t count() const { return n_; }

 private:
  double white_sigma_ = 0;
  std::vector<MarkovTerm> gm_;
  std::vector<double> x_, phi_;  ///< states; transitions of the last step (kept while the step repeats)
  double dt_ = -1;
  CounterRng rng_{0, Stream::HeadNoise, 0};
  std::vector<CounterRng> chunks_;  ///< rng_.derived(1, 2, ...) for terms 8.. (see next())
  std::uint64_t n_ = 0;
  double t_prev_ = 0;
};

// ---------------------------------------------------------------------------------------------
// Whitening, colouring and the exact likelihood (state space)

/// The Kalman filter of a model's state space, one sample at a time. whiten() returns the
/// standardised innovation (unit variance, independent across samples when the model is right);
/// colour() is its exact inverse. A constant `mean` may be given per call (it is subtracted).
class KalmanWhitener {
 public:
  KalmanWhitener() = default;
  explicit KalmanWhitener(const NoiseModel& m);
  void reset();
  /// Standardised innovation of y at t (non-decreasing t). var() is the innovation variance.
  double whiten(double t_s, double y);
  /// The inverse: the y whose whiten() would return z at t.
  double colour(double t_s, double z);
  /// Whitens several columns observed at the same time with this step's gains (a regressor matrix
  /// and the data, for generalised least squares): out[j] = whitened in[j]. The filter state of
  /// each column is kept separately (columns() fixes their number at the first call after reset).
  void whitenColumns(double t_s, const double* in, double* out, int columns);
  /// Innovation variance of the last step.
  double innovationVariance() const { return F_; }
  double logInnovationVariance() const { return logF_; }
  /// Sum over the steps since reset of log(2 pi F) + z^2 (for whiten()): -2 log-likelihood.
  double minusTwoLogLikelihood() const { return m2ll_; }
  std::size_t steps() const { return steps_; }

 private:
  void predict(double t_s);
  void gainStep();  // the gain K_ and innovation variance F_ of the predicted covariance
  double white_var_ = 0;
  std::vector<MarkovTerm> gm_;
  int k_ = 0;
  // Small dense arrays (k_ is a few to a dozen): row-major P (its upper triangle), per-term transition and gain.
  std::vector<double> phi_, q_, K_, s_, s_next_, P_;
  std::vector<double> pp_;  ///< phi_a phi_b of the current step (row-major k_ x k_)
  std::vector<double> X_;  ///< filter states, column-major k_ x columns_ (column 0 serves whiten()/colour())
  int columns_ = 0;
  double F_ = 1, logF_ = 0, inv_sqrt_F_ = 1, t_prev_ = 0, dt_prev_ = -1, m2ll_ = 0;
  bool started_ = false, frozen_ = false;
  bool pending_ = false;  ///< P_ is the prior of the last step; its update K_ s_^T is still to be made
  bool sums_ = false;     ///< s_ holds the row sums of P_ (made by predict's pass)
  std::size_t steps_ = 0;
  int settle_ = 0;
};

/// A series of one axis: times (s, increasing), values, and an optional per-sample mask.
struct NoiseSeries {
  std::vector<double> t_s;
  std::vector<double> y;
  std::size_t size() const { return y.size(); }
  /// The median sampling interval (s); 0 for fewer than two samples.
  double medianInterval() const;
  double span() const { return t_s.empty() ? 0.0 : t_s.back() - t_s.front(); }
};

/// -2 log-likelihood of y under the model (exact, through the Kalman filter), with the columns of X
/// (n x p, may be empty) profiled out by generalised least squares. reml adds log det(X^T S^-1 X)
/// (the restricted likelihood, unbiased variances when a mean or trend is fitted). beta (optional)
/// receives the GLS coefficients, beta_cov their covariance.
double minusTwoLogLikelihood(const NoiseModel& m, const NoiseSeries& s, const Eigen::MatrixXd& X = Eigen::MatrixXd(),
                             bool reml = true, Eigen::VectorXd* beta = nullptr, Eigen::MatrixXd* beta_cov = nullptr);

/// The exact likelihood at a point of a model's parameters with its first derivatives, for fitting:
/// `model(x)` gives the model at parameters x. In one pass over the series the Kalman filters of x and
/// of x +- h e_i run side by side (2p + 1 of them), so that
///  - m2ll is minusTwoLogLikelihood(model(x), s, X, reml),
///  - gradient its central difference in x (the same evaluations as 2p separate passes), and
///  - information the expected Hessian of -2 log L given this series (its gaps, its sampling, its
///    regressors): sum over the samples of d log F d log F^T + 2 d e d e^T / F, with e the innovation
///    (the regressors' GLS fit taken out) and F its variance, their derivatives by the same central
///    differences. The expectation uses only that an innovation is independent of the past it is
///    predicted from, so it holds at any x; at the optimum it is the Fisher information of the data's
///    own gaps, where a spectrum's information is that of a gap-free series.
struct LikelihoodScore {
  double m2ll = 0;
  Eigen::VectorXd gradient;
  Eigen::MatrixXd information;
};
/// central = false: forward differences from p + 1 filters (x and x + h e_i), for steps far from the
/// optimum where the gradient's O(h) error does not matter.
LikelihoodScore scoreLikelihood(const std::function<NoiseModel(const Eigen::VectorXd&)>& model, const Eigen::VectorXd& x,
                                double h, const NoiseSeries& s, const Eigen::MatrixXd& X = Eigen::MatrixXd(), bool reml = true,
                                bool central = true);

/// Whitened residuals of y (X's columns profiled out as above when X is given).
std::vector<double> whitenSeries(const NoiseModel& m, const NoiseSeries& s, const Eigen::MatrixXd& X = Eigen::MatrixXd());

// ---------------------------------------------------------------------------------------------
// Fitting and model choice

/// The structure of a model to fit: which terms, and which of their parameters are free.
enum class NoiseStructure : std::uint8_t {
  White,              ///< sigma_w
  WhiteGaussMarkov,   ///< sigma_w, sigma_gm, tau
  WhiteTwoGaussMarkov,///< sigma_w, sigma_1, tau_1, sigma_2, tau_2 (tau_1 < tau_2)
  WhitePowerLaw,      ///< sigma_w, sigma_pl, alpha, f_lo, f_hi
  GaussMarkov,        ///< sigma_gm, tau (no white part)
};
const char* noiseStructureName(NoiseStructure s);
/// The default candidate set of selectNoise().
std::vector<NoiseStructure> defaultNoiseStructures();

/// One fitted parameter. Levels, times and frequencies are fitted on a log scale (value = exp(x),
/// sigma from the delta method; log_sigma is the standard error of x); alpha on its own scale.
struct NoiseParam {
  std::string name;       ///< "white.sigma", "gm1.sigma", "gm1.tau_s", "pl.alpha", "pl.f_lo_hz", ... (model/overlay.h: noiseTermName)
  double value = 0;
  double sigma = 0;       ///< standard error (delta method from the log scale)
  double log_sigma = 0;   ///< standard error of log(value) (0 for alpha)
  bool log_scale = true;
  bool determined = true; ///< false: outside what the span and the sampling can determine (note says why)
  std::string note;
  double at_hz = 0;       ///< a spectral level's frequency ("pl.asd_pivot"), else 0
  bool derived = false;   ///< a function of the other parameters, outside NoiseFit::cov (its sigma by the delta method)
};

/// Which likelihood a fit maximises.
///  - Exact: the state-space likelihood of every sample (gaps and irregular sampling included); one
///    evaluation is a Kalman pass over the series, so a fit of a day costs seconds.
///  - Whittle: the frequency-domain approximation on the series' long gap-free runs (each run's
///    periodogram at its Fourier frequencies, runs taken as independent, pooled in narrow
///    log-frequency bins; the mean of each run drops out with its zero frequency). One evaluation
///    costs microseconds. Valid when the runs are long against the slowest correlation time fitted:
///    the determinable band then starts at band_lo / (longest run) instead of band_lo / span.
///    Uncertainties from the expected (Fisher) information of the periodogram.
///  - Auto: Whittle when at least `whittle_min_coverage` of the samples lie in runs of at least
///    `whittle_min_run` of the span (few, long gaps), else Exact.
enum class NoiseLikelihood : std::uint8_t { Exact, Whittle, Auto };
const char* noiseLikelihoodName(NoiseLikelihood l);

struct NoiseFitOptions {
  NoiseLikelihood likelihood = NoiseLikelihood::Exact;
  double whittle_min_coverage = 0.95;  ///< Auto: fraction of samples in long runs
  double whittle_min_run = 0.25;       ///< Auto: a long run, as a fraction of the span
  bool reml = true;
  int max_iterations = 60;
  /// Correlation times and corner frequencies are determined only inside [band_lo / span, fs /
  /// band_hi] (corner frequency 1/(2 pi tau)); outside, the parameter is reported not determined.
  double band_lo = 20, band_hi = 20;
  /// Number of terms of a fitted power law (fixed during the fit; 0: powerLawFitTerms of the series).
  int pl_terms = 0;
  /// A known part of the series' noise, added to every candidate and not fitted (e.g. what other
  /// sensors contribute to a difference series). NoiseFit::model does not include it.
  NoiseModel fixed;
  /// selectNoise: when white+gauss_markov does not lower BIC below white's, white+2gauss_markov and
  /// white+power_law are not fitted (listed with a message, model empty). Needs both fitted first
  /// (converged or not: the Gauss-Markov structure holds white, so a fit worse than white found no colour).
  /// Likewise white+power_law is not fitted when white+2gauss_markov does not lower BIC below
  /// white+gauss_markov's (one scale shows; needs both fitted first).
  bool skip_when_no_colour = true;
};

/// The power-law term count a fit uses by default: three per decade between 10 / span and 1 / (2 T)
/// (the widest band the data can show), 3..16.
int powerLawFitTerms(double span_s, double T_s);

struct NoiseFit {
  NoiseStructure structure = NoiseStructure::White;
  NoiseModel model;
  std::vector<NoiseParam> params;
  /// Covariance of the parameters that are not derived (params[i] for i < cov.rows()), on their
  /// reporting scale (log for log-scale ones). The power law's level enters as its amplitude spectral
  /// density at the pivot ("pl.asd_pivot"), the frequency where the data determine it best; its total
  /// sigma follows as a derived parameter. (Wald regions depend on the coordinates: in (sigma, alpha,
  /// corners) the likelihood is far from quadratic - the total variance couples the slope and the lower
  /// corner: over 200 exact fits the joint normalised error was 1.246 per degree of freedom, 1.021 with
  /// the level at the pivot; src/noise/DESIGN.md.)
  Eigen::MatrixXd cov;
  Eigen::VectorXd beta;           ///< GLS coefficients of X's columns
  Eigen::MatrixXd beta_cov;
  double m2ll = 0;                ///< -2 log-likelihood (restricted when reml)
  double aic = 0, bic = 0;
  std::size_t n = 0;
  bool converged = false;
  int evaluations = 0;            ///< likelihood evaluations (exact: each a pass over the series)
  NoiseLikelihood likelihood = NoiseLikelihood::Exact;  ///< the one used (never Auto)
  std::size_t whittle_samples = 0; ///< Whittle: samples in the runs used (the rest were in short runs)
  double f_det_lo = 0, f_det_hi = 0;  ///< the band in which its times and corners count as determined, Hz
  std::string message;            ///< why not converged, or ""
  const NoiseParam* find(const std::string& name) const;
  /// The fitted model's one-sided PSD at f (Hz; sampled every T_s: NoiseModel::psdSampled) as its natural log, with the
  /// standard error of that log from the fit's covariance (delta method on the fitting coordinates).
  /// Parameters on a bound of their range are held at it (the others' covariance is the one given
  /// them); a parameter without a variance for another reason (a flat direction of the likelihood) is
  /// held where the PSD at f hardly depends on it (under 0.01 per unit of its fitting scale) and
  /// makes the standard error infinite where it does (not determined at f). The model only, not a
  /// fixed part the fit held (fit.model). {NaN, NaN} for a fit without parameters.
  std::pair<double, double> logPsd(double f_hz, double T_s) const;
  // logPsd's inputs: the fitting coordinates, their covariance (the same as cov except for the power
  // law, whose cov is on the reporting scale) and which of them sit on a bound of their range
  Eigen::VectorXd x_fit;
  Eigen::MatrixXd cov_fit;
  std::vector<bool> on_bound;
};

/// Maximum-likelihood fit of one structure to a series (gaps allowed: the exact likelihood). The
/// columns of X (regressors such as a constant) are profiled out by GLS at every evaluation. The
/// Whittle likelihood (opt.likelihood) takes X as the mean of each run (it drops out with the zero
/// frequency); with other regressors the fit is exact.
NoiseFit fitNoise(const NoiseSeries& s, NoiseStructure structure, const Eigen::MatrixXd& X = Eigen::MatrixXd(),
                  const NoiseFitOptions& opt = {});

/// The white level alone from the differences of consecutive samples (on the series' regular grid):
/// d_k = y_k - y_{k-1} is 2 sigma^2 white with correlation -1/2 between differences that share a
/// sample, whatever changes slower than one interval (a mean, a drift, slow noise) adds almost nothing.
/// Exact Gaussian likelihood through the banded whitener: sigma^2 = d^T R^-1 d / n, standard error
/// sigma / sqrt(2 n). For spans too short to fit a coloured part: the white level without the slow
/// content a whole-variance fit would put into it. Structure White; m2ll is the differences'.
NoiseFit fitWhiteFromDifferences(const NoiseSeries& s);

struct NoiseSelection {
  std::vector<NoiseFit> fits;  ///< every candidate, in the order given
  int best = -1;               ///< index of the smallest BIC among the fits with a model (one that did not settle counts with the likelihood it reached)
  const NoiseFit& chosen() const { return fits[static_cast<std::size_t>(best)]; }
  /// The candidates' log PSD at f averaged with Akaike weights (w_k proportional to exp(-AIC_k / 2)
  /// over the fits with a model, as in the choice) and its unconditional standard error, sum_k w_k sqrt(se_k^2 +
  /// (logS_k - mean)^2) (Burnham and Anderson: the spread between the candidates is added to each
  /// one's own, so the choice of model is part of the uncertainty). Candidates with a weight under
  /// 1e-3 are left out; the error is infinite when a kept candidate's spectrum is not determined at
  /// f (NoiseFit::logPsd); {NaN, NaN} when no fit has a model.
  std::pair<double, double> averagedLogPsd(double f_hz, double T_s) const;
};

/// Fits every structure and chooses by the Bayesian information criterion.
NoiseSelection selectNoise(const NoiseSeries& s, const std::vector<NoiseStructure>& structures = defaultNoiseStructures(),
                           const Eigen::MatrixXd& X = Eigen::MatrixXd(), const NoiseFitOptions& opt = {});

// ---------------------------------------------------------------------------------------------
// Spectra and whiteness

/// Ljung-Box portmanteau test of a series taken as consecutive (whitened innovations are independent
/// whatever the gaps were): Q = n (n + 2) sum_{k=1..h} r_k^2 / (n - k), p-value from chi-square with
/// h - dof_used degrees of freedom.
struct LjungBox {
  double Q = 0, p_value = 1;
  int lags = 0, dof = 0;
};
LjungBox ljungBox(const std::vector<double>& z, int lags, int dof_used = 0);

/// One-sided periodogram (u^2/Hz) of a regularly sampled series by Welch's method (Hann windows of
/// `segment` samples, half overlapped, mean removed per segment). Frequencies k / (segment T).
struct Spectrum {
  std::vector<double> f_hz, psd;
  int segments = 0;
};
Spectrum welchPsd(const std::vector<double>& y, double T_s, std::size_t segment);

/// Welch PSD of an irregular series with gaps: the series is cut into runs on a regular grid of
/// interval T (samples within 10 % of the grid; a run ends at a gap), segments are taken within runs.
Spectrum welchPsdGapped(const NoiseSeries& s, double T_s, std::size_t segment);

// ---------------------------------------------------------------------------------------------
// Banded whitening (finite correlation length, e.g. CRN-filtered white noise)

/// Whitens sequences whose correlation between samples k and m is rho[round(|t_k - t_m| / D)] (zero
/// beyond the length of rho), by the banded Cholesky factor of their correlation matrix. Samples may
/// be missing (gaps): the factor follows the actual time lags.
class BandedWhitener {
 public:
  /// t: sample times (us, increasing); D: lag unit (s); rho: correlation at lags 0, 1, ... (rho[0] = 1).
  BandedWhitener(const std::vector<std::int64_t>& t_us, double D_s, const std::vector<double>& rho);
  std::size_t size() const { return n_; }
  int bandwidth() const { return K_; }
  /// L(k, m) for k - K <= m <= k.
  double factor(std::size_t k, std::size_t m) const;
  /// z_k = (x_k - sum_m L(k, m) z_m) / L(k, k), applied in place to a sequence of values that is
  /// walked in order: call with k = 0, 1, ...; `prev(m)` returns the already whitened z_m.
  template <typename T, typename Prev>
  T whitenAt(std::size_t k, T x, Prev prev) const {
    const std::size_t m0 = k >= static_cast<std::size_t>(K_) ? k - static_cast<std::size_t>(K_) : 0;
    for (std::size_t m = m0; m < k; ++m) x -= factor(k, m) * prev(m);
    return x / factor(k, k);
  }
  /// Whitens a whole sequence of doubles.
  std::vector<double> whiten(const std::vector<double>& x) const;

 private:
  std::size_t n_ = 0;
  int K_ = 0;
  std::vector<double> L_;
};

// ---------------------------------------------------------------------------------------------
// Variance-component estimation (Foerstner / Koch, as GROOPS weights star cameras and accelerometers)

/// One observation group of a least-squares problem, at the current weights: the group's
/// contribution N_g = A_g^T P_g A_g to the normal matrix (on the full parameter vector), its weighted
/// residual square sum e_g^T P_g e_g, and its number of observations.
struct VarianceGroup {
  std::string name;
  Eigen::MatrixXd N;
  double ssr = 0;
  double n_obs = 0;
};

struct VarianceComponents {
  std::vector<double> factor;      ///< estimated variance factor per group (multiply its variances by it)
  std::vector<double> redundancy;  ///< r_g = n_g - tr(N_g N^+)
  bool ok = false;
  std::string message;
};

/// One estimation step: with N = sum_g N_g, r_g = n_g - tr(N_g N^+), factor_g = ssr_g / r_g. Iterate
/// (re-weight each group's P_g by 1 / factor_g, re-solve, call again) until the factors are 1. N^+ is
/// the pseudo-inverse: directions that no group determines take no redundancy (a problem with an
/// unobservable direction, as method A's about an unexcited axis, has its components too).
VarianceComponents estimateVarianceComponents(const std::vector<VarianceGroup>& groups);

}  // namespace boresight::model
