// Benchmark: simulate GRACE-FO-rate telemetry (3 heads at 2 Hz, accelerometer at 10 Hz, orbit at 1 Hz)
// and write the Level-1 files (SCA1A, ACC1A, GNV1B, QSA1B), the LCM log and truth.yaml, as
// `boresight simulate` does. Target: a full day in under 5 s; memory bounded independent of the
// duration (the peak RSS counter must not grow from the 3 h to the 24 h run).
//
//   ninja -C build bench_sim && build/test/sim/bench/bench_sim
#include <boresight/sim/output.h>
#include <boresight/sim/scenario.h>
#include <boresight/sim/simulator.h>

#include <benchmark/benchmark.h>

#include <filesystem>
#include <string>
#include <sys/resource.h>
#include <vector>

namespace {

namespace fs = std::filesystem;
using namespace boresight;

double peakRssMiB() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_maxrss) / 1024.0;  // Linux: kilobytes
}

void BM_SimulateAndWrite(benchmark::State& state) {
  const double duration = static_cast<double>(state.range(0));
  sim::Scenario sc;
  std::string err;
  if (!sim::loadScenario(std::string(BORESIGHT_SOURCE_DIR) + "/config/sim_gracefo.yaml", sc, &err)) {
    state.SkipWithError(err.c_str());
    return;
  }
  const fs::path dir = fs::temp_directory_path() / "boresight_bench_sim";
  fs::create_directories(dir);
  std::uint64_t samples = 0, bytes = 0;
  for (auto _ : state) {
    sim::Simulator s;
    sim::Level1Sink l1;
    sim::LcmSink log;
    sim::TeeSink tee;
    if (!s.init(sc, 1, duration, &err) || !l1.open(dir.string(), sc, &err) ||
        !log.open((dir / "sim.lcmlog").string(), &err)) {
      state.SkipWithError(err.c_str());
      return;
    }
    tee.add(&l1);
    tee.add(&log);
    s.run(tee);
    auto files = l1.files();
    const std::string qsa = (dir / sim::productFileName("QSA1B", sc)).string();
    if (!l1.close(&err) || !log.close(&err) || !sim::writeQsa1b(qsa, s, &err) ||
        !sim::writeTruthYaml((dir / "truth.yaml").string(), s, {}, files, &err)) {
      state.SkipWithError(err.c_str());
      return;
    }
    samples = s.stats().acc_samples + s.stats().orbit_samples;
    for (auto n : s.stats().head_samples) samples += n;
    bytes = 0;
    for (const auto& e : fs::directory_iterator(dir)) bytes += static_cast<std::uint64_t>(e.file_size());
  }
  state.counters["samples"] = static_cast<double>(samples);
  state.counters["output_MiB"] = static_cast<double>(bytes) / (1024.0 * 1024.0);
  state.counters["peak_rss_MiB"] = peakRssMiB();
  state.SetItemsProcessed(static_cast<std::int64_t>(samples) * state.iterations());
  fs::remove_all(dir);
}

/// The simulation alone (no files): what the models and dynamics cost.
void BM_SimulateOnly(benchmark::State& state) {
  sim::Scenario sc;
  std::string err;
  if (!sim::loadScenario(std::string(BORESIGHT_SOURCE_DIR) + "/config/sim_gracefo.yaml", sc, &err)) {
    state.SkipWithError(err.c_str());
    return;
  }
  struct Null : sim::SimSink {
  } sink;
  for (auto _ : state) {
    sim::Simulator s;
    if (!s.init(sc, 1, static_cast<double>(state.range(0)), &err)) {
      state.SkipWithError(err.c_str());
      return;
    }
    s.run(sink);
  }
}
BENCHMARK(BM_SimulateOnly)->Arg(24 * 3600)->Iterations(1)->UseRealTime()->Unit(benchmark::kSecond);

/// The simulation alone with the noise preset `realistic` (config/sim_gracefo_realistic.yaml), and with
/// each of its coloured parts alone on top of sim_gracefo.yaml: what they cost (range(1): 0 the whole
/// preset, 1 coloured_noise, 2 fov_error, 3 thermal_wander, 4 acc_coloured_noise + acc_bias_wander).
void BM_SimulateNoisePreset(benchmark::State& state) {
  sim::Scenario sc;
  std::string err;
  const std::vector<std::vector<std::string>> parts = {
      {},
      {"coloured_noise:sensor=all,cross_arcsec=0.4,about_arcsec=3,alpha=1,f_lo_hz=1e-4,f_hi_hz=2e-2"},
      {"fov_error:sensor=all,arcsec=1,order=3"},
      {"thermal_wander:sensor=all,cross_arcsec=1,about_arcsec=2,alpha=1.5,f_lo_hz=2e-5,f_hi_hz=2e-3"},
      {"acc_coloured_noise:x=1e-8,y=3e-9,z=3e-9,alpha=1,f_lo_hz=1e-4,f_hi_hz=1e-2", "acc_bias_wander:x=1e-8,y=3e-9,z=3e-9"}};
  const auto part = static_cast<std::size_t>(state.range(1));
  const std::string file = part == 0 ? "/config/sim_gracefo_realistic.yaml" : "/config/sim_gracefo.yaml";
  if (!sim::loadScenario(std::string(BORESIGHT_SOURCE_DIR) + file, sc, &err) || !sim::addEffectArgs(sc, parts[part], &err)) {
    state.SkipWithError(err.c_str());
    return;
  }
  struct Null : sim::SimSink {
  } sink;
  for (auto _ : state) {
    sim::Simulator s;
    if (!s.init(sc, 1, static_cast<double>(state.range(0)), &err)) {
      state.SkipWithError(err.c_str());
      return;
    }
    s.run(sink);
  }
}
BENCHMARK(BM_SimulateNoisePreset)
    ->Args({24 * 3600, 0})
    ->Args({24 * 3600, 1})
    ->Args({24 * 3600, 2})
    ->Args({24 * 3600, 3})
    ->Args({24 * 3600, 4})
    ->Iterations(1)
    ->UseRealTime()
    ->Unit(benchmark::kSecond);

// 3 h, 12 h, 24 h: run in this order, so a growing peak RSS would show a duration-dependent memory.
BENCHMARK(BM_SimulateAndWrite)->Arg(3 * 3600)->Arg(12 * 3600)->Arg(24 * 3600)->Iterations(1)->UseRealTime()->Unit(benchmark::kSecond);

}  // namespace

BENCHMARK_MAIN();
