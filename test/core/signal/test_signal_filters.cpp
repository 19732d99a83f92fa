#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <stdexcept>
#include <vector>

#include "die_cushion_ident/core/signal/signal_filters.h"
#include "die_cushion_ident/core/signal/white_noise_estimator.h"

using namespace die_cushion_ident;

TEST(MovingAverageFilter, RejectsEvenOrZeroWidth) {
  EXPECT_THROW(MovingAverageFilter(30, 1), std::invalid_argument);
  EXPECT_THROW(MovingAverageFilter(0, 1), std::invalid_argument);
}

TEST(MovingAverageFilter, RampComesOutDelayedByHalfTheWidth) {
  MovingAverageFilter f(31, 1);
  EXPECT_EQ(f.delaySamples(), 15u);
  for (int k = 0; k < 100; ++k) {
    const bool ready = f.push(2.0 * k);
    EXPECT_EQ(ready, k >= 30);
    if (ready) {
      EXPECT_NEAR(f.output(0), 2.0 * (k - 15), 1e-12) << "a ramp is reproduced exactly, 15 samples late";
    }
  }
}

TEST(SymmetricDerivative, RejectsBadWidthOrPeriod) {
  EXPECT_THROW(SymmetricDerivative(24, 1, 0.002), std::invalid_argument);
  EXPECT_THROW(SymmetricDerivative(1, 1, 0.002), std::invalid_argument);
  EXPECT_THROW(SymmetricDerivative(25, 1, 0.0), std::invalid_argument);
  EXPECT_THROW(SymmetricDerivative(25, 1, -1.0), std::invalid_argument);
}

TEST(SymmetricDerivative, ExactForQuadraticsAtTheWindowCentre) {
  const double dt = 0.002;
  SymmetricDerivative d(25, 1, dt);
  EXPECT_EQ(d.delaySamples(), 12u);
  for (int k = 0; k < 200; ++k) {
    const double t = k * dt;
    if (!d.push(3.0 * t * t + 5.0 * t)) continue;
    const double centre = (k - 12) * dt;
    EXPECT_NEAR(d.output(0), 6.0 * centre + 5.0, 1e-9) << "central differences are exact for parabolas";
  }
}

TEST(DelayLine, DelaysByExactlyTheGivenSamples) {
  DelayLine line(4, 1);
  for (int k = 0; k < 20; ++k) {
    const double v = k;
    const bool ready = line.push(&v);
    EXPECT_EQ(ready, k >= 4);
    if (ready) {
      EXPECT_EQ(line.output(0), k - 4);
    }
  }
}

TEST(DelayLine, ZeroDelayPassesThrough) {
  DelayLine line(0, 1);
  const double v = 7.0;
  EXPECT_TRUE(line.push(&v));
  EXPECT_EQ(line.output(0), 7.0);
}

namespace die_cushion_ident {
namespace {

// The spool's noise from its second differences, unimpressed by the spool's own motion (a 5 Hz swing of
// 0.3 on the 2 ms grid) and by a step; within 5 % of the true 0.002 after 20 000 samples.
TEST(WhiteNoiseEstimator, FindsTheWhiteNoiseUnderAMovingSpool) {
  WhiteNoiseEstimator estimator;
  EXPECT_TRUE(std::isinf(estimator.sigma()));
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 0.002);
  std::vector<double> y;
  for (int k = 0; k < 20000; ++k) {
    const double t = 0.002 * k;
    y.push_back(0.3 * std::sin(2 * M_PI * 5 * t) + (k > 10000 ? 0.2 : 0.0) + noise(rng));
  }
  for (std::size_t k = 1; k + 1 < y.size(); ++k) estimator.add(y[k - 1], y[k], y[k + 1]);
  estimator.add(0.0, std::nan(""), 0.0);  // ignored
  EXPECT_EQ(estimator.count(), 256 + (19998 - 256) / 4) << "all of the first 256, then one in four";
  EXPECT_NEAR(estimator.sigma(), 0.002, 0.0001);
}

}  // namespace
}  // namespace die_cushion_ident
