// bench_audit_floor: the model audit's detection floor and error rates (issue: model audit, item 4).
//
// For every testable effect (hidden_effects.h) and every magnitude of its ladder, largest first, the
// audit runs on `--seeds` simulated spans (config/sim_audit.yaml, the effect drawn per seed: head,
// direction, harmonic, event time) and counts
//   found          the audit's own test of the injected effect on the injected sensor passes its
//                  family-wise threshold,
//   named          the effect is among the named causes (any sensor), and with the right sensor,
//   gain           the family that carries it gains on held-out data (held-out RMS or BIC),
// and on `--clean-seeds` clean spans (the same seeds, no effect) the false-alarm rate (a named cause
// or a "not explained" residual). The detection floor is the smallest magnitude found in >= 95 % of
// the seeds, every larger one too; the naming floor the same for the right cause named on the right
// sensor; the Wilson 95 % interval of the rate is given. A magnitude stops early once
// more than 5 % of its seeds failed (it cannot reach 95 %; --full runs every seed), the ladder stops
// after two failing magnitudes in a row and goes on below its smallest magnitude (at its last ratio)
// while every magnitude passes.
//
// Writes PREFIX.md (the table) and PREFIX.csv (every magnitude). Threads: --jobs (each audit runs its
// simulator on a second thread).
#include "hidden_effects.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <map>
#include <mutex>
#include <sstream>
#include <thread>

namespace {

using namespace boresight;

const char* kHelp =
    "bench_audit_floor: detection floor and error rates of the model audit, per effect of the catalogue\n"
    "\n"
    "Usage: bench_audit_floor [options]\n"
    "  --seeds N          seeds per magnitude (default 100)\n"
    "  --clean-seeds N    clean spans for the false-alarm rate (default: --seeds)\n"
    "  --first-seed N     first seed (default 1); seeds N, N+1, ...\n"
    "  --span S           simulated span per run, s (default 7200; 3600-21600 sensible)\n"
    "  --effects a,b,...  effects to measure (default: every testable effect); 'none': clean only\n"
    "  --jobs J           audits in parallel (default 2)\n"
    "  --ladder a,b,...   magnitudes to try, largest first, instead of the effect's ladder (one effect)\n"
    "  --false-alarm P    family-wise false-alarm rate of the audit (default: AuditOptions, 0.01)\n"
    "  --full             run every seed of every magnitude (no early stop)\n"
    "  --white-rows       the audit without the noise colour in time (boresight audit --white-rows), to compare\n"
    "  --max-harmonic N   largest thermal harmonic the audit tests (default: AuditOptions, 4)\n"
    "  --out PREFIX       write PREFIX.md and PREFIX.csv (default audit_floor)\n"
    "  --scenario FILE    the clean scenario (default config/sim_audit.yaml)\n"
    "  --single ARG       one audit of the effect ARG (NAME:key=value,..., or 'clean') at --first-seed,\n"
    "                     printed with its timings (for /usr/bin/time -v)\n"
    "  --help\n"
    "\n"
    "Testable effects and their magnitudes:\n";

struct Options {
  int seeds = 100, clean_seeds = -1, jobs = 2;
  std::uint64_t first_seed = 1;
  double span_s = 7200;
  double false_alarm = -1;
  bool full = false;
  bool white_rows = false;  ///< the audit without the noise colour in time (AuditOptions::time_colour)
  int max_harmonic = -1;    ///< AuditOptions::max_harmonic (-1: its default)
  std::vector<std::string> effects;
  std::vector<double> ladder;  ///< --ladder: replaces the (one) effect's ladder
  std::string out = "audit_floor", scenario, single;
};

struct RunResult {
  bool ok = false;
  std::string error;
  bool found = false, named_name = false, named_sensor = false, gain = false, alarm = false, det_alarm = false;
  int det_causes = 0;
  std::vector<std::string> named;  ///< "name[sensor]"
  std::vector<std::string> tests;  ///< every test, for --single
  double collect_s = 0, analyse_s = 0;
};

struct Rung {
  double magnitude = 0;
  int runs = 0, found = 0, named_name = 0, named_sensor = 0, gain = 0, errors = 0;
  int det_alarm = 0;  ///< runs with a deterministic cause named in the relative or reference family
  int det_causes = 0; ///< those causes (and residuals not explained there), all runs
  bool stopped_early = false;
  double collect_s = 0, analyse_s = 0;
  std::map<std::string, int> wrong;  ///< other named causes and how often
  std::string example;               ///< the --effect argument of the first seed
};

/// Wilson score interval (95 %) of k successes in n.
std::pair<double, double> wilson(int k, int n) {
  if (n <= 0) return {0, 1};
  const double z = 1.959963984540054, p = static_cast<double>(k) / n, z2n = z * z / n;
  const double c = (p + z2n / 2) / (1 + z2n), h = z * std::sqrt(p * (1 - p) / n + z2n / (4.0 * n)) / (1 + z2n);
  return {std::max(0.0, c - h), std::min(1.0, c + h)};
}

std::string pct(int k, int n) {
  if (n <= 0) return "-";
  char b[64];
  const auto w = wilson(k, n);
  std::snprintf(b, sizeof b, "%d/%d = %.0f %% [%.0f, %.0f]", k, n, 100.0 * k / n, 100 * w.first, 100 * w.second);
  return b;
}

RunResult runOne(const sim::Scenario& clean, const std::vector<audittest::Injected>& inj, std::uint64_t seed,
                 const Options& o) {
  RunResult r;
  sim::Scenario sc = clean;
  std::vector<std::string> args;
  for (const auto& i : inj) args.push_back(i.arg);
  std::string err;
  if (!sim::addEffectArgs(sc, args, &err)) {
    r.error = err;
    return r;
  }
  audit::SimulatedOptions so;
  so.seed = seed;
  so.duration_s = o.span_s;
  so.base = audittest::platformBase();
  if (o.false_alarm > 0) so.audit.false_alarm = o.false_alarm;
  so.audit.time_colour = !o.white_rows;
  if (o.max_harmonic >= 0) so.audit.max_harmonic = o.max_harmonic;
  const audit::SimulatedAudit a = audit::auditSimulated(sc, so);
  if (!a.run.ok) {
    r.error = a.run.error;
    return r;
  }
  r.ok = true;
  r.collect_s = a.run.collect_wall_s;
  r.analyse_s = a.analyse_wall_s;
  r.alarm = audittest::alarm(a.result);
  // a deterministic cause in the star-sensor families (what slow noise used to be read as)
  r.det_causes = audittest::deterministicCauses(a.result);
  r.det_alarm = r.det_causes > 0;
  for (const auto& e : a.result.named) r.named.push_back(e.name + "[" + e.sensor + "]");
  for (const auto& n : a.result.not_explained) r.named.push_back("not_explained(" + n.family + ")");
  for (const auto& e : a.result.effects) {
    char b[256];
    std::snprintf(b, sizeof b, "%s[%s] %s: statistic %.4g threshold %.4g p %.3g%s%s", e.name.c_str(), e.sensor.c_str(),
                  e.family.c_str(), e.statistic, e.threshold, e.p_value, e.detected ? " detected" : "",
                  e.named ? " named" : "");
    r.tests.push_back(b);
  }
  for (const auto& amb : a.result.ambiguous) {
    std::string g = "ambiguous:";
    for (const auto& c : amb.causes) g += " " + c;
    r.tests.push_back(g + " (" + amb.separate_by + ")");
  }
  if (!inj.empty()) {
    const auto& i = inj.front();
    const audit::EffectTest* t = audittest::testOf(a.result, i);
    r.found = t && t->detected;
    r.named_name = audittest::named(a.result, i.name);
    r.named_sensor = audittest::named(a.result, i.name, i.sensor);
    if (t) {
      const audit::Gain* g = audittest::gainOf(a.result, t->family);
      r.gain = g && audittest::positiveGain(*g);
    }
  }
  return r;
}

/// Runs `n` seeds (in parallel); stops once more than `max_fail` were not found (max_fail < 0: never).
Rung runRung(const sim::Scenario& clean, const audittest::Testable* t, double m, const Options& o, int n,
             int max_fail) {
  Rung rung;
  rung.magnitude = m;
  std::mutex mu;
  std::atomic<int> next{0};
  std::atomic<bool> stop{false};
  auto work = [&] {
    for (;;) {
      if (stop) return;
      const int k = next++;
      if (k >= n) return;
      const std::uint64_t seed = o.first_seed + static_cast<std::uint64_t>(k);
      std::vector<audittest::Injected> inj;
      if (t) {
        auto d = audittest::drawsFor(seed, t->name);
        inj.push_back(t->make(m, d, o.span_s));
      }
      const RunResult r = runOne(clean, inj, seed, o);
      std::lock_guard<std::mutex> l(mu);
      if (k == 0 && !inj.empty()) rung.example = inj.front().arg;
      if (!r.ok) {
        ++rung.errors;
        std::cerr << "  seed " << seed << ": " << r.error << "\n";
        if (rung.errors > 2) stop = true;
        continue;
      }
      ++rung.runs;
      rung.collect_s += r.collect_s;
      rung.analyse_s += r.analyse_s;
      rung.found += t ? r.found : r.alarm;
      rung.det_alarm += r.det_alarm;
      rung.det_causes += r.det_causes;
      rung.named_name += r.named_name;
      rung.named_sensor += r.named_sensor;
      rung.gain += r.gain;
      for (const auto& s : r.named) {
        const std::string mine = t ? std::string(t->name) + "[" + inj.front().sensor + "]" : "";
        if (s != mine) ++rung.wrong[s];
      }
      const int fails = t ? rung.runs - rung.found : rung.found;
      if (max_fail >= 0 && fails > max_fail) {
        rung.stopped_early = true;
        stop = true;
      }
    }
  };
  std::vector<std::thread> th;
  for (int j = 0; j < std::max(1, o.jobs); ++j) th.emplace_back(work);
  for (auto& x : th) x.join();
  return rung;
}

struct EffectReport {
  const audittest::Testable* t = nullptr;
  std::vector<Rung> rungs;
  int floor_index = -1;  ///< detection floor: smallest rung found in >= 95 %, every larger one too
  int named_index = -1;  ///< naming floor: the same for the right cause on the right sensor named
};

std::string wrongList(const std::map<std::string, int>& w, int runs, std::size_t most = 4) {
  std::vector<std::pair<int, std::string>> v;
  for (const auto& kv : w) v.emplace_back(kv.second, kv.first);
  std::sort(v.rbegin(), v.rend());
  std::string s;
  for (std::size_t i = 0; i < v.size() && i < most; ++i)
    s += (s.empty() ? "" : "; ") + v[i].second + " " + std::to_string(v[i].first) + "/" + std::to_string(runs);
  return s.empty() ? "-" : s;
}

int parseArgs(int argc, char** argv, Options& o) {
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto val = [&](const char* what) -> std::string {
      if (i + 1 >= argc) {
        std::cerr << "bench_audit_floor: " << a << " needs " << what << " (see --help)\n";
        std::exit(2);
      }
      return argv[++i];
    };
    auto number = [&](const char* what) {
      const std::string v = val(what);
      char* end = nullptr;
      const double d = std::strtod(v.c_str(), &end);
      if (v.empty() || *end || !std::isfinite(d) || d < 0) {
        std::cerr << "bench_audit_floor: " << a << ": expected " << what << ", got '" << v << "'\n";
        std::exit(2);
      }
      return d;
    };
    if (a == "--help" || a == "-h") {
      std::cout << kHelp;
      for (const auto& t : audittest::testables()) {
        std::cout << "  " << t.name << " [" << t.unit << "]: " << t.magnitude << "; ladder";
        for (double m : t.ladder) std::cout << " " << audittest::num(m);
        std::cout << "\n";
      }
      return 0;
    } else if (a == "--seeds") {
      o.seeds = static_cast<int>(number("a count"));
    } else if (a == "--clean-seeds") {
      o.clean_seeds = static_cast<int>(number("a count"));
    } else if (a == "--first-seed") {
      o.first_seed = static_cast<std::uint64_t>(number("a seed"));
    } else if (a == "--span") {
      o.span_s = number("seconds");
    } else if (a == "--jobs") {
      o.jobs = static_cast<int>(number("a count"));
    } else if (a == "--false-alarm") {
      o.false_alarm = number("a probability");
    } else if (a == "--full") {
      o.full = true;
    } else if (a == "--white-rows") {
      o.white_rows = true;
    } else if (a == "--max-harmonic") {
      o.max_harmonic = static_cast<int>(number("an order 0..10"));
      if (o.max_harmonic < 0 || o.max_harmonic > 10) {
        std::cerr << "bench_audit_floor: --max-harmonic must be 0..10\n";
        return 2;
      }
    } else if (a == "--out") {
      o.out = val("a prefix");
    } else if (a == "--scenario") {
      o.scenario = val("a file");
    } else if (a == "--single") {
      o.single = val("an effect");
    } else if (a == "--ladder") {
      std::stringstream ss(val("a list"));
      std::string e;
      while (std::getline(ss, e, ',')) {
        char* end = nullptr;
        const double d = std::strtod(e.c_str(), &end);
        if (e.empty() || *end || !(d > 0)) {
          std::cerr << "bench_audit_floor: --ladder: '" << e << "' is not a positive number\n";
          return 2;
        }
        o.ladder.push_back(d);
      }
    } else if (a == "--effects") {
      std::stringstream ss(val("a list"));
      std::string e;
      while (std::getline(ss, e, ','))
        if (!e.empty() && e != "none") {
          if (!audittest::findTestable(e)) {
            std::cerr << "bench_audit_floor: --effects: '" << e << "' is not a testable effect (see --help)\n";
            return 2;
          }
          o.effects.push_back(e);
        } else if (e == "none") {
          o.effects.push_back("none");
        }
    } else {
      std::cerr << "bench_audit_floor: unknown option " << a << " (see --help)\n";
      return 2;
    }
  }
  if (o.seeds < 1 || o.jobs < 1 || o.span_s < 60) {
    std::cerr << "bench_audit_floor: need --seeds >= 1, --jobs >= 1, --span >= 60\n";
    return 2;
  }
  if (o.clean_seeds < 0) o.clean_seeds = o.seeds;
  if (!o.ladder.empty() && o.effects.size() != 1) {
    std::cerr << "bench_audit_floor: --ladder needs exactly one effect in --effects\n";
    return 2;
  }
  return -1;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  if (const int rc = parseArgs(argc, argv, o); rc >= 0) return rc;
  std::string cmdline = "bench_audit_floor";
  for (int i = 1; i < argc; ++i) cmdline += std::string(" ") + argv[i];

  sim::Scenario clean;
  std::string err;
  const std::string scen = o.scenario.empty() ? audittest::auditScenarioPath() : o.scenario;
  if (!sim::loadScenario(scen, clean, &err)) {
    std::cerr << "bench_audit_floor: " << err << "\n";
    return 1;
  }

  if (!o.single.empty()) {
    std::vector<audittest::Injected> inj;
    if (o.single != "clean") {
      model::EffectSpec e;
      if (!model::parseEffectArg(o.single, e, &err)) {
        std::cerr << "bench_audit_floor: --single: " << err << "\n";
        return 2;
      }
      inj.push_back({e.name, e.sensor, o.single, 0});
    }
    const RunResult r = runOne(clean, inj, o.first_seed, o);
    if (!r.ok) {
      std::cerr << "bench_audit_floor: " << r.error << "\n";
      return 1;
    }
    std::printf("%s, seed %llu, span %.0f s: simulate + engine + collect %.3f s, analyse %.3f s\n", o.single.c_str(),
                static_cast<unsigned long long>(o.first_seed), o.span_s, r.collect_s, r.analyse_s);
    std::printf("named: %s\n", r.named.empty() ? "none" : "");
    for (const auto& s : r.named) std::printf("  %s\n", s.c_str());
    if (!inj.empty())
      std::printf("found %d, named %d, with sensor %d, held-out gain %d\n", r.found, r.named_name, r.named_sensor, r.gain);
    if (std::getenv("BENCH_AUDIT_TESTS"))
      for (const auto& s : r.tests) std::printf("    %s\n", s.c_str());
    return 0;
  }

  std::vector<const audittest::Testable*> todo;
  bool clean_only = false;
  for (const auto& e : o.effects)
    if (e == "none") clean_only = true;
    else todo.push_back(audittest::findTestable(e));
  if (o.effects.empty())
    for (const auto& t : audittest::testables())
      if (model::findEffect(t.name)) todo.push_back(&t);
  (void)clean_only;

  const auto t_start = std::chrono::steady_clock::now();
  std::fprintf(stderr, "clean: %d seeds, span %.0f s\n", o.clean_seeds, o.span_s);
  const Rung cleanRung = runRung(clean, nullptr, 0, o, o.clean_seeds, -1);
  std::fprintf(stderr, "clean: false alarms %s  (%s)\n", pct(cleanRung.found, cleanRung.runs).c_str(),
               wrongList(cleanRung.wrong, cleanRung.runs).c_str());
  std::fprintf(stderr, "clean: deterministic causes in the star-sensor families: %d in all, spans with one %s\n", cleanRung.det_causes,
               pct(cleanRung.det_alarm, cleanRung.runs).c_str());

  std::vector<EffectReport> reports;
  const int max_fail = o.full ? -1 : static_cast<int>(std::floor(0.05 * o.seeds + 1e-9));
  for (const audittest::Testable* t : todo) {
    EffectReport rep;
    rep.t = t;
    int failing_in_a_row = 0;
    bool all_pass_so_far = true, all_named_so_far = true;
    // The ladder, continued downwards at its last ratio (at most 8 more) while every magnitude passes.
    std::vector<double> ladder = o.ladder.empty() ? t->ladder : o.ladder;
    for (std::size_t li = 0; li < ladder.size(); ++li) {
      const double m = ladder[li];
      const Rung r = runRung(clean, t, m, o, o.seeds, max_fail);
      rep.rungs.push_back(r);
      const bool pass = r.runs > 0 && !r.stopped_early && r.found >= 0.95 * r.runs - 1e-9;
      const bool named_ok = pass && r.named_sensor >= 0.95 * r.runs - 1e-9;
      std::fprintf(stderr, "%s %s %s: found %s, named %d, with sensor %d, gain %d%s\n", t->name,
                   audittest::num(m).c_str(), t->unit, pct(r.found, r.runs).c_str(), r.named_name, r.named_sensor,
                   r.gain, r.stopped_early ? " (stopped early)" : "");
      all_pass_so_far = all_pass_so_far && pass;
      all_named_so_far = all_named_so_far && named_ok;
      if (all_pass_so_far) rep.floor_index = static_cast<int>(rep.rungs.size()) - 1;
      if (all_named_so_far) rep.named_index = static_cast<int>(rep.rungs.size()) - 1;
      failing_in_a_row = pass ? 0 : failing_in_a_row + 1;
      if (failing_in_a_row >= 2) break;
      const std::vector<double>& given = o.ladder.empty() ? t->ladder : o.ladder;
      if (li + 1 == ladder.size() && all_pass_so_far && given.size() >= 2 && ladder.size() < given.size() + 8) {
        const double next = m * given.back() / given[given.size() - 2];
        if (next >= t->smallest) ladder.push_back(next);
      }
    }
    reports.push_back(rep);
  }
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();

  // CSV: every magnitude
  std::ofstream csv(o.out + ".csv");
  csv << "effect,unit,magnitude,runs,found,found_rate,wilson_lo,wilson_hi,named,named_with_sensor,heldout_gain,"
         "stopped_early,errors,mean_collect_s,mean_analyse_s,other_named,example\n";
  auto csvRow = [&](const std::string& name, const std::string& unit, const Rung& r) {
    const auto w = wilson(r.found, r.runs);
    csv << name << "," << unit << "," << audittest::num(r.magnitude) << "," << r.runs << "," << r.found << ","
        << (r.runs ? static_cast<double>(r.found) / r.runs : 0) << "," << w.first << "," << w.second << ","
        << r.named_name << "," << r.named_sensor << "," << r.gain << "," << (r.stopped_early ? 1 : 0) << ","
        << r.errors << "," << (r.runs ? r.collect_s / r.runs : 0) << "," << (r.runs ? r.analyse_s / r.runs : 0)
        << ",\"" << wrongList(r.wrong, r.runs) << "\",\"" << r.example << "\"\n";
  };
  csvRow("clean (false alarms)", "-", cleanRung);
  for (const auto& rep : reports)
    for (const auto& r : rep.rungs) csvRow(rep.t->name, rep.t->unit, r);

  // Markdown table
  std::ofstream md(o.out + ".md");
  char head[512];
  std::snprintf(head, sizeof head,
                "Span %.0f s per run, %d seeds per magnitude (from %llu), %d clean seeds, %d jobs, %.0f s wall.\n\n",
                o.span_s, o.seeds, static_cast<unsigned long long>(o.first_seed), o.clean_seeds, o.jobs, wall);
  md << "# Model audit: detection floor and error rates\n\n`" << cmdline << "`\n\n" << head;
  md << "False alarms on clean data (a named cause or a \"not explained\" residual), family-wise rate "
     << (o.false_alarm > 0 ? o.false_alarm : audit::AuditOptions{}.false_alarm) << ": "
     << pct(cleanRung.found, cleanRung.runs) << "; named: " << wrongList(cleanRung.wrong, cleanRung.runs, 1000) << "\n\n"
     << "Spans with a deterministic cause named in the star-sensor families (relative, reference: a misalignment, "
        "harmonic, drift, step, time offset, clock drift, aberration or a \"not explained\" residual there; the noise "
        "findings and the accelerometer family aside): "
     << cleanRung.det_causes << " in all; spans with one " << pct(cleanRung.det_alarm, cleanRung.runs) << "\n\n";
  md << "| effect | magnitude | detection floor (found >= 95 %) | found there [Wilson 95 %] | naming floor (right "
        "cause and sensor named >= 95 %) | named there: cause / cause and sensor [Wilson 95 %] | held-out gain there | "
        "other causes named there |\n";
  md << "|---|---|---|---|---|---|---|---|\n";
  auto rungText = [&](const EffectReport& rep, int idx) {
    const Rung& r = rep.rungs[static_cast<std::size_t>(idx)];
    const bool bounded = idx + 1 < static_cast<int>(rep.rungs.size());  // a smaller magnitude was tried
    return std::string(bounded ? "" : "<= ") + audittest::num(r.magnitude) + " " + rep.t->unit;
  };
  for (const auto& rep : reports) {
    const std::string unit = rep.t->unit;
    md << "| " << rep.t->name << " | " << rep.t->magnitude << " | ";
    if (rep.floor_index < 0) {
      const Rung& r = rep.rungs.front();
      md << "> " << audittest::num(r.magnitude) << " " << unit << " (largest tried) | " << pct(r.found, r.runs)
         << " | - | " << pct(r.named_name, r.runs) << " / " << pct(r.named_sensor, r.runs) << " | "
         << pct(r.gain, r.runs) << " | " << wrongList(r.wrong, r.runs) << " |\n";
      continue;
    }
    const Rung& f = rep.rungs[static_cast<std::size_t>(rep.floor_index)];
    md << rungText(rep, rep.floor_index) << " | " << pct(f.found, f.runs) << " | ";
    if (rep.named_index < 0) {
      md << "> " << audittest::num(rep.rungs.front().magnitude) << " " << unit << " | ";
      const Rung& r = rep.rungs.front();
      md << pct(r.named_name, r.runs) << " / " << pct(r.named_sensor, r.runs) << " at the largest | "
         << pct(r.gain, r.runs) << " | " << wrongList(r.wrong, r.runs) << " |\n";
      continue;
    }
    const Rung& r = rep.rungs[static_cast<std::size_t>(rep.named_index)];
    md << rungText(rep, rep.named_index) << " | " << pct(r.named_name, r.runs) << " / " << pct(r.named_sensor, r.runs)
       << " | " << pct(r.gain, r.runs) << " | " << wrongList(r.wrong, r.runs) << " |\n";
  }
  md << "\nEvery magnitude tried (a magnitude stops once more than 5 % of its seeds were not found):\n\n";
  md << "| effect | magnitude | found | named | named with the sensor | held-out gain | mean collect s | mean analyse s |\n";
  md << "|---|---|---|---|---|---|---|---|\n";
  for (const auto& rep : reports)
    for (const auto& r : rep.rungs) {
      char b[64];
      std::snprintf(b, sizeof b, "%.3f | %.3f", r.runs ? r.collect_s / r.runs : 0, r.runs ? r.analyse_s / r.runs : 0);
      md << "| " << rep.t->name << " | " << audittest::num(r.magnitude) << " " << rep.t->unit << " | "
         << pct(r.found, r.runs) << (r.stopped_early ? " (stopped)" : "") << " | " << pct(r.named_name, r.runs)
         << " | " << pct(r.named_sensor, r.runs) << " | " << pct(r.gain, r.runs) << " | " << b << " |\n";
    }
  std::cout << "wrote " << o.out << ".md and " << o.out << ".csv (" << wall << " s)\n";
  std::ifstream in(o.out + ".md");
  std::cout << in.rdbuf();
  return 0;
}
