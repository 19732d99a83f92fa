// What the valve's interlocks read of the plant (issue 45): ages on the steady clock since each message
// arrived, whatever its stamp says, and stamps off the receiving clock named.
#include <gtest/gtest.h>

#include <cmath>

#include "die_cushion_ident/core/valve/plant_signals.h"

namespace die_cushion_ident {
namespace {

// A message that arrives at steady time `steady` while the clock reads `clock`.
Instant at(double steady, double clock) { return {steady, clock}; }

TEST(PlantSignals, ASignalNeverReceivedIsInfinitelyOld) {
  const PlantCondition c = PlantSignals().at(at(100.0, 5.0));
  EXPECT_TRUE(std::isnan(c.pressure));
  EXPECT_TRUE(std::isnan(c.velocity));
  for (double age : {c.pressure_age, c.position_age, c.valve_age, c.spool_age}) EXPECT_GT(age, 1e6);
  EXPECT_EQ(c.clock_problem, "");
}

// The fault of issue 45: with the drives stamping 1 s ahead of the clock, ages taken from the stamps let a
// dead bus go unnoticed for the lead plus 0.2 s. Taken from the arrivals, it is noticed at once.
TEST(PlantSignals, ADeadBusAgesEverySignalByItsSilenceWhateverTheStamps) {
  PlantSignals signals(2.0);  // a tolerance wider than the lead: only the ages are under test here
  for (int i = 0; i <= 100; ++i) {
    const double t = 0.001 * i;
    signals.pressure(t + 1.0, 20e5, at(t, t));
    signals.position(t + 1.0, 0.1, at(t, t));
    signals.valve(t + 1.0, 0.05, at(t, t));
  }
  PlantCondition c = signals.at(at(0.1, 0.1));
  EXPECT_NEAR(c.pressure_age, 0.0, 1e-12);
  c = signals.at(at(0.16, 0.16));  // 60 ms of silence
  for (double age : {c.pressure_age, c.position_age, c.valve_age, c.spool_age}) EXPECT_NEAR(age, 0.06, 1e-9);
}

TEST(PlantSignals, ADeadSensorAgesWhileTheOthersKeepComing) {
  PlantSignals signals;
  signals.pressure(1.0, 20e5, at(1.0, 1.0));
  for (int i = 0; i <= 100; ++i) signals.valve(1.0 + 0.001 * i, 0.1, at(1.0 + 0.001 * i, 1.0 + 0.001 * i));
  const PlantCondition c = signals.at(at(1.1, 1.1));
  EXPECT_NEAR(c.pressure_age, 0.1, 1e-9);
  EXPECT_NEAR(c.valve_age, 0.0, 1e-9);
}

TEST(PlantSignals, NonFiniteReadingsDoNotRefreshButAValveMessageWithoutSpoolShowsTheAmplifierAlive) {
  PlantSignals signals;
  signals.pressure(1.0, 20e5, at(1.0, 1.0));
  signals.valve(1.0, 0.1, at(1.0, 1.0));
  signals.pressure(1.05, NAN, at(1.05, 1.05));
  signals.valve(1.05, NAN, at(1.05, 1.05));
  const PlantCondition c = signals.at(at(1.05, 1.05));
  EXPECT_DOUBLE_EQ(c.pressure, 20e5);
  EXPECT_NEAR(c.pressure_age, 0.05, 1e-12);
  EXPECT_NEAR(c.spool_age, 0.05, 1e-12);
  EXPECT_NEAR(c.valve_age, 0.0, 1e-12);
  EXPECT_DOUBLE_EQ(signals.spoolArrival(), 1.0);
}

TEST(PlantSignals, StampsOffTheClockAreNamedAheadOrBehindUntilOneAgreesAgain) {
  PlantSignals signals(0.1);
  signals.pressure(11.0, 20e5, at(1.0, 10.0));  // 1 s ahead
  PlantCondition c = signals.at(at(1.0, 10.0));
  EXPECT_NE(c.clock_problem.find("pressure topic's stamps are 1.000 s ahead of the clock"), std::string::npos)
      << c.clock_problem;
  EXPECT_NEAR(c.pressure_age, 0.0, 1e-12) << "the reading itself arrived";
  signals.pressure(10.01, 20e5, at(1.01, 10.01));
  EXPECT_EQ(signals.at(at(1.01, 10.01)).clock_problem, "");
  signals.position(9.0, 0.1, at(1.02, 10.02));  // 1.02 s behind
  EXPECT_NE(signals.at(at(1.02, 10.02)).clock_problem.find("position topic's stamps are 1.020 s behind"),
            std::string::npos);
  signals.position(10.03, 0.1, at(1.03, 10.03));
  signals.valve(NAN, 0.0, at(1.03, 10.03));  // a stamp that is no time at all
  EXPECT_NE(signals.at(at(1.03, 10.03)).clock_problem.find("valve topic's stamps are not finite"),
            std::string::npos);
}

TEST(PlantSignals, VelocityFromThePositionMessages) {
  PlantSignals signals;
  for (int i = 0; i < 40; ++i) signals.position(0.001 * i, 0.1 + 0.05 * 0.001 * i, at(0.001 * i, 0.001 * i));
  EXPECT_NEAR(signals.at(at(0.04, 0.04)).velocity, 0.05, 1e-6);
  PlantSignals resting;
  for (int i = 0; i < 40; ++i) resting.position(0.001 * i, 0.1, at(0.001 * i, 0.001 * i));
  EXPECT_NEAR(resting.at(at(0.04, 0.04)).velocity, 0.0, 1e-9);
}

}  // namespace
}  // namespace die_cushion_ident
