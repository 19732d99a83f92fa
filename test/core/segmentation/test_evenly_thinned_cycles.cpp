// The offline analysis's grid, bounded in samples (issue 30): a recording that fits is kept whole, bit for
// bit; a longer one keeps every 2nd, 4th, ... press cycle whole, each with its lead-in, cut at the impacts
// the whole recording's segmentation finds, and the fit on what is kept still reads the plant. Plants of
// two press classes (a fast mechanical press and a small stiff chamber), 0.2 bar pressure noise.
#include <gtest/gtest.h>

#include <climits>
#include <cstring>

#include "die_cushion_ident/core/adequacy/held_out_test.h"
#include "die_cushion_ident/core/adequacy/model_assessment.h"
#include "die_cushion_ident/core/analysis/offline_analysis.h"
#include "die_cushion_ident/core/segmentation/evenly_thinned_cycles.h"
#include "die_cushion_ident/core/simulation/press_class.h"
#include "simulation_fixtures.h"

namespace die_cushion_ident {
namespace {

constexpr std::size_t kLeadIn = 250;

EvenlyThinnedCycles keep(const std::vector<GridSample>& grid, std::size_t bound) {
  EvenlyThinnedCycles store(bound, kLeadIn);
  store.reserve(grid.size());
  for (const GridSample& g : grid) store.push(g);
  return store;
}

bool sameSample(const GridSample& a, const GridSample& b) {
  return std::memcmp(&a, &b, sizeof(GridSample)) == 0;
}

class EvenlyThinnedCyclesOnPresses : public ::testing::TestWithParam<PressClass> {};

TEST_P(EvenlyThinnedCyclesOnPresses, ARecordingWithinTheBoundIsKeptWholeBitForBit) {
  const testing::Recording r = testing::record(pressClassPlant(GetParam(), 1), 10);
  const EvenlyThinnedCycles store = keep(r.grid, r.grid.size());
  ASSERT_EQ(store.grid().size(), r.grid.size());
  for (std::size_t i = 0; i < r.grid.size(); ++i) ASSERT_TRUE(sameSample(store.grid()[i], r.grid[i])) << i;
  EXPECT_EQ(store.stride(), 1);
  EXPECT_EQ(store.cyclesSeen(), static_cast<int>(r.strokes.cycle_start.size()));
  EXPECT_EQ(store.cyclesKept(), store.cyclesSeen());
}

TEST_P(EvenlyThinnedCyclesOnPresses, ALongerOneKeepsEveryStrideThCycleWholeWithItsLeadIn) {
  const testing::Recording r = testing::record(pressClassPlant(GetParam(), 2), 40);
  const std::size_t bound = r.grid.size() / 5;
  const EvenlyThinnedCycles store = keep(r.grid, bound);
  const std::vector<GridSample>& kept = store.grid();
  EXPECT_LE(kept.size(), bound);
  EXPECT_EQ(store.stride(), 8) << "40 cycles in a fifth of their samples: every 8th";
  const int impacts = static_cast<int>(r.strokes.cycle_start.size());
  EXPECT_EQ(store.cyclesSeen(), impacts);
  EXPECT_EQ(store.cyclesKept(), (impacts + store.stride() - 1) / store.stride());

  // The kept grid's own segmentation finds the kept impacts, at the whole recording's times.
  const StrokeSegmentation own = segmentStrokes(kept);
  ASSERT_EQ(static_cast<int>(own.cycle_start.size()), store.cyclesKept());
  for (int k = 0; k < store.cyclesKept(); ++k) {
    const std::size_t whole_impact = r.strokes.cycle_start[static_cast<std::size_t>(k * store.stride())];
    const std::size_t kept_impact = own.cycle_start[static_cast<std::size_t>(k)];
    ASSERT_DOUBLE_EQ(kept[kept_impact].t, r.grid[whole_impact].t) << "kept cycle " << k;
    // Whole from the lead-in before its impact to the next impact of the recording, unchanged but for the
    // discontinuity that begins each stretch.
    const std::size_t whole_end =
        k * store.stride() + 1 < impacts
            ? r.strokes.cycle_start[static_cast<std::size_t>(k * store.stride() + 1)]
            : r.grid.size();
    const std::size_t lead_in = std::min(kLeadIn, whole_impact);  // the first may come early
    ASSERT_GE(kept_impact, lead_in);
    for (std::size_t i = kept_impact - lead_in, w = whole_impact - lead_in; w < whole_end; ++i, ++w) {
      GridSample a = kept[i], b = r.grid[w];
      const bool begins_stretch = i == kept_impact - lead_in && w > 0;
      EXPECT_EQ(a.discontinuity, begins_stretch || b.discontinuity) << "kept cycle " << k << ", sample " << i;
      a.discontinuity = b.discontinuity = false;
      ASSERT_TRUE(sameSample(a, b)) << "kept cycle " << k << ", sample " << i;
    }
  }
  // The fit on the kept cycles reads the plant as the whole recording's does: within 3 of its own stds.
  const IdentificationConfig config = testing::configFor(r.plant);
  const HydraulicEstimate whole = fitOnCycles(r.grid, r.strokes, config, INT_MIN, INT_MAX);
  const HydraulicEstimate thinned = fitOnCycles(kept, own, config, INT_MIN, INT_MAX);
  for (const char* name : {"bulk_modulus", "valve_flow_gain", "dead_volume"}) {
    EXPECT_NEAR(testing::estimateOf(thinned, name), testing::estimateOf(whole, name),
                3.0 * testing::stdOf(thinned, name))
        << name;
  }
}

INSTANTIATE_TEST_SUITE_P(Presses, EvenlyThinnedCyclesOnPresses,
                         ::testing::Values(PressClass::kFastMechanical, PressClass::kSmallStiff),
                         [](const ::testing::TestParamInfo<PressClass>& info) {
                           return std::string(pressClassName(info.param));
                         });

// A press stroking faster than the lead-in is long (80 strokes a minute: the previous stroke drawing until
// 0.27 s before the impact, against half a second of lead-in): the stretch then begins mid-stroke, and the
// restarted phase classifier must not take that drawing for an impact: the kept grid holds just the kept
// cycles (the part of the stroke before in a lead-in is judged with its cycle).
TEST(EvenlyThinnedCycles, APressFasterThanTheLeadInKeepsJustItsKeptCycles) {
  SimulatorConfig plant = pressClassPlant(PressClass::kFastMechanical, 1);
  plant.cycle.rest_time = 0.04;
  plant.cycle.return_speed = 1.0;
  const testing::Recording r = testing::record(plant, 60);
  const std::size_t bound = r.grid.size() / 4;
  const EvenlyThinnedCycles store = keep(r.grid, bound);
  ASSERT_GE(store.stride(), 4);
  const StrokeSegmentation own = segmentStrokes(store.grid());
  ASSERT_EQ(static_cast<int>(own.cycle_start.size()), store.cyclesKept());
  for (int k = 0; k < store.cyclesKept(); ++k) {
    const std::size_t whole = r.strokes.cycle_start[static_cast<std::size_t>(k * store.stride())];
    EXPECT_DOUBLE_EQ(store.grid()[own.cycle_start[static_cast<std::size_t>(k)]].t, r.grid[whole].t) << k;
  }
}

TEST(EvenlyThinnedCycles, HoursWithoutAStrokeStayWithinTheBound) {
  std::vector<GridSample> rest(50000);
  for (std::size_t i = 0; i < rest.size(); ++i) {
    rest[i].t = 0.002 * static_cast<double>(i);
    rest[i].p = 20e5f;
  }
  const EvenlyThinnedCycles store = keep(rest, 10000);
  EXPECT_LE(store.grid().size(), 10000u);
  EXPECT_GT(store.grid().size(), 0u);
  EXPECT_EQ(store.samplesSeen(), rest.size());
  EXPECT_EQ(store.cyclesSeen(), 0);
}

// Every bound the configuration accepts makes an analysis: the half second of lead-in on a 10 us grid is
// 50 000 samples, more than a tenth of the lowest bound, and is cut to it.
TEST(EvenlyThinnedCycles, EveryValidBoundMakesAnAnalysis) {
  IdentificationConfig config;
  config.resampler.sample_period = 1e-5;
  config.identification_period = 1e-3;
  config.max_analysed_samples = 1e5;
  ASSERT_TRUE(config.validate().empty()) << config.validate().front();
  EXPECT_NO_THROW(OfflineAnalysis analysis(config));
}

TEST(EvenlyThinnedCycles, ABoundTooSmallForItsLeadInIsRefused) {
  EXPECT_THROW(EvenlyThinnedCycles(1000, kLeadIn), std::invalid_argument);
}

}  // namespace
}  // namespace die_cushion_ident
