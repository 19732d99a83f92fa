// The free-run pressure model and the stroke-phase classifier against the simulator's truth.
#include <gtest/gtest.h>

#include <cmath>
#include <map>

#include "die_cushion_ident/core/fits/free_run_pressure.h"
#include "die_cushion_ident/core/segmentation/stroke_phase_classifier.h"
#include "simulation_fixtures.h"

namespace die_cushion_ident {
namespace {

double freeRunErrorRms(const std::vector<GridSample>& grid, const HydraulicModel& model,
                       const ParameterVector& parameters) {
  FreeRunPressure free_run(model, 5e5);
  double sum = 0.0;
  int n = 0;
  for (const auto& g : grid) {
    const double p = free_run.step(g, parameters);
    if (std::isfinite(p) && !free_run.anchoredThisStep()) {
      sum += (p - g.p) * (p - g.p);
      ++n;
    }
  }
  EXPECT_GT(n, static_cast<int>(grid.size() / 2)) << "the model runs free most of the time";
  return std::sqrt(sum / n);
}

TEST(FreeRunPressure, TrueModelFollowsTheMeasurementAndAWrongOneDoesNot) {
  auto config = testing::randomPlant(5, {"leakage"});
  DieCushionSimulator plant(config);
  const auto grid = simulateGrid(plant, 3 * plant.program().cycleDuration());
  const ParameterVector truth = plant.trueParameters();
  const double true_error = freeRunErrorRms(grid, plant.model(), truth);
  // Measurement noise is 0.2 bar; the rest is the 2 ms grid's interpolation of the inputs.
  EXPECT_LT(true_error, 1.0e5);
  ParameterVector stiff(truth);
  stiff(HydraulicModel::kBulkModulus) = 2.0 * truth(HydraulicModel::kBulkModulus);
  ParameterVector without_leakage(truth);
  without_leakage(HydraulicModel::kFirstEffect) = 0.0;
  EXPECT_GT(freeRunErrorRms(grid, plant.model(), without_leakage), 3.0 * true_error);
  EXPECT_GT(freeRunErrorRms(grid, plant.model(), stiff), 1.5 * true_error);
}

TEST(FreeRunPressure, ReanchorsWhereTheModelDoesNotHold) {
  auto config = testing::randomPlant(6);
  DieCushionSimulator plant(config);
  const auto grid = simulateGrid(plant, plant.program().cycleDuration());
  FreeRunPressure free_run(plant.model(), 5e5);
  GridSample gap = grid[100];
  gap.complete = false;
  gap.p = NAN;
  EXPECT_TRUE(std::isnan(free_run.step(gap, plant.trueParameters())));
  EXPECT_DOUBLE_EQ(free_run.step(grid[101], plant.trueParameters()), grid[101].p);
  EXPECT_TRUE(free_run.anchoredThisStep());
  ParameterVector broken = plant.trueParameters();
  broken(HydraulicModel::kBulkModulus) = NAN;
  for (int i = 102; i < 200; ++i) EXPECT_TRUE(std::isfinite(free_run.step(grid[i], broken)));
}

TEST(StrokePhaseClassifier, AgreesWithTheSimulatedPressProgram) {
  auto config = testing::randomPlant(7);
  DieCushionSimulator plant(config);
  const auto grid = simulateGrid(plant, 4 * plant.program().cycleDuration());
  StrokePhaseClassifier classifier;
  std::map<StrokePhase, int> total, right;
  int all_right = 0;
  for (const auto& g : grid) {
    const StrokePhase truth = plant.program().at(g.t).phase;
    const StrokePhase guess = classifier.classify(g);
    if (g.t < plant.program().cycleDuration()) continue;  // the first stroke teaches the stroke depth
    ++total[truth];
    if (guess == truth) {
      ++right[truth];
      ++all_right;
    }
  }
  int n = 0;
  for (const auto& [phase, count] : total) n += count;
  EXPECT_GT(static_cast<double>(all_right) / n, 0.9);
  for (const auto& [phase, count] : total) {
    const double share = static_cast<double>(right[phase]) / count;
    std::printf("%-12s %5d samples, %.0f %% right\n", strokePhaseName(phase), count, 100 * share);
    EXPECT_GT(share, phase == StrokePhase::kImpact ? 0.3 : 0.7) << strokePhaseName(phase);
  }
}

}  // namespace
}  // namespace die_cushion_ident
