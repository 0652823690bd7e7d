// Fitting noise models to a residual series (noise.h): maximum likelihood through the exact
// state-space likelihood (gaps and irregular sampling included), started from a least-squares fit of
// the model's spectrum to the data's Welch spectrum; uncertainties from the observed information
// (a finite-difference Hessian of -2 log L on the fitting scale) or, on long series fitted by the
// scorer's steps, from the information of the data's own gaps (scoreLikelihood); model choice by BIC.
#include <boresight/model/minimise.h>
#include <boresight/model/noise.h>

#include <Eigen/Eigenvalues>
#include <unsupported/Eigen/FFT>

#include <algorithm>
#include <cmath>
#include <complex>
#include <functional>
#include <limits>
#include <sstream>

namespace boresight::model {
namespace {

constexpr double kTwoPi = 6.283185307179586;
constexpr double kInf = std::numeric_limits<double>::infinity();

struct ParamDef {
  const char* name;
  bool log_scale;
};

std::vector<ParamDef> paramDefs(NoiseStructure s) {
  switch (s) {
    case NoiseStructure::White: return {{"white.sigma", true}};
    case NoiseStructure::WhiteGaussMarkov: return {{"white.sigma", true}, {"gm1.sigma", true}, {"gm1.tau_s", true}};
    case NoiseStructure::WhiteTwoGaussMarkov:
      return {{"white.sigma", true}, {"gm1.sigma", true}, {"gm1.tau_s", true}, {"gm2.sigma", true}, {"gm2.tau_s", true}};
    case NoiseStructure::WhitePowerLaw:
      return {{"white.sigma", true}, {"pl.sigma", true}, {"pl.alpha", false}, {"pl.f_lo_hz", true}, {"pl.f_hi_hz", true}};
    case NoiseStructure::GaussMarkov: return {{"gm1.sigma", true}, {"gm1.tau_s", true}};
  }
  return {};
}

NoiseModel modelOf(NoiseStructure s, const Eigen::VectorXd& x, int pl_terms, const NoiseModel* fixed = nullptr) {
  NoiseModel m;
  if (fixed) m.terms = fixed->terms;
  auto e = [&](int i) { return std::exp(x[i]); };
  switch (s) {
    case NoiseStructure::White: m.add(NoiseTerm::white(e(0))); break;
    case NoiseStructure::WhiteGaussMarkov:
      m.add(NoiseTerm::white(e(0))).add(NoiseTerm::gaussMarkov(e(1), e(2)));
      break;
    case NoiseStructure::WhiteTwoGaussMarkov:
      m.add(NoiseTerm::white(e(0))).add(NoiseTerm::gaussMarkov(e(1), e(2))).add(NoiseTerm::gaussMarkov(e(3), e(4)));
      break;
    case NoiseStructure::WhitePowerLaw:
      m.add(NoiseTerm::white(e(0))).add(NoiseTerm::powerLaw(e(1), x[2], e(3), e(4), pl_terms));
      break;
    case NoiseStructure::GaussMarkov: m.add(NoiseTerm::gaussMarkov(e(0), e(1))); break;
  }
  return m;
}

/// The box the fit stays in (fitting scale), from the data's scale, interval and span.
struct Box {
  Eigen::VectorXd lo, hi;
  Eigen::VectorXd clamp(const Eigen::VectorXd& x) const { return x.cwiseMax(lo).cwiseMin(hi); }
  /// Parameter i of x on (within 1e-3 of) a bound: the data do not pull it inside.
  bool atBound(const Eigen::VectorXd& x, Eigen::Index i) const { return x[i] <= lo[i] + 1e-3 || x[i] >= hi[i] - 1e-3; }
};

Box boxOf(NoiseStructure s, double sd, double T, double span) {
  const auto defs = paramDefs(s);
  Box b;
  const auto n = static_cast<Eigen::Index>(defs.size());
  b.lo.resize(n);
  b.hi.resize(n);
  const double ls = std::log(sd);
  for (Eigen::Index i = 0; i < n; ++i) {
    const std::string name = defs[static_cast<std::size_t>(i)].name;
    if (name.find("sigma") != std::string::npos) {
      b.lo[i] = ls - 12;
      b.hi[i] = ls + 4;
    } else if (name.find("tau") != std::string::npos) {
      b.lo[i] = std::log(T / 10);
      b.hi[i] = std::log(std::max(span, T) * 100);
    } else if (name == "pl.alpha") {
      b.lo[i] = 0.02;
      b.hi[i] = 1.98;
    } else {  // corner frequencies
      b.lo[i] = std::log(1.0 / (std::max(span, T) * 100));
      b.hi[i] = std::log(5.0 / T);
    }
  }
  return b;
}

/// Keeps structural orderings: f_hi above f_lo, the two Gauss-Markov terms' times apart.
Eigen::VectorXd project(NoiseStructure s, const Box& box, const Eigen::VectorXd& x0) {
  Eigen::VectorXd x = box.clamp(x0);
  if (s == NoiseStructure::WhitePowerLaw) x[4] = std::max(x[4], x[3] + std::log(1.05));
  return x;
}

// --- minimisers ------------------------------------------------------------------------------


Eigen::VectorXd nelderMead(const Objective& f, const Eigen::VectorXd& x0, double step, int max_eval, double* fbest) {
  const auto n = x0.size();
  std::vector<Eigen::VectorXd> p(static_cast<std::size_t>(n + 1), x0);
  std::vector<double> v(static_cast<std::size_t>(n + 1));
  for (Eigen::Index i = 0; i < n; ++i) p[static_cast<std::size_t>(i + 1)][i] += step;
  for (std::size_t i = 0; i < p.size(); ++i) v[i] = f(p[i]);
  int evals = static_cast<int>(p.size());
  while (evals < max_eval) {
    std::vector<std::size_t> idx(p.size());
    for (std::size_t i = 0; i < idx.size(); ++i) idx[i] = i;
    std::sort(idx.begin(), idx.end(), [&](std::size_t a, std::size_t b) { return v[a] < v[b]; });
    const std::size_t best = idx.front(), worst = idx.back(), second = idx[idx.size() - 2];
    if (std::abs(v[worst] - v[best]) < 1e-10 * (std::abs(v[best]) + 1e-10)) break;
    Eigen::VectorXd c = Eigen::VectorXd::Zero(n);
    for (std::size_t i = 0; i < p.size(); ++i)
      if (i != worst) c += p[i];
    c /= static_cast<double>(n);
    const Eigen::VectorXd xr = c + (c - p[worst]);
    const double fr = f(xr);
    ++evals;
    if (fr < v[best]) {
      const Eigen::VectorXd xe = c + 2.0 * (c - p[worst]);
      const double fe = f(xe);
      ++evals;
      if (fe < fr) {
        p[worst] = xe;
        v[worst] = fe;
      } else {
        p[worst] = xr;
        v[worst] = fr;
      }
    } else if (fr < v[second]) {
      p[worst] = xr;
      v[worst] = fr;
    } else {
      const Eigen::VectorXd xc = fr < v[worst] ? Eigen::VectorXd(c + 0.5 * (xr - c)) : Eigen::VectorXd(c + 0.5 * (p[worst] - c));
      const double fc = f(xc);
      ++evals;
      if (fc < std::min(fr, v[worst])) {
        p[worst] = xc;
        v[worst] = fc;
      } else {
        for (std::size_t i = 0; i < p.size(); ++i) {
          if (i == best) continue;
          p[i] = p[best] + 0.5 * (p[i] - p[best]);
          v[i] = f(p[i]);
          ++evals;
        }
      }
    }
  }
  std::size_t b = 0;
  for (std::size_t i = 1; i < v.size(); ++i)
    if (v[i] < v[b]) b = i;
  if (fbest) *fbest = v[b];
  return p[b];
}

/// Central finite-difference Hessian of f at x; g (optional) receives the central-difference gradient
/// from the same stencil; fx: f(x) when the caller has it (else evaluated here).
Eigen::MatrixXd hessian(const Objective& f, const Eigen::VectorXd& x, double h, Eigen::VectorXd* g = nullptr,
                        double fx = std::numeric_limits<double>::quiet_NaN()) {
  const auto n = x.size();
  Eigen::MatrixXd H(n, n);
  if (g) g->resize(n);
  const double f0 = std::isnan(fx) ? f(x) : fx;
  for (Eigen::Index i = 0; i < n; ++i) {
    Eigen::VectorXd a = x, b = x;
    a[i] += h;
    b[i] -= h;
    const double fa = f(a), fb = f(b);
    H(i, i) = (fa - 2 * f0 + fb) / (h * h);
    if (g) (*g)[i] = (fa - fb) / (2 * h);
    for (Eigen::Index j = 0; j < i; ++j) {
      Eigen::VectorXd pp = x, pm = x, mp = x, mm = x;
      pp[i] += h, pp[j] += h;
      pm[i] += h, pm[j] -= h;
      mp[i] -= h, mp[j] += h;
      mm[i] -= h, mm[j] -= h;
      H(i, j) = H(j, i) = (f(pp) - f(pm) - f(mp) + f(mm)) / (4 * h * h);
    }
  }
  return H;
}

using Information = std::function<Eigen::MatrixXd(const Eigen::VectorXd&)>;
using Scorer = std::function<LikelihoodScore(const Eigen::VectorXd&, bool central)>;

/// Damped Newton-type steps from a point near the minimum (eigenvalues of the step's matrix floored, so
/// a step always descends). With `info` (the expected information of -2 log L, cheap to evaluate) the
/// steps start as Fisher scoring: a central-difference gradient (2n evaluations) and that matrix. When
/// the decrement is small, the finite-difference Hessian (2n^2 + 1 evaluations) is taken and the fit
/// counts as settled only when the decrement under it is small too; else the steps go on with that
/// Hessian, updated by BFGS from the gradients (quasi-Newton), and it is taken again when they settle.
/// Without `info`, every step takes the finite-difference Hessian. Newton's method needs two or three
/// steps where BFGS from the identity needs many; scoring a few more, each at a fifth of the cost.
/// H_out: the finite-difference Hessian at the returned point when converged.
/// With `scorer` (the exact likelihood's gradient and the information of the data's own gaps and
/// regressors, from one lock-step pass: scoreLikelihood) every step is a scoring step under that
/// information, and a small decrement under it settles the fit (H_out: that information, with central
/// differences). A step that achieves less than a quarter of the decrease it predicts, or needs the
/// line search, raises a Levenberg-Marquardt damping (H + lambda diag H) instead of calling for the
/// finite-difference Hessian (on a realistic head axis's power law the upper corner, above the band,
/// swung by the step cap between two values for 16 steps); a good step lowers it. Only a point from
/// which no step descends takes the finite-difference Hessian.
Eigen::VectorXd newton(const Objective& f, Eigen::VectorXd x, int max_iter, bool* converged, Eigen::MatrixXd* H_out,
                       const Information& info = nullptr, const Scorer& scorer = nullptr) {
  *converged = false;
  enum class Mode { Scoring, QuasiNewton, Full } mode = info || scorer ? Mode::Scoring : Mode::Full;
  Eigen::MatrixXd B;                 // the quasi-Newton matrix
  Eigen::VectorXd g_prev, x_prev;    // the last step's start, for the BFGS update
  constexpr double kSettled = 1e-2;  // a hundredth of the unit of -2 log L that one standard error spans
  double fx = f(x);                  // f at the current point (each evaluation is a pass over the data)
  double lambda = 0;                 // Levenberg-Marquardt damping of the scorer's steps
  double last_decrement = kInf;      // the decrement of the last step (the scorer's first pass is forward)
  for (int it = 0; it < max_iter; ++it) {
    Eigen::VectorXd g, d;
    Eigen::MatrixXd H;
    auto decrementOf = [&]() {
      const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(0.5 * (H + H.transpose()));
      if (es.info() != Eigen::Success) return std::numeric_limits<double>::quiet_NaN();
      const double lmax = std::max(es.eigenvalues().cwiseAbs().maxCoeff(), 1e-12);
      const Eigen::VectorXd lam = es.eigenvalues().cwiseAbs().cwiseMax(1e-8 * lmax);
      d = -es.eigenvectors() * (es.eigenvectors().transpose() * g).cwiseQuotient(lam);
      return -g.dot(d);
    };
    bool exact = false;   // H is the finite-difference Hessian at x, or the data's information (scorer)
    bool scored = false;  // H is the scorer's information
    bool central = true;  // the scorer's differences were central
    auto full = [&]() {
      H = hessian(f, x, 2e-3, &g, fx);
      if (H_out) *H_out = H;
      B = H;
      exact = true;
    };
    if (mode == Mode::Full) {
      full();
      if (scorer) {
        mode = Mode::Scoring;
      } else if (info) {
        mode = Mode::QuasiNewton;
      }
    } else if (scorer) {
      // Forward differences (p + 1 passes instead of 2p + 1) while the last decrement says the optimum
      // is more than a few units of -2 log L away; central ones near it, where the settling test and
      // the information reported need them.
      central = !(last_decrement > 4);
      const LikelihoodScore sc = scorer(x, central);
      g = sc.gradient;
      H = sc.information;
      if (H_out) *H_out = H;
      exact = scored = true;
    } else {
      g = centralGradient(f, x, 1e-4);
      if (mode == Mode::Scoring) {
        H = info(x);
      } else {
        const Eigen::VectorXd sv = x - x_prev, y = g - g_prev;
        const double sy = sv.dot(y);
        if (sy > 1e-12) {
          const Eigen::VectorXd Bs = B * sv;
          B += y * y.transpose() / sy - Bs * Bs.transpose() / sv.dot(Bs);
        }
        H = B;
      }
    }
    double decrement = decrementOf();
    if (scored && !central && decrement <= 4) {  // near: again with central differences
      const LikelihoodScore sc = scorer(x, true);
      g = sc.gradient;
      H = sc.information;
      if (H_out) *H_out = H;
      decrement = decrementOf();
    }
    if (scored) last_decrement = decrement;
    if (!std::isfinite(decrement)) return x;
    if (decrement < kSettled && !exact) {
      // settled under an approximate matrix: the finite-difference Hessian decides
      full();
      mode = Mode::QuasiNewton;
      decrement = decrementOf();
      if (!std::isfinite(decrement)) return x;
    }
    if (decrement < kSettled) {
      *converged = true;
      return x;
    }
    if (scored && lambda > 0) {  // the damped step: (H + lambda diag H) d = -g
      const Eigen::MatrixXd H0 = H;
      H.diagonal() *= 1 + lambda;
      decrementOf();
      H = H0;
    }
    const double dmax = d.cwiseAbs().maxCoeff();
    if (dmax > 1.0) d /= dmax;
    const double f0 = fx;
    double t = 1.0;
    bool moved = false;
    for (int k = 0; k < 20 && !moved; ++k, t *= 0.5) {
      const Eigen::VectorXd xn = x + t * d;
      const double fn = f(xn);
      if (fn < f0) {
        // An approximate matrix that predicts the decrease badly (less than a quarter of it achieved)
        // is not the curvature here (a flat direction that scoring sees as curved): the
        // finite-difference Hessian next.
        const double predicted = -(t * g.dot(d) + 0.5 * t * t * d.dot(H * d));
        if (scored) {
          // The scorer's information is the data's, so a step that overshoots (a flat direction, a
          // parameter swinging between two values) is damped rather than replaced by the
          // finite-difference Hessian (2p^2 evaluations).
          if (k > 0 || f0 - fn < 0.25 * predicted) {
            lambda = lambda > 0 ? 4 * lambda : 0.1;
          } else if (f0 - fn > 0.75 * predicted) {
            lambda = lambda > 0.01 ? lambda / 4 : 0.0;
          }
        } else if (!exact && f0 - fn < 0.25 * predicted) {
          mode = Mode::Full;
        }
        x_prev = x;
        g_prev = g;
        x = xn;
        fx = fn;
        moved = true;
      }
    }
    if (!moved) {
      if (exact && !scored) return x;
      mode = Mode::Full;  // no descent along an approximate direction: the finite-difference Hessian next
    }
  }
  return x;
}

// --- starting values ---------------------------------------------------------------------------

struct DataScale {
  double T = 1, span = 1, var = 1, white_var = 1;
};

DataScale scaleOf(const NoiseSeries& s, const Eigen::MatrixXd& X) {
  DataScale d;
  d.T = std::max(s.medianInterval(), 1e-9);
  d.span = std::max(s.span(), d.T);
  Eigen::Map<const Eigen::VectorXd> y(s.y.data(), static_cast<Eigen::Index>(s.y.size()));
  Eigen::VectorXd r = y;
  if (X.cols() > 0) r -= X * X.colPivHouseholderQr().solve(y);
  else r.array() -= r.mean();
  d.var = std::max(r.squaredNorm() / std::max<double>(1.0, static_cast<double>(r.size()) - static_cast<double>(X.cols())), 1e-300);
  // white level from first differences on regular steps (an upper bound: slow terms add little)
  double sd = 0;
  std::size_t nd = 0;
  for (std::size_t i = 1; i < s.size(); ++i) {
    if (std::abs(s.t_s[i] - s.t_s[i - 1] - d.T) > 0.1 * d.T) continue;
    const double v = r[static_cast<Eigen::Index>(i)] - r[static_cast<Eigen::Index>(i - 1)];
    sd += v * v;
    ++nd;
  }
  d.white_var = nd > 0 ? std::min(d.var, sd / (2.0 * static_cast<double>(nd))) : d.var;
  d.white_var = std::max(d.white_var, 1e-6 * d.var);
  return d;
}

/// Log-binned log-spectrum of the data (geometric mean per bin of 1/8 decade).
struct LogSpectrum {
  std::vector<double> f, logp;
};

LogSpectrum logSpectrum(const NoiseSeries& s, double T) {
  LogSpectrum out;
  // the longest run on the regular grid decides the segment length
  std::size_t longest = 0, run = 1;
  for (std::size_t i = 1; i < s.size(); ++i) {
    if (std::abs(s.t_s[i] - s.t_s[i - 1] - T) <= 0.1 * T) ++run;
    else run = 1;
    longest = std::max(longest, run);
  }
  std::size_t seg = 32;
  while (seg * 2 <= std::min<std::size_t>(longest, s.size() / 4)) seg *= 2;
  if (longest < 32) return out;
  const Spectrum sp = welchPsdGapped(s, T, seg);
  if (sp.segments == 0) return out;
  const double f0 = sp.f_hz.front();
  double bin_lo = f0;
  double acc = 0;
  int cnt = 0;
  double facc = 0;
  for (std::size_t k = 0; k < sp.f_hz.size(); ++k) {
    if (sp.f_hz[k] >= bin_lo * std::pow(10.0, 0.125) && cnt > 0) {
      out.f.push_back(std::exp(facc / cnt));
      out.logp.push_back(acc / cnt);
      acc = facc = 0;
      cnt = 0;
      bin_lo = sp.f_hz[k];
    }
    if (sp.psd[k] > 0) {
      acc += std::log(sp.psd[k]);
      facc += std::log(sp.f_hz[k]);
      ++cnt;
    }
  }
  if (cnt > 0) {
    out.f.push_back(std::exp(facc / cnt));
    out.logp.push_back(acc / cnt);
  }
  return out;
}

/// Starting points per structure, from the data's scale.
std::vector<Eigen::VectorXd> starts(NoiseStructure s, const DataScale& d) {
  const double lw = 0.5 * std::log(d.white_var);
  const double lc = 0.5 * std::log(std::max(d.var - d.white_var, 0.05 * d.var));
  const double tau_lo = 10 * d.T, tau_hi = d.span / 50;
  std::vector<double> taus;
  for (double t = tau_lo; t <= std::max(tau_lo, tau_hi) * 1.0001; t *= 10) taus.push_back(t);
  std::vector<Eigen::VectorXd> out;
  switch (s) {
    case NoiseStructure::White: out.push_back((Eigen::VectorXd(1) << 0.5 * std::log(d.var)).finished()); break;
    case NoiseStructure::WhiteGaussMarkov:
      for (double t : taus) out.push_back((Eigen::VectorXd(3) << lw, lc, std::log(t)).finished());
      break;
    case NoiseStructure::GaussMarkov:
      for (double t : taus) out.push_back((Eigen::VectorXd(2) << 0.5 * std::log(d.var), std::log(t)).finished());
      break;
    case NoiseStructure::WhiteTwoGaussMarkov:
      for (std::size_t i = 0; i < taus.size(); ++i)
        for (std::size_t j = i + 1; j < taus.size(); ++j)
          out.push_back((Eigen::VectorXd(5) << lw, lc - 0.35, std::log(taus[i]), lc - 0.35, std::log(taus[j])).finished());
      if (out.empty()) out.push_back((Eigen::VectorXd(5) << lw, lc - 0.35, std::log(tau_lo), lc - 0.35, std::log(tau_lo * 30)).finished());
      break;
    case NoiseStructure::WhitePowerLaw: {
      const double flo = 1.0 / std::max(d.span / 20, 20 * d.T), fhi = 1.0 / (kTwoPi * 5 * d.T);
      for (double a : {0.5, 1.0, 1.5})
        out.push_back((Eigen::VectorXd(5) << lw, lc, a, std::log(flo), std::log(std::max(fhi, 3 * flo))).finished());
      break;
    }
  }
  return out;
}

// --- the Whittle likelihood ----------------------------------------------------------------------

/// The largest n' <= n whose only prime factors are 2, 3 and 5 (a fast FFT length).
std::size_t smoothBelow(std::size_t n) {
  std::size_t best = 1;
  for (std::size_t a = 1; a <= n; a *= 2)
    for (std::size_t b = a; b <= n; b *= 3)
      for (std::size_t c = b; c <= n; c *= 5) best = std::max(best, c);
  return best;
}

/// The periodogram ordinates of a series' long gap-free runs, pooled in narrow log-frequency bins.
struct WhittleData {
  std::vector<double> f, isum, m;  ///< per bin: mean frequency, sum of ordinates, their number
  double T = 1;
  std::size_t samples = 0;         ///< samples in the pieces used
  double longest_s = 0;            ///< the longest piece, s
  bool ok() const { return !f.empty(); }
};

/// Runs on the grid of interval T (steps within 10 %) of at least min_len samples; each cut into
/// pieces of fast FFT lengths (what is left below min_len is not used). Ordinate k of a piece of L
/// samples (its mean removed): I_k = 2 T / L |sum_n y_n exp(-2 pi i k n / L)|^2 at f = k / (L T),
/// k = 1 .. (L - 1) / 2, distributed as S(f) times a unit exponential when S is the one-sided sampled
/// PSD (white: 2 T sigma^2), independent between ordinates and pieces. (First differences instead,
/// to cut the leakage of steep low-frequency power, made the power-law fits worse: the differenced
/// white part then leaks into the low frequencies.)
WhittleData whittleData(const NoiseSeries& s, double T, std::size_t min_len) {
  WhittleData w;
  w.T = T;
  min_len = std::max<std::size_t>(min_len, 16);
  std::vector<std::pair<double, double>> ord;
  Eigen::FFT<double> fft;
  std::vector<double> buf;
  std::vector<std::complex<double>> spec;
  auto piece = [&](std::size_t i0, std::size_t L) {
    buf.assign(s.y.begin() + static_cast<std::ptrdiff_t>(i0), s.y.begin() + static_cast<std::ptrdiff_t>(i0 + L));
    double mean = 0;
    for (double v : buf) mean += v;
    mean /= static_cast<double>(L);
    for (double& v : buf) v -= mean;
    fft.fwd(spec, buf);
    const double scale = 2.0 * T / static_cast<double>(L);
    for (std::size_t k = 1; 2 * k < L; ++k)
      ord.emplace_back(static_cast<double>(k) / (static_cast<double>(L) * T), scale * std::norm(spec[k]));
    w.samples += L;
    w.longest_s = std::max(w.longest_s, static_cast<double>(L) * T);
  };
  std::size_t i0 = 0;
  for (std::size_t i = 1; i <= s.size(); ++i) {
    if (i < s.size() && std::abs(s.t_s[i] - s.t_s[i - 1] - T) <= 0.1 * T) continue;
    std::size_t left = i - i0, at = i0;
    while (left >= min_len) {
      const std::size_t L = smoothBelow(left);
      piece(at, L);
      at += L;
      left -= L;
    }
    i0 = i;
  }
  std::sort(ord.begin(), ord.end());
  // Bins 1 % wide in frequency: the spectra fitted change little across one, so the Whittle sum over
  // a bin's ordinates is m (log S + mean I / S) at the bin's mean frequency to second order.
  for (std::size_t k = 0; k < ord.size();) {
    const double edge = ord[k].first * 1.01;
    double fs = 0, is = 0;
    std::size_t n = 0;
    for (; k < ord.size() && (n == 0 || ord[k].first < edge); ++k, ++n) {
      fs += ord[k].first;
      is += ord[k].second;
    }
    w.f.push_back(fs / static_cast<double>(n));
    w.isum.push_back(is);
    w.m.push_back(static_cast<double>(n));
  }
  return w;
}

/// -2 log of the Whittle likelihood on the scale of the time-domain one (two real
/// samples per ordinate, S / (2 T) their variance): sum over ordinates of 2 (log(2 pi S / (2 T)) + I / S).
double whittleM2ll(const NoiseModel& m, const WhittleData& w) {
  double r = 0;
  const double c = std::log(kTwoPi / (2.0 * w.T));
  for (std::size_t b = 0; b < w.f.size(); ++b) {
    const double S = m.psdSampled(w.f[b], w.T);
    if (!(S > 0)) return kInf;
    r += 2.0 * (w.m[b] * (std::log(S) + c) + w.isum[b] / S);
  }
  return r;
}

/// The ordinates of one gap-free piece of n samples at interval T (k / (n T), k = 1 .. (n - 1) / 2),
/// pooled in the Whittle bins; no periodogram (isum zero). The frequencies at which the expected
/// information of n samples is summed.
WhittleData ordinateGrid(std::size_t n, double T) {
  WhittleData w;
  w.T = T;
  w.samples = n;
  w.longest_s = static_cast<double>(n) * T;
  const double df = 1.0 / (static_cast<double>(n) * T);
  for (std::size_t k = 1; 2 * k < n;) {
    const double edge = static_cast<double>(k) * df * 1.01;
    double fs = 0;
    std::size_t m = 0;
    for (; 2 * k < n && (m == 0 || static_cast<double>(k) * df < edge); ++k, ++m) fs += static_cast<double>(k) * df;
    w.f.push_back(fs / static_cast<double>(m));
    w.isum.push_back(0.0);
    w.m.push_back(static_cast<double>(m));
  }
  return w;
}

/// The expected information of the Whittle likelihood on the bins of w, in the parameters idx of x:
/// sum over ordinates of grad log S grad log S^T (each ordinate is S times a unit exponential); twice
/// it is the expected Hessian of -2 log L.
Eigen::MatrixXd spectralInformation(const std::function<NoiseModel(const Eigen::VectorXd&)>& model, const Eigen::VectorXd& x,
                                    const std::vector<Eigen::Index>& idx, const WhittleData& w) {
  const auto k = static_cast<Eigen::Index>(idx.size());
  Eigen::MatrixXd G(static_cast<Eigen::Index>(w.f.size()), k);
  const double h = 1e-4;
  for (Eigen::Index a = 0; a < k; ++a) {
    Eigen::VectorXd xp = x, xm = x;
    xp[idx[static_cast<std::size_t>(a)]] += h;
    xm[idx[static_cast<std::size_t>(a)]] -= h;
    const NoiseModel mp = model(xp), mm = model(xm);
    for (std::size_t b = 0; b < w.f.size(); ++b)
      G(static_cast<Eigen::Index>(b), a) = (std::log(mp.psdSampled(w.f[b], w.T)) - std::log(mm.psdSampled(w.f[b], w.T))) / (2 * h);
  }
  const Eigen::Map<const Eigen::VectorXd> m(w.m.data(), static_cast<Eigen::Index>(w.m.size()));
  return 2.0 * G.transpose() * m.asDiagonal() * G;
}

/// Samples in runs (steps within 10 % of T) of at least min_len samples.
std::size_t samplesInRuns(const NoiseSeries& s, double T, std::size_t min_len) {
  std::size_t in = 0, run = s.size() == 0 ? 0 : 1;
  for (std::size_t i = 1; i <= s.size(); ++i) {
    if (i < s.size() && std::abs(s.t_s[i] - s.t_s[i - 1] - T) <= 0.1 * T) {
      ++run;
      continue;
    }
    if (run >= min_len) in += run;
    run = 1;
  }
  return in;
}

bool constantColumns(const Eigen::MatrixXd& X) {
  for (Eigen::Index c = 0; c < X.cols(); ++c)
    if (X.rows() > 0 && (X.col(c).array() != X(0, c)).any()) return false;
  return X.cols() <= 1;
}

/// The power law's level on the reporting scale: params[1] (the total sigma, fitted) becomes the
/// amplitude spectral density of the power law at the pivot, the frequency between its corners where
/// that density's variance is least (the level the data determine; its error is uncorrelated with the
/// slope's there), and the covariance follows by the delta method (exact for the Hessian at a
/// stationary point). The total sigma stays as a derived parameter with its own delta-method sigma.
/// Parameters that the fit left undetermined (on a bound, along a flat direction) are held where they
/// are: their covariance entries stay undefined and the level's is conditional on them.
void reportAtThePivot(NoiseFit& fit, const Eigen::VectorXd& x, int pl_terms, double T) {
  const Eigen::Index np = x.size();
  if (np != 5 || fit.params.size() != 5 || fit.cov.rows() != np) return;
  auto logAsd = [&](const Eigen::VectorXd& v, double f) {
    NoiseModel m;
    m.add(NoiseTerm::powerLaw(std::exp(v[1]), v[2], std::exp(v[3]), std::exp(v[4]), pl_terms));
    return 0.5 * std::log(m.psdContinuous(f, T));
  };
  auto rowAt = [&](double f) {
    Eigen::RowVectorXd r(np);
    for (Eigen::Index j = 0; j < np; ++j) {
      Eigen::VectorXd a = x, b = x;
      a[j] += 1e-5;
      b[j] -= 1e-5;
      r[j] = (logAsd(a, f) - logAsd(b, f)) / 2e-5;
    }
    return r;
  };
  const Eigen::MatrixXd C = fit.cov.unaryExpr([](double v) { return std::isfinite(v) ? v : 0.0; });
  double f_p = std::exp(0.5 * (x[3] + x[4])), v_p = kInf;
  constexpr int kGrid = 60;
  for (int q = 0; q <= kGrid; ++q) {
    const double f = std::exp(x[3] + (x[4] - x[3]) * q / kGrid);
    const Eigen::RowVectorXd r = rowAt(f);
    const double v = (r * C * r.transpose())(0, 0);
    if (std::isfinite(v) && v < v_p) {
      v_p = v;
      f_p = f;
    }
  }
  Eigen::MatrixXd J = Eigen::MatrixXd::Identity(np, np);
  J.row(1) = rowAt(f_p);
  Eigen::MatrixXd C1 = J * C * J.transpose();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (Eigen::Index i = 0; i < np; ++i)
    for (Eigen::Index j = 0; j < np; ++j) {
      // undefined where either parameter is (the level's entries are defined through the total sigma's)
      if (!std::isfinite(fit.cov(i, i)) || !std::isfinite(fit.cov(j, j)) || (i != 1 && j != 1 && !std::isfinite(fit.cov(i, j))))
        C1(i, j) = nan;
    }
  NoiseParam total = fit.params[1];
  total.derived = true;
  NoiseParam& level = fit.params[1];
  level.name = "pl.asd_pivot";
  level.log_scale = true;
  level.value = std::exp(logAsd(x, f_p));
  level.log_sigma = std::isfinite(C1(1, 1)) && C1(1, 1) >= 0 ? std::sqrt(C1(1, 1)) : nan;
  level.sigma = level.value * level.log_sigma;
  level.at_hz = f_p;
  if (level.note.empty()) {
    std::ostringstream o;
    o.precision(3);
    o << "amplitude spectral density of the power law at " << f_p
      << " Hz (the pivot: where the data determine its level best), per sqrt(Hz)";
    level.note = o.str();
  }
  fit.params.push_back(total);
  fit.cov = C1;
}

}  // namespace

const char* noiseLikelihoodName(NoiseLikelihood l) {
  switch (l) {
    case NoiseLikelihood::Exact: return "exact";
    case NoiseLikelihood::Whittle: return "whittle";
    case NoiseLikelihood::Auto: return "auto";
  }
  return "?";
}

const char* noiseStructureName(NoiseStructure s) {
  switch (s) {
    case NoiseStructure::White: return "white";
    case NoiseStructure::WhiteGaussMarkov: return "white+gauss_markov";
    case NoiseStructure::WhiteTwoGaussMarkov: return "white+2gauss_markov";
    case NoiseStructure::WhitePowerLaw: return "white+power_law";
    case NoiseStructure::GaussMarkov: return "gauss_markov";
  }
  return "?";
}

std::vector<NoiseStructure> defaultNoiseStructures() {
  return {NoiseStructure::White, NoiseStructure::WhiteGaussMarkov, NoiseStructure::WhiteTwoGaussMarkov,
          NoiseStructure::WhitePowerLaw};
}

int powerLawFitTerms(double span_s, double T_s) {
  const double decades = std::log10(std::max(10.0, span_s / (2 * T_s)) / 10.0);
  return std::clamp(static_cast<int>(std::lround(3.0 * decades)) + 1, 3, 16);
}

const NoiseParam* NoiseFit::find(const std::string& name) const {
  for (const auto& p : params)
    if (p.name == name) return &p;
  return nullptr;
}

NoiseFit fitNoise(const NoiseSeries& s, NoiseStructure structure, const Eigen::MatrixXd& X, const NoiseFitOptions& opt) {
  NoiseFit fit;
  fit.structure = structure;
  fit.n = s.size();
  const auto defs = paramDefs(structure);
  const auto np = static_cast<Eigen::Index>(defs.size());
  if (s.size() < static_cast<std::size_t>(np + X.cols() + 3)) {
    fit.message = "too few samples (" + std::to_string(s.size()) + ") for " + noiseStructureName(structure);
    return fit;
  }
  DataScale d = scaleOf(s, X);
  if (!opt.fixed.empty()) {  // the starting values are for the part that is fitted
    d.white_var = std::max(d.white_var - opt.fixed.whiteVariance(), 1e-6 * d.var);
    d.var = std::max(d.var - opt.fixed.variance(), 1e-3 * d.var);
  }
  const Box box = boxOf(structure, std::sqrt(d.var), d.T, d.span);

  // The power law's number of terms is fixed for the whole fit (the model is smooth in its parameters
  // only for a fixed count): three per decade of the widest band the data can show, at most 16.
  const int pl_terms = opt.pl_terms > 0 ? opt.pl_terms : powerLawFitTerms(d.span, d.T);
  // 1. Starting values: the model spectrum fitted to the data's log spectrum (cheap), from several starts.
  const LogSpectrum ls = logSpectrum(s, d.T);
  std::vector<Eigen::VectorXd> x0s = starts(structure, d);
  const std::vector<Eigen::VectorXd> raw_starts = x0s;
  if (ls.f.size() >= static_cast<std::size_t>(np + 2)) {
    const Objective spec = [&](const Eigen::VectorXd& x) {
      const NoiseModel m = modelOf(structure, project(structure, box, x), pl_terms, &opt.fixed);
      double r = 0;
      for (std::size_t k = 0; k < ls.f.size(); ++k) {
        const double e = std::log(m.psdSampled(ls.f[k], d.T)) - ls.logp[k];
        r += e * e;
      }
      return r;
    };
    for (auto& x : x0s) x = project(structure, box, nelderMead(spec, x, 0.5, 300 * static_cast<int>(np), nullptr));
  }
  // 2. The likelihood: Whittle on the long runs where asked for (and, for Auto, where the gaps are few
  // and the runs long), else exact.
  WhittleData wd, starter;
  // An exact fit of a long series starts from the Whittle optimum of its runs (cheap and close: the
  // exact Newton steps from there are few); the fit itself is then exact.
  constexpr std::size_t kCoarse = 20000;
  if (constantColumns(X) && (opt.likelihood != NoiseLikelihood::Exact || s.size() > 2 * kCoarse)) {
    std::size_t longest = 0, run = 1;
    for (std::size_t i = 1; i < s.size(); ++i) {
      run = std::abs(s.t_s[i] - s.t_s[i - 1] - d.T) <= 0.1 * d.T ? run + 1 : 1;
      longest = std::max(longest, run);
    }
    auto minLen = [&](double ref) { return static_cast<std::size_t>(std::max(16.0, std::ceil(opt.whittle_min_run * ref))); };
    auto dataOf = [&](std::size_t min_len) {
      WhittleData w = whittleData(s, d.T, min_len);
      if (w.f.size() < static_cast<std::size_t>(2 * np + 2)) w = WhittleData{};
      return w;
    };
    const bool use = opt.likelihood == NoiseLikelihood::Whittle ||
                     (opt.likelihood == NoiseLikelihood::Auto &&
                      static_cast<double>(samplesInRuns(s, d.T, minLen(d.span / d.T))) >= opt.whittle_min_coverage * static_cast<double>(s.size()));
    if (use) wd = dataOf(opt.likelihood == NoiseLikelihood::Auto ? minLen(d.span / d.T) : minLen(static_cast<double>(longest)));
    if (!wd.ok() && s.size() > 2 * kCoarse) starter = dataOf(minLen(static_cast<double>(longest)));
  }
  const bool whittle = wd.ok();
  fit.likelihood = whittle ? NoiseLikelihood::Whittle : NoiseLikelihood::Exact;
  fit.whittle_samples = wd.samples;
  const Objective nll = [&](const Eigen::VectorXd& x) {
    const NoiseModel m = modelOf(structure, project(structure, box, x), pl_terms, &opt.fixed);
    if (whittle) return whittleM2ll(m, wd);
    ++fit.evaluations;
    return minusTwoLogLikelihood(m, s, X, opt.reml);
  };
  // The expected information for Fisher scoring: the Whittle likelihood's where it is used, else that
  // of as many samples without gaps (the gaps and the regressors change it by little: it only chooses
  // the steps, the uncertainties come from the observed information at the end).
  const WhittleData info_grid = whittle ? WhittleData{} : ordinateGrid(s.size(), d.T);
  std::vector<Eigen::Index> all(static_cast<std::size_t>(np));
  for (Eigen::Index i = 0; i < np; ++i) all[static_cast<std::size_t>(i)] = i;
  const Information info = [&](const Eigen::VectorXd& x) {
    return spectralInformation([&](const Eigen::VectorXd& v) { return modelOf(structure, project(structure, box, v), pl_terms, &opt.fixed); },
                               x, all, whittle ? wd : info_grid);
  };
  // The exact likelihood's scoring steps on long series: gradient and the data's information in one
  // lock-step pass (below 2 kCoarse samples a pass is cheap, and the finite-difference Hessian copes
  // better with the flat directions of short series: on a 789-sample accelerometer series the
  // information of a second, slow Gauss-Markov term was near singular and the scoring steps stalled).
  const Scorer scorer = whittle || s.size() <= 2 * kCoarse ? Scorer() : Scorer([&](const Eigen::VectorXd& x, bool central) {
    fit.evaluations += (central ? 2 : 1) * static_cast<int>(np) + 1;
    return scoreLikelihood([&](const Eigen::VectorXd& v) { return modelOf(structure, project(structure, box, v), pl_terms, &opt.fixed); },
                           x, 1e-4, s, X, opt.reml, central);
  });
  Eigen::VectorXd best = x0s.front();
  double fbest = kInf;
  for (const auto& x : x0s) {
    const double v = nll(x);
    if (v < fbest) {
      fbest = v;
      best = x;
    }
  }
  std::string why;
  // 3. Long series: first by the Whittle likelihood of its runs when it has long ones, else on every
  // d-th sample (the same model, exact at the longer intervals; it keeps the slow terms and costs 1/d),
  // then from there on the whole series.
  bool started = false;
  if (!whittle && starter.ok()) {
    const Objective w = [&](const Eigen::VectorXd& x) {
      return whittleM2ll(modelOf(structure, project(structure, box, x), pl_terms, &opt.fixed), starter);
    };
    Eigen::VectorXd wbest = best;
    double wf = kInf;
    for (const auto& x0 : x0s) {
      bool conv = false;
      const Eigen::VectorXd x1 = project(structure, box, minimiseBfgs(w, x0, opt.max_iterations, &conv, nullptr));
      const double v = w(x1);
      if (v < wf) {
        wf = v;
        wbest = x1;
      }
    }
    const double v = nll(wbest);
    if (v < fbest) {
      fbest = v;
      best = wbest;
      started = true;
    }
  }
  // The exact likelihood of every d-th sample (the same model at the longer intervals: it keeps the slow
  // terms, across the gaps, at 1/d of the cost), minimised by BFGS from x0.
  auto coarseFrom = [&](const Eigen::VectorXd& x0) {
    const std::size_t dec = std::max<std::size_t>(1, s.size() / kCoarse);
    NoiseSeries c;
    Eigen::MatrixXd Xc(X.cols() > 0 ? static_cast<Eigen::Index>(s.size() / dec + 1) : 0, X.cols());
    for (std::size_t i = 0; i < s.size(); i += dec) {
      if (X.cols() > 0) Xc.row(static_cast<Eigen::Index>(c.size())) = X.row(static_cast<Eigen::Index>(i));
      c.t_s.push_back(s.t_s[i]);
      c.y.push_back(s.y[i]);
    }
    Xc.conservativeResize(X.cols() > 0 ? static_cast<Eigen::Index>(c.size()) : 0, X.cols());
    const Objective coarse = [&](const Eigen::VectorXd& x) {
      return minusTwoLogLikelihood(modelOf(structure, project(structure, box, x), pl_terms, &opt.fixed), c, Xc, opt.reml);
    };
    bool conv = false;
    return Eigen::VectorXd(project(structure, box, minimiseBfgs(coarse, x0, opt.max_iterations, &conv, nullptr)));
  };
  if (!whittle && !started && s.size() > 2 * kCoarse) best = coarseFrom(best);
  // 4. Newton on the whole series from there (its last matrix is the information below: the
  // finite-difference Hessian, or the scorer's information on long series).
  if (whittle || s.size() <= 2 * kCoarse) {
    bool conv = false;
    best = project(structure, box, minimiseBfgs(nll, best, opt.max_iterations, &conv, &why));
  }
  Eigen::MatrixXd H_final;
  Eigen::VectorXd x = project(structure, box, newton(nll, best, 16, &fit.converged, &H_final, info, scorer));
  // A fit that ends on a bound of its box, or where Newton's method did not settle, may sit in a local
  // optimum that every start led into once refined on the log spectrum and by Whittle on short runs
  // (seen: a power law's slope on its bound 1.98 with the lower corner 5x off, -2 log L 24 above the
  // truth's; another unsettled with the lower corner 100x off, 19 above). Newton's method again from
  // the best of the structure's plain starts (before any refinement: for a power law slopes 0.5, 1 and
  // 1.5 across the band the data show); the lower -2 log L is kept.
  // Costs a second refinement only for such fits (exact likelihood only; for both, see below).
  {
    auto onBound = [&](const Eigen::VectorXd& v) {
      for (Eigen::Index i = 0; i < np; ++i)
        if (box.atBound(v, i)) return true;
      return false;
    };
    // A coloured term with a negligible level (its variance below 1e-4 of the white part's) is a
    // stationary point of every such fit, whatever its time or band: the gradient in them vanishes with
    // the level (seen on a 789-sample accelerometer series: a Gauss-Markov term stuck at 1e-4 of the white
    // sigma, -2 log L 47 above the fit from the plain starts; by Whittle, 1 of 200 simulated sums of
    // two terms collapsed into one, its parameters 30 sigma off).
    auto negligible = [&](const Eigen::VectorXd& v) {
      for (Eigen::Index i = 1; i < np; ++i) {
        const std::string name = defs[static_cast<std::size_t>(i)].name;
        if (name.size() > 6 && name.compare(name.size() - 6, 6, ".sigma") == 0 && v[i] < v[0] + 0.5 * std::log(1e-4)) return true;
      }
      return false;
    };
    const bool edge = !whittle && (onBound(x) || !fit.converged);
    // Such a fit is refined again by either likelihood (on white data, where the level vanishes rightly,
    // the second refinement ends there too, at the cost of its evaluations: src/noise/DESIGN.md).
    if (edge || (std::string(defs.front().name) == "white.sigma" && negligible(x))) {
      double f_alt = kInf;
      Eigen::VectorXd alt;
      for (const auto& r : raw_starts) {
        const Eigen::VectorXd p = project(structure, box, r);
        if ((p - x).cwiseAbs().maxCoeff() < 1e-2) continue;
        const double v = nll(p);
        if (v < f_alt) {
          f_alt = v;
          alt = p;
        }
      }
      if (alt.size() == np) {
        bool conv2 = false;
        Eigen::MatrixXd H2;
        const Eigen::VectorXd y = project(structure, box, newton(nll, alt, 24, &conv2, &H2, info, scorer));
        if (nll(y) < nll(x) - 1e-6) {
          x = y;
          fit.converged = conv2;
          H_final = H2;
        }
      }
    }
  }
  why = fit.converged ? std::string() : "the scoring and Newton steps did not settle (16 iterations, 24 from a second start)";
  if (structure == NoiseStructure::WhiteTwoGaussMarkov && x[2] > x[4]) {  // order the terms by time
    std::swap(x[1], x[3]);
    std::swap(x[2], x[4]);
  }
  fit.message = why;
  fit.model = modelOf(structure, x, pl_terms);
  if (whittle) {
    fit.m2ll = whittleM2ll(modelOf(structure, x, pl_terms, &opt.fixed), wd);
    if (X.cols() == 1) {  // the mean of the samples, its variance from the PSD at zero frequency
      double mean = 0;
      for (double v : s.y) mean += v;
      const auto n = static_cast<double>(s.size());
      fit.beta = Eigen::VectorXd::Constant(1, mean / n / X(0, 0));
      const double var0 = modelOf(structure, x, pl_terms, &opt.fixed).psdSampled(0.0, d.T) / (2.0 * d.T * n);
      fit.beta_cov = Eigen::MatrixXd::Constant(1, 1, var0 / (X(0, 0) * X(0, 0)));
    }
  } else {
    fit.m2ll = minusTwoLogLikelihood(modelOf(structure, x, pl_terms, &opt.fixed), s, X, opt.reml, &fit.beta, &fit.beta_cov);
  }
  auto whittleHessian = [&](const std::vector<Eigen::Index>& idx) {
    return spectralInformation([&](const Eigen::VectorXd& v) { return modelOf(structure, v, pl_terms, &opt.fixed); }, x, idx, wd);
  };

  // 5. Uncertainties: the information of the parameters that are not on a bound.
  std::vector<Eigen::Index> free;
  std::vector<bool> at_bound(static_cast<std::size_t>(np), false);
  for (Eigen::Index i = 0; i < np; ++i) {
    at_bound[static_cast<std::size_t>(i)] = box.atBound(x, i);
    if (!at_bound[static_cast<std::size_t>(i)]) free.push_back(i);
  }
  fit.cov = Eigen::MatrixXd::Constant(np, np, std::numeric_limits<double>::quiet_NaN());
  bool info_ok = false;
  if (!free.empty()) {
    const Objective sub = [&](const Eigen::VectorXd& z) {
      Eigen::VectorXd full = x;
      for (std::size_t k = 0; k < free.size(); ++k) full[free[k]] = z[static_cast<Eigen::Index>(k)];
      return nll(full);
    };
    Eigen::VectorXd z(static_cast<Eigen::Index>(free.size()));
    for (std::size_t k = 0; k < free.size(); ++k) z[static_cast<Eigen::Index>(k)] = x[free[k]];
    // Newton's last matrix when it was taken at this point with every parameter free.
    const bool reuse = !whittle && fit.converged && free.size() == static_cast<std::size_t>(np) && H_final.rows() == np;
    const Eigen::MatrixXd H = whittle ? whittleHessian(free) : reuse ? H_final : hessian(sub, z, 2e-3);
    // Where the information is singular (a second Gauss-Markov term much slower than the span: only
    // sigma^2 / tau shows), the parameters that move along the flat direction are not determined; the
    // others' covariance comes from the rest of the Hessian (given the flat ones), so a white level
    // keeps its uncertainty. Repeated while a direction stays flat.
    std::vector<std::size_t> keep(free.size());
    for (std::size_t k = 0; k < keep.size(); ++k) keep[k] = k;
    while (!keep.empty()) {
      const auto nk = static_cast<Eigen::Index>(keep.size());
      Eigen::MatrixXd Hk(nk, nk);
      for (Eigen::Index a = 0; a < nk; ++a)
        for (Eigen::Index b = 0; b < nk; ++b)
          Hk(a, b) = 0.5 * (H(static_cast<Eigen::Index>(keep[static_cast<std::size_t>(a)]), static_cast<Eigen::Index>(keep[static_cast<std::size_t>(b)])) +
                            H(static_cast<Eigen::Index>(keep[static_cast<std::size_t>(b)]), static_cast<Eigen::Index>(keep[static_cast<std::size_t>(a)])));
      const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(Hk);
      if (es.info() != Eigen::Success) break;
      if (es.eigenvalues().minCoeff() > 1e-9 * std::max(1.0, es.eigenvalues().maxCoeff())) {
        const Eigen::MatrixXd C = 2.0 * es.eigenvectors() * es.eigenvalues().cwiseInverse().asDiagonal() * es.eigenvectors().transpose();
        for (Eigen::Index a = 0; a < nk; ++a)
          for (Eigen::Index b = 0; b < nk; ++b)
            fit.cov(free[keep[static_cast<std::size_t>(a)]], free[keep[static_cast<std::size_t>(b)]]) = C(a, b);
        info_ok = true;
        break;
      }
      // the flattest direction: every parameter with a share of it leaves (the largest one at least)
      const Eigen::VectorXd v = es.eigenvectors().col(0);
      Eigen::Index big = 0;
      v.cwiseAbs().maxCoeff(&big);
      std::vector<std::size_t> rest;
      for (Eigen::Index a = 0; a < nk; ++a)
        if (a != big && std::abs(v[a]) < 0.2) rest.push_back(keep[static_cast<std::size_t>(a)]);
      keep.swap(rest);
    }
  }

  // 6. Parameters, with what the span and the sampling can determine.
  // (Whittle: the runs are taken as independent, so the longest one sets the slow end.)
  const double f_det_lo = opt.band_lo / (whittle ? wd.longest_s : d.span), f_det_hi = 1.0 / (d.T * opt.band_hi);
  fit.f_det_lo = f_det_lo;
  fit.f_det_hi = f_det_hi;
  for (Eigen::Index i = 0; i < np; ++i) {
    NoiseParam p;
    p.name = defs[static_cast<std::size_t>(i)].name;
    p.log_scale = defs[static_cast<std::size_t>(i)].log_scale;
    p.value = p.log_scale ? std::exp(x[i]) : x[i];
    const double v = fit.cov(i, i);
    const double se = std::isfinite(v) && v >= 0 ? std::sqrt(v) : std::numeric_limits<double>::quiet_NaN();
    p.log_sigma = p.log_scale ? se : 0.0;
    p.sigma = p.log_scale ? p.value * se : se;
    if (at_bound[static_cast<std::size_t>(i)]) {
      p.determined = false;
      p.note = "at the bound of its range (the data do not pull it inside)";
    } else if (!info_ok || !std::isfinite(se)) {
      p.determined = false;
      p.note = info_ok ? "the likelihood is flat along a direction in which this parameter moves (no finite uncertainty)"
                       : "the likelihood is flat in this parameter (no finite uncertainty)";
    }
    double fc = 0;
    if (p.name.find("tau_s") != std::string::npos) fc = 1.0 / (kTwoPi * p.value);
    if (p.name.find("f_lo_hz") != std::string::npos || p.name.find("f_hi_hz") != std::string::npos) fc = p.value;
    if (fc > 0 && p.determined && (fc < f_det_lo || fc > f_det_hi)) {
      std::ostringstream o;
      o.precision(3);
      o << "corner frequency " << fc << " Hz outside what " << d.span << " s sampled every " << d.T
        << " s determine (" << f_det_lo << " to " << f_det_hi << " Hz)";
      p.determined = false;
      p.note = o.str();
    }
    fit.params.push_back(p);
  }
  // A coloured term whose level is not significant leaves its time or band undetermined.
  auto level_weak = [&](const std::string& prefix) {
    const NoiseParam* sp = fit.find(prefix + ".sigma");
    return sp && (!sp->determined || !(sp->log_sigma < 0.5));
  };
  for (auto& p : fit.params) {
    const auto dot = p.name.find('.');
    const std::string prefix = p.name.substr(0, dot);
    if (prefix == "white" || p.name == prefix + ".sigma" || !p.determined) continue;
    if (level_weak(prefix)) {
      p.determined = false;
      p.note = "its term's level is not significant";
    }
  }
  fit.x_fit = x;
  fit.cov_fit = fit.cov;
  fit.on_bound = at_bound;
  if (structure == NoiseStructure::WhitePowerLaw) reportAtThePivot(fit, x, pl_terms, d.T);
  const auto k = static_cast<double>(np + X.cols());
  fit.aic = fit.m2ll + 2 * k;
  fit.bic = fit.m2ll + k * std::log(static_cast<double>(whittle ? wd.samples : s.size()));
  return fit;
}

std::pair<double, double> NoiseFit::logPsd(double f_hz, double T_s) const {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const Eigen::Index np = x_fit.size();
  if (np == 0 || cov_fit.rows() != np) return {nan, nan};
  int pl_terms = 0;  // the power law's term count, as the fit fixed it
  for (const auto& t : model.terms)
    if (t.kind == NoiseKind::PowerLaw) pl_terms = t.powerLawTermCount();
  auto logS = [&](const Eigen::VectorXd& v) { return std::log(modelOf(structure, v, pl_terms).psdSampled(f_hz, T_s)); };
  const double at = logS(x_fit);
  Eigen::RowVectorXd g = Eigen::RowVectorXd::Zero(np);
  bool undetermined = false;
  for (Eigen::Index j = 0; j < np; ++j) {
    Eigen::VectorXd a = x_fit, b = x_fit;
    a[j] += 1e-5;
    b[j] -= 1e-5;
    const double gj = (logS(a) - logS(b)) / 2e-5;
    // A parameter on a bound is held (the covariance of the others is the one given it); one without a
    // variance for another reason (a flat direction) leaves the PSD at f undetermined where the PSD
    // depends on it (a hundredth per unit of its fitting scale or more), else it is held too.
    const bool bound = static_cast<std::size_t>(j) < on_bound.size() && on_bound[static_cast<std::size_t>(j)];
    if (std::isfinite(cov_fit(j, j)))
      g[j] = gj;
    else if (!bound && std::abs(gj) >= 1e-2)
      undetermined = true;
  }
  if (undetermined) return {at, std::numeric_limits<double>::infinity()};
  const Eigen::MatrixXd C = cov_fit.unaryExpr([](double v) { return std::isfinite(v) ? v : 0.0; });
  const double var = (g * C * g.transpose())(0, 0);
  return {at, var >= 0 ? std::sqrt(var) : nan};
}

std::pair<double, double> NoiseSelection::averagedLogPsd(double f_hz, double T_s) const {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  double aic_min = std::numeric_limits<double>::infinity();
  // every fit with a model is a candidate, as in the choice (a fit that did not settle counts with the
  // likelihood it reached); skipped structures have none
  for (const auto& f : fits)
    if (!f.model.empty() && std::isfinite(f.aic)) aic_min = std::min(aic_min, f.aic);
  if (!std::isfinite(aic_min)) return {nan, nan};
  double wsum = 0;
  std::vector<std::pair<double, std::pair<double, double>>> kept;  // weight, {log PSD, se}
  for (const auto& f : fits) {
    if (f.model.empty() || !std::isfinite(f.aic)) continue;
    kept.push_back({std::exp(-0.5 * (f.aic - aic_min)), f.logPsd(f_hz, T_s)});
    wsum += kept.back().first;
  }
  double mean = 0, wkept = 0;
  for (auto& k : kept) {
    k.first /= wsum;
    if (k.first < 1e-3) continue;
    if (!std::isfinite(k.second.first)) return {nan, nan};
    mean += k.first * k.second.first;
    wkept += k.first;
  }
  mean /= wkept;
  double se = 0;
  for (const auto& [w, p] : kept) {
    if (w < 1e-3) continue;
    if (!std::isfinite(p.second)) return {mean, std::numeric_limits<double>::infinity()};
    se += w / wkept * std::sqrt(p.second * p.second + (p.first - mean) * (p.first - mean));
  }
  return {mean, se};
}

NoiseFit fitWhiteFromDifferences(const NoiseSeries& s) {
  NoiseFit fit;
  fit.structure = NoiseStructure::White;
  const double T = s.medianInterval();
  std::vector<std::int64_t> t_us;
  std::vector<double> d;
  for (std::size_t i = 1; i < s.size(); ++i) {
    if (!(T > 0) || std::abs(s.t_s[i] - s.t_s[i - 1] - T) > 0.1 * T) continue;
    t_us.push_back(static_cast<std::int64_t>(std::llround(s.t_s[i] * 1e6)));
    d.push_back(s.y[i] - s.y[i - 1]);
  }
  fit.n = d.size();
  if (d.size() < 3) {
    fit.message = "fewer than three consecutive pairs of samples";
    return fit;
  }
  // Differences one interval apart share a sample (correlation -1/2); further apart they share none.
  const BandedWhitener w(t_us, T, {1.0, -0.5});
  const std::vector<double> z = w.whiten(d);
  double q = 0;
  for (double v : z) q += v * v;
  const auto n = static_cast<double>(d.size());
  const double var_d = q / n;  // ML variance of the differences: 2 sigma^2
  const double sigma = std::sqrt(var_d / 2);
  fit.model = NoiseModel::white(sigma);
  NoiseParam p;
  p.name = "white.sigma";
  p.value = sigma;
  p.log_sigma = 1.0 / std::sqrt(2 * n);  // var of an ML variance of n: 2 var^2 / n
  p.sigma = sigma * p.log_sigma;
  p.note = "from the differences of consecutive samples";
  fit.params.push_back(p);
  fit.cov = Eigen::MatrixXd::Constant(1, 1, p.log_sigma * p.log_sigma);
  double logdet = 0;
  for (std::size_t k = 0; k < d.size(); ++k) logdet += 2 * std::log(w.factor(k, k));
  fit.m2ll = n * std::log(kTwoPi * var_d) + logdet + n;
  fit.aic = fit.m2ll + 2;
  fit.bic = fit.m2ll + std::log(n);
  fit.converged = true;
  return fit;
}

NoiseSelection selectNoise(const NoiseSeries& s, const std::vector<NoiseStructure>& structures, const Eigen::MatrixXd& X,
                           const NoiseFitOptions& opt) {
  NoiseSelection sel;
  auto fitOf = [&](NoiseStructure st) -> const NoiseFit* {
    for (const auto& f : sel.fits)
      if (f.structure == st && !f.model.empty()) return &f;
    return nullptr;
  };
  // Nested shortcuts (opt.skip_when_no_colour): a structure with more coloured terms is not fitted when
  // the simpler pair below it shows nothing for them to take up; it is listed with the reason.
  // - When one Gauss-Markov term on top of white does not lower BIC, the two-term and power-law
  //   structures: the series shows no colour that one term could take up, and each costs a full fit.
  // - The same one level up: a power law only where two Gauss-Markov terms lower BIC below one. A power
  //   law that the data can tell from one term spreads its power over more than one scale, and two free
  //   terms then take up more of it than one; where they do not, the series shows one scale. (It is the
  //   costliest candidate, a dozen states; on the realistic seed-1 day two terms lost to one on 7 of the
  //   9 head axes, and the power law lost there too, by 19.5-22.)
  auto skipReason = [&](NoiseStructure st) -> const char* {
    if (!opt.skip_when_no_colour) return nullptr;
    const NoiseFit *w = fitOf(NoiseStructure::White), *g = fitOf(NoiseStructure::WhiteGaussMarkov),
                   *g2 = fitOf(NoiseStructure::WhiteTwoGaussMarkov);
    if ((st == NoiseStructure::WhiteTwoGaussMarkov || st == NoiseStructure::WhitePowerLaw) && w && g && !(g->bic < w->bic))
      return "not fitted: white+gauss_markov does not improve BIC on white (no colour to take up)";
    if (st == NoiseStructure::WhitePowerLaw && g && g2 && !(g2->bic < g->bic))
      return "not fitted: white+2gauss_markov does not improve BIC on white+gauss_markov (one scale shows)";
    return nullptr;
  };
  for (NoiseStructure st : structures) {
    if (const char* why = skipReason(st)) {
      NoiseFit skipped;
      skipped.structure = st;
      skipped.n = s.size();
      skipped.message = why;
      sel.fits.push_back(skipped);
      continue;
    }
    sel.fits.push_back(fitNoise(s, st, X, opt));
    const auto i = static_cast<int>(sel.fits.size()) - 1;
    const NoiseFit& f = sel.fits.back();
    if (f.model.empty()) continue;
    if (sel.best < 0 || f.bic < sel.fits[static_cast<std::size_t>(sel.best)].bic) sel.best = i;
  }
  return sel;
}

}  // namespace boresight::model
