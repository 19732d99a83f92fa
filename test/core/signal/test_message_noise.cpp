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
  EXPECT_NEAR(messages.forGrid(0.5e-3), kSigma, 0.05 * kSigma) << "no grid followed: the sensor's";
  EXPECT_EQ(messages.forGrid(2e-3), 0.0) << "samples two messages apart share none: the grid's own estimate";
}

// What each grid sample holds: at 0.5 ms from 1 kHz every second sample is the mean of two messages
// (sigma^2 / 2), the others a message (sigma^2): sqrt(3/4) of the sensor's sigma on average. The grid's
// second differences see far less; the samples' own spread is the reference.
TEST(MessageNoise, AFollowedGridIsJudgedByTheNoiseItsSamplesHold) {
  std::mt19937 rng(9);
  std::normal_distribution<double> noise(0.0, kSigma);
  std::normal_distribution<double> jitter(0.0, 50e-6);  // the simulator's sampling jitter
  for (const double period : {0.5e-3, 1e-3}) {
    MessageNoise messages;
    messages.followGrid(period, 0.0);
    double a_stamp = NAN, a_noise = 0.0, sum_squares = 0.0;
    long samples = 0;
    double next_grid = 0.0;
    for (int i = 0; i < 40000; ++i) {
      const double stamp = i * kInterval + jitter(rng), n = noise(rng);
      messages.add(stamp, smooth(stamp) + n);
      for (; std::isfinite(a_stamp) && next_grid <= stamp; next_grid += period) {
        if (next_grid <= a_stamp) continue;
        const double w = (next_grid - a_stamp) / (stamp - a_stamp);
        const double held = a_noise + w * (n - a_noise);
        sum_squares += held * held;
        ++samples;
      }
      a_stamp = stamp;
      a_noise = n;
    }
    const double held_rms = std::sqrt(sum_squares / static_cast<double>(samples));
    EXPECT_NEAR(messages.forGrid(period), held_rms, 0.03 * kSigma) << period;
    if (period == 0.5e-3) {
      EXPECT_NEAR(messages.gridShare(), std::sqrt(0.75), 0.02);
    } else {
      EXPECT_GT(messages.gridShare(), 0.85) << "50 us of jitter against 1 ms: mostly a message";
    }
  }
}

// Stamps on grid points (a simulator's, or a sensor clocked with the controller) at a Unix epoch: each grid
// point is counted once, the one on a message's stamp with that message alone. A quotient stamp / period that
// rounded across an integer counted such points twice or not at all (the share of a 0.5 ms grid over 1 kHz
// messages came out 0.04 % off on a recording).
TEST(MessageNoise, GridPointsOnTheMessagesStampsAreCountedOnce) {
  MessageNoise messages;
  messages.followGrid(0.5e-3, 0.0);
  for (int i = 0; i < 100000; ++i) messages.add(1.7e9 + i * kInterval, smooth(i * kInterval));
  // 1e-4: the stamps themselves are rounded to 0.24 us at 1.7e9 s; the quotient's rounding lost 1600 of the
  // 200000 points and read 1.2e-3 low.
  EXPECT_NEAR(messages.gridShare(), std::sqrt(0.75), 1e-4)
      << "every second point a message, every other a mean";
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
