// Fitting noise models (model/noise.h) against the simulated truth: a small Monte Carlo per model
// (the full one, 200 runs of a day per model, is the bench tool bench_noise_fit), model choice by
// BIC, and what a fit says when a correlation time is outside what the span can determine.
#include "noise_test_util.h"

#include <boresight/model/noise.h>

#include <gtest/gtest.h>

using namespace boresight::model;
using namespace boresight::model::noisetest;

namespace {
constexpr double kT = 1.0;
/// 2 h at 1 Hz and 10 runs for the one-scale models; a day and 4 runs for the two-scale ones: their
/// shape needs the two decades between 20 / span and fs / 20 that a day at 1 Hz has (over 6 h a
/// power law's slope and corners trade off and the fits wander).
std::size_t slotsOf(int model) { return model < 2 ? 7200 : 86400; }
int runsOf(int model) { return model < 2 ? 10 : 4; }
FitCase caseOf(int model) { return fitCases(static_cast<double>(slotsOf(model)) * kT, kT)[static_cast<std::size_t>(model)]; }
}  // namespace

class NoiseFitMc : public ::testing::TestWithParam<int> {};

TEST_P(NoiseFitMc, RecoversTheTruthWithConsistentSigmas) {
  // 10 or 4 runs with 5 % gaps per model (CI size; bench_noise_fit runs 200 days per model). Every
  // determined parameter within 3 sigma in all but at most one run (with right sigmas, P(two or more
  // outside) <= 3e-4); the summed normalised error squared inside its chi-square 99 % bounds; BIC
  // never rejects the simulated structure (within 10 of the best: over two decades a power law and
  // two Gauss-Markov terms are look-alikes) and picks it outright for the one-scale models.
  const FitCase c = caseOf(GetParam());
  const int kRuns = runsOf(GetParam());
  const FitMcResult r = runFitMc(c, kRuns, slotsOf(GetParam()), kT, 0.05, 1000, /*also_select=*/true);
  EXPECT_GE(r.converged, kRuns - 1) << c.name;
  for (const auto& [name, v] : c.values) {
    const int det = r.determined.count(name) ? r.determined.at(name) : 0;
    EXPECT_GE(det, kRuns - 1) << c.name << " " << name << " determined in " << det << " runs";
    const int in = r.within3.count(name) ? r.within3.at(name) : 0;
    EXPECT_GE(in, det - 1) << c.name << " " << name << ": " << in << " of " << det << " within 3 sigma";
  }
  const double lo = boresight::model::stats::chi2Quantile(0.995, r.nees_dof), hi = boresight::model::stats::chi2Quantile(0.005, r.nees_dof);
  EXPECT_GE(r.nees_sum, lo) << c.name << ": sigmas too large";
  EXPECT_LE(r.nees_sum, hi) << c.name << ": sigmas too small (NEES " << r.nees_sum / r.nees_dof << " per dof)";
  EXPECT_EQ(r.truth_not_rejected, kRuns) << c.name;
  if (GetParam() < 2) {
    EXPECT_GE(r.chosen_right, kRuns - 1) << c.name << ": BIC chose the simulated structure in " << r.chosen_right;
  }
}

std::string modelName(const ::testing::TestParamInfo<int>& p) { return caseOf(p.param).name; }
INSTANTIATE_TEST_SUITE_P(Models, NoiseFitMc, ::testing::Range(0, 4), modelName);

TEST(NoiseFit, CorrelationTimesOutsideTheSpanAreNotDetermined) {
  // A Gauss-Markov term of 5000 s in a 2 h span: its corner (3.2e-5 Hz) is below 20 / span.
  const NoiseModel m = NoiseModel::white(1.0).add(NoiseTerm::gaussMarkov(3.0, 5000.0));
  const NoiseSeries s = gappedSeries(m, 7200, kT, 0.05, 5, 0.0);
  const NoiseFit f = fitNoise(s, NoiseStructure::WhiteGaussMarkov, Eigen::MatrixXd::Ones(static_cast<Eigen::Index>(s.size()), 1));
  const NoiseParam* tau = f.find("gm1.tau_s");
  ASSERT_NE(tau, nullptr);
  EXPECT_FALSE(tau->determined) << tau->value << " s";
  EXPECT_FALSE(tau->note.empty());
  const NoiseParam* w = f.find("white.sigma");
  ASSERT_NE(w, nullptr);
  EXPECT_TRUE(w->determined);
  EXPECT_NEAR(w->value, 1.0, 3 * w->sigma);
}
