// bench_core: a full day of GRACE-FO-rate synthetic data through the whole real-time core.
//   3 heads at 2 Hz (172 800 epochs), accelerometer at 10 Hz (864 000 samples), rows at 1 Hz.
// Reported: time per full day (the benchmark's Time column), and counters: per-epoch median and
// 99.9th percentile step time (one epoch = one stepHeads plus the accelerometer samples up to it),
// the core's state size in bytes (sizeof(Pipeline): all of its memory), rows produced.
// BM_CoreDayWithStars adds 30 star vectors per epoch (10 per head, > kMaxStars: selection runs).
#include "boresight/core/pipeline.h"
#include "boresight/core/rotation.h"

#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <memory>
#include <random>
#include <vector>

namespace {

using namespace boresight;
using namespace boresight::core;

constexpr int kHeadEpochs = 86400 * 2;
constexpr TimeUs kT0 = 738849600LL * kUsPerSecond;

struct Day {
  PipelineConfig cfg;
  std::vector<HeadEpoch> heads;
  std::vector<TimeUs> acc_t;
  std::vector<Vec3> acc_a;
  std::vector<StarEpoch> star_pool;
};

HeadSetConfig gracefoLikeHeads() {
  HeadSetConfig c;
  c.n_heads = 3;
  const Vec3 axes[3] = {Vec3(1.2, 0.3, -0.4), Vec3(-1.1, 0.9, 0.2), Vec3(0.1, -1.3, 1.0)};
  for (int k = 0; k < 3; ++k) {
    c.head[static_cast<std::size_t>(k)].id = k + 1;
    c.head[static_cast<std::size_t>(k)].q_Si_B = quatExp(axes[k]);
  }
  return c;
}

const Day& day() {
  static const std::unique_ptr<Day> d = [] {
    auto out = std::make_unique<Day>();
    std::mt19937_64 rng(2026);
    std::normal_distribution<double> n(0, 1);
    out->cfg.heads = gracefoLikeHeads();
    const Mat3 C_B_A = out->cfg.C_B_A;
    const double w_orb = 2 * kPi / 5640.0;
    auto att = [&](double t) {  // orbit-rate pitch plus a small libration
      return quatExp(Vec3(0, -w_orb * t, 0)) * quatExp(Vec3(1e-4 * std::sin(0.02 * t), 2e-4 * std::sin(0.011 * t), 0));
    };
    auto alpha = [&](double t) {
      return Vec3(-1e-4 * 0.02 * 0.02 * std::sin(0.02 * t), -2e-4 * 0.011 * 0.011 * std::sin(0.011 * t), 0);
    };
    out->heads.resize(kHeadEpochs);
    for (int i = 0; i < kHeadEpochs; ++i) {
      HeadEpoch& e = out->heads[static_cast<std::size_t>(i)];
      e.t = kT0 + 30000 + static_cast<TimeUs>(i) * 500000;
      const Quat q_I_B = att(toSeconds(e.t - kT0));
      e.n = 3;
      for (int k = 0; k < 3; ++k) {
        const HeadConfig& h = out->cfg.heads.head[static_cast<std::size_t>(k)];
        const Vec3 eps(h.sigma_cross_rad * n(rng), h.sigma_cross_rad * n(rng), h.sigma_roll_rad * n(rng));
        e.sample[static_cast<std::size_t>(k)].head_id = h.id;
        e.sample[static_cast<std::size_t>(k)].q_I_Si = q_I_B * h.q_Si_B.conjugate() * quatExp(eps);
      }
      if (i % 1000 < 40 && i > 1000) e.n = 2;  // head 3 blinded now and then
    }
    const int n_acc = 86400 * 10;
    out->acc_t.resize(static_cast<std::size_t>(n_acc));
    out->acc_a.resize(static_cast<std::size_t>(n_acc));
    for (int i = 0; i < n_acc; ++i) {
      const TimeUs t = kT0 + 6901 + static_cast<TimeUs>(i) * 100000;
      out->acc_t[static_cast<std::size_t>(i)] = t;
      out->acc_a[static_cast<std::size_t>(i)] =
          C_B_A.transpose() * alpha(toSeconds(t - kT0)) + Vec3(1e-6 * n(rng), 2e-7 * n(rng), 2e-7 * n(rng));
    }
    out->star_pool.resize(64);
    for (auto& se : out->star_pool) {
      const Quat q_I_B = att(0);
      for (int k = 0; k < 3; ++k)
        for (int j = 0; j < 10; ++j) {
          StarObservation& o = se.star[static_cast<std::size_t>(se.n++)];
          o.head_id = k + 1;
          o.s_Sk = Vec3(0.12 * (n(rng) * 0.5), 0.12 * (n(rng) * 0.5), 1).normalized();
          o.r_I = (q_I_B * out->cfg.heads.head[static_cast<std::size_t>(k)].q_Si_B.conjugate()) * o.s_Sk;
        }
    }
    return out;
  }();
  return *d;
}

// Runs the day; per-epoch times into `lat` when given. Returns rows.
long runDay(Pipeline& p, bool stars, std::vector<double>* lat) {
  const Day& d = day();
  p.reset();
  std::size_t ia = 0;
  long rows = 0;
  PipelineRow row;
  StarEpoch se;
  for (int i = 0; i < kHeadEpochs; ++i) {
    const HeadEpoch& e = d.heads[static_cast<std::size_t>(i)];
    std::chrono::steady_clock::time_point t0;
    if (lat) t0 = std::chrono::steady_clock::now();
    while (ia < d.acc_t.size() && d.acc_t[ia] <= e.t) {
      p.stepAcc(d.acc_t[ia], d.acc_a[ia]);
      ++ia;
    }
    p.stepHeads(e);
    if (stars) {
      const StarEpoch& s = d.star_pool[static_cast<std::size_t>(i) % d.star_pool.size()];
      // the time tag is the only field that changes
      const_cast<StarEpoch&>(s).t = e.t;
      p.stepStars(s);
    }
    while (p.popRow(row)) ++rows;
    if (lat) lat->push_back(std::chrono::duration<double, std::nano>(std::chrono::steady_clock::now() - t0).count());
  }
  p.flush();
  while (p.popRow(row)) ++rows;
  return rows;
}

void benchDay(benchmark::State& state, bool stars) {
  const Day& d = day();
  auto p = std::make_unique<Pipeline>();
  if (p->configure(d.cfg) != Status::kOk) {
    state.SkipWithError("configure failed");
    return;
  }
  long rows = 0;
  for (auto _ : state) {
    rows = runDay(*p, stars, nullptr);
    benchmark::DoNotOptimize(rows);
  }
  std::vector<double> lat;
  lat.reserve(kHeadEpochs);
  runDay(*p, stars, &lat);
  std::sort(lat.begin(), lat.end());
  state.counters["epoch_median_ns"] = lat[lat.size() / 2];
  state.counters["epoch_p999_ns"] = lat[static_cast<std::size_t>(0.999 * static_cast<double>(lat.size()))];
  state.counters["epoch_max_ns"] = lat.back();
  state.counters["state_bytes"] = static_cast<double>(sizeof(Pipeline));
  state.counters["rows"] = static_cast<double>(rows);
  state.counters["rows_with_rates_and_acc"] = 0;
  // one more check that the rows are complete (outside the timing)
  p->reset();
  long complete = 0;
  {
    std::size_t ia = 0;
    PipelineRow row;
    for (int i = 0; i < kHeadEpochs; ++i) {
      const HeadEpoch& e = d.heads[static_cast<std::size_t>(i)];
      while (ia < d.acc_t.size() && d.acc_t[ia] <= e.t) p->stepAcc(d.acc_t[ia], d.acc_a[ia]), ++ia;
      p->stepHeads(e);
      while (p->popRow(row)) complete += (row.has_rates && row.has_acc) ? 1 : 0;
    }
  }
  state.counters["rows_with_rates_and_acc"] = static_cast<double>(complete);
}

void BM_CoreDay(benchmark::State& state) { benchDay(state, false); }
void BM_CoreDayWithStars(benchmark::State& state) { benchDay(state, true); }

BENCHMARK(BM_CoreDay)->Unit(benchmark::kMillisecond)->Iterations(3);
BENCHMARK(BM_CoreDayWithStars)->Unit(benchmark::kMillisecond)->Iterations(3);

}  // namespace

BENCHMARK_MAIN();
