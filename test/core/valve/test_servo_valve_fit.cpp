// The valve model fit on synthetic frequency responses with known truth and noise.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "die_cushion_ident/core/valve/servo_valve_fit.h"

namespace die_cushion_ident {
namespace {

std::vector<FrequencyResponsePoint> pointsOf(const ServoValveParameters& truth, double relative_noise,
                                             unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, relative_noise);
  std::vector<FrequencyResponsePoint> points;
  for (int f = 10; f <= 160; f += 10) {
    const auto g = servoValveResponse(truth, f) * std::complex<double>(1.0 + noise(rng), noise(rng));
    FrequencyResponsePoint p;
    p.frequency = f;
    p.re = g.real();
    p.im = g.imag();
    p.magnitude = std::abs(g);
    p.phase = std::arg(g);
    p.magnitude_std = relative_noise * p.magnitude;
    p.phase_std = relative_noise;
    points.push_back(p);
  }
  return points;
}

ServoValveParameters valve(double f0, double damping, double gain, double dead_time) {
  ServoValveParameters p;
  p.natural_frequency = f0;
  p.damping = damping;
  p.gain = gain;
  p.dead_time = dead_time;
  return p;
}

TEST(ServoValveFit, RecoversExactParametersFromNoiseFreePoints) {
  for (const auto& truth :
       {valve(50, 0.5, 0.1, 0.003), valve(120, 0.9, 0.2, 0.001), valve(80, 0.7, 0.1, 0.002)}) {
    const auto fit = fitServoValve(pointsOf(truth, 0.0, 1));
    ASSERT_TRUE(fit.success) << fit.message;
    EXPECT_NEAR(fit.parameters.natural_frequency / truth.natural_frequency, 1.0, 1e-6);
    EXPECT_NEAR(fit.parameters.damping / truth.damping, 1.0, 1e-6);
    EXPECT_NEAR(fit.parameters.gain / truth.gain, 1.0, 1e-6);
    EXPECT_NEAR(fit.parameters.dead_time, truth.dead_time, 1e-8);
    EXPECT_EQ(fit.points_used, 16);
  }
}

// With 1 % noise per point the reported standard deviations must cover the error (3 sigma) and be of the
// right size: over 200 noisy sweeps the scatter of the estimates matches the mean reported std within 30 %.
TEST(ServoValveFit, ReportedUncertaintyMatchesTheScatter) {
  const auto truth = valve(80, 0.7, 0.1, 0.002);
  double f0_sum = 0, f0_squares = 0, f0_std = 0, td_sum = 0, td_squares = 0, td_std = 0;
  const int trials = 200;
  for (int seed = 0; seed < trials; ++seed) {
    const auto fit = fitServoValve(pointsOf(truth, 0.01, seed));
    ASSERT_TRUE(fit.success);
    EXPECT_LT(std::abs(fit.parameters.natural_frequency - 80.0), 5 * fit.natural_frequency_std);
    f0_sum += fit.parameters.natural_frequency;
    f0_squares += fit.parameters.natural_frequency * fit.parameters.natural_frequency;
    f0_std += fit.natural_frequency_std / trials;
    td_sum += fit.parameters.dead_time;
    td_squares += fit.parameters.dead_time * fit.parameters.dead_time;
    td_std += fit.dead_time_std / trials;
  }
  const double f0_scatter = std::sqrt(f0_squares / trials - std::pow(f0_sum / trials, 2));
  const double td_scatter = std::sqrt(td_squares / trials - std::pow(td_sum / trials, 2));
  EXPECT_NEAR(f0_scatter / f0_std, 1.0, 0.3);
  EXPECT_NEAR(td_scatter / td_std, 1.0, 0.3);
}

TEST(ServoValveFit, LeavesOutDistortedPointsAndHandlesInvertedPolarity) {
  auto truth = valve(70, 0.6, -0.1, 0.002);
  auto points = pointsOf(truth, 0.0, 1);
  points[15].magnitude *= 0.5;  // a saturated point, flagged
  points[15].distorted = true;
  const auto fit = fitServoValve(points);
  ASSERT_TRUE(fit.success);
  EXPECT_EQ(fit.points_rejected, 1);
  EXPECT_NEAR(fit.parameters.gain, -0.1, 1e-7);
  EXPECT_NEAR(fit.parameters.natural_frequency, 70.0, 1e-4);
  EXPECT_NEAR(fit.parameters.dead_time, 0.002, 1e-8);
}

TEST(ServoValveFit, RefusesTooFewPointsWithAReason) {
  auto points = pointsOf(valve(80, 0.7, 0.1, 0.002), 0.0, 1);
  points.resize(4);
  const auto fit = fitServoValve(points);
  EXPECT_FALSE(fit.success);
  EXPECT_NE(fit.message.find("at least 5"), std::string::npos) << fit.message;
  EXPECT_FALSE(fitServoValve({}).success);
}

}  // namespace
}  // namespace die_cushion_ident
