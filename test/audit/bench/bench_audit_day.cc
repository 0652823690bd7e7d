// Google Benchmark of the model audit of a full simulated day (issue: model audit, "Must reach": under
// 10 s, limit 30 s). config/sim_audit.yaml with a thermal deformation of head 2 and an accelerometer
// bias (so that the analysis names, extends and re-estimates), seed 1:
//   BM_AuditAnalyse/SPAN     analyse() alone on a Collector filled once (the statistics, selection,
//                            extension and gain)
//   BM_AuditInMemory/SPAN    simulator + engine + Collector + analyse() in memory (audit/simulated.h)
// SPAN in seconds (3600, 21600, 86400). The file path (`boresight simulate` to files, then
// `boresight audit` on them, with /usr/bin/time -v for memory) is bench_audit_day.sh.
//   bench_audit_day --benchmark_repetitions=5 --benchmark_report_aggregates_only=false
#include "hidden_effects.h"

#include <benchmark/benchmark.h>

#include <map>
#include <memory>

namespace {

using namespace boresight;

const std::vector<std::string> kEffects = {
    "thermal_periodic:sensor=2,harmonic=1,x_arcsec=4,y_arcsec=-3,phase_deg=30",
    "acc_bias:sensor=acc,x=2e-6,y=-1e-6,z=1.5e-6"};

sim::Scenario scenario() {
  sim::Scenario sc;
  std::string err;
  if (!audittest::scenarioWith(kEffects, sc, &err)) {
    std::fprintf(stderr, "%s\n", err.c_str());
    std::abort();
  }
  return sc;
}

audit::SimulatedOptions options(double span_s) {
  audit::SimulatedOptions o;
  o.seed = 1;
  o.duration_s = span_s;
  o.base = audittest::platformBase();
  return o;
}

/// One filled Collector per span, kept for the analysis benchmark.
const audit::Collector& collected(double span_s) {
  static std::map<double, std::unique_ptr<audit::Collector>> cache;
  auto& c = cache[span_s];
  if (!c) {
    c = std::make_unique<audit::Collector>();
    const audit::SimulatedRun r = audit::collectSimulated(scenario(), options(span_s), *c);
    if (!r.ok) {
      std::fprintf(stderr, "collect: %s\n", r.error.c_str());
      std::abort();
    }
  }
  return *c;
}

void BM_AuditAnalyse(benchmark::State& st) {
  const double span = static_cast<double>(st.range(0));
  const audit::Collector& c = collected(span);
  const audit::AuditOptions opt;
  std::size_t named = 0;
  for (auto _ : st) {
    const audit::AuditResult r = audit::analyse(c, opt);
    named = r.named.size();
    benchmark::DoNotOptimize(named);
  }
  st.counters["named"] = static_cast<double>(named);
  st.counters["span_h"] = span / 3600.0;
}
BENCHMARK(BM_AuditAnalyse)->Arg(3600)->Arg(21600)->Arg(86400)->Unit(benchmark::kMillisecond)->Iterations(1);

void BM_AuditInMemory(benchmark::State& st) {
  const double span = static_cast<double>(st.range(0));
  const sim::Scenario sc = scenario();
  double collect = 0, analyse = 0;
  std::size_t named = 0;
  for (auto _ : st) {
    const audit::SimulatedAudit a = audit::auditSimulated(sc, options(span));
    if (!a.run.ok) {
      st.SkipWithError(a.run.error.c_str());
      return;
    }
    collect = a.run.collect_wall_s;
    analyse = a.analyse_wall_s;
    named = a.result.named.size();
  }
  st.counters["collect_s"] = collect;
  st.counters["analyse_s"] = analyse;
  st.counters["named"] = static_cast<double>(named);
}
BENCHMARK(BM_AuditInMemory)->Arg(3600)->Arg(21600)->Arg(86400)->Unit(benchmark::kMillisecond)->Iterations(1)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
