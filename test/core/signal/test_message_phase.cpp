// Where within a period a stream's messages fall (messagePhase): the phase the grid's points are put on.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "die_cushion_ident/core/signal/message_phase.h"

using die_cushion_ident::MessagePhase;
using die_cushion_ident::messagePhase;

namespace {
constexpr double kPeriod = 1e-3;  // [s] 1 kHz messages
constexpr double kEpoch = 1.7e9;  // [s] a Unix stamp

std::vector<double> stamps(double phase, double jitter, double period, int count, unsigned seed = 1) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, jitter);
  std::vector<double> out;
  for (int i = 0; i < count; ++i)
    out.push_back(kEpoch + i * period + phase + (jitter > 0.0 ? noise(rng) : 0.0));
  return out;
}
}  // namespace

// At a Unix epoch, with the simulator's 50 us of jitter: the phase to a few microseconds, the coherence what
// the jitter leaves (exp(-(2 pi 0.05)^2 / 2) = 0.952).
TEST(MessagePhase, FindsThePhaseOfJitteredMessagesAtAUnixEpoch) {
  for (const double phase : {0.0, 0.35e-3, 0.7e-3}) {
    const MessagePhase found = messagePhase(stamps(phase, 50e-6, kPeriod, 10000), kPeriod);
    EXPECT_NEAR(std::remainder(found.phase - phase, kPeriod), 0.0, 3e-6) << phase;
    EXPECT_NEAR(found.coherence, std::exp(-0.5 * std::pow(2.0 * M_PI * 0.05, 2)), 0.01);
    EXPECT_GE(found.phase, 0.0);
    EXPECT_LT(found.phase, kPeriod);
  }
}

// Stamps on both sides of the period's end: the circular mean (near 0 or the period), not the plain mean
// of the remainders (half the period).
TEST(MessagePhase, StampsAcrossThePeriodsEndAverageToItsEnd) {
  std::vector<double> across;
  for (int i = 0; i < 1000; ++i) across.push_back(kEpoch + i * kPeriod + (i % 2 == 0 ? 20e-6 : -20e-6));
  const MessagePhase found = messagePhase(across, kPeriod);
  EXPECT_NEAR(std::remainder(found.phase, kPeriod), 0.0, 1e-6);
  EXPECT_GT(found.coherence, 0.95);
}

// Messages whose rate is off the period turn their phase over the stamps: no phase to keep. A message every
// second period (500 Hz against 1 ms) keeps it; so do dropped messages.
TEST(MessagePhase, ARateOffThePeriodHasNoPhaseAndASubmultipleOrADroppedMessageKeepsIt) {
  EXPECT_LT(messagePhase(stamps(0.0, 0.0, 1.0001e-3, 20000), kPeriod).coherence, 0.2);
  const MessagePhase half_rate = messagePhase(stamps(0.4e-3, 10e-6, 2e-3, 5000), kPeriod);
  EXPECT_GT(half_rate.coherence, 0.99);
  EXPECT_NEAR(half_rate.phase, 0.4e-3, 2e-6);
  std::vector<double> dropped = stamps(0.2e-3, 0.0, kPeriod, 1000);
  dropped.erase(dropped.begin() + 500, dropped.begin() + 510);
  EXPECT_NEAR(messagePhase(dropped, kPeriod).phase, 0.2e-3, 1e-6);
}

TEST(MessagePhase, TooFewStampsOrNoPeriodGiveNoCoherence) {
  EXPECT_EQ(messagePhase({}, kPeriod).coherence, 0.0);
  EXPECT_EQ(messagePhase({kEpoch, kEpoch + kPeriod}, kPeriod).coherence, 0.0);
  EXPECT_EQ(messagePhase(stamps(0.0, 0.0, kPeriod, 100), 0.0).coherence, 0.0);
  EXPECT_EQ(messagePhase(stamps(0.0, 0.0, kPeriod, 100), std::nan("")).coherence, 0.0);
  EXPECT_EQ(messagePhase({NAN, kEpoch, INFINITY}, kPeriod).coherence, 0.0);
}
