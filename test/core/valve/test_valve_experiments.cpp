// One supervisor for the valve experiments (issue 28): a sweep and a step test never run at once, each is
// refused with its reason (kept for the diagnostics), each abort hands the valve back at its offset once,
// and the feed-forward stays paused until that hand-back went out. A property test drives random sequences
// of starts, aborts, plant conditions and ticks through it.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "die_cushion_ident/core/valve/valve_experiments.h"
#include "sweep_fixtures.h"

namespace die_cushion_ident {
namespace {

PlantCondition atRest() { return testing::plantAtRest(); }

StepTestRequest step(double offset = 0.2) {
  StepTestRequest request;
  request.offset = offset;
  request.step = -0.5;
  return request;
}

SweepRequest sweep(double offset = 0.1) {
  SweepRequest request;
  request.offset = offset;
  request.frequencies = {10.0, 20.0, 40.0, 80.0, 160.0};
  return request;
}

TEST(ValveExperiments, OneAtATimeAndTheRefusalSaysWhichHoldsTheValve) {
  ValveExperiments experiments{SweepLimits()};
  EXPECT_EQ(experiments.holder(), "");
  ASSERT_EQ(experiments.startStepTest(step(), Instant::simulated(0.0), atRest()), "");
  EXPECT_EQ(experiments.running(), ValveExperiments::Kind::kStepTest);
  EXPECT_EQ(experiments.holder(), "a step test");
  const std::string refusal = experiments.startSweep(sweep(), Instant::simulated(0.01), atRest());
  EXPECT_NE(refusal.find("a step test holds the valve"), std::string::npos) << refusal;
  EXPECT_EQ(experiments.running(), ValveExperiments::Kind::kStepTest);
  EXPECT_NE(experiments.lastRefusal().find("valve sweep refused"), std::string::npos);
  EXPECT_DOUBLE_EQ(experiments.lastRefusalTime(), 0.01) << "on the steady clock";
  // A second step test is refused too.
  EXPECT_NE(experiments.startStepTest(step(), Instant::simulated(0.02), atRest()), "");
}

TEST(ValveExperiments, TheExperimentsOwnInterlocksRefuseWithTheirReason) {
  ValveExperiments experiments{SweepLimits()};
  PlantCondition moving = atRest();
  moving.velocity = 0.2;
  const std::string refusal = experiments.startSweep(sweep(), Instant::simulated(0.0), moving);
  EXPECT_NE(refusal, "");
  EXPECT_EQ(experiments.running(), ValveExperiments::Kind::kNone);
  EXPECT_NE(experiments.lastRefusal().find(refusal), std::string::npos);
  StepTestRequest too_far = step(9.8);
  too_far.step = 0.5;  // 10.3 V: beyond sweep_max_voltage
  EXPECT_NE(experiments.startStepTest(too_far, Instant::simulated(0.0), atRest()).find("would leave"),
            std::string::npos);
}

TEST(ValveExperiments, AnAbortHandsTheValveBackOnceAndPausesTheFeedForwardUntilThen) {
  for (bool sweep_first : {true, false}) {
    ValveExperiments experiments{SweepLimits()};
    const double offset = sweep_first ? 0.1 : 0.2;
    ASSERT_EQ(sweep_first ? experiments.startSweep(sweep(offset), Instant::simulated(0.0), atRest())
                          : experiments.startStepTest(step(offset), Instant::simulated(0.0), atRest()),
              "");
    ASSERT_TRUE(experiments.command(0.0005).has_value());
    const std::string aborted = experiments.abort("aborted by request");
    EXPECT_NE(aborted.find("aborted"), std::string::npos);
    EXPECT_EQ(experiments.running(), ValveExperiments::Kind::kNone);
    EXPECT_TRUE(experiments.holdsValve()) << "the hand-back is still to be sent";
    EXPECT_NE(experiments.holder(), "");
    // Another experiment waits for the hand-back.
    EXPECT_NE(experiments.startStepTest(step(), Instant::simulated(0.001), atRest()), "");
    const auto back = experiments.command(0.001);
    ASSERT_TRUE(back.has_value());
    EXPECT_DOUBLE_EQ(*back, offset);
    EXPECT_FALSE(experiments.command(0.0015).has_value()) << "the offset is sent once";
    EXPECT_FALSE(experiments.holdsValve());
    EXPECT_EQ(experiments.holder(), "") << "the feed-forward may resume";
    EXPECT_NE(experiments.lastEnd().find("aborted: aborted by request"), std::string::npos);
    EXPECT_EQ(experiments.abort("again"), "") << "nothing left to abort";
  }
}

TEST(ValveExperiments, AnInterlockThatTripsHandsBackToo) {
  ValveExperiments experiments{SweepLimits()};
  ASSERT_EQ(experiments.startStepTest(step(0.3), Instant::simulated(0.0), atRest()), "");
  PlantCondition moving = atRest();
  moving.velocity = 0.1;
  experiments.supervise(Instant::simulated(0.1), moving);
  EXPECT_EQ(experiments.running(), ValveExperiments::Kind::kNone);
  EXPECT_TRUE(experiments.holdsValve());
  EXPECT_DOUBLE_EQ(experiments.command(0.1).value_or(NAN), 0.3);
  EXPECT_FALSE(experiments.holdsValve());
  EXPECT_NE(experiments.lastEnd().find("step test aborted"), std::string::npos);
}

TEST(ValveExperiments, AFinishedStepTestEndsAtItsOffset) {
  ValveExperiments experiments{SweepLimits()};
  ASSERT_EQ(experiments.startStepTest(step(0.2), Instant::simulated(0.0), atRest()), "");
  std::optional<double> last;
  for (double t = 0.0; t < 3.0; t += 0.001) {
    experiments.supervise(Instant::simulated(t), atRest());
    if (const auto u = experiments.command(t)) last = u;
  }
  EXPECT_DOUBLE_EQ(last.value_or(NAN), 0.2);
  EXPECT_FALSE(experiments.holdsValve());
  EXPECT_EQ(experiments.lastEnd(), "step test finished");
  EXPECT_EQ(experiments.startSweep(sweep(), Instant::simulated(3.0), atRest()), "")
      << "the valve is free again";
}

// Random starts, aborts, plant conditions and ticks: never two experiments at once, every command within
// the voltage limits, the feed-forward never free while a command is still to be handed back.
TEST(ValveExperiments, PropertyNoSequenceRunsTwoOrLeavesTheLimits) {
  SweepLimits limits;
  limits.min_voltage = -2.0;
  limits.max_voltage = 2.0;
  std::mt19937 random(28);
  std::uniform_real_distribution<double> voltage(-3.0, 3.0), unit(0.0, 1.0);
  int sweeps = 0, step_tests = 0;
  for (int sequence = 0; sequence < 200; ++sequence) {
    ValveExperiments experiments(limits);
    double t = 0.0;
    for (int tick = 0; tick < 3000; ++tick) {
      t += 0.0005 + (unit(random) < 0.01 ? 0.2 : 0.0);
      PlantCondition plant = atRest();
      if (unit(random) < 0.002) plant.velocity = 0.1;
      if (unit(random) < 0.002) plant.pressure_age = 1.0;
      if (unit(random) < 0.002) plant.pressure = 300e5;
      const double action = unit(random);
      if (action < 0.003) {
        SweepRequest s = sweep(voltage(random));
        s.amplitude = 0.5 * unit(random) + 0.1;
        sweeps += experiments.startSweep(s, Instant::simulated(t), plant).empty() ? 1 : 0;
      } else if (action < 0.006) {
        StepTestRequest r = step(voltage(random));
        r.step = voltage(random);
        r.duration = 0.2;
        step_tests += experiments.startStepTest(r, Instant::simulated(t), plant).empty() ? 1 : 0;
      } else if (action < 0.008) {
        experiments.abort("random abort");
      }
      experiments.supervise(Instant::simulated(t), plant);
      ASSERT_FALSE(experiments.sweep().running() && experiments.stepTest().running())
          << "sequence " << sequence;
      const bool held = experiments.holdsValve();
      const auto u = experiments.command(t);
      if (u) {
        ASSERT_TRUE(held) << "a command only from an experiment that holds the valve";
        ASSERT_GE(*u, limits.min_voltage);
        ASSERT_LE(*u, limits.max_voltage);
      }
      if (experiments.running() != ValveExperiments::Kind::kNone) {
        ASSERT_NE(experiments.holder(), "");
      }
    }
  }
  // Both kinds ran, often: the sequences exercised them, not only their refusals.
  EXPECT_GT(sweeps, 100);
  EXPECT_GT(step_tests, 100);
}

}  // namespace
}  // namespace die_cushion_ident
