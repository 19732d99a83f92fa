#include <gtest/gtest.h>

#include <cmath>
#include <map>

#include "die_cushion_ident/core/simulation/die_cushion_simulator.h"

using namespace die_cushion_ident;

TEST(DieCushionSimulator, RejectsUnknownParametersAndBadSteps) {
  SimulatorConfig c;
  c.parameters["bulk_modulos"] = 1e9;
  EXPECT_THROW(DieCushionSimulator{c}, std::invalid_argument) << "a typo in a true parameter must not pass";
  c = {};
  c.parameters["leakage_conductance"] = 1e-11;  // effect not active in the plant
  EXPECT_THROW(DieCushionSimulator{c}, std::invalid_argument);
  c = {};
  c.integration_step = 0.01;
  EXPECT_THROW(DieCushionSimulator{c}, std::invalid_argument);
}

TEST(DieCushionSimulator, ControllerHoldsTheDrawingPressureProfile) {
  SimulatorConfig c;
  DieCushionSimulator sim(c);
  double worst = 0.0;
  int samples = 0;
  while (sim.state().t < 2 * sim.program().cycleDuration()) {
    sim.step(nullptr);
    const auto point = sim.program().at(sim.state().t);
    // Judge the steady part of drawing, after the build-up at impact.
    if (point.phase == StrokePhase::kDrawing && point.x > 0.03 && point.v > 0.19) {
      worst = std::max(worst, std::abs(sim.state().p - sim.state().pressure_setpoint));
      ++samples;
    }
    ASSERT_GE(sim.state().p, -kAtmosphericPressure) << "never below vacuum";
    ASSERT_TRUE(std::isfinite(sim.state().p));
  }
  EXPECT_GT(samples, 1000);
  EXPECT_LT(worst, 5e5) << "pressure within 5 bar of the set-point while drawing";
}

TEST(DieCushionSimulator, SensorsDeliverTheirRatesAndNoise) {
  SimulatorConfig c;
  c.sensors.drop_probability = 0.1;
  DieCushionSimulator sim(c);
  std::vector<SimulatedMeasurement> out;
  sim.run(0.4, &out);  // at rest: pressure ramps slowly, position is exactly 0
  std::map<InputStream, int> count;
  double sum_x2 = 0.0;
  int nx = 0;
  double last_stamp[3] = {-1, -1, -1};
  for (const auto& m : out) {
    ++count[m.stream];
    const int s = static_cast<int>(m.stream);
    EXPECT_GT(m.sample.stamp, last_stamp[s]) << "stamps increase within a stream";
    last_stamp[s] = m.sample.stamp;
    if (m.stream == InputStream::kPosition) {
      sum_x2 += m.sample.first * m.sample.first;
      ++nx;
    }
  }
  for (auto s : {InputStream::kPressure, InputStream::kPosition, InputStream::kValve}) {
    EXPECT_NEAR(count[s], 0.9 * 400, 40) << "1 kHz with 10 % of the messages dropped";
  }
  EXPECT_NEAR(std::sqrt(sum_x2 / nx), 2e-6, 0.3e-6) << "position noise of 2 um";
}

TEST(DieCushionSimulator, TrueParametersCanStepMidRun) {
  SimulatorConfig c;
  DieCushionSimulator sim(c);
  EXPECT_DOUBLE_EQ(sim.trueParameter("bulk_modulus"), 1.2e9);
  sim.setTrueParameter("bulk_modulus", 1.44e9);
  EXPECT_DOUBLE_EQ(sim.trueParameter("bulk_modulus"), 1.44e9);
  EXPECT_THROW(sim.setTrueParameter("bulk_modulus", std::nan("")), std::invalid_argument);
}

TEST(DieCushionSimulator, StartOfTheReturnStrokeCavitates) {
  // The data must contain the region where the model does not hold, so the identifier's exclusion is tested.
  SimulatorConfig c;
  DieCushionSimulator sim(c);
  double lowest_in_return = 1e9;
  while (sim.state().t < sim.program().cycleDuration()) {
    sim.step(nullptr);
    if (sim.state().phase == StrokePhase::kReturn)
      lowest_in_return = std::min(lowest_in_return, sim.state().p);
  }
  EXPECT_LT(lowest_in_return, 2e5) << "pressure falls near zero when the cushion starts upwards";
}

TEST(DieCushionSimulator, ValveCommandOverrideDrivesTheSpool) {
  SimulatorConfig c;
  DieCushionSimulator sim(c);
  sim.setValveCommandOverride(2.0);
  sim.run(0.1, nullptr);
  EXPECT_NEAR(sim.state().y, 0.2, 1e-3);
  EXPECT_DOUBLE_EQ(sim.state().u, 2.0);
}
