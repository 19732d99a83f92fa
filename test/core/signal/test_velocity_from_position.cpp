#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "die_cushion_ident/core/signal/velocity_from_position.h"

using die_cushion_ident::CausalVelocity;
using die_cushion_ident::GridSample;
using die_cushion_ident::VelocityFromPosition;

namespace {

constexpr double kDt = 0.002;  // [s] the default grid
constexpr int kHalfWidth = 5;

// A grid sample of a linear encoder: position only, the velocity NaN.
GridSample encoderSample(int k, double x) {
  GridSample g;
  g.t = k * kDt;
  g.x = static_cast<float>(x);
  g.v = NAN;
  g.p = 50e5f;
  return g;
}

}  // namespace

// A ramp's slope is its velocity: the least-squares slope over the centred window recovers it exactly, each
// sample leaving K samples later with every channel of its own instant.
TEST(VelocityFromPosition, ARampGivesItsSlopeKSamplesLater) {
  VelocityFromPosition derive(kHalfWidth);
  std::vector<GridSample> out;
  constexpr double kSpeed = -0.2;  // [m/s] drawing
  for (int k = 0; k < 200; ++k) {
    derive.push(encoderSample(k, 0.1 + kSpeed * k * kDt), &out);
    EXPECT_EQ(out.size(), static_cast<std::size_t>(std::max(0, k + 1 - kHalfWidth))) << "K behind at " << k;
  }
  derive.flush(&out);
  ASSERT_EQ(out.size(), 200u);
  for (std::size_t i = 0; i < out.size(); ++i) {
    EXPECT_DOUBLE_EQ(out[i].t, i * kDt) << "in order, each with its own stamp";
    // float positions: 0.2 m resolved to 1.5e-8 m, over a 20 ms window 1e-6 m/s.
    EXPECT_NEAR(out[i].v, kSpeed, 1e-5) << "one-sided at the ends, centred inside: " << i;
    EXPECT_TRUE(out[i].velocity_derived) << "marked, so that the free run reads the position instead";
  }
  EXPECT_EQ(derive.derived(), 200u);
  EXPECT_EQ(derive.delaySamples(), kHalfWidth);
}

// Position noise alone: sigma_v = sigma_x sqrt(12 / (n (n^2 - 1))) / dt with n = 2K + 1 (the header's
// formula).
TEST(VelocityFromPosition, PositionNoiseGivesTheStatedVelocityNoise) {
  VelocityFromPosition derive(kHalfWidth);
  std::mt19937 rng(11);
  constexpr double kSigmaX = 2e-6;  // [m] an encoder's noise
  std::normal_distribution<double> noise(0.0, kSigmaX);
  std::vector<GridSample> out;
  for (int k = 0; k < 40000; ++k) derive.push(encoderSample(k, 0.05 + noise(rng)), &out);
  double squares = 0.0;
  int n = 0;
  for (std::size_t i = kHalfWidth; i + kHalfWidth < out.size(); ++i) {
    squares += static_cast<double>(out[i].v) * out[i].v;
    ++n;
  }
  const double window = 2 * kHalfWidth + 1;
  const double stated = kSigmaX * std::sqrt(12.0 / (window * (window * window - 1.0))) / kDt;
  EXPECT_NEAR(std::sqrt(squares / n), stated, 0.05 * stated);
}

TEST(VelocityFromPosition, AMeasuredVelocityPassesUnchangedAndUndelayed) {
  VelocityFromPosition derive(kHalfWidth);
  std::vector<GridSample> out;
  for (int k = 0; k < 50; ++k) {
    GridSample g = encoderSample(k, 0.1 + 0.3 * k * kDt);
    g.v = 0.25f;  // the topic's own velocity, deliberately not the slope
    derive.push(g, &out);
    ASSERT_EQ(out.size(), static_cast<std::size_t>(k + 1)) << "nothing waits: no delay";
    EXPECT_EQ(out.back().v, 0.25f);
    EXPECT_FALSE(out.back().velocity_derived);
  }
  EXPECT_EQ(derive.derived(), 0u);
}

// A discontinuity (the bag played again, the grid restarted): the windows do not reach across it, so the jump
// in position between the two stretches is no velocity.
TEST(VelocityFromPosition, TheWindowDoesNotReachAcrossADiscontinuity) {
  VelocityFromPosition derive(kHalfWidth);
  std::vector<GridSample> out;
  for (int k = 0; k < 60; ++k) {
    GridSample g = encoderSample(k, k < 30 ? 0.2 - 0.1 * k * kDt : 0.0 + 0.1 * (k - 30) * kDt);
    g.discontinuity = k == 30;
    derive.push(g, &out);
  }
  derive.flush(&out);
  ASSERT_EQ(out.size(), 60u);
  for (int k = 0; k < 60; ++k) EXPECT_NEAR(out[k].v, k < 30 ? -0.1 : 0.1, 1e-5) << k;
  EXPECT_TRUE(out[30].discontinuity) << "the mark travels with its sample";
}

// The sweep's safety check: the causal slope of raw messages, NaN until it has enough of them, noise not
// taken for motion, out-of-order messages ignored, a gap starting over.
TEST(CausalVelocity, SlopeOfTheLastWindowWithoutNoiseTakenForMotion) {
  CausalVelocity velocity(0.02);
  EXPECT_TRUE(std::isnan(velocity.velocity()));
  velocity.push(0.0, 0.1);
  velocity.push(0.001, 0.1);
  EXPECT_TRUE(std::isnan(velocity.velocity())) << "two messages are no slope";
  for (int i = 2; i < 40; ++i) velocity.push(i * 1e-3, 0.1 + 0.05 * i * 1e-3);
  EXPECT_NEAR(velocity.velocity(), 0.05, 1e-9);
  velocity.push(0.0, 5.0);  // out of order: ignored
  EXPECT_NEAR(velocity.velocity(), 0.05, 1e-9);
  velocity.push(1.0, 0.2);  // after a gap longer than the window: starts again
  EXPECT_TRUE(std::isnan(velocity.velocity()));

  CausalVelocity at_rest(0.02);
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0.0, 2e-6);
  double largest = 0.0;
  for (int i = 0; i < 2000; ++i) {
    at_rest.push(i * 1e-3, 0.1 + noise(rng));
    if (std::isfinite(at_rest.velocity())) largest = std::max(largest, std::abs(at_rest.velocity()));
  }
  EXPECT_LT(largest, 1e-3) << "2 um of noise is not a cushion moving (as a difference: up to 8 mm/s)";
}
