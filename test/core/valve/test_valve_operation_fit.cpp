// The valve model from ordinary operation (fitValveToOperation) and the exact propagation it runs
// (ServoValve::exact): the free run is driven by this model's spool, so it must be the valve's.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>

#include "die_cushion_ident/core/simulation/press_class.h"
#include "die_cushion_ident/core/valve/valve_operation_fit.h"

using namespace die_cushion_ident;

// Between command switches the linear model has a closed-form solution; RK4 at 10 us must agree with it.
TEST(ServoValve, TheExactPropagationAgreesWithFineRungeKutta) {
  for (double damping : {0.4, 1.0, 1.6}) {
    ServoValveParameters p;
    p.natural_frequency = 120.0;
    p.damping = damping;
    p.dead_time = 0.0013;
    ServoValve exact = ServoValve::exact(p), fine(p, 1e-5);
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> command(-5.0, 5.0);
    double largest = 0.0;
    for (int k = 0; k < 2000; ++k) {
      const double u = command(rng);
      const double dt = 0.001 + 0.0002 * std::sin(k);  // uneven intervals, as recorded stamps are
      largest = std::max(largest, std::abs(exact.advance(dt, u) - fine.advance(dt, u)));
    }
    EXPECT_LT(largest, 1e-5) << "damping " << damping;
  }
}

// Each class's valve, fitted to 8 press cycles of its own operation (no sweep), from the default model's
// start (80 Hz, 2 ms): natural frequency and dead time within 5 % and 10 %, and the spool explained to the
// sensor's noise.
TEST(ValveOperationFit, RecoversEachClassesValveFromItsOperation) {
  for (PressClass press : allPressClasses()) {
    SCOPED_TRACE(pressClassName(press));
    const SimulatorConfig plant = pressClassPlant(press, 2);
    DieCushionSimulator simulator(plant);
    std::vector<SimulatedMeasurement> messages;
    simulator.run(8 * simulator.program().cycleDuration(), &messages);
    std::vector<ValveSample> valve;
    for (const auto& m : messages) {
      if (m.stream == InputStream::kValve) valve.push_back({m.sample.stamp, m.sample.first, m.sample.second});
    }
    const ValveOperationFit fit = fitValveToOperation(valve, ServoValveParameters());
    ASSERT_TRUE(fit.success) << fit.message;
    EXPECT_NEAR(fit.parameters.natural_frequency / plant.valve.natural_frequency, 1.0, 0.05) << fit.message;
    EXPECT_NEAR(fit.parameters.dead_time / plant.valve.dead_time, 1.0, 0.1) << fit.message;
    EXPECT_NEAR(fit.parameters.gain / plant.valve.gain, 1.0, 0.01) << fit.message;
    EXPECT_LT(fit.residual_rms, 1.1 * fit.noise_sigma) << fit.message;
  }
}

// A valve reported at half its amplifier's rate (a 1 kHz controller, the spool read at every second command):
// the commands without a spool reading still drive the model (NaN spool), and the fit finds the valve; the
// same messages without those commands (each reported one held to the next, as the topic shows them) give a
// valve the hold has bent. Two classes: the fast press's valve and the small stiff press's.
TEST(ValveOperationFit, CommandsWithoutASpoolReadingDriveTheModel) {
  for (PressClass press : {PressClass::kFastMechanical, PressClass::kSmallStiff}) {
    SCOPED_TRACE(pressClassName(press));
    const SimulatorConfig plant = pressClassPlant(press, 3);
    DieCushionSimulator simulator(plant);
    std::vector<SimulatedMeasurement> messages;
    simulator.run(8 * simulator.program().cycleDuration(), &messages);
    std::vector<ValveSample> every_command, reported;
    for (const auto& m : messages) {
      if (m.stream != InputStream::kValve) continue;
      ValveSample s{m.sample.stamp, m.sample.first, m.sample.second};
      if (every_command.size() % 2 == 1) s.spool = std::numeric_limits<double>::quiet_NaN();
      every_command.push_back(s);
      if (std::isfinite(s.spool)) reported.push_back(s);
    }
    const ValveOperationFit fit = fitValveToOperation(every_command, ServoValveParameters(), 0.02, 30000);
    ASSERT_TRUE(fit.success) << fit.message;
    EXPECT_EQ(fit.samples, static_cast<int>(reported.size())) << "the spool readings, not the commands";
    EXPECT_NEAR(fit.parameters.natural_frequency / plant.valve.natural_frequency, 1.0, 0.05) << fit.message;
    EXPECT_NEAR(fit.parameters.dead_time / plant.valve.dead_time, 1.0, 0.1) << fit.message;
    const ValveOperationFit held = fitValveToOperation(reported, ServoValveParameters());
    std::printf(
        "%s: true %.1f Hz %.3f ms; every command %.1f Hz %.3f ms; reported ones held %.1f Hz %.3f ms\n",
        pressClassName(press), plant.valve.natural_frequency, 1e3 * plant.valve.dead_time,
        fit.parameters.natural_frequency, 1e3 * fit.parameters.dead_time, held.parameters.natural_frequency,
        1e3 * held.parameters.dead_time);
    EXPECT_GT(std::abs(held.parameters.dead_time / plant.valve.dead_time - 1.0), 0.2)
        << "the commands between the readings matter: without them the dead time is bent";
  }
}

// Too little to fit: a few messages, or a spool that never moves, say why and keep the start.
TEST(ValveOperationFit, RefusesWhatCannotBeFitted) {
  std::vector<ValveSample> few;
  for (int k = 0; k < 50; ++k) few.push_back({k * 0.001, 0.0, 0.0});
  ValveOperationFit fit = fitValveToOperation(few, ServoValveParameters());
  EXPECT_FALSE(fit.success);
  EXPECT_NE(fit.message.find("too few"), std::string::npos) << fit.message;
  std::vector<ValveSample> still;
  std::mt19937 rng(1);
  std::normal_distribution<double> noise(0.0, 0.002);
  for (int k = 0; k < 3000; ++k) still.push_back({k * 0.001, 0.0, noise(rng)});
  fit = fitValveToOperation(still, ServoValveParameters());
  EXPECT_FALSE(fit.success);
  EXPECT_NE(fit.message.find("hardly moved"), std::string::npos) << fit.message;
  EXPECT_DOUBLE_EQ(fit.parameters.natural_frequency, ServoValveParameters().natural_frequency);
}

namespace {

// 10 s at 1 kHz of commands the simulated presses do not make (random steps of 20-80 ms and a 7 Hz sine) and
// the valve's spool under them, measured with 0.002 of noise; `commands` and `sensor` may be one generator.
std::vector<ValveSample> randomOperation(const ServoValveParameters& truth, std::mt19937& commands,
                                         std::mt19937& sensor) {
  ServoValve valve(truth, 1e-5);
  std::uniform_real_distribution<double> level(-4.0, 4.0), hold(0.02, 0.08);
  std::normal_distribution<double> noise(0.0, 0.002);
  std::vector<ValveSample> samples;
  double step = 0.0, next_step = 0.0;
  for (int k = 0; k < 10000; ++k) {
    const double t = 0.001 * k;
    if (t >= next_step) {
      step = level(commands);
      next_step = t + hold(commands);
    }
    const double u = step + 2.0 * std::sin(2.0 * M_PI * 7.0 * t);
    samples.push_back({t, u, valve.position() + noise(sensor)});
    valve.advance(0.001, u);
  }
  return samples;
}

}  // namespace

// Valves unlike any press class's and unlike the default start (80 Hz, damping 0.7, 2 ms), under commands
// the simulated presses do not make (random steps and a slow sine, 10 s at 1 kHz, the spool measured with
// 0.002 of noise): the start screen must find each one's basin, not the local minimum where the natural
// frequency trades against the dead time.
TEST(ValveOperationFit, FindsValvesUnlikeTheStartFromRandomCommands) {
  struct Valve {
    double frequency, damping, dead_time;
  };
  for (const Valve& v : {Valve{300.0, 0.45, 0.0003}, Valve{35.0, 1.1, 0.005}, Valve{164.0, 0.7, 0.00085},
                         Valve{120.0, 0.6, 0.0}, Valve{60.0, 0.9, 0.0035}}) {
    SCOPED_TRACE(std::to_string(v.frequency) + " Hz, dead time " + std::to_string(1e3 * v.dead_time) + " ms");
    ServoValveParameters truth;
    truth.natural_frequency = v.frequency;
    truth.damping = v.damping;
    truth.dead_time = v.dead_time;
    std::mt19937 rng(7);
    const ValveOperationFit fit = fitValveToOperation(randomOperation(truth, rng, rng), ServoValveParameters());
    ASSERT_TRUE(fit.success) << fit.message;
    EXPECT_NEAR(fit.parameters.natural_frequency / v.frequency, 1.0, 0.03) << fit.message;
    EXPECT_NEAR(fit.parameters.damping / v.damping, 1.0, 0.05) << fit.message;
    EXPECT_NEAR(fit.parameters.dead_time, v.dead_time, 5e-5) << fit.message;
    EXPECT_LT(fit.residual_rms, 1.05 * fit.noise_sigma) << fit.message;
  }
}

// The fit's covariance against the scatter of its estimates over the spool sensor's noise: two valves (a
// fast press's and a slow one's), random commands (10 s at 1 kHz), ten noise draws each. Per parameter the
// rms of (estimate - truth) / std over the twenty fits lies within 0.5-2 (a calibrated std gives 1; 20
// draws put 95 % of rms values within about 0.7-1.3; over 40 draws: natural frequency 1.08, damping 1.11,
// gain 0.78, dead time 1.08), and the covariance is positive definite: it is what the valve model's part of
// the hydraulic parameters' stds is made from.
TEST(ValveOperationFit, ItsCovarianceMatchesTheScatterOverTheSpoolsNoise) {
  struct Valve {
    double frequency, damping, dead_time;
  };
  std::array<double, 4> squares = {0.0, 0.0, 0.0, 0.0};
  int fits = 0;
  for (const Valve& v : {Valve{164.0, 0.7, 0.00085}, Valve{60.0, 0.9, 0.0035}}) {
    ServoValveParameters truth;
    truth.natural_frequency = v.frequency;
    truth.damping = v.damping;
    truth.dead_time = v.dead_time;
    for (unsigned seed = 1; seed <= 10; ++seed) {
      SCOPED_TRACE(std::to_string(v.frequency) + " Hz, noise seed " + std::to_string(seed));
      std::mt19937 commands(7), sensor(seed);
      const ValveOperationFit fit =
          fitValveToOperation(randomOperation(truth, commands, sensor), ServoValveParameters());
      ASSERT_TRUE(fit.success) << fit.message;
      const Eigen::SelfAdjointEigenSolver<Eigen::Matrix4d> eigen(fit.covariance);
      ASSERT_GT(eigen.eigenvalues().minCoeff(), 0.0) << fit.covariance;
      const std::array<double, 4> errors = {
          fit.parameters.natural_frequency - truth.natural_frequency, fit.parameters.damping - truth.damping,
          fit.parameters.gain - truth.gain, fit.parameters.dead_time - truth.dead_time};
      for (int i = 0; i < 4; ++i) squares[i] += errors[i] * errors[i] / fit.covariance(i, i);
      ++fits;
    }
  }
  const char* names[] = {"natural_frequency", "damping", "gain", "dead_time"};
  for (int i = 0; i < 4; ++i) {
    const double rms = std::sqrt(squares[i] / fits);
    EXPECT_GT(rms, 0.5) << names[i];
    std::printf("%s: rms of error / std %.2f over %d fits\n", names[i], rms, fits);
    EXPECT_LT(rms, 2.0) << names[i];
  }
}
