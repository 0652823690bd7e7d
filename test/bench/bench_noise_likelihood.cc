// bench_noise_likelihood: the cost of one exact likelihood evaluation (model::minusTwoLogLikelihood,
// the Kalman whitener) on a day at 1 Hz with 5 % gaps of 40 samples on average and 10 us time-tag
// jitter - the unit of work of `boresight noise`'s exact fits, which make thousands of them.
// Models: white + one Gauss-Markov term (a state of 1), and a head axis as `boresight noise` fits it on
// the realistic preset: white + a power law of the fit's term count + six Gauss-Markov terms standing
// for the other heads' merged coloured parts (a state of 19-20). Counters: samples per second.
#include "boresight/model/noise.h"

#include <benchmark/benchmark.h>

#include <random>

namespace {

using namespace boresight::model;

NoiseSeries daySeries(const NoiseModel& m) {
  NoiseSeries s;
  NoiseSimulator sim(m, CounterRng(7, Stream::HeadNoise, 1));
  std::mt19937_64 g(11);
  std::uniform_real_distribution<double> u(0, 1);
  std::normal_distribution<double> jitter(0.0, 10e-6);
  for (int i = 0; i < 86400; ++i) {
    if (u(g) < 0.05 / 40) {  // a gap of 1-80 samples
      i += static_cast<int>(u(g) * 80);
      continue;
    }
    const double t = i + jitter(g);
    s.t_s.push_back(t);
    s.y.push_back(sim.next(t));
  }
  return s;
}

NoiseModel headAxis() {
  NoiseModel m = NoiseModel::white(2.3);
  m.add(NoiseTerm::powerLaw(1.0, 1.0, 1e-4, 0.02, powerLawFitTerms(86400, 1)));
  const double taus[6] = {30, 100, 300, 1000, 3000, 10000};
  for (double tau : taus) m.add(NoiseTerm::gaussMarkov(0.5, tau));
  return m;
}

void run(benchmark::State& state, const NoiseModel& m) {
  const NoiseSeries s = daySeries(m);
  const Eigen::MatrixXd X = Eigen::MatrixXd::Ones(static_cast<Eigen::Index>(s.size()), 1);
  double sink = 0;
  for (auto _ : state) {
    sink += minusTwoLogLikelihood(m, s, X, false);
    benchmark::DoNotOptimize(sink);
  }
  state.counters["samples/s"] =
      benchmark::Counter(static_cast<double>(s.size()) * static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
  state.counters["state"] = static_cast<double>(m.markovTerms().size());
}

void BM_LikelihoodWhiteGaussMarkov(benchmark::State& state) {
  NoiseModel m = NoiseModel::white(2.3);
  m.add(NoiseTerm::gaussMarkov(1.3, 130));
  run(state, m);
}
BENCHMARK(BM_LikelihoodWhiteGaussMarkov)->Unit(benchmark::kMillisecond);

void BM_LikelihoodHeadAxisPowerLaw(benchmark::State& state) { run(state, headAxis()); }
BENCHMARK(BM_LikelihoodHeadAxisPowerLaw)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
