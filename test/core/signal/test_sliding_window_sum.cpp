#include <gtest/gtest.h>

#include <random>
#include <stdexcept>

#include "die_cushion_ident/core/signal/sliding_window_sum.h"

using die_cushion_ident::SlidingWindowSum;

TEST(SlidingWindowSum, RejectsZeroWidthOrDimension) {
  EXPECT_THROW(SlidingWindowSum(0, 1), std::invalid_argument);
  EXPECT_THROW(SlidingWindowSum(3, 0), std::invalid_argument);
}

TEST(SlidingWindowSum, SumsOnlyTheLastWidthSamples) {
  SlidingWindowSum w(3, 2);
  const double samples[][2] = {{1, 10}, {2, 20}, {3, 30}, {4, 40}};
  w.push(samples[0]);
  EXPECT_FALSE(w.full());
  EXPECT_DOUBLE_EQ(w.sum(0), 1.0) << "before the window is full the sum covers what has arrived";
  w.push(samples[1]);
  w.push(samples[2]);
  EXPECT_TRUE(w.full());
  EXPECT_DOUBLE_EQ(w.sum(1), 60.0);
  w.push(samples[3]);
  EXPECT_DOUBLE_EQ(w.sum(0), 9.0) << "the oldest sample must leave";
  EXPECT_DOUBLE_EQ(w.sum(1), 90.0);
  w.clear();
  EXPECT_EQ(w.count(), 0u);
  EXPECT_DOUBLE_EQ(w.sum(0), 0.0);
}

TEST(SlidingWindowSum, ExactRefreshBoundsRoundingDriftOverTenMillionSamples) {
  // Pressure-like values (1e7 Pa with 2e4 Pa noise): a plain running sum drifts (NUMERICS.md).
  SlidingWindowSum w(31, 1);
  std::mt19937_64 rng(3);
  std::normal_distribution<double> noise(0.0, 2e4);
  double ring[31] = {};
  for (int i = 0; i < 10'000'000; ++i) {
    const double v = 1e7 + noise(rng);
    ring[i % 31] = v;
    w.push(v);
  }
  long double exact = 0.0L;
  for (double v : ring) exact += v;
  EXPECT_NEAR(w.sum(0), static_cast<double>(exact), 1e-6)
      << "window sum of 3.1e8 Pa must stay within 1e-6 Pa of the exact sum after 1e7 samples";
}
