// Clock offsets between the topics (estimateTopicDelays), on every press class: a position topic stamped
// 10 or 20 ms late and a valve topic 5 or 10 ms late are found within 0.3 ms, and the stated standard
// uncertainty covers the error (issue 26: an offset was found 1.3 ms off with +-0.3 ms claimed).
#include <gtest/gtest.h>

#include <cmath>

#include "die_cushion_ident/core/estimation/identification_pipeline.h"
#include "die_cushion_ident/core/estimation/topic_delay_estimator.h"
#include "die_cushion_ident/core/simulation/press_class.h"

using namespace die_cushion_ident;

namespace {

// The class's press with topics stamped `position_late` and `valve_late` seconds late, on a 1 ms grid.
struct Stamped {
  IdentificationConfig config;
  std::vector<GridSample> grid;
};

// `overlap` > 0 sets the valve overlap's value (a share of the spool; the class's own otherwise).
Stamped record(PressClass press, const std::vector<std::string>& effects, double position_late,
               double valve_late, double overlap = 0.0) {
  SimulatorConfig plant = pressClassPlant(press, 0, effects, 3);
  if (overlap > 0.0) plant.parameters["valve_overlap"] = overlap;
  DieCushionSimulator simulator(plant);
  std::vector<SimulatedMeasurement> messages;
  simulator.run(8 * simulator.program().cycleDuration(), &messages);
  Stamped s;
  s.config.geometry = plant.geometry;
  s.config.valve = plant.valve;
  s.config.resampler.sample_period = 0.001;
  s.config.velocity_window = 0.002;
  IdentificationPipeline pipeline(s.config);
  pipeline.setGridCallback([&](const GridSample& g, const HydraulicIdentifier&) { s.grid.push_back(g); });
  for (auto m : messages) {
    if (m.stream == InputStream::kPosition) m.sample.stamp += position_late;
    if (m.stream == InputStream::kValve) m.sample.stamp += valve_late;
    pipeline.push(m.stream, m.sample);
  }
  pipeline.flush();
  return s;
}

}  // namespace

TEST(TopicDelayEstimator, FindsTenAndTwentyMillisecondsOnEveryPressClass) {
  for (PressClass press : allPressClasses()) {
    for (const auto& [position_late, valve_late] : {std::pair<double, double>{0.010, 0.005}, {0.020, 0.010}}) {
      SCOPED_TRACE(std::string(pressClassName(press)) + ", position " + std::to_string(position_late));
      const Stamped s = record(press, {}, position_late, valve_late);
      const TopicDelayEstimate e = estimateTopicDelays(s.grid, s.config);
      ASSERT_TRUE(e.valid) << e.message;
      EXPECT_NEAR(e.delays[1], position_late, 0.3e-3);
      EXPECT_NEAR(e.delays[2], valve_late, 0.3e-3);
      EXPECT_LE(std::abs(e.delays[1] - position_late), 2.0 * e.resolution[1]) << "covered by the stated uncertainty";
      EXPECT_LE(std::abs(e.delays[2] - valve_late), 2.0 * e.resolution[2]) << "covered by the stated uncertainty";
      EXPECT_TRUE(e.distinguishable());
    }
  }
}

// A valve with a dead band (overlap) the balance's first-order form could not describe pulled the offset by
// 0.5 ms, and with both topics late into a neighbouring basin 14 ms off: the opening's piecewise-linear form
// and the map's three basins find it.
TEST(TopicDelayEstimator, AValveOverlapDoesNotPullTheOffset) {
  const Stamped s = record(PressClass::kFastMechanical, {"valve_overlap"}, 0.020, 0.010);
  const TopicDelayEstimate e = estimateTopicDelays(s.grid, s.config);
  ASSERT_TRUE(e.valid) << e.message;
  EXPECT_NEAR(e.delays[1], 0.020, 0.3e-3);
  EXPECT_NEAR(e.delays[2], 0.010, 0.3e-3);
}

// Overlaps across the simulator's range (2-5 % of the spool) on two classes, the clocks agreeing and not:
// with the opening's kinks at 1, 2, 4 and 7 % an overlap of 4.7 % fell between two, and a fast press's
// offsets came out -43 and -40 ms where the clocks agreed (issue 47; its fit then implausible).
TEST(TopicDelayEstimator, AnyOverlapWithinTheSpoolsRangeLeavesTheOffsets) {
  for (PressClass press : {PressClass::kFastMechanical, PressClass::kSmallStiff}) {
    for (double overlap : {0.025, 0.035, 0.047}) {
      for (const auto& [position_late, valve_late] : {std::pair<double, double>{0.0, 0.0}, {0.010, 0.005}}) {
        SCOPED_TRACE(std::string(pressClassName(press)) + ", overlap " + std::to_string(overlap) +
                     ", position " + std::to_string(position_late));
        const Stamped s = record(press, {"valve_overlap"}, position_late, valve_late, overlap);
        const TopicDelayEstimate e = estimateTopicDelays(s.grid, s.config);
        ASSERT_TRUE(e.valid) << e.message;
        EXPECT_NEAR(e.delays[1], position_late, 0.3e-3);
        EXPECT_NEAR(e.delays[2], valve_late, 0.3e-3);
      }
    }
  }
}

// Topics stamped by one clock: offsets within a few tenths of a millisecond of zero, and not told apart from it.
TEST(TopicDelayEstimator, WellStampedTopicsAreLeftAlone) {
  const Stamped s = record(PressClass::kSlowHydraulic, {}, 0.0, 0.0);
  const TopicDelayEstimate e = estimateTopicDelays(s.grid, s.config);
  ASSERT_TRUE(e.valid) << e.message;
  EXPECT_NEAR(e.delays[1], 0.0, 0.3e-3);
  EXPECT_NEAR(e.delays[2], 0.0, 0.3e-3);
  EXPECT_FALSE(e.distinguishable()) << e.delays[1] << " +- " << e.resolution[1];
}

// Too little motion: no estimate, and a reason.
TEST(TopicDelayEstimator, SaysWhyWhenTheRecordingCannotTell) {
  SimulatorConfig plant;
  plant.cycle.rest_time = 100.0;  // the cushion never moves
  DieCushionSimulator simulator(plant);
  IdentificationConfig config;
  const std::vector<GridSample> grid = simulateGrid(simulator, 5.0, config.resamplerConfig());
  const TopicDelayEstimate e = estimateTopicDelays(grid, config);
  EXPECT_FALSE(e.valid);
  EXPECT_NE(e.message.find("too few"), std::string::npos) << e.message;
}
