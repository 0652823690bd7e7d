// bench_thermal: the thermal harmonic model's cost.
//   BM_ThermalFitDay: a full day of GRACE-FO-rate head epochs (3 heads at 2 Hz, 172 800 epochs) and GNI1B
//   records at 1 Hz (86 400) through calib::fitThermal (validator + monitor per epoch, orbit track,
//   normal equations, fit with harmonics 1..3). Counters: epochs per second.
//   BM_ThermalPredictPair: one core prediction of a pair not through the datum (3 harmonics).
#include "boresight/calib/thermal_fit.h"
#include "boresight/core/rotation.h"
#include "boresight/core/thermal_harmonics.h"

#include <benchmark/benchmark.h>

#include "../common/three_heads.h"

#include <cmath>
#include <random>
#include <vector>

namespace {

using namespace boresight;

constexpr double kT0 = 738849600.0;

core::HeadSetConfig heads3() { return testutil::threeTiltedHeads(); }

struct Data {
  std::vector<core::HeadEpoch> epochs;
  std::vector<io::GnvRecord> orbit;
};

const Data& day() {
  static const Data d = [] {
    Data out;
    const core::HeadSetConfig h = heads3();
    std::mt19937_64 rng(1);
    std::normal_distribution<double> n(0.0, 1.0);
    const double w = 2 * kPi / 5660.0, r0 = 6.868e6, v0 = r0 * w, inc = 89.0 * kRadPerDeg;
    for (int i = 0; i <= 86400; ++i) {  // a circular orbit
      const double u = w * i;
      const Vec3 r = r0 * Vec3(std::cos(u), std::sin(u) * std::cos(inc), std::sin(u) * std::sin(inc));
      const Vec3 v = v0 * Vec3(-std::sin(u), std::cos(u) * std::cos(inc), std::cos(u) * std::sin(inc));
      io::GnvRecord g;
      g.t = static_cast<TimeUs>(std::llround((kT0 + i) * 1e6));
      g.coord_ref = 'I';
      for (int a = 0; a < 3; ++a) {
        g.pos[a] = r(a);
        g.vel[a] = v(a);
      }
      out.orbit.push_back(g);
    }
    for (int i = 0; i < 2 * 86400; ++i) {
      const double t = 0.5 * i + 0.25, u = w * t;
      const Quat q_I_B = core::quatExp(Vec3(0.3, -0.2, 1.1e-3 * t));
      core::HeadEpoch e;
      e.t = static_cast<TimeUs>(std::llround((kT0 + t) * 1e6));
      for (int k = 0; k < 3; ++k) {
        const auto s = static_cast<std::size_t>(k);
        const Vec3 dk = k == 0 ? Vec3(Vec3::Zero()) : Vec3(Vec3(20, -10, 30) * kRadPerArcsec * std::cos(u + k));
        const Quat q_C0 = h.head[0].q_Si_B * h.head[s].q_Si_B.conjugate();
        const Quat q = q_I_B * h.head[0].q_Si_B.conjugate() * core::quatExp(dk) * q_C0;
        core::HeadSample& hs = e.sample[static_cast<std::size_t>(e.n++)];
        hs.head_id = k + 1;
        hs.q_I_Si = (q * core::quatExp(Vec3(n(rng), n(rng), 8 * n(rng)) * 6 * kRadPerArcsec)).normalized();
      }
      out.epochs.push_back(e);
    }
    return out;
  }();
  return d;
}

void BM_ThermalFitDay(benchmark::State& st) {
  const Data& d = day();
  const core::HeadSetConfig h = heads3();
  for (auto _ : st) {
    const calib::ThermalFitResult r = calib::fitThermal(h, {}, d.epochs, d.orbit);
    if (!r.ok) st.SkipWithError(r.error.c_str());
    benchmark::DoNotOptimize(r.heads.data());
  }
  st.counters["epochs_per_s"] =
      benchmark::Counter(static_cast<double>(d.epochs.size()) * static_cast<double>(st.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_ThermalFitDay)->Unit(benchmark::kMillisecond);

void BM_ThermalPredictPair(benchmark::State& st) {
  core::ThermalHarmonicModel m;
  m.n_harmonics = 3;
  m.order = {1, 2, 3};
  for (int k = 1; k < 3; ++k) {
    m.head[static_cast<std::size_t>(k)].valid = true;
    for (int n = 0; n < 3; ++n) m.head[static_cast<std::size_t>(k)].cos_rad[static_cast<std::size_t>(n)] = Vec3(1e-5, 2e-5, 3e-5);
  }
  core::ThermalPredictor p;
  if (p.configure(heads3(), m) != core::Status::kOk) st.SkipWithError("configure");
  double u = 0;
  for (auto _ : st) {
    Vec3 d;
    Mat3 P;
    p.predictPair(1, 2, u, 0.9, d, P);
    benchmark::DoNotOptimize(d);
    u += 1e-3;
  }
}
BENCHMARK(BM_ThermalPredictPair);

}  // namespace

BENCHMARK_MAIN();
