// The stochastic sensor models: tags, missing samples, outliers, sign flips, accelerometer noise.
#include <boresight/model/rotation.h>
#include <boresight/model/stochastic.h>

#include <algorithm>
#include <cmath>
#include <iterator>
#include <utility>

namespace boresight::model {

TimeUs TagModel::tag(std::uint64_t k) const {
  const double nominal = static_cast<double>(k) * static_cast<double>(period);
  TimeUs t = start + static_cast<TimeUs>(k) * period + static_cast<TimeUs>(std::llround(drift_ppm * 1e-6 * nominal));
  if (jitter_us > 0) t += static_cast<TimeUs>(std::llround((2 * jitter_rng.uniform(k) - 1) * jitter_us));
  return t;
}

double TagModel::expectedTag(std::uint64_t k) const {
  const double nominal = static_cast<double>(k) * static_cast<double>(period);
  return static_cast<double>(start) + nominal * (1.0 + drift_ppm * 1e-6);
}

double TagModel::jitter(std::uint64_t k) const {
  return jitter_us > 0 ? (2 * jitter_rng.uniform(k) - 1) * jitter_us : 0.0;
}

double TagModel::jitterSigmaUs() const { return jitter_us / std::sqrt(3.0); }

TagModel makeTagModel(TimeUs start, double rate_hz, TimeUs offset_us, double drift_ppm, double jitter_us,
                      std::uint64_t seed, Stream stream) {
  TagModel s;
  s.period = static_cast<TimeUs>(std::llround(1e6 / rate_hz));
  const TimeUs sec0 = ((start + kUsPerSecond - 1) / kUsPerSecond) * kUsPerSecond;
  s.start = sec0 + offset_us;
  while (s.start - s.period >= start) s.start -= s.period;
  s.drift_ppm = drift_ppm;
  s.jitter_us = jitter_us;
  s.jitter_rng = CounterRng(seed, stream, static_cast<std::uint64_t>(s.period) * 1000003ULL + static_cast<std::uint64_t>(offset_us));
  return s;
}

double expectedMissingFraction(const RandomGaps& g) {
  if (!(g.per_s > 0) || !(g.mean_s > 0)) return 0.0;
  const double p = std::min(g.per_s, 1.0), m = g.mean_s;
  // log P(free | f) = sum_k log(1 - p e^{-(k+f)/m}); averaged over f in the slot by the midpoint rule.
  constexpr int kF = 64;
  double free = 0;
  for (int i = 0; i < kF; ++i) {
    const double f = (i + 0.5) / kF;
    double lg = 0;
    if (p < 0.5) {
      // -sum_j p^j/j e^{-j f/m} / (1 - e^{-j/m}): the series of log(1 - x) summed over k in closed form.
      double pj = 1;
      for (int j = 1; j < 100000; ++j) {
        pj *= p;
        const double term = pj / j * std::exp(-j * f / m) / -std::expm1(-j / m);
        lg -= term;
        if (term < 1e-17 * std::abs(lg)) break;
      }
    } else {
      for (long k = 0; k < 10000000L; ++k) {
        const double x = p * std::exp(-(static_cast<double>(k) + f) / m);
        if (x < 1e-18) break;
        lg += std::log1p(-x);
      }
    }
    free += std::exp(lg);
  }
  return 1.0 - free / kF;
}

double expectedMissingFraction(const std::vector<RandomGaps>& g) {
  double free = 1;
  for (const auto& x : g) free *= 1.0 - expectedMissingFraction(x);
  return 1.0 - free;
}

namespace {

/// The union of half-open intervals as disjoint intervals in time order (empty ones dropped), so that a
/// time is looked up by bisection: the audit's loop gives one interval per gap of the data (thousands).
std::vector<Interval> disjointUnion(std::vector<Interval> v) {
  v.erase(std::remove_if(v.begin(), v.end(), [](const Interval& i) { return !(i.end_s > i.start_s); }), v.end());
  std::sort(v.begin(), v.end(), [](const Interval& a, const Interval& b) { return a.start_s < b.start_s; });
  std::vector<Interval> out;
  for (const Interval& i : v) {
    if (!out.empty() && i.start_s <= out.back().end_s) out.back().end_s = std::max(out.back().end_s, i.end_s);
    else out.push_back(i);
  }
  return out;
}

bool inUnion(const std::vector<Interval>& u, double t) {
  auto it = std::upper_bound(u.begin(), u.end(), t, [](double x, const Interval& i) { return x < i.start_s; });
  return it != u.begin() && std::prev(it)->contains(t);
}

}  // namespace

GapProcess::GapProcess(const std::vector<RandomGaps>& random, std::vector<Interval> fixed, std::vector<Interval> dropouts,
                       std::uint64_t seed, Stream stream, std::uint64_t sensor) {
  fixed.insert(fixed.end(), dropouts.begin(), dropouts.end());
  fixed_ = disjointUnion(std::move(fixed));
  for (std::size_t j = 0; j < random.size(); ++j) {
    Proc p;
    p.g = random[j];
    p.rng = CounterRng(seed, stream, processKey(sensor, j));
    procs_.push_back(p);
  }
}

bool GapProcess::randomMissing(double t) {
  bool miss = false;
  const auto slot = static_cast<std::int64_t>(std::floor(t));
  for (auto& p : procs_) {
    if (!(p.g.per_s > 0)) continue;
    for (; p.next_slot <= slot; ++p.next_slot) {
      const auto k = static_cast<std::uint64_t>(p.next_slot);
      if (p.rng.uniform(k, 0) < p.g.per_s)
        p.until = std::max(p.until, static_cast<double>(p.next_slot) - p.g.mean_s * std::log(p.rng.uniform(k, 1)));
    }
    miss = miss || t < p.until;
  }
  return miss;
}

bool GapProcess::fixedMissing(double t) const { return inUnion(fixed_, t); }

bool GapProcess::missing(double t) {
  const bool r = randomMissing(t);
  return r || fixedMissing(t);
}

double GapProcess::expectedRandomFraction() const {
  std::vector<RandomGaps> g;
  for (const auto& p : procs_) g.push_back(p.g);
  return expectedMissingFraction(g);
}

OutlierSampler::OutlierSampler(const std::vector<OutlierProcess>& p, std::uint64_t seed, std::uint64_t head_id)
    : procs_(p) {
  for (std::size_t j = 0; j < p.size(); ++j) rng_.emplace_back(seed, Stream::HeadOutlier, processKey(head_id, j));
}

double OutlierSampler::probability() const {
  double none = 1;
  for (const auto& p : procs_) none *= 1.0 - std::clamp(p.prob, 0.0, 1.0);
  return 1.0 - none;
}

bool OutlierSampler::fires(std::size_t j, std::uint64_t n) const {
  return procs_[j].prob > 0 && rng_[j].uniform(n, 0) < procs_[j].prob;
}

Vec3 OutlierSampler::rotation(std::size_t j, std::uint64_t n) const {
  const Vec3 axis(rng_[j].normal(n, 1), rng_[j].normal(n, 2), rng_[j].normal(n, 3));
  return axis.normalized() * procs_[j].rad;
}

bool OutlierSampler::apply(std::uint64_t n, Quat& q) const {
  bool any = false;
  for (std::size_t j = 0; j < procs_.size(); ++j) {
    if (!fires(j, n)) continue;
    q = q * quatExp(rotation(j, n));
    any = true;
  }
  return any;
}

SignFlipSampler::SignFlipSampler(const std::vector<double>& probs, std::uint64_t seed, std::uint64_t head_id) : p_(probs) {
  for (std::size_t j = 0; j < probs.size(); ++j) rng_.emplace_back(seed, Stream::HeadSignFlip, processKey(head_id, j));
}

double SignFlipSampler::probability() const {
  double none = 1;
  for (double p : p_) none *= 1.0 - std::clamp(p, 0.0, 1.0);
  return 1.0 - none;
}

bool SignFlipSampler::fires(std::uint64_t n) const {
  bool any = false;
  for (std::size_t j = 0; j < p_.size(); ++j) any = any || (p_[j] > 0 && rng_[j].uniform(n, 0) < p_[j]);
  return any;
}

NoiseProcess::NoiseProcess(const NoiseModel& m, std::uint64_t seed, Stream stream, std::uint64_t sensor, int axis)
    : sim_(m, CounterRng(seed, stream, colouredProcessKey(sensor, axis, 0))), empty_(m.empty()) {}

NoiseProcess3::NoiseProcess3(const std::array<NoiseModel, 3>& models, std::uint64_t seed, Stream stream,
                             std::uint64_t sensor) {
  for (int k = 0; k < 3; ++k) {
    axis_[static_cast<std::size_t>(k)] = NoiseProcess(models[static_cast<std::size_t>(k)], seed, stream, sensor, k);
    empty_ = empty_ && axis_[static_cast<std::size_t>(k)].empty();
  }
}

Vec3 NoiseProcess3::next(double t_s) {
  Vec3 v = Vec3::Zero();
  for (int k = 0; k < 3; ++k) v[k] = axis_[static_cast<std::size_t>(k)].next(t_s);
  return v;
}

AccNoiseModel::AccNoiseModel(const AccelConfig& c, std::uint64_t seed)
    : white_(c.white_rad_s2),
      lin_white_(c.lin_white_m_s2),
      lf_(c.lowfreq_rad_s2),
      T_(1.0 / c.rate_hz),
      phi_(std::exp(-(1.0 / c.rate_hz) / c.lowfreq_tau_s)),
      white_rng_(seed, Stream::AccNoise, 0),
      lf_rng_(seed, Stream::AccLowFreq, 0) {
  for (int k = 0; k < 3; ++k) {
    NoiseModel& m = models_[static_cast<std::size_t>(k)];
    if (white_[k] != 0) m.add(NoiseTerm::white(std::abs(white_[k])));
    if (lf_[k] != 0) m.add(NoiseTerm::gaussMarkov(std::abs(lf_[k]), c.lowfreq_tau_s));
  }
}

Vec3 AccNoiseModel::lowFreqInitial() const {
  return Vec3(lf_.x() * lf_rng_.normal(0, 0), lf_.y() * lf_rng_.normal(0, 1), lf_.z() * lf_rng_.normal(0, 2));
}

Vec3 AccNoiseModel::lowFreqNext(const Vec3& lf_n, std::uint64_t n) const {
  double g0, g1, g2, g3;
  lf_rng_.normal2(n + 1, 0, g0, g1);
  lf_rng_.normal2(n + 1, 1, g2, g3);
  return Vec3(gaussMarkovStep(lf_n.x(), phi_, lf_.x(), g0), gaussMarkovStep(lf_n.y(), phi_, lf_.y(), g1),
              gaussMarkovStep(lf_n.z(), phi_, lf_.z(), g2));
}

void AccNoiseModel::white(std::uint64_t n, Vec3& ang, Vec3& lin) const {
  double w[6];
  white_rng_.normal2(n, 0, w[0], w[1]);
  white_rng_.normal2(n, 1, w[2], w[3]);
  white_rng_.normal2(n, 2, w[4], w[5]);
  ang = white_.cwiseProduct(Vec3(w[0], w[1], w[2]));
  lin = lin_white_.cwiseProduct(Vec3(w[3], w[4], w[5]));
}

Vec3 AccNoiseModel::whiteVariance() const {
  return Vec3(models_[0].whiteVariance(), models_[1].whiteVariance(), models_[2].whiteVariance());
}
Vec3 AccNoiseModel::lowFreqVariance() const {
  Vec3 v = Vec3::Zero();
  for (int k = 0; k < 3; ++k)
    for (const auto& m : models_[static_cast<std::size_t>(k)].markovTerms()) v[k] += m.var;
  return v;
}

Vec3 AccNoiseModel::autocovariance(std::uint64_t k) const {
  Vec3 c;
  for (int i = 0; i < 3; ++i) c[i] = models_[static_cast<std::size_t>(i)].autocovariance(static_cast<double>(k) * T_);
  return c;
}

Vec3 AccNoiseModel::psdOneSided(double f_hz) const {
  Vec3 p;
  for (int i = 0; i < 3; ++i) p[i] = models_[static_cast<std::size_t>(i)].psdSampled(f_hz, T_);
  return p;
}

}  // namespace boresight::model
