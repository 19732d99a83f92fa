#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "die_cushion_ident/core/signal/message_noise.h"
#include "die_cushion_ident/core/signal/uniform_resampler.h"

using die_cushion_ident::GridSample;
using die_cushion_ident::InputStream;
using die_cushion_ident::MessageNoise;
using die_cushion_ident::UniformResampler;
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
  EXPECT_NEAR(messages.forGrid(2e-3), kSigma, 0.05 * kSigma)
      << "samples two messages apart share two of the cubic's four: the sensor's";
  EXPECT_EQ(messages.forGrid(4e-3), 0.0) << "samples four messages apart share none: the grid's own estimate";
}

// What each grid sample holds, measured on the resampler's own grid (pure noise as the pressure): a sample
// on a message holds its sigma, one between two messages the cubic's weighted four (0.64 of the variance
// at the middle). The grid's second differences see far less; the samples' own spread is the reference, on
// grids at 0.5, 1 and 2 ms, on the messages and between them (grid_phase).
TEST(MessageNoise, AFollowedGridIsJudgedByTheNoiseItsSamplesHold) {
  for (const double period : {0.5e-3, 1e-3, 2e-3}) {
    for (const double phase : {0.0, 0.35e-3}) {
      std::mt19937 rng(9);
      std::normal_distribution<double> noise(0.0, kSigma);
      std::normal_distribution<double> jitter(0.0, 50e-6);  // the simulator's sampling jitter
      MessageNoise messages;
      messages.followGrid(period, 0.0, phase);
      UniformResampler::Config config;
      config.sample_period = period;
      config.grid_phase = phase;
      UniformResampler resampler(config);
      std::vector<GridSample> grid;
      for (int i = 0; i < 40000; ++i) {
        const double stamp = i * kInterval + jitter(rng), n = noise(rng);
        messages.add(stamp, n);
        resampler.push(InputStream::kPressure, {stamp, n, NAN}, &grid);
        resampler.push(InputStream::kPosition, {i * kInterval, 0.1, 0.0}, &grid);
        resampler.push(InputStream::kValve, {i * kInterval, 0.0, 0.0}, &grid);
      }
      double sum_squares = 0.0;
      for (const GridSample& g : grid) sum_squares += static_cast<double>(g.p) * g.p;
      const double held_rms = std::sqrt(sum_squares / static_cast<double>(grid.size()));
      EXPECT_NEAR(messages.forGrid(period), held_rms, 0.03 * kSigma) << period << " phase " << phase;
      if (period == 0.5e-3) {
        EXPECT_NEAR(messages.gridShare(), std::sqrt(0.5 * (1.0 + 0.640625)), 0.02) << "a message, a middle";
      } else if (phase == 0.0) {
        EXPECT_GT(messages.gridShare(), 0.9) << "50 us of jitter against 1 ms: mostly a message";
      } else {
        EXPECT_LT(messages.gridShare(), 0.9) << "0.35 of the way between messages";
      }
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
  EXPECT_NEAR(messages.gridShare(), std::sqrt(0.5 * (1.0 + 0.640625)), 1e-4)
      << "every second point a message, every other the cubic's middle";
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
