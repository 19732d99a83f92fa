// An effect that starts within one recording is named with the press cycle it starts in (issue 27): the
// library effect's parameter, fitted to each cycle alone, steps there. Random plants of the paper's press
// (0.2 bar pressure noise, 10 cycles, the base model configured); analyze_bag's version over every press
// class and sensor configuration is in test_press_classes.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "die_cushion_ident/core/adequacy/effect_onset.h"
#include "die_cushion_ident/core/adequacy/model_assessment.h"
#include "die_cushion_ident/core/segmentation/evenly_thinned_cycles.h"
#include "die_cushion_ident/core/signal/uniform_resampler.h"
#include "die_cushion_ident/core/simulation/press_class.h"
#include "simulation_fixtures.h"

namespace die_cushion_ident {
namespace {

// `cycles` press cycles of `plant`, its effects' parameters 0 before cycle `from` (none when from < 0).
std::vector<GridSample> recordWithOnset(const SimulatorConfig& plant, int cycles, int from) {
  DieCushionSimulator simulator(plant);
  const double cycle = simulator.program().cycleDuration();
  const ParameterVector truth = simulator.trueParameters();
  const auto& infos = simulator.model().parameterInfos();
  const auto setEffects = [&](bool acting) {
    for (std::size_t i = HydraulicModel::kDeadVolume + 1; i < infos.size(); ++i) {
      simulator.setTrueParameter(infos[i].name, acting ? truth(static_cast<Eigen::Index>(i)) : 0.0);
    }
  };
  UniformResampler resampler({});
  std::vector<GridSample> grid;
  if (from > 0) {
    setEffects(false);
    simulateOnGrid(simulator, from * cycle, resampler, &grid);
    setEffects(true);
  }
  simulateOnGrid(simulator, (cycles - std::max(from, 0)) * cycle, resampler, &grid);
  resampler.flush(&grid);
  return grid;
}

struct Onset {
  std::optional<EffectOnset> found;
  double true_time = 0.0;  // [s] from the grid's first sample
};

Onset analyse(std::uint64_t seed, const std::string& effect, int from) {
  const SimulatorConfig plant = testing::randomPlant(
      seed, effect.empty() ? std::vector<std::string>{} : std::vector<std::string>{effect});
  const std::vector<GridSample> grid = recordWithOnset(plant, 10, from);
  const StrokeSegmentation strokes = segmentStrokes(grid);
  Onset o;
  o.found = findEffectOnset(grid, strokes, testing::configFor(plant, {}), 1e-3, 0);
  o.true_time =
      from * DieCushionSimulator(plant).program().cycleDuration() - (grid.empty() ? 0.0 : grid.front().t);
  return o;
}

TEST(EffectOnset, ALeakThatStartsMidRecordingIsNamedWithItsCycle) {
  for (std::uint64_t seed : {11u, 12u, 13u}) {
    const int from = 3 + static_cast<int>(seed % 4);
    const Onset o = analyse(seed, "leakage", from);
    ASSERT_TRUE(o.found) << "seed " << seed;
    EXPECT_EQ(o.found->effect, "leakage");
    EXPECT_EQ(o.found->parameter, "leakage_conductance");
    // The named cycle is the first whose impact comes after the leak started (within one either side).
    const double cycles_off = (o.found->time - o.true_time) / o.found->cycle_period;
    EXPECT_GT(cycles_off, -1.0) << o.found->explanation;
    EXPECT_LT(cycles_off, 2.0) << o.found->explanation;
    EXPECT_LT(std::abs(o.found->before), 3.0 * o.found->before_std + 1e-15) << "no leak before";
    EXPECT_GT(o.found->after, 10.0 * o.found->after_std) << "a leak after";
    EXPECT_LT(o.found->p_value, 1e-3);
    EXPECT_NE(o.found->explanation.find("leakage from press cycle"), std::string::npos);
  }
}

// On a long recording's evenly thinned grid (every 4th cycle kept, EvenlyThinnedCycles) the onset is told in
// the recording's own cycles and time: the first kept cycle the leak acts in, 21 of 40 cycles where it
// started in the 21st, on a fast mechanical press and the paper's.
TEST(EffectOnset, OnEvenlySpacedCyclesTheOnsetIsToldInTheRecordingsCycles) {
  for (const PressClass press : {PressClass::kFastMechanical, PressClass::kSlowHydraulic}) {
    const SimulatorConfig plant = pressClassPlant(press, 1, {"leakage"});
    const std::vector<GridSample> grid = recordWithOnset(plant, 40, 21);
    EvenlyThinnedCycles kept(grid.size() / 2, 250);
    for (const GridSample& g : grid) kept.push(g);
    ASSERT_EQ(kept.stride(), 4) << pressClassName(press);
    const auto found =
        findEffectOnset(kept.grid(), segmentStrokes(kept.grid()), testing::configFor(plant, {}), 1e-3, 0, 60,
                        kept.stride(), kept.firstTime());
    ASSERT_TRUE(found) << pressClassName(press);
    EXPECT_EQ(found->cycle, 24) << found->explanation;  // kept: 0, 4, ..., 20 without it, 24 with
    const StrokeSegmentation whole = segmentStrokes(grid);
    EXPECT_DOUBLE_EQ(found->time, grid[whole.cycle_start[24]].t - grid.front().t) << found->explanation;
    const double period = grid[whole.cycle_start[30]].t - grid[whole.cycle_start[29]].t;
    EXPECT_NEAR(found->cycle_period, period, 0.02 * period);
    EXPECT_NE(found->explanation.find("from press cycle 24 on"), std::string::npos) << found->explanation;
  }
}

TEST(EffectOnset, AirDrawnInMidRecordingIsNamed) {
  const Onset o = analyse(21, "entrained_air", 5);
  ASSERT_TRUE(o.found);
  EXPECT_EQ(o.found->effect, "entrained_air");
  EXPECT_NEAR((o.found->time - o.true_time) / o.found->cycle_period, 0.5, 1.0);
}

TEST(EffectOnset, NothingOnASteadyPlantOrAnEffectPresentThroughout) {
  for (std::uint64_t seed : {31u, 32u, 33u}) {
    EXPECT_FALSE(analyse(seed, "", -1).found) << "clean plant, seed " << seed;
    EXPECT_FALSE(analyse(seed, "leakage", -1).found)
        << "a leak all along is missing, not starting; seed " << seed;
  }
}

TEST(EffectOnset, AGradualDriftIsNotAnOnset) {
  // The oil warming: the bulk modulus falls by a third, a little every cycle.
  const SimulatorConfig plant = testing::randomPlant(41);
  DieCushionSimulator simulator(plant);
  const double cycle = simulator.program().cycleDuration();
  const double start = simulator.trueParameter("bulk_modulus");
  UniformResampler resampler({});
  std::vector<GridSample> grid;
  for (int c = 0; c < 10; ++c) {
    simulator.setTrueParameter("bulk_modulus", start * (1.0 - c / 30.0));
    simulateOnGrid(simulator, cycle, resampler, &grid);
  }
  resampler.flush(&grid);
  const auto found = findEffectOnset(grid, segmentStrokes(grid), testing::configFor(plant, {}), 1e-3, 0);
  EXPECT_FALSE(found) << found->explanation;
}

TEST(EffectOnset, TooFewCyclesNameNothing) {
  const SimulatorConfig plant = testing::randomPlant(51, {"leakage"});
  const std::vector<GridSample> grid = recordWithOnset(plant, 5, 3);
  EXPECT_FALSE(findEffectOnset(grid, segmentStrokes(grid), testing::configFor(plant, {}), 1e-3, 0));
}

}  // namespace
}  // namespace die_cushion_ident
