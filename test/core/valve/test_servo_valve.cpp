#include <gtest/gtest.h>

#include <cmath>

#include "die_cushion_ident/core/valve/servo_valve.h"

using namespace die_cushion_ident;

TEST(ServoValve, RejectsNonPhysicalParameters) {
  ServoValveParameters p;
  p.natural_frequency = 0.0;
  EXPECT_THROW(ServoValve{p}, std::invalid_argument);
  p = {};
  p.damping = -0.1;
  EXPECT_THROW(ServoValve{p}, std::invalid_argument);
  p = {};
  p.dead_time = -1e-3;
  EXPECT_THROW(ServoValve{p}, std::invalid_argument);
}

TEST(ServoValve, StepResponseWaitsTheDeadTimeAndSettlesAtGainTimesVoltage) {
  ServoValve valve({80.0, 0.7, 0.1, 0.002});
  for (int k = 0; k < 19; ++k) valve.advance(1e-4, 5.0);
  EXPECT_NEAR(valve.position(), 0.0, 1e-12) << "nothing moves within the 2 ms dead time";
  for (int k = 0; k < 2000; ++k) valve.advance(1e-4, 5.0);
  EXPECT_NEAR(valve.position(), 0.5, 1e-6);
}

TEST(ServoValve, FrequencyResponseAtTheNaturalFrequency) {
  // At w0 the 2nd-order magnitude is K / (2 D) and the phase -90 deg minus the dead time's w0 * T.
  const double f0 = 80.0, D = 0.7, K = 0.1, T = 0.002, amplitude = 1.0;
  ServoValve valve({f0, D, K, T});
  const double dt = 1e-5, w = 2 * M_PI * f0;
  double re = 0, im = 0;
  const int settle = static_cast<int>(0.5 / dt), periods = 20;
  const int n = static_cast<int>(periods / f0 / dt);
  for (int k = 0; k < settle + n; ++k) {
    const double t = k * dt;
    const double y = valve.advance(dt, amplitude * std::sin(w * t));
    if (k >= settle) {
      const double tm = t + dt;  // the position returned is at the end of the step
      re += y * std::sin(w * tm);
      im += y * std::cos(w * tm);
    }
  }
  const double magnitude = 2.0 * std::hypot(re, im) / n;
  const double phase = std::atan2(im, re);
  EXPECT_NEAR(magnitude, K / (2 * D) * amplitude, 1e-3);
  EXPECT_NEAR(phase, -M_PI / 2 - w * T, 0.01);
}

TEST(ServoValve, SpoolStopsAtItsEndsAndRespectsTheVelocityLimit) {
  ServoValveParameters p{80.0, 0.7, 0.1, 0.0, 20.0};
  ServoValve valve(p);
  double previous = 0.0, fastest = 0.0;
  for (int k = 0; k < 3000; ++k) {
    valve.advance(1e-4, 50.0);  // asks for 5x full stroke
    fastest = std::max(fastest, (valve.position() - previous) / 1e-4);
    previous = valve.position();
    EXPECT_LE(valve.position(), 1.0);
  }
  EXPECT_DOUBLE_EQ(valve.position(), 1.0);
  EXPECT_LE(fastest, 20.0 * (1 + 1e-9));
}

// The regressor's sample-by-sample valve (bilinear transform, dead time in whole samples) follows the exact
// integration within 2.5 % of its swing on the 2 ms grid (a command ramped as the grid interpolates it), and
// settles at gain x voltage.
TEST(SampledServoValve, FollowsTheIntegratedValveOnTheGrid) {
  ServoValveParameters p;
  const double dt = 0.002;
  ServoValve exact(p);
  SampledServoValve sampled(p, dt);
  sampled.reset(0.0);
  double worst = 0.0;
  for (int k = 0; k < 200; ++k) {
    // The grid's command is interpolated between samples, as the bilinear transform assumes.
    const double u = k < 100 ? 0.02 * std::min(k, 100) : 2.0 - 0.03 * (k - 100);
    worst = std::max(worst, std::abs(sampled.step(u) - exact.position()));  // both at this sample's time
    exact.advance(dt, u);
  }
  EXPECT_LT(worst, 0.005) << "within 2.5 % of the 0.2 swing (measured 0.0021)";
  for (int k = 0; k < 50; ++k) sampled.step(-1.0);
  EXPECT_NEAR(sampled.step(-1.0), -0.1, 1e-6) << "settles at gain x voltage";
  // reset() starts at rest where it is told.
  sampled.reset(0.05);
  EXPECT_NEAR(sampled.step(0.5), 0.05, 1e-9);
}
