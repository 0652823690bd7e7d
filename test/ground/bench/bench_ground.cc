// Benchmark (must reach): a 3-position measurement, 40 targets and 2000 accelerometer samples per
// position, solved (seed, both Ceres solves, covariance, observability) in under 50 ms. Also the
// seed alone, reading the same measurement from its YAML file, and reading plus solving (what the
// command `boresight ground` does).
//
//   ninja -C build bench_ground && build/test/ground/bench/bench_ground
#include <boresight/ground/simulate.h>
#include <boresight/ground/solver.h>

#include <benchmark/benchmark.h>

#include <filesystem>

namespace {

using namespace boresight::ground;

Measurement threePositions(const char* setup) {
  SimConfig cfg;
  applySetup(setup, cfg);
  cfg.seed = 42;
  cfg.targets = 40;
  cfg.accel_samples = 2000;
  Measurement m;
  SimTruth t;
  simulateGround(cfg, m, t, nullptr);
  return m;
}

void BM_SolveGround(benchmark::State& state, const char* setup) {
  const Measurement m = threePositions(setup);
  GroundResult r;
  std::string err;
  for (auto _ : state) {
    if (!solveGround(m, RefineOptions{}, r, &err)) {
      state.SkipWithError(err.c_str());
      return;
    }
    benchmark::DoNotOptimize(r.error_angles_rad.data());
  }
  state.counters["positions"] = static_cast<double>(m.positions.size());
}
BENCHMARK_CAPTURE(BM_SolveGround, tilted_3pos, "tilted")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_SolveGround, turned_3pos, "turned")->Unit(benchmark::kMillisecond);

void BM_Seed(benchmark::State& state) {
  const Measurement m = threePositions("tilted");
  SeedResult s;
  for (auto _ : state) {
    solveSeed(m, s, nullptr);
    benchmark::DoNotOptimize(s.C_s_t.data());
  }
}
BENCHMARK(BM_Seed)->Unit(benchmark::kMillisecond);

/// The must-reach measurement written to a temporary file (removed when the case ends).
struct TempFile {
  std::filesystem::path path;
  explicit TempFile(const Measurement& m)
      : path(std::filesystem::temp_directory_path() / "boresight_bench_ground.yaml") {
    writeMeasurement(path.string(), m, nullptr);
  }
  ~TempFile() { std::filesystem::remove(path); }
};

// Reading the 308 kB file (loadMeasurement: the sample reader for accel_mps2, yaml-cpp for the rest,
// validation). The command `boresight ground` spends this plus the solve.
void BM_LoadFile(benchmark::State& state) {
  const TempFile f(threePositions("tilted"));
  Measurement back;
  std::string err;
  for (auto _ : state) {
    if (!loadMeasurement(f.path.string(), back, &err)) {
      state.SkipWithError(err.c_str());
      return;
    }
    benchmark::DoNotOptimize(back.positions.data());
  }
  state.counters["bytes"] = static_cast<double>(std::filesystem::file_size(f.path));
}
BENCHMARK(BM_LoadFile)->Unit(benchmark::kMillisecond);

// The command's work on the must-reach file: load and solve (the JSON writing is not included).
void BM_LoadAndSolve(benchmark::State& state, const char* setup) {
  const TempFile f(threePositions(setup));
  Measurement m;
  GroundResult r;
  std::string err;
  for (auto _ : state) {
    if (!loadMeasurement(f.path.string(), m, &err) || !solveGround(m, RefineOptions{}, r, &err)) {
      state.SkipWithError(err.c_str());
      return;
    }
    benchmark::DoNotOptimize(r.error_angles_rad.data());
  }
}
BENCHMARK_CAPTURE(BM_LoadAndSolve, tilted_3pos, "tilted")->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
