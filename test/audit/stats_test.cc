// The audit's distribution functions against independent reference values (closed forms and
// textbook quantiles), and their internal consistency (quantile inverts the tail).
#include <boresight/model/stats.h>

#include <gtest/gtest.h>

#include <cmath>

namespace st = boresight::model::stats;

TEST(AuditStats, ChiSquareTailMatchesClosedForms) {
  // k = 2: P(chi2 > x) = exp(-x/2); k = 1: erfc(sqrt(x/2)); k = 4: exp(-x/2) (1 + x/2)
  for (double x : {0.1, 1.0, 5.0, 20.0, 80.0}) {
    EXPECT_NEAR(st::chi2Sf(x, 2) / std::exp(-x / 2), 1.0, 1e-10) << x;
    EXPECT_NEAR(st::chi2Sf(x, 1) / std::erfc(std::sqrt(x / 2)), 1.0, 1e-9) << x;
    EXPECT_NEAR(st::chi2Sf(x, 4) / (std::exp(-x / 2) * (1 + x / 2)), 1.0, 1e-10) << x;
  }
}

TEST(AuditStats, TextbookQuantiles) {
  EXPECT_NEAR(st::chi2Quantile(0.05, 1), 3.841459, 1e-5);
  EXPECT_NEAR(st::chi2Quantile(0.01, 3), 11.344867, 1e-5);
  EXPECT_NEAR(st::fQuantile(0.05, 3, 20), 3.098391, 1e-5);
  EXPECT_NEAR(st::fQuantile(0.01, 6, 100), 2.987685, 1e-5);  // Simpson integration of the F(6, 100) density
  EXPECT_NEAR(st::normalQuantile2(0.05), 1.959964, 1e-5);
}

TEST(AuditStats, FTailLimitsAndBeta) {
  // F(1, d2) = t^2 with d2 dof; F(d1, infinity) = chi2_d1 / d1
  EXPECT_NEAR(st::fSf(4.0, 3, 1e9), st::chi2Sf(12.0, 3), 1e-12);
  EXPECT_NEAR(st::fSf(st::fQuantile(1e-6, 4, 50), 4, 50), 1e-6, 1e-9);
  // I_x(1, 1) = x; I_x(a, 1) = x^a
  EXPECT_NEAR(st::betaI(1, 1, 0.3), 0.3, 1e-14);
  EXPECT_NEAR(st::betaI(2.5, 1, 0.4), std::pow(0.4, 2.5), 1e-12);
}

TEST(AuditStats, PoissonTail) {
  // P(X >= 1) = 1 - exp(-lambda); P(X >= 2) = 1 - exp(-l)(1 + l)
  EXPECT_NEAR(st::poissonSfGe(1, 0.3), 1 - std::exp(-0.3), 1e-12);
  EXPECT_NEAR(st::poissonSfGe(2, 0.3), 1 - std::exp(-0.3) * 1.3, 1e-12);
  EXPECT_EQ(st::poissonSfGe(0, 0.3), 1.0);
  EXPECT_LT(st::poissonSfGe(1, 1e-6), 1.1e-6);
}
