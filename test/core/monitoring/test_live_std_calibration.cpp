// How far the live estimate's standard deviations can be trusted: on plants of every press class, the
// published estimate (LiveIdentification::estimate) against the truth in units of its stds, sampled at the
// end of each press cycle once the estimate has forgotten its start.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include "die_cushion_ident/core/monitoring/live_identification.h"
#include "die_cushion_ident/core/simulation/press_class.h"
#include "simulation_fixtures.h"

namespace die_cushion_ident {
namespace {

struct Calibration {
  std::vector<double> z;  // |estimate - truth| / std
  double median() const {
    std::vector<double> sorted = z;
    std::sort(sorted.begin(), sorted.end());
    return sorted.empty() ? NAN : sorted[sorted.size() / 2];
  }
  double within(double k) const {
    return static_cast<double>(std::count_if(z.begin(), z.end(), [k](double v) { return v <= k; })) /
           static_cast<double>(std::max<std::size_t>(z.size(), 1));
  }
};

struct Calibrations {
  Calibration published, regression;
  std::map<std::string, Calibration> by_class;  // published
};

// 40 press cycles of three plants of each class with `effects` in plant and model, the paper's settings
// (the survey off: the same grid for every run), sampled from cycle 14 on; the base parameters.
Calibrations calibrate(const std::vector<std::string>& effects) {
  Calibrations result;
  for (PressClass press : allPressClasses()) {
    for (std::uint64_t variation = 1; variation <= 3; ++variation) {
      const SimulatorConfig plant = pressClassPlant(press, variation, effects, variation);
      DieCushionSimulator simulator(plant);
      LiveIdentificationSettings settings;
      settings.choose_settings = false;
      // The stamps are right, and said so: the monitor's own offset estimate on the 2 ms grid is biased on
      // the small stiff presses (-0.55 ms on a clean one, -0.87 ms with a leakage; the survey, on by
      // default, chooses a finer grid and refines it), and a false correction would bias what is measured.
      IdentificationConfig config = testing::configFor(plant, effects);
      config.topic_delays = {0.0, 0.0, 0.0};
      LiveIdentification live(config, settings);
      const double cycle = simulator.program().cycleDuration();
      for (int c = 0; c < 40; ++c) {
        testing::feed(simulator, cycle, {0.0, 0.0, 0.0},
                      [&live](InputStream stream, const StreamSample& sample) { live.push(stream, sample); });
        if (c < 13) continue;
        const HydraulicEstimate e = live.estimate(), own = live.pipeline().identifier().estimate();
        for (const char* name : {"bulk_modulus", "valve_flow_gain", "dead_volume"}) {
          const double error = std::abs(testing::estimateOf(e, name) - plant.parameters.at(name));
          EXPECT_GE(testing::stdOf(e, name), testing::stdOf(own, name)) << "never below the regression's";
          result.published.z.push_back(error / testing::stdOf(e, name));
          result.by_class[pressClassName(press)].z.push_back(error / testing::stdOf(e, name));
          result.regression.z.push_back(error / testing::stdOf(own, name));
        }
      }
    }
  }
  for (const auto& [name, c] : result.by_class) {
    std::printf("%-16s median |error|/std %.2f, within 1.96 std %.0f %%\n", name.c_str(), c.median(),
                100.0 * c.within(1.96));
  }
  std::printf(
      "all classes      median |error|/std %.2f, within 1.96 std %.0f %% (the regression's alone: %.2f, "
      "%.0f %%)\n",
      result.published.median(), 100.0 * result.published.within(1.96), result.regression.median(),
      100.0 * result.regression.within(1.96));
  return result;
}

// The regression's own stds (Newey-West over rows a few windows apart) covered 90 % of the errors at 1.96
// std (median 0.89); with the scatter over the last minute of cycles 93-94 % on every class (0.70-0.83).
// A Gaussian error with its true std: median 0.67, 95 % within 1.96.
TEST(LiveStdCalibration, ThePublishedStdsCoverTheTruthOnEveryPressClass) {
  const Calibrations c = calibrate({});
  for (const auto& [name, of_class] : c.by_class) EXPECT_GE(of_class.within(1.96), 0.90) << name;
  EXPECT_GE(c.published.within(1.96), 0.92);
  EXPECT_LE(c.published.within(1.96), 0.98) << "not inflated into uselessness";
  EXPECT_GT(c.published.median(), 0.55);
  EXPECT_LT(c.published.median(), 0.85);
  EXPECT_GT(c.published.within(1.96), c.regression.within(1.96) + 0.02)
      << "the scatter adds what the sandwich misses";
}

// With a leakage in plant and model: 92 % within 1.96 std (median 0.77; the regression's alone 87 %, 0.87),
// 88-96 % by class (the paper's press the least).
TEST(LiveStdCalibration, WithALeakageInPlantAndModel) {
  const Calibrations c = calibrate({"leakage"});
  for (const auto& [name, of_class] : c.by_class) EXPECT_GE(of_class.within(1.96), 0.85) << name;
  EXPECT_GE(c.published.within(1.96), 0.90);
  EXPECT_LT(c.published.median(), 0.85);
  EXPECT_GT(c.published.within(1.96), c.regression.within(1.96) + 0.02);
}

}  // namespace
}  // namespace die_cushion_ident
