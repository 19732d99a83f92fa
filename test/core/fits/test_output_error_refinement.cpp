// The output-error refinement (refineByOutputError) with a user's formula in the model. Its free runs are
// evaluated on several threads (the Jacobian's columns, the stds' columns); a formula's parser is one per
// effect instance and reads its variables from that instance, so the threads must not share it: on two
// threads the refinement must give, bit for bit, what it gives on one.
#include <gtest/gtest.h>

#include <climits>

#include "../../simulation_fixtures.h"
#include "die_cushion_ident/core/adequacy/held_out_test.h"
#include "die_cushion_ident/core/fits/output_error_refinement.h"

using namespace die_cushion_ident;

namespace {

OutputErrorFit refinedOn(int jobs, const die_cushion_ident::testing::Recording& r,
                         const IdentificationConfig& config, const HydraulicEstimate& start) {
  const HydraulicModel model =
      HydraulicModel::fromNames(config.geometry, config.effects, config.custom_effects, config.oil);
  OutputErrorOptions options;
  options.jobs = jobs;
  options.max_samples = 6000;
  options.kept_up_to_noise = 10.0;
  return refineByOutputError(r.grid, model, start.values(), start.standardDeviations(), config.min_pressure,
                             options);
}

}  // namespace

TEST(OutputErrorRefinement, AUsersFormulaRefinesAlikeOnOneAndTwoThreads) {
  // A leaking plant, and the user's own leakage formula in the model.
  const die_cushion_ident::testing::Recording r =
      die_cushion_ident::testing::record(die_cushion_ident::testing::randomPlant(11, {"leakage"}), 6);
  IdentificationConfig config = die_cushion_ident::testing::configFor(r.plant);
  config.custom_effects = {"my_leak=p"};
  const HydraulicEstimate start = fitOnCycles(r.grid, r.strokes, config, INT_MIN, INT_MAX);
  ASSERT_GT(start.updates, 0);
  const OutputErrorFit one = refinedOn(1, r, config, start);
  const OutputErrorFit two = refinedOn(2, r, config, start);
  ASSERT_TRUE(one.improved) << one.message;
  EXPECT_LT(one.rms, one.start_rms);
  EXPECT_EQ(one.rms, two.rms);
  ASSERT_EQ(one.theta.size(), two.theta.size());
  for (Eigen::Index i = 0; i < one.theta.size(); ++i) {
    EXPECT_EQ(one.theta(i), two.theta(i)) << "parameter " << i;
    EXPECT_EQ(one.std(i), two.std(i)) << "std of parameter " << i;
  }
}
