// bench_calib: SpanBuilder + solve() on 1 h, 6 h, 1 day and 3 days of synthetic GRACE-FO-rate epochs
// (3 heads at 2 Hz, accelerometer at 10 Hz; calibration manoeuvres about x, y, z in every orbit).
// One orbit (5650 s, the attitude closes: a 2 pi pitch) is generated once and replayed with shifted
// tags, so the timing is of the span builder (CRN per head, accelerometer CRN, relative normal
// equations, decimation) and the solver only, not of the data generator.
// Counters: build_s and solve_s (wall, this iteration), observations, span_MB (the span's heap:
// observations at capacity), maxrss_MB (the process's peak resident set so far: the benchmarks run in
// order of the span, so each figure is the peak of that span or a shorter one).
// Second argument 1: SpanOptions::keep_observations = false and the solver works from the moments.
#include "../synthetic.h"

#include <benchmark/benchmark.h>

#include <sys/resource.h>

#include <chrono>
#include <memory>

namespace {

using namespace boresight;
using namespace boresight::calib;

struct Recorder {
  std::vector<core::HeadEpoch> heads;
  std::vector<std::pair<TimeUs, Vec3>> acc;
  void pushHeads(const core::HeadEpoch& e) { heads.push_back(e); }
  void pushAcc(TimeUs t, const Vec3& a) { acc.emplace_back(t, a); }
};

const synth::Config& orbitConfig() {
  static const synth::Config c = [] {
    synth::Config x;
    x.seed = 77;
    x.q_S_B_nominal = synth::gracefoMountings();
    x.orbit_period_s = 5650.0;
    x.duration_s = 5650.0;
    x.manoeuvres = synth::threeAxisManoeuvres(150.0, 1200.0);
    x.truth.r_S[0] = Vec3(300, -200, 500) * kRadPerArcsec;
    x.truth.r_S[1] = Vec3(-250, 400, -300) * kRadPerArcsec;
    x.truth.r_S[2] = Vec3(100, 350, 600) * kRadPerArcsec;
    x.truth.acc_bias = Vec3(1.31e-5, 1.19e-4, -7.81e-4);
    return x;
  }();
  return c;
}

const Recorder& orbit() {
  static const Recorder r = [] {
    Recorder x;
    synth::stream(orbitConfig(), x);
    return x;
  }();
  return r;
}

double maxRssMb() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_maxrss) / 1024.0;
}

// range(0): span in s; range(1): 1 = keep no observation, solve from the moments (constant memory).
void BM_SpanAndSolve(benchmark::State& state) {
  const double duration_s = static_cast<double>(state.range(0));
  const bool moments = state.range(1) != 0;
  const Recorder& o = orbit();
  const TimeUs period = static_cast<TimeUs>(std::llround(orbitConfig().orbit_period_s * 1e6));
  const TimeUs t_end = orbitConfig().t0 + static_cast<TimeUs>(std::llround(duration_s * 1e6));
  double build_s = 0, solve_s = 0;
  std::size_t n_obs = 0, span_bytes = 0;
  for (auto _ : state) {
    const auto t0 = std::chrono::steady_clock::now();
    auto b = std::make_unique<SpanBuilder>();
    std::string err;
    SpanOptions so;
    so.keep_observations = !moments;
    if (!b->configure(synth::pipelineConfig(orbitConfig()), so, &err)) {
      state.SkipWithError(err.c_str());
      return;
    }
    bool done = false;
    for (TimeUs shift = 0; !done; shift += period) {
      std::size_t ia = 0;
      for (const core::HeadEpoch& e0 : o.heads) {
        core::HeadEpoch e = e0;
        e.t += shift;
        if (e.t >= t_end) {
          done = true;
          break;
        }
        while (ia < o.acc.size() && o.acc[ia].first + shift <= e.t) {
          b->pushAcc(o.acc[ia].first + shift, o.acc[ia].second);
          ++ia;
        }
        b->pushHeads(e);
      }
      for (; !done && ia < o.acc.size(); ++ia) b->pushAcc(o.acc[ia].first + shift, o.acc[ia].second);
    }
    b->finish();
    const auto t1 = std::chrono::steady_clock::now();
    const SolveResult r = solve(b->span(), SolveOptions{});
    const auto t2 = std::chrono::steady_clock::now();
    if (!r.ok) {
      state.SkipWithError(r.message.c_str());
      return;
    }
    benchmark::DoNotOptimize(r.heads.data());
    build_s = std::chrono::duration<double>(t1 - t0).count();
    solve_s = std::chrono::duration<double>(t2 - t1).count();
    n_obs = b->span().epochs_total;
    span_bytes = b->span().obs.capacity() * sizeof(Observation);
  }
  state.counters["build_s"] = build_s;
  state.counters["solve_s"] = solve_s;
  state.counters["observations"] = static_cast<double>(n_obs);
  state.counters["span_MB"] = static_cast<double>(span_bytes) / 1e6;
  state.counters["maxrss_MB"] = maxRssMb();
}

BENCHMARK(BM_SpanAndSolve)
    ->ArgsProduct({{3600, 6 * 3600, 86400, 3 * 86400}, {0, 1}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
