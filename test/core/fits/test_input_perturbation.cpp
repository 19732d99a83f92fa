// The reconstructed inputs' part of the refined parameters' stds (InputPerturbation,
// OutputErrorFit::input_std): the valve model's uncertainty carried through the free run it drives must be
// what a refit on the changed spool gives.
#include <gtest/gtest.h>

#include <climits>
#include <cmath>
#include <limits>

#include "../../simulation_fixtures.h"
#include "die_cushion_ident/core/adequacy/held_out_test.h"
#include "die_cushion_ident/core/fits/output_error_refinement.h"
#include "die_cushion_ident/core/model/hydraulic_model.h"
#include "die_cushion_ident/core/simulation/press_class.h"

using namespace die_cushion_ident;

namespace {

OutputErrorOptions refinement() {
  OutputErrorOptions options;
  options.max_samples = 6000;
  options.kept_up_to_noise = 10.0;
  return options;
}

}  // namespace

// A valve gain known to 0.1 % (the other valve parameters to a millionth of theirs), the model's spool
// driving the free run, on a fast and a small stiff press: the gain's part of the flow gain's std is K_v
// times 0.1 % (the pressure sees only their product), and each parameter's part is the change a refit on the
// spool moved by that std makes, within a quarter of it (or of a tenth of the parameter's own std where the
// part is that small).
TEST(InputPerturbation, TheValveModelsPartIsTheRefitsChange) {
  for (PressClass press : {PressClass::kFastMechanical, PressClass::kSmallStiff}) {
    SCOPED_TRACE(pressClassName(press));
    // The model's spool is free of the sensor's noise (a shut valve integrates it): here the spool measured
    // without noise.
    SimulatorConfig plant = pressClassPlant(press, 5);
    plant.sensors.spool_noise = 0.0;
    die_cushion_ident::testing::Recording r = die_cushion_ident::testing::record(plant, 6);
    for (GridSample& g : r.grid) g.y_model = g.y;
    const IdentificationConfig config = die_cushion_ident::testing::configFor(r.plant);
    const HydraulicModel model =
        HydraulicModel::fromNames(config.geometry, config.effects, config.custom_effects, config.oil);
    const HydraulicEstimate start = fitOnCycles(r.grid, r.strokes, config, INT_MIN, INT_MAX);
    ASSERT_GT(start.updates, 0);
    Eigen::Matrix4d covariance = Eigen::Matrix4d::Zero();
    const ServoValveParameters& valve = r.plant.valve;
    covariance.diagonal() << std::pow(1e-6 * valve.natural_frequency, 2), std::pow(1e-6 * valve.damping, 2),
        std::pow(1e-3 * valve.gain, 2), std::pow(1e-6 * std::max(valve.dead_time, 1e-4), 2);
    OutputErrorOptions options = refinement();
    options.inputs = valveModelPerturbations(r.grid, options.max_samples, valve, covariance);
    ASSERT_EQ(options.inputs.size(), 4u);
    const OutputErrorFit fit = refineByOutputError(r.grid, model, start.values(), start.standardDeviations(),
                                                   config.min_pressure, options);
    ASSERT_TRUE(fit.improved) << fit.message;
    ASSERT_EQ(fit.input_std.count("valve_model"), 1u);
    const ParameterVector& part = fit.input_std.at("valve_model");
    const Eigen::Index flow_gain = HydraulicModel::kValveFlowGain;
    EXPECT_NEAR(part(flow_gain) / (1e-3 * fit.theta(flow_gain)), 1.0, 0.1);

    // The refit on the spool moved by the gain's std (its axis: the largest spool change).
    std::size_t gain_axis = 0;
    double largest = 0.0;
    for (std::size_t j = 0; j < options.inputs.size(); ++j) {
      double sum = 0.0;
      for (float dy : options.inputs[j].spool) sum += std::abs(dy);
      if (sum > largest) {
        largest = sum;
        gain_axis = j;
      }
    }
    OutputErrorOptions plain = refinement();
    plain.with_stds = false;
    const std::vector<GridSample> moved = perturbed(r.grid, r.grid.size(), options.inputs[gain_axis], 1.0);
    const OutputErrorFit refit =
        refineByOutputError(moved, model, fit.theta, fit.std, config.min_pressure, plain);
    ASSERT_TRUE(refit.improved) << refit.message;
    for (Eigen::Index i = 0; i < fit.theta.size(); ++i) {
      const double change = std::abs(refit.theta(i) - fit.theta(i));
      EXPECT_NEAR(change, part(i), std::max(0.25 * part(i), 0.1 * fit.std(i))) << "parameter " << i;
    }
  }
}
