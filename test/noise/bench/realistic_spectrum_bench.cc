// Bench (label bench, not in CI: about two minutes per seed): does `boresight noise` recover the
// realistic preset's stationary head noise as a spectrum? Twelve hours of the GRACE-FO scenario with the
// stationary parts of config/preset_realistic.yaml: the excerpt's white levels, a power law per head
// axis (0.4" across, 3" about the boresight, slope 1, 1e-4 to 2e-2 Hz) and the thermal wander (1" / 2",
// slope 1.5, 2e-5 to 2e-3 Hz); the field-of-view error is left out (it follows the stars: not a
// stationary process). The sum of two power laws is not in the family the command fits (white + one or
// two Gauss-Markov terms, or one power law), so parameters cannot be compared; spectra can. A second
// test leaves the wander out: the truth is then the power-law candidate's own structure. On every head
// axis, at 12 frequencies across the band the fit can determine, the z of each candidate's log PSD
// against the truth's (its own standard error from the fit's covariance: NoiseFit::logPsd) is printed,
// with the candidates averaged with Akaike weights and the unconditional standard error
// (NoiseSelection::averagedLogPsd); every candidate is fitted (NoiseOptions::every_structure). The seed
// is BORESIGHT_BENCH_SEED (default 11).
//
// Asserted: (1) the chosen model's spectrum lies within 3.5 standard errors of the truth's on every head
// axis (9 axes with 3-5 parameters each: about 40 independent comparisons, P(|z| > 3.5) = 5e-4 each);
// (2) with the wander, the same comparison against the truth without it fails on most axes (the check
// can tell). A spectrum that is not determined (a flat direction: an infinite standard error) counts as
// not recovered. (1) FAILS on the code of 2026-11-27, with or without the wander: over seeds 11-13 and
// both truths (54 head axes) BIC's choice (one Gauss-Markov term on most axes) is within 3.5 on 12 of
// 54, AIC's choice on 44, the Akaike-weighted average on 46 (the printed summary lines;
// src/noise/DESIGN.md, Limits, "The realistic preset as a spectrum").
#include <boresight/model/noise.h>
#include <boresight/noise/run.h>

#include "../excerpt_scenario.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <cstdio>
#include <limits>
#include <string>
#include <utility>
#include <vector>

using namespace boresight;

namespace {

const noise::AxisResult* headAxis(const noise::NoiseOutput& o, int h, const std::string& ax) {
  for (const auto& a : o.axes)
    if (a.sensor == "head " + std::to_string(h) && a.axis == ax) return &a;
  return nullptr;
}

/// The largest |z| of a fit's log PSD against `truth` at the frequencies of the axis's band that
/// `boresight noise` reports (noise::bandSpectrum: 12, log-spaced), printed when `print`; NaN when a
/// standard error is missing.
template <class LogPsd>
double worstZ(const noise::AxisResult& a, const LogPsd& logPsd, const model::NoiseModel& truth, bool print) {
  double worst = 0;
  for (const noise::BandPoint& b : noise::bandSpectrum(a)) {
    const double fq = b.f_hz;
    const auto [ls, se] = logPsd(fq, a.interval_s);
    if (!(std::isfinite(ls) && std::isfinite(se) && se > 0)) return std::numeric_limits<double>::quiet_NaN();
    const double z = (ls - std::log(truth.psdSampled(fq, a.interval_s))) / se;
    worst = std::max(worst, std::abs(z));
    if (print) std::printf(" %+6.1f", z);
  }
  return worst;
}

/// The seed of the simulated span: BORESIGHT_BENCH_SEED, else 11.
int benchSeed() {
  const char* e = std::getenv("BORESIGHT_BENCH_SEED");
  return e && *e ? std::atoi(e) : 11;
}

const char* const kPowerLawEffect =
    "  - {name: coloured_noise, sensor: all, cross_arcsec: 0.4, about_arcsec: 3, alpha: 1, f_lo_hz: 1.0e-4, f_hi_hz: 2.0e-2}\n";
const char* const kWanderEffect =
    "  - {name: thermal_wander, sensor: all, cross_arcsec: 1, about_arcsec: 2, alpha: 1.5, f_lo_hz: 2.0e-5, f_hi_hz: 2.0e-3}\n";

/// Simulates 12 h with the power law (and the wander when `wander`), runs `boresight noise` with every
/// candidate fitted, prints per head axis every candidate's z against the truth, the AIC choice and the
/// Akaike-weighted average, and asserts the chosen (BIC) model's spectrum within 3.5 of its standard
/// errors. With the wander, also that the chosen model is told from the truth without the wander.
void compareWithTheTruth(const std::string& tag, bool wander) {
  noise::NoiseOptions options;
  options.every_structure = true;
  noise::NoiseOutput out;
  const int seed = benchSeed();
  std::printf("seed %d, %s\n", seed, wander ? "power law + thermal wander (outside the family)" : "power law only (inside the family)");
  ASSERT_TRUE(testutil::simulateExcerptScenarioAndFitNoise(tag, std::string(kPowerLawEffect) + (wander ? kWanderEffect : ""), seed, 43200,
                                                           options, out));
  const double* cross = testutil::kExcerptCross;
  const double* about = testutil::kExcerptAbout;
  int axes = 0, wrong_rejected = 0, bic_in = 0, aic_in = 0, avg_in = 0;
  for (int h = 1; h <= 3; ++h)
    for (const char* ax : {"cross_x", "cross_y", "about_boresight"}) {
      const noise::AxisResult* a = headAxis(out, h, ax);
      ASSERT_TRUE(a != nullptr && a->fitted()) << "head " << h << " " << ax;
      ASSERT_GT(a->f_det_hi, a->f_det_lo);
      const bool is_about = std::string(ax) == "about_boresight";
      model::NoiseModel truth = model::NoiseModel::white(is_about ? about[h - 1] : cross[h - 1]);
      truth.add(model::NoiseTerm::powerLaw(is_about ? 3.0 : 0.4, 1.0, 1e-4, 2e-2));
      const model::NoiseModel no_wander = truth;
      if (wander) truth.add(model::NoiseTerm::powerLaw(is_about ? 2.0 : 1.0, 1.5, 2e-5, 2e-3));
      const model::NoiseFit& chosen = a->selection.chosen();
      const model::NoiseFit* by_aic = nullptr;
      for (const auto& f : a->selection.fits)
        if (f.converged && !f.model.empty() && (!by_aic || f.aic < by_aic->aic)) by_aic = &f;  // among the fits that settled
      std::printf("head %d %s: chosen %s (AIC: %s); z of log PSD against the truth at 12 frequencies %.2g..%.2g Hz\n", h, ax,
                  model::noiseStructureName(chosen.structure), by_aic ? model::noiseStructureName(by_aic->structure) : "none",
                  a->f_det_lo, a->f_det_hi);
      for (const auto& f : a->selection.fits) {
        if (f.model.empty()) continue;
        std::printf("  %-22s BIC %.1f AIC %.1f%s:", model::noiseStructureName(f.structure), f.bic, f.aic, f.converged ? "" : " (not settled)");
        const double w = worstZ(*a, [&](double fq, double T) { return f.logPsd(fq, T); }, truth, true);
        std::printf("  max %.1f\n", w);
      }
      std::printf("  %-22s                          :", "Akaike-weighted average");
      const double worst_avg = worstZ(*a, [&](double fq, double T) { return a->selection.averagedLogPsd(fq, T); }, truth, true);
      std::printf("  max %.1f\n", worst_avg);
      auto chosenPsd = [&](double fq, double T) { return chosen.logPsd(fq, T); };
      const double worst = worstZ(*a, chosenPsd, truth, false);
      bic_in += worst <= 3.5;
      aic_in += by_aic && worstZ(*a, [&](double fq, double T) { return by_aic->logPsd(fq, T); }, truth, false) <= 3.5;
      avg_in += worst_avg <= 3.5;
      EXPECT_LE(worst, 3.5) << "head " << h << " " << ax << ": the chosen spectrum departs from the truth's";
      if (wander) {
        const double worst_wrong = worstZ(*a, chosenPsd, no_wander, false);
        std::printf("  chosen against the truth without the wander: max |z| %.1f\n", worst_wrong);
        wrong_rejected += worst_wrong > 3.5;
      }
      ++axes;
    }
  EXPECT_EQ(axes, 9);
  std::printf("within 3.5 standard errors on all 12 frequencies: BIC's choice on %d of 9 axes, AIC's on %d, the Akaike-weighted "
              "average on %d\n", bic_in, aic_in, avg_in);
  if (wander) {
    EXPECT_GE(wrong_rejected, 6) << "the comparison cannot tell the truth from the truth without its thermal wander";
  }
}

}  // namespace

TEST(NoiseRealisticSpectrum, TheChosenModelsSpectrumIsTheTruthsInTheDeterminableBand) {
  compareWithTheTruth("noise_realistic_spectrum", true);
}

TEST(NoiseRealisticSpectrum, TheChosenModelsSpectrumIsTheTruthsWhenTheFamilyHoldsIt) {
  // The same without the thermal wander: the truth (white + one power law) is the power-law
  // candidate's structure, so a miss here is the choice's, not the family's.
  compareWithTheTruth("noise_inside_family_spectrum", false);
}

