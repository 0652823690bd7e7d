// Bench (label bench, not in CI: about two minutes): does `boresight noise` recover the realistic
// preset's stationary head noise as a spectrum? Twelve hours of the GRACE-FO scenario with the stationary
// parts of config/preset_realistic.yaml: the excerpt's white levels, a power law per head axis (0.4"
// across, 3" about the boresight, slope 1, 1e-4 to 2e-2 Hz) and the thermal wander (1" / 2", slope
// 1.5, 2e-5 to 2e-3 Hz); the field-of-view error is left out (it follows the stars: not a stationary
// process). The sum of two power laws is not in the family the command fits (white + one or two
// Gauss-Markov terms, or one power law), so parameters cannot be compared; spectra can. On every head
// axis, at 12 frequencies across the band the fit can determine, the z of each candidate's log PSD
// against the truth's (its own standard error from the fit's covariance: NoiseFit::logPsd) is printed;
// every candidate is fitted (NoiseOptions::every_structure).
//
// Asserted: (1) the chosen model's spectrum lies within 3.5 standard errors of the truth's on every head
// axis (9 axes with 3-5 parameters each: about 40 independent comparisons, P(|z| > 3.5) = 5e-4 each);
// (2) the same comparison against the truth without its thermal wander fails on most axes (the check can
// tell). A spectrum that is not determined (a flat direction: NoiseFit::logPsd's infinite standard
// error) counts as not recovered. (1) FAILS on the code of 2026-11-26 (seed 11): BIC chooses one
// Gauss-Markov term on 8 of 9 axes; on 7 axes the chosen spectrum is 4.8-10.1 standard errors off (too
// low at 5-30 mHz) or not determined; the power-law candidate is within 2.0 on 7 of 9
// (src/noise/DESIGN.md, Limits, "The realistic preset as a spectrum").
#include <boresight/model/noise.h>
#include <boresight/noise/run.h>

#include "../excerpt_scenario.h"

#include <gtest/gtest.h>

#include <cmath>
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

/// Frequency q of 12, log-spaced across the axis's determinable band.
double bandFrequency(const noise::AxisResult& a, int q) { return a.f_det_lo * std::pow(a.f_det_hi / a.f_det_lo, q / 11.0); }

/// The largest |z| of a fit's log PSD against `truth` at 12 log-spaced frequencies of the axis's band
/// (printed when `print`); NaN when a standard error is missing.
double worstZ(const noise::AxisResult& a, const model::NoiseFit& f, const model::NoiseModel& truth, bool print) {
  double worst = 0;
  for (int q = 0; q < 12; ++q) {
    const double fq = bandFrequency(a, q);
    const auto [ls, se] = f.logPsd(fq, a.interval_s);
    if (!(std::isfinite(ls) && std::isfinite(se) && se > 0)) return std::numeric_limits<double>::quiet_NaN();
    const double z = (ls - std::log(truth.psdSampled(fq, a.interval_s))) / se;
    worst = std::max(worst, std::abs(z));
    if (print) std::printf(" %+6.1f", z);
  }
  return worst;
}

}  // namespace

TEST(NoiseRealisticSpectrum, TheChosenModelsSpectrumIsTheTruthsInTheDeterminableBand) {
  noise::NoiseOptions options;
  options.every_structure = true;
  noise::NoiseOutput out;
  ASSERT_TRUE(testutil::simulateExcerptScenarioAndFitNoise(
      "noise_realistic_spectrum",
      "  - {name: coloured_noise, sensor: all, cross_arcsec: 0.4, about_arcsec: 3, alpha: 1, f_lo_hz: 1.0e-4, f_hi_hz: 2.0e-2}\n"
      "  - {name: thermal_wander, sensor: all, cross_arcsec: 1, about_arcsec: 2, alpha: 1.5, f_lo_hz: 2.0e-5, f_hi_hz: 2.0e-3}\n",
      11, 43200, options, out));
  const double* cross = testutil::kExcerptCross;
  const double* about = testutil::kExcerptAbout;
  int axes = 0, wrong_rejected = 0;
  for (int h = 1; h <= 3; ++h)
    for (const char* ax : {"cross_x", "cross_y", "about_boresight"}) {
      const noise::AxisResult* a = headAxis(out, h, ax);
      ASSERT_TRUE(a != nullptr && a->fitted()) << "head " << h << " " << ax;
      ASSERT_GT(a->f_det_hi, a->f_det_lo);
      const bool is_about = std::string(ax) == "about_boresight";
      model::NoiseModel truth = model::NoiseModel::white(is_about ? about[h - 1] : cross[h - 1]);
      truth.add(model::NoiseTerm::powerLaw(is_about ? 3.0 : 0.4, 1.0, 1e-4, 2e-2));
      const model::NoiseModel no_wander = truth;
      truth.add(model::NoiseTerm::powerLaw(is_about ? 2.0 : 1.0, 1.5, 2e-5, 2e-3));
      const model::NoiseFit& chosen = a->selection.chosen();
      std::printf("head %d %s: chosen %s; z of log PSD against the truth at 12 frequencies %.2g..%.2g Hz\n", h, ax,
                  model::noiseStructureName(chosen.structure), a->f_det_lo, a->f_det_hi);
      for (const auto& f : a->selection.fits) {
        if (f.model.empty()) continue;
        std::printf("  %-22s BIC %.1f AIC %.1f:", model::noiseStructureName(f.structure), f.bic, f.aic);
        const double w = worstZ(*a, f, truth, true);
        std::printf("  max %.1f\n", w);
      }
      // For the next step (printed, not asserted): the candidates averaged with Akaike weights, the
      // spread between their log PSDs added to the variance (Burnham and Anderson's unconditional one).
      {
        double aic_min = std::numeric_limits<double>::infinity();
        for (const auto& f : a->selection.fits)
          if (!f.model.empty()) aic_min = std::min(aic_min, f.aic);
        double worst_avg = 0;
        std::printf("  %-22s                          :", "Akaike-weighted average");
        for (int q = 0; q < 12; ++q) {
          const double fq = bandFrequency(*a, q);
          double wsum = 0, mean = 0;
          std::vector<std::pair<double, std::pair<double, double>>> parts;
          for (const auto& f : a->selection.fits) {
            if (f.model.empty()) continue;
            const auto p = f.logPsd(fq, a->interval_s);
            if (!std::isfinite(p.second)) continue;
            const double w = std::exp(-0.5 * (f.aic - aic_min));
            parts.push_back({w, p});
            wsum += w;
            mean += w * p.first;
          }
          mean /= wsum;
          double se = 0;
          for (const auto& [w, p] : parts) se += w / wsum * std::sqrt(p.second * p.second + (p.first - mean) * (p.first - mean));
          const double z = (mean - std::log(truth.psdSampled(fq, a->interval_s))) / se;
          worst_avg = std::max(worst_avg, std::abs(z));
          std::printf(" %+6.1f", z);
        }
        std::printf("  max %.1f\n", worst_avg);
      }
      const double worst = worstZ(*a, chosen, truth, false), worst_wrong = worstZ(*a, chosen, no_wander, false);
      std::printf("  chosen against the truth without the wander: max |z| %.1f\n", worst_wrong);
      EXPECT_LE(worst, 3.5) << "head " << h << " " << ax << ": the chosen spectrum departs from the truth's";
      wrong_rejected += worst_wrong > 3.5;
      ++axes;
    }
  EXPECT_EQ(axes, 9);
  EXPECT_GE(wrong_rejected, 6) << "the comparison cannot tell the truth from the truth without its thermal wander";
}
