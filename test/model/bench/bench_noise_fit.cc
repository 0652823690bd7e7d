// Monte Carlo of the noise fits (model/noise.h): per model (white, Gauss-Markov, power law, a sum of
// two Gauss-Markov terms), seeded series with random gaps, fitted by maximum likelihood; prints how
// often each determined parameter lies within 3 sigma of the truth (with the Wilson 95 % interval),
// the normalised error squared per degree of freedom against its chi-square 95 % bounds, how often
// BIC chose the simulated structure, and the time per fit.
//
//   bench_noise_fit [--runs 200] [--span 86400] [--dt 1] [--gaps 0.05] [--gap-length 40] [--seed 1000]
//                   [--jobs 2] [--models white,gauss_markov,power_law,sum] [--likelihood exact] [--select]
#include "../noise_test_util.h"

#include <boresight/model/noise.h>
#include <boresight/model/stats.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <mutex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

using namespace boresight::model;
using namespace boresight::model::noisetest;

namespace {

void wilson(int k, int n, double& lo, double& hi) {
  if (n == 0) {
    lo = 0, hi = 1;
    return;
  }
  const double z = 1.959963984540054, p = static_cast<double>(k) / n;
  const double d = 1 + z * z / n, c = p + z * z / (2 * n), r = z * std::sqrt(p * (1 - p) / n + z * z / (4.0 * n * n));
  lo = (c - r) / d;
  hi = (c + r) / d;
}

void usage() {
  std::puts(
      "bench_noise_fit [--runs N] [--span S] [--dt T] [--gaps F] [--gap-length L] [--seed S0] [--jobs J]\n"
      "                [--models a,b] [--likelihood exact|whittle|auto] [--select] [--verbose]\n"
      "  Monte Carlo of the noise-model fits against the simulated truth (defaults: 200 runs of one day at\n"
      "  1 Hz with 5 % gaps of 40 samples on average, seeds 1000.., two threads, every model, the exact\n"
      "  likelihood; --select also runs the BIC choice).");
}

}  // namespace

int main(int argc, char** argv) {
  int runs = 200, jobs = 2;
  double span = 86400, dt = 1, gaps = 0.05;
  std::uint64_t seed0 = 1000;
  bool select = false, verbose = false;
  McSetup setup;
  std::vector<std::string> models = {"white", "gauss_markov", "power_law", "sum"};
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> const char* {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "bench_noise_fit: %s needs a value\n", a.c_str());
        std::exit(2);
      }
      return argv[++i];
    };
    if (a == "--help" || a == "-h") {
      usage();
      return 0;
    } else if (a == "--runs") runs = std::atoi(next());
    else if (a == "--span") span = std::atof(next());
    else if (a == "--dt") dt = std::atof(next());
    else if (a == "--gaps") gaps = std::atof(next());
    else if (a == "--gap-length") setup.gap_mean_len = std::atof(next());
    else if (a == "--likelihood") {
      const std::string l = next();
      if (l == "exact") setup.likelihood = NoiseLikelihood::Exact;
      else if (l == "whittle") setup.likelihood = NoiseLikelihood::Whittle;
      else if (l == "auto") setup.likelihood = NoiseLikelihood::Auto;
      else {
        std::fprintf(stderr, "bench_noise_fit: --likelihood exact, whittle or auto\n");
        return 2;
      }
    }
    else if (a == "--seed") seed0 = std::strtoull(next(), nullptr, 10);
    else if (a == "--jobs") jobs = std::max(1, std::atoi(next()));
    else if (a == "--select") select = true;
    else if (a == "--verbose") verbose = true;
    else if (a == "--models") {
      models.clear();
      std::stringstream ss(next());
      for (std::string m; std::getline(ss, m, ',');) models.push_back(m);
    } else {
      std::fprintf(stderr, "bench_noise_fit: unknown option %s (--help)\n", a.c_str());
      return 2;
    }
  }
  setup.gap_fraction = gaps;
  if (runs < 1 || !(span > 0) || !(dt > 0) || !(gaps >= 0 && gaps < 0.9) || !(setup.gap_mean_len >= 1)) {
    std::fprintf(stderr, "bench_noise_fit: bad option value (--help)\n");
    return 2;
  }
  const auto slots = static_cast<std::size_t>(span / dt);
  std::printf("noise-fit Monte Carlo: %d runs per model, span %.0f s at %g s (%zu slots), %.0f %% gaps of %g samples on "
              "average, %s likelihood, seeds %llu..%llu\n",
              runs, span, dt, slots, gaps * 100, setup.gap_mean_len, noiseLikelihoodName(setup.likelihood),
              static_cast<unsigned long long>(seed0),
              static_cast<unsigned long long>(seed0 + static_cast<std::uint64_t>(runs) - 1));
  for (const FitCase& c : fitCases(span, dt)) {
    if (std::find(models.begin(), models.end(), c.name) == models.end()) continue;
    if (verbose) {  // one line per run and parameter: what a run got wrong (one thread)
      NoiseFitOptions opt;
      opt.likelihood = setup.likelihood;
      for (int k = 0; k < runs; ++k) {
        const NoiseSeries s = gappedSeries(c.truth, slots, dt, gaps, seed0 + static_cast<std::uint64_t>(k), 0.0, setup.gap_mean_len);
        const NoiseFit f = fitNoise(s, c.structure, Eigen::MatrixXd::Ones(static_cast<Eigen::Index>(s.size()), 1), opt);
        const double m2ll_truth = minusTwoLogLikelihood(c.truth, s, Eigen::MatrixXd::Ones(static_cast<Eigen::Index>(s.size()), 1));
        int dof = 0;
        const double nees = jointNees(f, c, &dof);
        std::printf("%s seed %llu: %s, %d evaluations, -2 log L %.2f (at the truth %.2f), NEES %.2f for %d%s%s\n", c.name.c_str(),
                    static_cast<unsigned long long>(seed0 + static_cast<std::uint64_t>(k)), f.converged ? "converged" : "NOT converged",
                    f.evaluations, f.m2ll, m2ll_truth, nees, dof, f.message.empty() ? "" : ": ", f.message.c_str());
        for (const NoiseParam& p : f.params) {
          const double t = truthOf(c, p);
          const double e = p.log_scale ? std::log(p.value) - std::log(t) : p.value - t;
          const double se = p.log_scale ? p.log_sigma : p.sigma;
          std::printf("    %-12s truth %-10.4g fit %-10.4g sigma %-10.3g z %7.2f%s\n", p.name.c_str(), t, p.value, se, e / se,
                      p.determined ? "" : " (not determined)");
        }
      }
      continue;
    }
    std::printf("\n%s: truth %s, fitted as %s\n", c.name.c_str(), c.truth.describe().c_str(), noiseStructureName(c.structure));
    // Split the runs over the threads by seed; each thread sums its own result.
    std::vector<FitMcResult> part(static_cast<std::size_t>(jobs));
    std::vector<std::thread> th;
    const auto t0 = std::chrono::steady_clock::now();
    for (int j = 0; j < jobs; ++j)
      th.emplace_back([&, j] {
        FitMcResult& r = part[static_cast<std::size_t>(j)];
        for (int k = j; k < runs; k += jobs) {
          const FitMcResult one = runFitMc(c, 1, slots, dt, setup, seed0 + static_cast<std::uint64_t>(k), select);
          r.runs += one.runs;
          r.converged += one.converged;
          r.whittle += one.whittle;
          r.chosen_right += one.chosen_right;
          r.truth_not_rejected += one.truth_not_rejected;
          r.nees_sum += one.nees_sum;
          r.nees_dof += one.nees_dof;
          r.lr_sum += one.lr_sum;
          r.lr_dof += one.lr_dof;
          for (const auto& [n, v] : one.determined) r.determined[n] += v;
          for (const auto& [n, v] : one.within3) r.within3[n] += v;
        }
      });
    for (auto& t : th) t.join();
    const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    FitMcResult r;
    for (const auto& p : part) {
      r.runs += p.runs;
      r.converged += p.converged;
      r.whittle += p.whittle;
      r.chosen_right += p.chosen_right;
      r.truth_not_rejected += p.truth_not_rejected;
      r.nees_sum += p.nees_sum;
      r.nees_dof += p.nees_dof;
      r.lr_sum += p.lr_sum;
      r.lr_dof += p.lr_dof;
      for (const auto& [n, v] : p.determined) r.determined[n] += v;
      for (const auto& [n, v] : p.within3) r.within3[n] += v;
    }
    std::printf("  converged %d/%d (Whittle likelihood in %d); %.3f s per run (%d threads%s)\n", r.converged, r.runs, r.whittle,
                secs * jobs / r.runs, jobs, select ? ", fit and BIC choice" : "");
    std::printf("  %-14s %10s %12s %18s %14s\n", "parameter", "truth", "determined", "within 3 sigma", "Wilson 95 %");
    for (const auto& [name, v] : c.values) {
      const int det = r.determined.count(name) ? r.determined.at(name) : 0;
      const int in = r.within3.count(name) ? r.within3.at(name) : 0;
      double lo, hi;
      wilson(in, det, lo, hi);
      char truth[32];
      if (std::isnan(v)) std::snprintf(truth, sizeof truth, "at pivot");  // a level at each fit's pivot
      else std::snprintf(truth, sizeof truth, "%.4g", v);
      std::printf("  %-14s %10s %8d/%-3d %10d (%5.1f %%) %6.1f-%5.1f %%\n", name.c_str(), truth, det, r.runs, in,
                  det ? 100.0 * in / det : 0.0, 100 * lo, 100 * hi);
    }
    double lo, hi;
    neesBounds(r.nees_dof, lo, hi);
    std::printf("  NEES per degree of freedom %.3f (%d dof; 95 %% bounds %.3f-%.3f)%s\n", r.nees_sum / std::max(1, r.nees_dof),
                r.nees_dof, lo, hi, (r.nees_sum / r.nees_dof >= lo && r.nees_sum / r.nees_dof <= hi) ? "" : "  OUTSIDE");
    if (r.lr_dof > 0) {  // the same question without the quadratic approximation (exact likelihood only)
      neesBounds(r.lr_dof, lo, hi);
      const double lr = r.lr_sum / r.lr_dof;
      std::printf("  likelihood ratio at the truth per fitted parameter %.3f (%d; 95 %% bounds %.3f-%.3f)%s\n", lr, r.lr_dof, lo, hi,
                  (lr >= lo && lr <= hi) ? "" : "  OUTSIDE");
    }
    if (select)
      std::printf("  BIC chose %s in %d/%d runs; the simulated structure within 10 of the best in %d/%d\n",
                  noiseStructureName(c.structure), r.chosen_right, r.runs, r.truth_not_rejected, r.runs);
  }
  return 0;
}
