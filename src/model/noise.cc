// Noise models: terms, canonical form, spectra, autocovariance and simulation (noise.h).
#include <boresight/model/noise.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

namespace boresight::model {
namespace {
constexpr double kTwoPi = 6.283185307179586;
}

const char* noiseKindName(NoiseKind k) {
  switch (k) {
    case NoiseKind::White: return "white";
    case NoiseKind::GaussMarkov: return "gauss_markov";
    case NoiseKind::PowerLaw: return "power_law";
  }
  return "?";
}

NoiseTerm NoiseTerm::white(double sigma) {
  NoiseTerm t;
  t.kind = NoiseKind::White;
  t.sigma = sigma;
  return t;
}

NoiseTerm NoiseTerm::gaussMarkov(double sigma, double tau_s) {
  NoiseTerm t;
  t.kind = NoiseKind::GaussMarkov;
  t.sigma = sigma;
  t.tau_s = tau_s;
  return t;
}

NoiseTerm NoiseTerm::powerLaw(double sigma, double alpha, double f_lo_hz, double f_hi_hz, int terms) {
  NoiseTerm t;
  t.pl_terms = terms;
  t.kind = NoiseKind::PowerLaw;
  t.sigma = sigma;
  t.alpha = alpha;
  t.f_lo_hz = f_lo_hz;
  t.f_hi_hz = f_hi_hz;
  return t;
}

bool NoiseTerm::operator==(const NoiseTerm& o) const {
  if (kind != o.kind || sigma != o.sigma) return false;
  switch (kind) {
    case NoiseKind::White: return true;
    case NoiseKind::GaussMarkov: return tau_s == o.tau_s;
    case NoiseKind::PowerLaw:
      return alpha == o.alpha && f_lo_hz == o.f_lo_hz && f_hi_hz == o.f_hi_hz && powerLawTermCount() == o.powerLawTermCount();
  }
  return false;
}

int NoiseTerm::powerLawTermCount() const {
  if (pl_terms > 0) return pl_terms;
  if (!(f_hi_hz > f_lo_hz) || !(f_lo_hz > 0)) return 2;
  return std::max(2, static_cast<int>(std::lround(3.0 * std::log10(f_hi_hz / f_lo_hz))) + 1);
}

NoiseModel NoiseModel::white(double sigma) {
  NoiseModel m;
  m.terms.push_back(NoiseTerm::white(sigma));
  return m;
}

NoiseModel& NoiseModel::add(const NoiseTerm& t) {
  terms.push_back(t);
  return *this;
}

std::string NoiseModel::validate() const {
  for (std::size_t i = 0; i < terms.size(); ++i) {
    const NoiseTerm& t = terms[i];
    const std::string at = "term " + std::to_string(i + 1) + " (" + noiseKindName(t.kind) + "): ";
    if (!std::isfinite(t.sigma) || t.sigma < 0) return at + "sigma must be finite and >= 0";
    if (t.kind == NoiseKind::GaussMarkov && !(std::isfinite(t.tau_s) && t.tau_s > 0))
      return at + "tau_s must be finite and > 0";
    if (t.kind == NoiseKind::PowerLaw) {
      if (!(std::isfinite(t.alpha) && t.alpha > 0 && t.alpha < 2)) return at + "alpha must be in (0, 2)";
      if (!(std::isfinite(t.f_lo_hz) && t.f_lo_hz > 0)) return at + "f_lo_hz must be finite and > 0";
      if (!(std::isfinite(t.f_hi_hz) && t.f_hi_hz > t.f_lo_hz)) return at + "f_hi_hz must be finite and > f_lo_hz";
      if (t.f_hi_hz / t.f_lo_hz > 1e8) return at + "f_hi_hz / f_lo_hz must be <= 1e8";
      if (t.pl_terms < 0 || t.pl_terms == 1 || t.pl_terms > 64) return at + "pl_terms must be 0 (three per decade) or 2..64";
    }
  }
  return {};
}

std::vector<MarkovTerm> powerLawTerms(const NoiseTerm& p) {
  const int K = p.powerLawTermCount();
  std::vector<MarkovTerm> out(static_cast<std::size_t>(K));
  const double lr = std::log(p.f_hi_hz / p.f_lo_hz) / (K - 1);
  double wsum = 0;
  for (int k = 0; k < K; ++k) {
    const double fk = p.f_lo_hz * std::exp(lr * k);
    auto& t = out[static_cast<std::size_t>(k)];
    t.var = std::exp((1.0 - p.alpha) * lr * k);  // (f_k / f_lo)^(1 - alpha)
    t.tau_s = 1.0 / (kTwoPi * fk);
    wsum += t.var;
  }
  const double s2 = p.sigma * p.sigma;
  for (auto& t : out) t.var *= s2 / wsum;
  return out;
}

double NoiseModel::whiteVariance() const {
  double v = 0;
  for (const auto& t : terms)
    if (t.kind == NoiseKind::White) v += t.sigma * t.sigma;
  return v;
}

std::vector<MarkovTerm> NoiseModel::markovTerms() const {
  std::vector<MarkovTerm> out;
  for (const auto& t : terms) {
    if (t.kind == NoiseKind::GaussMarkov) out.push_back({t.sigma * t.sigma, t.tau_s});
    if (t.kind == NoiseKind::PowerLaw) {
      const auto p = powerLawTerms(t);
      out.insert(out.end(), p.begin(), p.end());
    }
  }
  return out;
}

double NoiseModel::variance() const {
  double v = whiteVariance();
  for (const auto& m : markovTerms()) v += m.var;
  return v;
}

double NoiseModel::autocovariance(double lag_s) const {
  const double a = std::abs(lag_s);
  double c = a == 0 ? whiteVariance() : 0.0;
  for (const auto& m : markovTerms()) c += m.var * std::exp(-a / m.tau_s);
  return c;
}

double NoiseModel::psdSampled(double f_hz, double T_s) const {
  // A sampled Gauss-Markov term is an AR(1) with phi = exp(-T/tau) and innovation variance
  // var (1 - phi^2): its one-sided PSD is 2 T var (1 - phi^2) / (1 - 2 phi cos(2 pi f T) + phi^2).
  double s = 2.0 * T_s * whiteVariance();
  const double c = std::cos(kTwoPi * f_hz * T_s);
  for (const auto& m : markovTerms()) {
    const double phi = std::exp(-T_s / m.tau_s);
    s += 2.0 * T_s * m.var * (1.0 - phi * phi) / (1.0 - 2.0 * phi * c + phi * phi);
  }
  return s;
}

double NoiseModel::psdContinuous(double f_hz, double T_s) const {
  double s = 2.0 * T_s * whiteVariance();
  for (const auto& m : markovTerms()) {
    const double x = kTwoPi * f_hz * m.tau_s;
    s += 4.0 * m.var * m.tau_s / (1.0 + x * x);
  }
  return s;
}

std::string NoiseModel::describe(double scale, const std::string& unit) const {
  if (terms.empty()) return "none";
  std::ostringstream o;
  o.precision(3);
  for (std::size_t i = 0; i < terms.size(); ++i) {
    const NoiseTerm& t = terms[i];
    if (i) o << " + ";
    switch (t.kind) {
      case NoiseKind::White: o << "white " << t.sigma * scale << unit; break;
      case NoiseKind::GaussMarkov: o << "GM(" << t.sigma * scale << unit << ", tau " << t.tau_s << " s)"; break;
      case NoiseKind::PowerLaw:
        o << "PL(" << t.sigma * scale << unit << ", f^-" << t.alpha << ", " << t.f_lo_hz << "-" << t.f_hi_hz << " Hz, "
          << t.powerLawTermCount() << " terms)";
        break;
    }
  }
  return o.str();
}

// ---------------------------------------------------------------------------------------------

NoiseSimulator::NoiseSimulator(const NoiseModel& m, const CounterRng& rng)
    : white_sigma_(std::sqrt(m.whiteVariance())), gm_(m.markovTerms()), x_(gm_.size(), 0.0), phi_(gm_.size(), 0.0), rng_(rng) {
  for (std::size_t c = 1; c * 8 <= gm_.size(); ++c) chunks_.push_back(rng_.derived(c));
}

double NoiseSimulator::next(double t_s) {
  // Normal m of sample n (m = 0 the white term, m = 1 + j Gauss-Markov term j) is draw (n, m % 8) of
  // the stream rng_.derived(m / 8): a CounterRng index carries eight normals (subs 0..7; sub 8 would be
  // the next index's sub 0), so every eight terms take a stream of their own, and a term's draws do not
  // depend on how many terms follow it.
  const std::uint64_t n = n_++;
  auto normal = [&](std::uint64_t m) { return m < 8 ? rng_.normal(n, m) : chunks_[m / 8 - 1].normal(n, m % 8); };
  double v = white_sigma_ > 0 ? white_sigma_ * normal(0) : 0.0;
  const double dt = n == 0 ? 0.0 : std::max(0.0, t_s - t_prev_);
  t_prev_ = t_s;
  if (n > 0 && dt != dt_) {  // a regular grid computes its transitions once
    dt_ = dt;
    for (std::size_t j = 0; j < gm_.size(); ++j) phi_[j] = std::exp(-dt / gm_[j].tau_s);
  }
  for (std::size_t j = 0; j < gm_.size(); ++j) {
    const double s = std::sqrt(gm_[j].var);
    const double e = normal(1 + j);
    x_[j] = n == 0 ? s * e : gaussMarkovStep(x_[j], phi_[j], s, e);
    v += x_[j];
  }
  return v;
}

}  // namespace boresight::model
