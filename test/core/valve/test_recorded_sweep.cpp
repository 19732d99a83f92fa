// Offline valve identification: a recorded valve signal with a sine sweep between ordinary controller
// activity is analysed without metadata.
#include <gtest/gtest.h>

#include <cmath>

#include "simulation_fixtures.h"
#include "sweep_fixtures.h"

namespace die_cushion_ident {
namespace {

using testing::cushionAtRest;
using testing::randomValve;
using testing::SweepRig;

// 2 s of pressure control at rest, the default sweep, 2 s of pressure control again.
std::vector<ValveSample> recordSweep(const SimulatorConfig& plant, SweepRig* rig_out = nullptr) {
  SweepRig rig(plant, SweepLimits());
  for (int i = 0; i < 2000; ++i) rig.tick();
  EXPECT_EQ(rig.start(), "");
  rig.runToEnd();
  EXPECT_EQ(rig.sweep().state(), ValveSweep::State::kFinished);
  rig.plant().setValveCommandOverride(std::nullopt);
  for (int i = 0; i < 2000; ++i) rig.tick();
  if (rig_out) *rig_out = std::move(rig);
  return rig.valveRecord();
}

TEST(RecordedSweep, FindsEverySegmentAndIdentifiesTheValveWithoutMetadata) {
  for (std::uint64_t seed = 11; seed <= 14; ++seed) {
    const auto truth = randomValve(seed);
    const auto record = recordSweep(cushionAtRest(truth, seed));
    const auto result = analyzeRecordedSweep(record);
    ASSERT_EQ(result.segments.size(), 16u) << "seed " << seed;
    for (std::size_t i = 0; i < result.segments.size(); ++i) {
      EXPECT_NEAR(result.segments[i].frequency, 10.0 * (i + 1), 1e-3 * 10.0 * (i + 1));
      EXPECT_NEAR(result.segments[i].amplitude, 0.5, 0.05);
      EXPECT_NEAR(result.segments[i].offset, 0.0, 0.02);
    }
    ASSERT_TRUE(result.fit.success) << result.fit.message;
    const auto& p = result.fit.parameters;
    EXPECT_NEAR(p.natural_frequency / truth.natural_frequency, 1.0, 0.03);
    EXPECT_NEAR(p.damping / truth.damping, 1.0, 0.10);
    EXPECT_NEAR(p.gain / truth.gain, 1.0, 0.02);
    EXPECT_NEAR(p.dead_time, truth.dead_time, 0.3e-3);
  }
}

TEST(RecordedSweep, ToleratesDroppedMessages) {
  const auto truth = randomValve(21);
  SimulatorConfig plant = cushionAtRest(truth, 21);
  plant.sensors.drop_probability = 0.02;
  const auto result = analyzeRecordedSweep(recordSweep(plant));
  ASSERT_EQ(result.segments.size(), 16u);
  ASSERT_TRUE(result.fit.success) << result.fit.message;
  EXPECT_NEAR(result.fit.parameters.natural_frequency / truth.natural_frequency, 1.0, 0.03);
  EXPECT_NEAR(result.fit.parameters.dead_time, truth.dead_time, 0.3e-3);
}

TEST(RecordedSweep, FindsNoSweepInPressCyclesOrInASquareWave) {
  auto plant_config = testing::randomPlant(3);
  DieCushionSimulator plant(plant_config);
  std::vector<SimulatedMeasurement> messages;
  plant.run(3 * plant.program().cycleDuration(), &messages);
  std::vector<ValveSample> cycles;
  for (const auto& m : messages) {
    if (m.stream == InputStream::kValve) cycles.push_back({m.sample.stamp, m.sample.first, m.sample.second});
  }
  EXPECT_TRUE(detectSweepSegments(cycles).empty());
  const auto result = analyzeRecordedSweep(cycles);
  EXPECT_FALSE(result.fit.success);
  EXPECT_FALSE(result.fit.message.empty());

  std::vector<ValveSample> square;
  for (int i = 0; i < 3000; ++i) {
    const double t = i * 1e-3;
    square.push_back({t, std::sin(2 * M_PI * 20 * t) >= 0 ? 0.5 : -0.5, 0.0});
  }
  EXPECT_TRUE(detectSweepSegments(square).empty());
}

// analyze_bag keeps the raw valve signal only where a sweep can be: an hour of strokes must not be stored,
// a sweep must come through whole (the same points as from the complete signal).
TEST(SweepCandidateFilter, KeepsTheSweepAndDropsThePressStrokes) {
  auto plant_config = testing::randomPlant(5);
  DieCushionSimulator plant(plant_config);
  std::vector<SimulatedMeasurement> messages;
  plant.run(8 * plant.program().cycleDuration(), &messages);
  std::vector<ValveSample> signal;
  for (const auto& m : messages) {
    if (m.stream == InputStream::kValve) signal.push_back({m.sample.stamp, m.sample.first, m.sample.second});
  }
  const std::size_t strokes = signal.size();
  const auto truth = randomValve(12);
  const double shift = signal.back().t + 1.0;
  for (ValveSample s : recordSweep(cushionAtRest(truth, 12))) {
    s.t += shift;
    signal.push_back(s);
  }
  SweepCandidateFilter filter;
  std::vector<ValveSample> kept;
  for (const auto& s : signal) filter.push(s, &kept);
  filter.flush(&kept);
  std::size_t kept_strokes = 0;
  for (const auto& s : kept) kept_strokes += s.t < shift ? 1 : 0;
  EXPECT_LT(kept_strokes, strokes / 10) << "at most a tenth of the press strokes' valve messages is kept";
  for (std::size_t i = 1; i < kept.size(); ++i) ASSERT_GT(kept[i].t, kept[i - 1].t) << "in time order";
  const RecordedSweep whole = analyzeRecordedSweep(signal), filtered = analyzeRecordedSweep(kept);
  ASSERT_EQ(whole.points.size(), 16u);
  ASSERT_EQ(filtered.points.size(), whole.points.size());
  for (std::size_t i = 0; i < whole.points.size(); ++i) {
    EXPECT_DOUBLE_EQ(filtered.points[i].magnitude, whole.points[i].magnitude) << whole.points[i].frequency;
    EXPECT_DOUBLE_EQ(filtered.points[i].phase, whole.points[i].phase);
  }
}

TEST(RecordedSweep, HandlesEmptyAndTinyInput) {
  EXPECT_TRUE(detectSweepSegments({}).empty());
  EXPECT_FALSE(analyzeRecordedSweep({}).fit.success);
  std::vector<ValveSample> constant(5000, ValveSample{0.0, 1.0, 0.1});
  for (std::size_t i = 0; i < constant.size(); ++i) constant[i].t = i * 1e-3;
  EXPECT_TRUE(detectSweepSegments(constant).empty());
  std::vector<ValveSample> nonfinite = constant;
  for (auto& s : nonfinite) s.voltage = std::nan("");
  EXPECT_TRUE(detectSweepSegments(nonfinite).empty());
}

}  // namespace
}  // namespace die_cushion_ident
