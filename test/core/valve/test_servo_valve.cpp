#include <gtest/gtest.h>

#include <cmath>
#include <limits>

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

// The spool's integral over time, which the resampler turns into the model spool's mean over each grid
// interval (GridSample::y_model_mean): the exact propagation's closed form agrees with a fine quadrature of
// its own positions across commands that switch inside the stretches, and with RK4's quadrature, for a valve
// under and over critical damping.
TEST(ServoValve, IntegratesItsSpoolOverTime) {
  for (const double damping : {0.7, 1.4}) {
    SCOPED_TRACE(damping);
    ServoValveParameters p;
    p.natural_frequency = 180.0;
    p.damping = damping;
    p.dead_time = 7.5e-4;  // the delayed switches fall inside the 1 ms stretches
    ServoValve exact = ServoValve::exact(p);
    ServoValve integrated(p, 1e-6);
    ServoValve fine = ServoValve::exact(p);
    double quadrature = 0.0;
    for (int k = 0; k < 200; ++k) {
      const double u = 2.0 * std::sin(2.0 * M_PI * 40.0 * 1e-3 * k) + (k % 7 == 0 ? 1.0 : 0.0);
      exact.advance(1e-3, u);
      integrated.advance(1e-3, u);
      for (int i = 0; i < 1000; ++i) {  // the trapezoid at 1 us: its error is far below the bound below
        const double before = fine.position();
        fine.advance(1e-6, i == 0 ? u : std::numeric_limits<double>::quiet_NaN());
        quadrature += 0.5e-6 * (before + fine.position());
      }
    }
    // 0.2 s of a spool swinging +-0.2: the integral is of the order of 1e-2 s.
    EXPECT_NEAR(exact.integral(), quadrature, 1e-8);
    EXPECT_NEAR(integrated.integral(), quadrature, 1e-8);
    exact.reset(0.1);
    EXPECT_EQ(exact.integral(), 0.0) << "reset starts the integral again";
  }
}

// A spool held at its mechanical stop averages exactly the stop: the integral follows the clamped position
// (RK4's stages unclamped had averaged up to 1.0055 over 1 ms on a 300 Hz valve driven to twice its range).
TEST(ServoValve, ASpoolAtItsStopIntegratesToTheStop) {
  for (const double frequency : {80.0, 200.0, 300.0}) {
    ServoValveParameters p;
    p.natural_frequency = frequency;
    p.gain = 0.2;
    ServoValve valve = ServoValve::exact(p);
    valve.reset(1.0);
    for (int k = 0; k < 20; ++k) valve.advance(1e-3, 10.0);  // K u = 2: pinned at the stop
    const double before = valve.integral();
    valve.advance(1e-3, 10.0);
    EXPECT_NEAR((valve.integral() - before) / 1e-3, 1.0, 1e-12) << frequency << " Hz";
  }
}
