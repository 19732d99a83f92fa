// Faults the node meets on a production cell: it is (re)started in the middle of a stroke, the bag it is fed
// is played again (time jumps back), and a topic falls silent for a while. Each time the identification
// must come back to the same accuracy as from a clean start.
#include <gtest/gtest.h>

#include <cmath>

#include "simulation_fixtures.h"

namespace die_cushion_ident {
namespace {

using testing::configFor;
using testing::estimateOf;
using testing::randomPlant;

void expectConverged(const HydraulicEstimate& e, const DieCushionSimulator& plant, const std::string& what) {
  for (const char* name : {"bulk_modulus", "valve_flow_gain"}) {
    const double error = estimateOf(e, name) / plant.trueParameter(name) - 1.0;
    EXPECT_LT(std::abs(error), name == std::string("bulk_modulus") ? 0.05 : 0.02) << what << ": " << name;
  }
}

TEST(Recovery, StartedInTheMiddleOfADrawingStroke) {
  const auto config = randomPlant(31);
  DieCushionSimulator plant(config);
  std::vector<SimulatedMeasurement> skipped;
  plant.run(1.1, &skipped);  // the node comes up 0.6 s into the drawing stroke
  IdentificationPipeline pipeline(configFor(config));
  testing::feed(plant, pipeline, 4 * plant.program().cycleDuration());
  expectConverged(pipeline.identifier().estimate(), plant, "started mid-stroke");
}

TEST(Recovery, BagPlayedAgainRestartsCleanly) {
  const auto config = randomPlant(32);
  DieCushionSimulator plant(config);
  std::vector<SimulatedMeasurement> messages;
  plant.run(3 * plant.program().cycleDuration(), &messages);
  IdentificationPipeline pipeline(configFor(config));
  for (int loop = 0; loop < 2; ++loop) {  // rosbag play --loop: the stamps jump back to the start
    for (const auto& m : messages) pipeline.push(m.stream, m.sample);
  }
  EXPECT_EQ(pipeline.resampler().restarts(), 1u);
  expectConverged(pipeline.identifier().estimate(), plant, "after the restart");
}

TEST(Recovery, APositionTopicSilentForTwoSecondsIsBridgedWithoutDamage) {
  const auto config = randomPlant(33);
  DieCushionSimulator plant(config);
  IdentificationPipeline pipeline(configFor(config));
  testing::feed(plant, pipeline, 2 * plant.program().cycleDuration());
  std::vector<SimulatedMeasurement> messages;
  plant.run(2.0, &messages);
  for (const auto& m : messages) {
    if (m.stream != InputStream::kPosition) pipeline.push(m.stream, m.sample);
  }
  EXPECT_TRUE(pipeline.resampler().health(InputStream::kPosition).stale);
  const HydraulicEstimate during = pipeline.identifier().estimate();
  for (const auto& p : during.parameters)
    EXPECT_TRUE(std::isfinite(p.value) && std::isfinite(p.std)) << p.name;
  testing::feed(plant, pipeline, 3 * plant.program().cycleDuration());
  EXPECT_FALSE(pipeline.resampler().health(InputStream::kPosition).stale);
  expectConverged(pipeline.identifier().estimate(), plant, "after the silent topic");
}

// Hostile-input review: 20 pressure messages of 1e300 Pa left every std and the comparison NaN for good,
// and one message stamped 100 s in the past (or 1000 s ahead) each second kept restarting everything.
TEST(Recovery, AbsurdValuesAndWildStampsNeitherPoisonNorRestartTheEstimator) {
  const auto config = randomPlant(34);
  DieCushionSimulator plant(config);
  IdentificationPipeline pipeline(configFor(config));
  testing::feed(plant, pipeline, 2 * plant.program().cycleDuration());
  std::vector<SimulatedMeasurement> messages;
  plant.run(3 * plant.program().cycleDuration(), &messages);
  int pressure = 0;
  for (const auto& m : messages) {
    StreamSample sample = m.sample;
    if (m.stream == InputStream::kPressure && ++pressure % 1000 < 20) sample.first = 1e300;  // bursts
    if (m.stream == InputStream::kPosition && pressure % 1000 == 500) sample.stamp -= 100.0;  // wild stamps
    if (m.stream == InputStream::kValve && pressure % 1000 == 700) sample.stamp += 1000.0;
    pipeline.push(m.stream, sample);
  }
  EXPECT_EQ(pipeline.resampler().restarts(), 0u);
  EXPECT_GT(pipeline.resampler().health(InputStream::kPressure).implausible, 100u);
  EXPECT_GT(pipeline.resampler().health(InputStream::kPosition).wild_stamps, 0u);
  const HydraulicEstimate e = pipeline.identifier().estimate();
  EXPECT_TRUE(std::isfinite(e.equation_error_rms));
  for (const auto& p : e.parameters) EXPECT_TRUE(std::isfinite(p.value) && std::isfinite(p.std)) << p.name;
  expectConverged(e, plant, "through bursts of 1e300 Pa and wild stamps");
}

}  // namespace
}  // namespace die_cushion_ident
