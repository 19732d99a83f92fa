#include <gtest/gtest.h>

#include <cmath>

#include "die_cushion_ident/core/valve/plant_signals.h"

using die_cushion_ident::PlantCondition;
using die_cushion_ident::PlantSignals;

TEST(PlantSignals, ASignalNeverReceivedIsInfinitelyOld) {
  const PlantCondition c = PlantSignals().at(100.0);
  EXPECT_TRUE(std::isnan(c.pressure));
  EXPECT_TRUE(std::isnan(c.velocity));
  EXPECT_GT(c.pressure_age, 1e6);
  EXPECT_GT(c.spool_age, 1e6);
}

// Queued messages are judged against the newest stamp, not the clock: a clock that ran ahead of the
// callback queue (a simulator catching up under /use_sim_time) does not make fresh messages stale.
TEST(PlantSignals, AgesCountFromTheNewestStampUntilAllInputsFallSilent) {
  PlantSignals signals;
  signals.pressure(10.000, 20e5);
  signals.spool(10.005, 0.1);
  PlantCondition c = signals.at(10.15);  // the clock 145 ms ahead: within the silence tolerance
  EXPECT_DOUBLE_EQ(c.pressure, 20e5);
  EXPECT_NEAR(c.pressure_age, 0.005, 1e-12);
  EXPECT_NEAR(c.spool_age, 0.0, 1e-12);
  c = signals.at(10.505);  // all silent for 0.5 s: everything ages by the silence
  EXPECT_NEAR(c.pressure_age, 0.505, 1e-9);
  EXPECT_NEAR(c.spool_age, 0.5, 1e-9);
}

TEST(PlantSignals, ADeadSensorAgesWhileTheOthersKeepComing) {
  PlantSignals signals;
  signals.pressure(1.0, 20e5);
  for (int i = 0; i <= 100; ++i) signals.spool(1.0 + 0.001 * i, 0.1);
  EXPECT_NEAR(signals.at(1.1).pressure_age, 0.1, 1e-9);
}

TEST(PlantSignals, NonFiniteReadingsDoNotRefresh) {
  PlantSignals signals;
  signals.pressure(1.0, 20e5);
  signals.spool(1.0, 0.1);
  signals.pressure(1.05, NAN);
  signals.spool(1.05, NAN);
  const PlantCondition c = signals.at(1.05);
  EXPECT_DOUBLE_EQ(c.pressure, 20e5);
  EXPECT_NEAR(c.pressure_age, 0.0, 1e-12) << "the newest stamp is still 1.0";
  EXPECT_DOUBLE_EQ(signals.spoolStamp(), 1.0);
}

TEST(PlantSignals, VelocityFromThePositionMessages) {
  PlantSignals signals;
  for (int i = 0; i < 40; ++i) signals.position(0.001 * i, 0.1 + 0.05 * 0.001 * i);  // 50 mm/s
  EXPECT_NEAR(signals.at(0.04).velocity, 0.05, 1e-6);
  PlantSignals resting;
  for (int i = 0; i < 40; ++i) resting.position(0.001 * i, 0.1);
  EXPECT_NEAR(resting.at(0.04).velocity, 0.0, 1e-9);
}
