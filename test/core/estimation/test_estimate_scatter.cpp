#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "die_cushion_ident/core/estimation/estimate_scatter.h"

using die_cushion_ident::EstimateScatter;
using die_cushion_ident::ParameterVector;

// An estimate that wanders about a constant with a known spread: the scatter is that spread, per parameter,
// and nothing is reported before a tenth of the horizon has been seen.
TEST(EstimateScatter, TheSpreadAboutTheLongRunMean) {
  EstimateScatter scatter(5000.0);
  std::mt19937 rng(2);
  std::normal_distribution<double> noise(0.0, 1.0);
  double slow = 0.0;  // an AR(1) with a memory of 50 steps, as a forgetting estimator moves
  constexpr double kKeep = 1.0 - 1.0 / 50.0;
  const double spread = std::sqrt(1.0 / (1.0 - kKeep * kKeep));
  for (int t = 0; t < 60000; ++t) {
    slow = kKeep * slow + noise(rng);
    ParameterVector estimate(2);
    estimate << 1.5e9 + 1e7 * slow, 3e-3 - 1e-5 * slow;
    scatter.add(estimate);
    if (t == 400) EXPECT_EQ(scatter.stds().norm(), 0.0) << "too few steps to tell";
  }
  // Over 5000 steps about 100 of the AR(1)'s memories: its spread within 15 % (about 2 standard errors).
  EXPECT_NEAR(scatter.stds()(0), 1e7 * spread, 0.15 * 1e7 * spread);
  EXPECT_NEAR(scatter.stds()(1) / scatter.stds()(0), 1e-12, 1e-14) << "each parameter in its own unit";
}

TEST(EstimateScatter, NonFiniteEstimatesAreSkippedAndResetStartsOver) {
  EstimateScatter scatter(100.0);
  for (int t = 0; t < 500; ++t) {
    ParameterVector estimate(1);
    estimate << (t % 2 ? 1.0 : -1.0);
    scatter.add(estimate);
    if (t % 50 == 0) {
      estimate << NAN;
      scatter.add(estimate);
    }
  }
  EXPECT_NEAR(scatter.stds()(0), 1.0, 0.02);
  scatter.reset();
  EXPECT_EQ(scatter.stds().size(), 0);
}
