// Issue 13 (paper, Fig. 19): the identified model as a feed-forward next to the PI pressure controller.
// On random simulated plants the PI controller alone, PI plus the identified model's feed-forward, and PI
// plus a deliberately wrong model's feed-forward track the drawing pressure; the identified one at least
// three times better than PI alone, and better than the wrong ones.
#include <gtest/gtest.h>

#include <climits>
#include <cmath>
#include <cstdio>
#include <memory>

#include "die_cushion_ident/core/analysis/held_out_test.h"
#include "die_cushion_ident/core/control/pressure_feed_forward.h"
#include "simulation_fixtures.h"

namespace die_cushion_ident {
namespace {

double drawingTrackingError(const SimulatorConfig& plant, std::shared_ptr<const PressureFeedForward> feed_forward,
                            bool nominal_velocity_feed_forward = false) {
  return drawingPressureErrorRms(plant, std::move(feed_forward), nominal_velocity_feed_forward, 3);
}

TEST(PressureFeedForward, TheIdentifiedModelTracksTheDrawingPressureThreeTimesBetterThanPiAlone) {
  const std::vector<std::vector<std::string>> models = {{}, {"leakage"}, {"entrained_air"}};
  for (std::uint64_t seed : {41, 42, 43}) {
    const auto& effects = models[seed % models.size()];
    SCOPED_TRACE("seed " + std::to_string(seed));
    const SimulatorConfig plant = testing::randomPlant(seed, effects);
    // Identified from a recording made with the press's own controller.
    const testing::Recording recording = testing::record(plant, 6);
    const std::vector<GridSample>& grid = recording.grid;
    const StrokeSegmentation& strokes = recording.strokes;
    const IdentificationConfig config = testing::configFor(plant, effects);
    const HydraulicEstimate estimate = fitOnCycles(grid, strokes, config, INT_MIN, INT_MAX);
    const HydraulicModel model = HydraulicModel::fromNames(config.geometry, effects);
    ParameterVector theta(model.parameterCount());
    for (int i = 0; i < model.parameterCount(); ++i) theta(i) = estimate.parameters[i].value;
    // The valve model as a sweep identifies it (README: natural frequency within 1 %, dead time 0.1 ms).
    const auto with = [&](const ParameterVector& parameters) {
      return std::make_shared<const PressureFeedForward>(model, parameters, plant.valve,
                                                         plant.controller.max_voltage);
    };
    const double pi_alone = drawingTrackingError(plant, nullptr);
    const double press_default = drawingTrackingError(plant, nullptr, true);
    const double identified = drawingTrackingError(plant, with(theta));
    ParameterVector soft = theta, weak = theta;
    soft(HydraulicModel::kBulkModulus) *= 1.5;
    weak(HydraulicModel::kValveFlowGain) *= 1.5;
    const double wrong_bulk_modulus = drawingTrackingError(plant, with(soft));
    const double wrong_flow_gain = drawingTrackingError(plant, with(weak));
    std::printf("seed %llu: drawing pressure error rms: PI alone %.2f bar, PI + nominal velocity feed-forward "
                "%.2f bar, PI + identified model %.2f bar (%.1fx better than PI alone); bulk modulus +50 %% "
                "%.2f bar, flow gain +50 %% %.2f bar\n",
                static_cast<unsigned long long>(seed), pi_alone * 1e-5, press_default * 1e-5, identified * 1e-5,
                pi_alone / identified, wrong_bulk_modulus * 1e-5, wrong_flow_gain * 1e-5);
    EXPECT_GE(pi_alone, 3.0 * identified);
    EXPECT_GT(wrong_bulk_modulus, identified);
    EXPECT_GT(wrong_flow_gain, identified);
  }
}

TEST(PressureFeedForward, NeverCommandsOutsideTheValveRangeAndIgnoresNonFiniteInput) {
  const SimulatorConfig plant = testing::randomPlant(7);
  const HydraulicModel model = HydraulicModel::fromNames(plant.geometry, {});
  const PressureFeedForward ff(model, model.nominalParameters(), plant.valve, 4.0);
  for (double p : {-1e7, 0.0, 50e5, 150e5, 1e9}) {
    for (double dp : {-1e12, -1e8, 0.0, 1e8, 1e12}) {
      for (double v : {-50.0, -0.2, 0.0, 0.2, 50.0}) {
        const double u = ff.command(p, dp, 0.1, v);
        EXPECT_LE(std::abs(u), 4.0) << p << " " << dp << " " << v;
      }
    }
  }
  bool valid = true;
  EXPECT_EQ(ff.command(std::nan(""), 0.0, 0.1, 0.1, &valid), 0.0);
  EXPECT_FALSE(valid);
  EXPECT_EQ(ff.command(100e5, INFINITY, 0.1, 0.1, &valid), 0.0);
  EXPECT_FALSE(valid);
  ServoValveParameters no_gain = plant.valve;
  no_gain.gain = 0.0;
  EXPECT_THROW(PressureFeedForward(model, model.nominalParameters(), no_gain, 4.0), std::invalid_argument);
  EXPECT_THROW(PressureFeedForward(model, model.nominalParameters(), plant.valve, 0.0), std::invalid_argument);
}

// The inverse is exact: the spool opening it gives makes the model's own pressure rate equal the request.
TEST(PressureFeedForward, TheSpoolOpeningReproducesTheRequestedPressureRate) {
  const SimulatorConfig plant = testing::randomPlant(8, {"leakage", "valve_overlap"});
  const HydraulicModel model = HydraulicModel::fromNames(plant.geometry, {"leakage", "valve_overlap"});
  ParameterVector theta = model.nominalParameters();
  theta(HydraulicModel::kFirstEffect) = 2e-11;
  theta(HydraulicModel::kFirstEffect + 1) = 0.03;
  const PressureFeedForward ff(model, theta, plant.valve, 10.0);
  for (double dp : {-5e8, -1e7, 0.0, 1e7, 5e8}) {
    HydraulicSignals s;
    s.p = 120e5;
    s.x = 0.1;
    s.v = 0.2;
    s.y = ff.spoolOpening(s.p, dp, s.x, s.v);
    s.V = model.chamberVolume(s.x, theta(HydraulicModel::kDeadVolume));
    if (std::abs(s.y) >= 1.0) continue;  // beyond the valve's range
    EXPECT_NEAR(model.pressureRate(s, theta), dp, 1e-6 * std::max(std::abs(dp), 1e6)) << dp;
  }
}

}  // namespace
}  // namespace die_cushion_ident
