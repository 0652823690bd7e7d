// Parse throughput of the Level-1 readers on generated full-day files (SCA1A: 3 heads at 2 Hz,
// ACC1A at 10 Hz, written by the project's own writers with realistic full-precision values).
//
//   build/test/bench/bench_parse                      # generates the files once, then benchmarks
//   BORESIGHT_BENCH_DIR=/some/dir build/test/bench/bench_parse --generate-only
//
// The files go to $BORESIGHT_BENCH_DIR (default: $TMPDIR or /tmp, subfolder boresight-bench).
// tools/bench_parse.sh runs this and pandas' C parser on the same files in one go.
#include <boresight/io/any_product.h>
#include <boresight/io/level1.h>
#include <boresight/io/product_stream.h>

#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <random>
#include <string>
#include <sys/stat.h>

using namespace boresight;
using namespace boresight::io;

namespace {

std::string benchDir() {
  if (const char* d = std::getenv("BORESIGHT_BENCH_DIR")) return d;
  const char* t = std::getenv("TMPDIR");
  return std::string(t ? t : "/tmp") + "/boresight-bench";
}

bool exists(const std::string& p) {
  struct stat st {};
  return ::stat(p.c_str(), &st) == 0 && st.st_size > 0;
}

const TimeUs kDay0 = 738849600LL * kUsPerSecond;  // 2023-06-01 00:00:00 GPS

std::string sca1aPath() { return benchDir() + "/SCA1A_2023-06-01_C_04.txt"; }
std::string acc1aPath() { return benchDir() + "/ACC1A_2023-06-01_C_04.txt"; }

void generate() {
  ::mkdir(benchDir().c_str(), 0777);
  std::mt19937_64 rng(42);
  std::normal_distribution<double> n01;
  if (!exists(sca1aPath())) {
    auto f = makeProduct<Sca1aRecord>(Product::SCA1A, 'C');
    f.records.reserve(86400 * 2 * 3);
    for (int k = 0; k < 86400 * 2; ++k) {
      for (int h = 1; h <= 3; ++h) {
        Sca1aRecord r;
        r.t = kDay0 + k * 500000LL + 29992;
        r.head = static_cast<std::uint8_t>(h);
        double ang = 2 * kPi * k / (2 * 5640.0) + h;  // one revolution per orbit
        Quat q(Eigen::AngleAxisd(ang, Vec3(0.3 * h, 1, 0.2).normalized()));
        q.coeffs() += 1e-5 * Eigen::Vector4d(n01(rng), n01(rng), n01(rng), n01(rng));
        q.normalize();
        quatToScalarFirst(q, r.q);
        r.nstars = 30 + static_cast<int>(k % 20);
        r.confid = 1 + k % 3;
        r.mode = Bits{0b11000001, 8};
        r.qualflg = Bits{0b11000000, 8};
        f.records.push_back(r);
      }
    }
    std::string err;
    if (!writeProduct(sca1aPath(), f, &err)) std::fprintf(stderr, "%s\n", err.c_str());
  }
  if (!exists(acc1aPath())) {
    auto f = makeProduct<FlaggedRecord>(Product::ACC1A, 'C');
    f.records.reserve(864000);
    for (int k = 0; k < 864000; ++k) {
      FlaggedRecord r;
      r.t = kDay0 + k * 100000LL + 7739;
      r.prod_flag = Bits{0b00000100000000000000000000111111u, 32};
      r.value[0] = -1.0649e-05 + 1e-9 * n01(rng);
      r.value[1] = -1.8e-07 + 1e-9 * n01(rng);
      r.value[2] = -2.8e-07 + 1e-9 * n01(rng);
      r.value[3] = 1.3e-05 + 2e-7 * n01(rng);
      r.value[4] = 1.192e-04 + 2e-8 * n01(rng);
      r.value[5] = -7.813e-04 + 2e-8 * n01(rng);
      r.value[26] = 0;
      f.records.push_back(r);
    }
    std::string err;
    if (!writeProduct(acc1aPath(), f, &err)) std::fprintf(stderr, "%s\n", err.c_str());
  }
}

template <typename Rec>
void parseBench(benchmark::State& state, const std::string& path) {
  std::string text, err;
  if (!readFileToString(path, text, &err)) {
    state.SkipWithError(err.c_str());
    return;
  }
  std::size_t n = 0;
  ReadOptions opt;
  opt.threads = static_cast<int>(state.range(0));
  for (auto _ : state) {
    auto f = parseProduct<Rec>(text, path, opt);
    n = f.records.size();
    if (!f.ok || f.rejected_count) state.SkipWithError("parse failed");
    benchmark::DoNotOptimize(f.records.data());
  }
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations()) * static_cast<std::int64_t>(text.size()));
  state.counters["records"] = static_cast<double>(n);
  state.counters["file_MB"] = static_cast<double>(text.size()) / 1e6;
}

// Threads: state.range(0) (0 = automatic: every hardware thread). Throughput is per wall-clock second.
void BM_ParseSca1aFullDay(benchmark::State& s) { parseBench<Sca1aRecord>(s, sca1aPath()); }
void BM_ParseAcc1aFullDay(benchmark::State& s) { parseBench<Acc1aRecord>(s, acc1aPath()); }
// The same file through the general prod_flag reader (296-byte records: memory bound).
void BM_ParseAcc1aFullDayFlagged(benchmark::State& s) { parseBench<FlaggedRecord>(s, acc1aPath()); }
// From disk, including the read into memory.
void BM_ReadAcc1aFullDayFromFile(benchmark::State& state) {
  std::size_t bytes = 0;
  for (auto _ : state) {
    auto f = readProduct<Acc1aRecord>(acc1aPath());
    benchmark::DoNotOptimize(f.records.data());
    if (!f.ok) state.SkipWithError(f.error.c_str());
    struct stat st {};
    ::stat(acc1aPath().c_str(), &st);
    bytes = static_cast<std::size_t>(st.st_size);
  }
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations()) * static_cast<std::int64_t>(bytes));
}

// What `boresight inspect` does: the file read in blocks and every record parsed and checked, in
// constant memory (no record vector). Threads: state.range(0) (0 = automatic).
void BM_SummarizeAcc1aFullDayFromFile(benchmark::State& state) {
  struct stat st {};
  ::stat(acc1aPath().c_str(), &st);
  ReadOptions opt;
  opt.threads = static_cast<int>(state.range(0));
  std::size_t n = 0;
  for (auto _ : state) {
    ProductSummary s = summarizeProduct(acc1aPath(), opt);
    if (!s.ok || s.rejected_count) state.SkipWithError("summary failed");
    n = s.records;
  }
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations()) * static_cast<std::int64_t>(st.st_size));
  state.counters["records"] = static_cast<double>(n);
}
// The streaming record reader the replay engine uses (one thread, 1 MB buffer).
void BM_StreamAcc1aFullDayFromFile(benchmark::State& state) {
  struct stat st {};
  ::stat(acc1aPath().c_str(), &st);
  std::size_t n = 0;
  for (auto _ : state) {
    ProductStream<FlaggedRecord> s;
    std::string err;
    if (!s.open(acc1aPath(), {}, &err)) state.SkipWithError(err.c_str());
    FlaggedRecord r;
    n = 0;
    while (s.next(r)) ++n;
    benchmark::DoNotOptimize(r.t);
  }
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations()) * static_cast<std::int64_t>(st.st_size));
  state.counters["records"] = static_cast<double>(n);
}

}  // namespace

BENCHMARK(BM_SummarizeAcc1aFullDayFromFile)->Arg(1)->Arg(0)->Unit(benchmark::kMillisecond)->MinTime(2.0)->UseRealTime();
BENCHMARK(BM_StreamAcc1aFullDayFromFile)->Unit(benchmark::kMillisecond)->MinTime(2.0)->UseRealTime();
BENCHMARK(BM_ParseSca1aFullDay)->Arg(1)->Arg(0)->Unit(benchmark::kMillisecond)->MinTime(2.0)->UseRealTime();
BENCHMARK(BM_ParseAcc1aFullDay)->Arg(1)->Arg(0)->Unit(benchmark::kMillisecond)->MinTime(2.0)->UseRealTime();
BENCHMARK(BM_ParseAcc1aFullDayFlagged)->Arg(1)->Arg(0)->Unit(benchmark::kMillisecond)->MinTime(2.0)->UseRealTime();
BENCHMARK(BM_ReadAcc1aFullDayFromFile)->Unit(benchmark::kMillisecond)->MinTime(2.0)->UseRealTime();

int main(int argc, char** argv) {
  bool only = false;
  for (int i = 1; i < argc; ++i)
    if (!std::strcmp(argv[i], "--generate-only")) only = true;
  generate();
  if (only) {
    std::printf("%s\n%s\n", sca1aPath().c_str(), acc1aPath().c_str());
    return 0;
  }
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
