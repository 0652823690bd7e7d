// Seeded series for the noise library's tests and benches: a model drawn on a grid with random gaps.
#pragma once

#include <boresight/model/noise.h>

#include <cmath>
#include <cstdint>
#include <limits>

namespace boresight::model::noisetest {

/// `slots` grid times k T (each moved by up to +-jitter T, uniformly), a fraction of about
/// `gap_fraction` of them removed in gaps of exponential length with a mean of `mean_len` samples
/// (40: many short gaps; hundreds: a few long ones); the model drawn at the remaining times
/// (NoiseSimulator, so the gaps are exact).
inline NoiseSeries gappedSeries(const NoiseModel& m, std::size_t slots, double T, double gap_fraction, std::uint64_t seed,
                                double jitter, double mean_len = 40) {
  NoiseSeries s;
  const CounterRng gaps(seed, Stream::HeadGap, 77), jit(seed, Stream::HeadTagJitter, 77);
  NoiseSimulator sim(m, CounterRng(seed, Stream::HeadNoise, 77));
  const double p = gap_fraction > 0 ? gap_fraction / (mean_len * (1 - gap_fraction)) : 0;
  double gap_until = -1;
  for (std::size_t k = 0; k < slots; ++k) {
    if (p > 0 && gaps.uniform(k, 0) < p) gap_until = std::max(gap_until, static_cast<double>(k) - mean_len * std::log(gaps.uniform(k, 1)));
    if (static_cast<double>(k) < gap_until) continue;
    const double t = (static_cast<double>(k) + jitter * (2 * jit.uniform(k) - 1)) * T;
    s.t_s.push_back(t);
    s.y.push_back(sim.next(t));
  }
  return s;
}

}  // namespace boresight::model::noisetest

#include <boresight/model/stats.h>

#include <Eigen/Cholesky>

#include <map>
#include <string>
#include <vector>

namespace boresight::model::noisetest {

/// One Monte Carlo case of the fitting tests: a true model, the structure fitted, and the true
/// parameter values by the fit's parameter names.
struct FitCase {
  std::string name;
  NoiseModel truth;
  NoiseStructure structure;
  std::map<std::string, double> values;
};

/// The four cases of the issue (white, Gauss-Markov, power law, a sum), with correlation times and
/// corner frequencies inside [20 / span, fs / 20] for a span of `span_s` sampled every T.
inline std::vector<FitCase> fitCases(double span_s, double T) {
  const double f_lo = 20.0 / span_s, f_hi = 1.0 / (20.0 * T);  // the determinable band
  const double g = std::sqrt(f_lo * f_hi);                      // its geometric middle
  const double tau = 1.0 / (6.283185307179586 * g);
  const double tau1 = 1.0 / (6.283185307179586 * std::sqrt(g * f_hi)), tau2 = 1.0 / (6.283185307179586 * std::sqrt(g * f_lo));
  std::vector<FitCase> c;
  c.push_back({"white", NoiseModel::white(2.0), NoiseStructure::White, {{"white.sigma", 2.0}}});
  c.push_back({"gauss_markov", NoiseModel::white(1.0).add(NoiseTerm::gaussMarkov(1.5, tau)), NoiseStructure::WhiteGaussMarkov,
               {{"white.sigma", 1.0}, {"gm1.sigma", 1.5}, {"gm1.tau_s", tau}}});
  const double pl_lo = f_lo * 2, pl_hi = f_hi / 2;
  // the fit's own term count (the truth is a member of the family fitted)
  const int K = powerLawFitTerms(span_s, T);
  c.push_back({"power_law", NoiseModel::white(1.0).add(NoiseTerm::powerLaw(3.0, 1.0, pl_lo, pl_hi, K)), NoiseStructure::WhitePowerLaw,
               {{"white.sigma", 1.0}, {"pl.asd_pivot", std::numeric_limits<double>::quiet_NaN()}, {"pl.sigma", 3.0},
                {"pl.alpha", 1.0}, {"pl.f_lo_hz", pl_lo}, {"pl.f_hi_hz", pl_hi}}});  // the level at the fit's pivot: truthOf
  c.push_back({"sum", NoiseModel::white(1.0).add(NoiseTerm::gaussMarkov(1.5, tau1)).add(NoiseTerm::gaussMarkov(2.0, tau2)),
               NoiseStructure::WhiteTwoGaussMarkov,
               {{"white.sigma", 1.0}, {"gm1.sigma", 1.5}, {"gm1.tau_s", tau1}, {"gm2.sigma", 2.0}, {"gm2.tau_s", tau2}}});
  return c;
}

/// Per parameter: how often |error| <= 3 sigma among the runs where it was determined; and the
/// normalised error squared over the determined parameters (its sum over runs is chi-square with
/// the summed degrees of freedom when the sigmas are right).
struct FitMcResult {
  std::map<std::string, int> within3, determined;
  int runs = 0, converged = 0, chosen_right = 0, truth_not_rejected = 0;
  int whittle = 0;  ///< fits that used the Whittle likelihood
  double nees_sum = 0;
  int nees_dof = 0;
  /// Exact likelihood: the likelihood-ratio statistic at the truth, -2 log L(truth) + 2 log L(fit),
  /// summed over the runs, and the fitted parameters summed (chi-square with that many degrees of
  /// freedom when the fits are the maxima; unlike NEES it does not depend on the parameterisation).
  double lr_sum = 0;
  int lr_dof = 0;
  double seconds_per_fit = 0;
};

/// The truth's value of a fitted parameter: from the case's table, or for a spectral level at a
/// frequency (the power law's "pl.asd_pivot", at the fit's pivot) from the true model's power law.
inline double truthOf(const FitCase& c, const NoiseParam& p) {
  if (p.at_hz > 0) {
    NoiseModel pl;
    for (const NoiseTerm& t : c.truth.terms)
      if (t.kind == NoiseKind::PowerLaw) pl.add(t);
    return std::sqrt(pl.psdContinuous(p.at_hz, 1.0));  // no white part: the interval does not enter
  }
  return c.values.at(p.name);
}

/// A fit's normalised error squared over its determined parameters that are not derived, with their
/// joint covariance (the errors on the reporting scale: log for log-scale parameters); *dof receives
/// their number.
inline double jointNees(const NoiseFit& f, const FitCase& c, int* dof) {
  std::vector<Eigen::Index> idx;
  std::vector<double> err;
  for (std::size_t i = 0; i < f.params.size(); ++i) {
    const NoiseParam& p = f.params[i];
    if (!p.determined || p.derived) continue;
    const double t = truthOf(c, p);
    idx.push_back(static_cast<Eigen::Index>(i));
    err.push_back(p.log_scale ? std::log(p.value) - std::log(t) : p.value - t);
  }
  *dof = static_cast<int>(idx.size());
  if (idx.empty()) return 0.0;
  const auto n = static_cast<Eigen::Index>(idx.size());
  Eigen::MatrixXd C(n, n);
  Eigen::VectorXd e(n);
  for (Eigen::Index a = 0; a < n; ++a) {
    e[a] = err[static_cast<std::size_t>(a)];
    for (Eigen::Index b = 0; b < n; ++b) C(a, b) = f.cov(idx[static_cast<std::size_t>(a)], idx[static_cast<std::size_t>(b)]);
  }
  return e.dot(C.ldlt().solve(e));
}

/// The series of the Monte Carlo runs: how many gaps and how long, and the likelihood fitted.
struct McSetup {
  double gap_fraction = 0.05;
  double gap_mean_len = 40;  ///< samples
  NoiseLikelihood likelihood = NoiseLikelihood::Exact;
};

inline FitMcResult runFitMc(const FitCase& c, int runs, std::size_t slots, double T, const McSetup& setup, std::uint64_t seed0,
                            bool also_select = false) {
  FitMcResult r;
  NoiseFitOptions opt;
  opt.likelihood = setup.likelihood;
  for (int k = 0; k < runs; ++k) {
    const NoiseSeries s = gappedSeries(c.truth, slots, T, setup.gap_fraction, seed0 + static_cast<std::uint64_t>(k), 0.0,
                                       setup.gap_mean_len);
    Eigen::MatrixXd X = Eigen::MatrixXd::Ones(static_cast<Eigen::Index>(s.size()), 1);  // an unknown mean
    // With the BIC choice, the fit of the simulated structure is the selection's own.
    NoiseSelection sel;
    if (also_select) sel = selectNoise(s, defaultNoiseStructures(), X, opt);
    NoiseFit f;
    for (const auto& g : sel.fits)
      if (g.structure == c.structure) f = g;
    if (!also_select) f = fitNoise(s, c.structure, X, opt);
    ++r.runs;
    r.whittle += f.likelihood == NoiseLikelihood::Whittle;
    r.converged += f.converged;
    for (const NoiseParam& p : f.params) {
      if (!p.determined) continue;
      const double t = truthOf(c, p);
      const double e = p.log_scale ? std::log(p.value) - std::log(t) : p.value - t;
      ++r.determined[p.name];
      r.within3[p.name] += std::abs(e) <= 3 * (p.log_scale ? p.log_sigma : p.sigma);
    }
    int dof = 0;
    const double nees = jointNees(f, c, &dof);
    if (dof > 0) {
      r.nees_sum += nees;
      r.nees_dof += dof;
    }
    if (f.likelihood == NoiseLikelihood::Exact && !f.model.empty()) {
      r.lr_sum += minusTwoLogLikelihood(c.truth, s, X, opt.reml) - f.m2ll;
      for (const NoiseParam& p : f.params) r.lr_dof += p.derived ? 0 : 1;  // the parameters fitted
    }
    if (also_select) {
      r.chosen_right += sel.best >= 0 && sel.chosen().structure == c.structure;
      for (const auto& g : sel.fits)
        if (g.structure == c.structure) r.truth_not_rejected += sel.best >= 0 && g.bic - sel.chosen().bic < 10;
    }
  }
  return r;
}

/// Two-sided 95 % bounds of a chi-square variable with k degrees of freedom, divided by k.
inline void neesBounds(int k, double& lo, double& hi) {
  lo = stats::chi2Quantile(0.975, k) / k;
  hi = stats::chi2Quantile(0.025, k) / k;
}

}  // namespace boresight::model::noisetest
