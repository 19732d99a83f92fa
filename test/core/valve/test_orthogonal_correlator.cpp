// The correlator against signals whose Fourier coefficients are known exactly, the noise figure against
// Monte-Carlo, and the frequency-point estimator against the analytic response of a held command.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "die_cushion_ident/core/valve/frequency_response.h"
#include "die_cushion_ident/core/valve/orthogonal_correlator.h"
#include "die_cushion_ident/core/valve/servo_valve.h"
#include "die_cushion_ident/core/valve/servo_valve_fit.h"

namespace die_cushion_ident {
namespace {

TEST(OrthogonalCorrelator, RecoversMeanFundamentalAndHarmonicsExactly) {
  const double f = 30.0;  // 33.3 samples per period at 1 kHz: no whole number of samples per period
  OrthogonalCorrelator c(f, 3, 0.2);
  std::mt19937 rng(3);
  std::normal_distribution<double> jitter(0.0, 5e-5);
  for (int i = 0; i < 700; ++i) {
    const double t = 0.2 + i * 1e-3 + jitter(rng);
    const double w = 2 * M_PI * f * (t - 0.2);
    c.add(t, 4.0 + 0.5 * std::sin(w) - 0.2 * std::cos(w) + 0.05 * std::sin(3 * w + 0.4));
  }
  c.solve();
  EXPECT_NEAR(c.mean(), 4.0, 1e-10);
  EXPECT_NEAR(c.phasor(1).real(), 0.5, 1e-10);
  EXPECT_NEAR(c.phasor(1).imag(), -0.2, 1e-10);
  EXPECT_NEAR(std::abs(c.phasor(2)), 0.0, 1e-10);
  EXPECT_NEAR(std::abs(c.phasor(3)), 0.05, 1e-10);
  EXPECT_NEAR(std::arg(c.phasor(3)), 0.4, 1e-8);
  EXPECT_LT(c.residualVariance(), 1e-12 * c.acVariance());  // round-off only
}

TEST(OrthogonalCorrelator, WholePeriodsOnAUniformGridEqualTheClassicCorrelation) {
  const double f = 25.0;  // 40 samples per period
  OrthogonalCorrelator c(f, 1, 0.0);
  double classic_re = 0.0, classic_im = 0.0;
  const int n = 400;  // 10 periods
  for (int i = 0; i < n; ++i) {
    const double t = i * 1e-3;
    const double value = 0.3 * std::sin(2 * M_PI * f * t + 0.7) + 0.01 * std::sin(2 * M_PI * 90 * t);
    c.add(t, value);
    classic_re += 2.0 / n * value * std::sin(2 * M_PI * f * t);
    classic_im += 2.0 / n * value * std::cos(2 * M_PI * f * t);
  }
  c.solve();
  EXPECT_NEAR(c.phasor(1).real(), classic_re, 1e-12);
  EXPECT_NEAR(c.phasor(1).imag(), classic_im, 1e-12);
}

TEST(OrthogonalCorrelator, ReportedPhasorVarianceMatchesMonteCarlo) {
  const double sigma = 0.01;
  std::mt19937 rng(11);
  std::normal_distribution<double> noise(0.0, sigma);
  double sum = 0.0, sum_squares = 0.0, reported = 0.0;
  const int trials = 400;
  for (int trial = 0; trial < trials; ++trial) {
    OrthogonalCorrelator c(40.0, 3, 0.0);
    for (int i = 0; i < 500; ++i) c.add(i * 1e-3, 0.1 * std::sin(2 * M_PI * 40.0 * i * 1e-3) + noise(rng));
    c.solve();
    sum += c.phasor(1).real();
    sum_squares += c.phasor(1).real() * c.phasor(1).real();
    reported += c.phasorComponentVariance(1) / trials;
  }
  const double empirical = sum_squares / trials - (sum / trials) * (sum / trials);
  EXPECT_NEAR(empirical / reported, 1.0, 0.2);  // 400 trials: the variance ratio is known to about 7 %
  EXPECT_NEAR(reported, 2.0 * sigma * sigma / 500, 0.1 * 2.0 * sigma * sigma / 500);
}

TEST(OrthogonalCorrelator, IgnoresNonFiniteSamplesAndRejectsBadSetup) {
  OrthogonalCorrelator c(10.0, 1, 0.0);
  c.add(0.0, std::nan(""));
  c.add(std::numeric_limits<double>::infinity(), 1.0);
  EXPECT_EQ(c.samples(), 0);
  EXPECT_FALSE(c.solvable());
  EXPECT_THROW(OrthogonalCorrelator(0.0, 1, 0.0), std::invalid_argument);
  EXPECT_THROW(OrthogonalCorrelator(std::nan(""), 1, 0.0), std::invalid_argument);
  EXPECT_THROW(OrthogonalCorrelator(10.0, 0, 0.0), std::invalid_argument);
  EXPECT_THROW(OrthogonalCorrelator(10.0, 9, 0.0), std::invalid_argument);
}

// A valve driven by a command held for 1 ms, as the sweep drives it: the point must match the valve's own
// analytic response, i.e. the hold's half-period lag (0.5 ms, 29 degrees at 160 Hz) is removed.
TEST(FrequencyPointEstimator, RemovesTheCommandHoldAndMatchesTheAnalyticResponse) {
  ServoValveParameters truth;
  truth.natural_frequency = 90.0;
  truth.damping = 0.6;
  truth.gain = 0.12;
  truth.dead_time = 0.0015;
  for (double f : {10.0, 60.0, 160.0}) {
    ServoValve valve(truth, 1e-5);
    FrequencyPointEstimator::Options options;
    options.command_hold = 1e-3;
    FrequencyPointEstimator estimator(f, 0.2, 20, options);
    for (int k = 0; !estimator.complete(); ++k) {
      const double t = k * 1e-3;
      const double u = 0.5 * std::sin(2 * M_PI * f * t);
      estimator.add(t, u, valve.position());  // spool sampled at the update, command in force from t on
      valve.advance(1e-3, u);
    }
    const auto point = estimator.result();
    const auto expected = servoValveResponse(truth, f);
    // What is left is aliasing: the staircase's image at 1000 - f Hz passes the valve attenuated and the
    // 1 kHz spool sampling folds it onto f (0.2 % and 3.5 mrad = 3 us of dead time at 160 Hz).
    EXPECT_NEAR(point.magnitude / std::abs(expected), 1.0, 5e-3) << f << " Hz";
    EXPECT_NEAR(wrapAngle(point.phase - std::arg(expected)), 0.0, 5e-3) << f << " Hz";
    EXPECT_FALSE(point.distorted);
    EXPECT_LT(point.convergence, 1e-3);
    EXPECT_EQ(static_cast<int>(point.history.size()), 19);  // one per period; the last is the result
  }
}

TEST(FrequencyResponse, UnwrapPhasesFollowsADeadTimeBeyondPi) {
  std::vector<FrequencyResponsePoint> points;
  for (int i = 1; i <= 16; ++i) {
    FrequencyResponsePoint p;
    p.frequency = 10.0 * i;
    p.phase = wrapAngle(-2 * M_PI * p.frequency * 0.004);  // 4 ms: -4.0 rad at 160 Hz
    points.push_back(p);
  }
  std::reverse(points.begin(), points.end());
  unwrapPhases(&points);
  for (const auto& p : points) EXPECT_NEAR(p.phase, -2 * M_PI * p.frequency * 0.004, 1e-12);
}

}  // namespace
}  // namespace die_cushion_ident
