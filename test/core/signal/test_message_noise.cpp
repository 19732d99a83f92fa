#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "die_cushion_ident/core/signal/message_noise.h"

using die_cushion_ident::MessageNoise;
using die_cushion_ident::WhiteNoiseEstimator;

namespace {

constexpr double kSigma = 0.2e5;    // [Pa] the simulator's pressure sensor
constexpr double kInterval = 1e-3;  // [s] 1 kHz messages

// A pressure stroke's smooth rise and fall (60 bar over a second) under white noise.
double smooth(double t) { return 60e5 * std::sin(M_PI * std::fmod(t, 1.0)); }

}  // namespace

TEST(MessageNoise, ReadsTheSensorsNoiseAndRateFromItsMessages) {
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0.0, kSigma);
  MessageNoise messages;
  for (int i = 0; i < 20000; ++i) messages.add(i * kInterval, smooth(i * kInterval) + noise(rng));
  EXPECT_NEAR(messages.sigma(), kSigma, 0.05 * kSigma);
  EXPECT_NEAR(messages.meanInterval(), kInterval, 1e-9);
}

// Why it exists: at 0.5 ms from 1 kHz messages every second grid sample is the mean of two messages, and the
// grid's second differences see a noise several times smaller than the sensor's.
TEST(MessageNoise, AGridBetweenTheMessagesIsJudgedByTheSensorsNoise) {
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(0.0, kSigma);
  MessageNoise messages;
  WhiteNoiseEstimator on_grid(1);
  double before = NAN, grid[3] = {NAN, NAN, NAN};
  const auto onGrid = [&](double p) {
    grid[0] = grid[1];
    grid[1] = grid[2];
    grid[2] = p;
    on_grid.add(grid[0], grid[1], grid[2]);
  };
  for (int i = 0; i < 20000; ++i) {
    const double p = smooth(i * kInterval) + noise(rng);
    messages.add(i * kInterval, p);
    if (std::isfinite(before)) onGrid(0.5 * (before + p));  // the grid sample between two messages
    onGrid(p);
    before = p;
  }
  EXPECT_LT(on_grid.sigma(), 0.5 * kSigma) << "the interpolated grid's own estimate";
  EXPECT_NEAR(messages.forGrid(0.5e-3), kSigma, 0.05 * kSigma);
  EXPECT_EQ(messages.forGrid(1e-3), 0.0) << "a grid at the messages' rate sees the sensor's noise itself";
  EXPECT_EQ(messages.forGrid(2e-3), 0.0);
}

TEST(MessageNoise, SkipsNonFiniteSamplesAndStartsOverWhereTheStampsJumpBack) {
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, kSigma);
  MessageNoise messages;
  EXPECT_TRUE(std::isnan(messages.meanInterval()));
  EXPECT_EQ(messages.forGrid(0.5e-3), 0.0) << "nothing known yet";
  for (int loop = 0; loop < 3; ++loop) {  // a bag played with --loop: the stamps start over, the level jumps
    for (int i = 0; i < 5000; ++i) {
      const double t = i * kInterval;
      messages.add(t, i % 97 == 0 ? NAN : smooth(t) + 1e7 * loop + noise(rng));
      if (i % 501 == 0) messages.add(NAN, 1.0);
    }
  }
  EXPECT_NEAR(messages.sigma(), kSigma, 0.06 * kSigma);
  // Between finite messages: one in 97 is missing, so 1 % longer.
  EXPECT_NEAR(messages.meanInterval(), kInterval * 97.0 / 96.0, 1e-3 * kInterval);
}
