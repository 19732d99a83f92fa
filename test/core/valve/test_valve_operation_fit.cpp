// The valve model from ordinary operation (fitValveToOperation) and the exact propagation it runs
// (ServoValve::exact): the free run is driven by this model's spool, so it must be the valve's.
#include <gtest/gtest.h>

#include <cmath>
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
