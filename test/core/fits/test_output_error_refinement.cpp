// The output-error refinement (refineByOutputError) with a user's formula in the model. Its free runs are
// evaluated on several threads (the Jacobian's columns, the stds' columns); a formula's parser is one per
// effect instance and reads its variables from that instance, so the threads must not share it: on two
// threads the refinement must give, bit for bit, what it gives on one.
#include <gtest/gtest.h>

#include <climits>
#include <cmath>
#include <cstdio>
#include <limits>
#include <vector>

#include "../../simulation_fixtures.h"
#include "die_cushion_ident/core/adequacy/held_out_test.h"
#include "die_cushion_ident/core/fits/output_error_refinement.h"
#include "die_cushion_ident/core/simulation/press_class.h"

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

// The topics' common clock offset against the pressure, as the survey refines it where the estimated offsets
// were applied: on a fast press (whose 4 ms impact pins the timing) the pressure read 80 us earlier is found
// 80 us later again, to within 10 us (measured: 84 and 86 us, about one of its std of 5-7 us), with the
// position's own shift unmoved, and a sandwich std small enough for the survey to take it (below a tenth of
// a 0.1 ms prior). The fixture's grid as recorded already reads the pressure 11-14 us apart.
TEST(OutputErrorRefinement, TheCommonClockOffsetAgainstThePressureIsFoundOnFastPresses) {
  for (std::uint64_t variation : {1, 2}) {
    const die_cushion_ident::testing::Recording r =
        die_cushion_ident::testing::record(pressClassPlant(PressClass::kFastMechanical, variation), 8);
    const IdentificationConfig config = die_cushion_ident::testing::configFor(r.plant);
    const HydraulicModel model =
        HydraulicModel::fromNames(config.geometry, config.effects, config.custom_effects, config.oil);
    const HydraulicEstimate start = fitOnCycles(r.grid, r.strokes, config, INT_MIN, INT_MAX);
    ASSERT_GT(start.updates, 0);
    const auto refinedWithThePressureShifted = [&](double pressure_shift) {
      OutputErrorOptions options;
      options.max_samples = 6000;
      options.kept_up_to_noise = 10.0;
      options.position_shift_scale = 1e-4;
      options.pressure_shift_scale = 1e-4;
      return refineByOutputError(timingShifted(r.grid, r.grid.size(), 0.0, pressure_shift), model,
                                 start.values(), start.standardDeviations(), config.min_pressure, options);
    };
    constexpr double kEarly = -80e-6;  // [s] the pressure read 80 us early
    const OutputErrorFit as_recorded = refinedWithThePressureShifted(0.0);
    const OutputErrorFit early = refinedWithThePressureShifted(kEarly);
    ASSERT_TRUE(as_recorded.improved) << as_recorded.message;
    ASSERT_TRUE(early.improved) << early.message;
    EXPECT_NEAR(early.pressure_shift - as_recorded.pressure_shift, -kEarly, 10e-6)
        << "variation " << variation;
    EXPECT_NEAR(early.position_shift, as_recorded.position_shift, 10e-6) << "variation " << variation;
    ASSERT_TRUE(std::isfinite(early.pressure_shift_std));
    EXPECT_GT(early.pressure_shift_std, 0.0);
    EXPECT_LT(early.pressure_shift_std, 10e-6);
    std::printf("variation %d: pressure shift %.1f us as recorded, %.1f us read 80 us early (std %.1f us)\n",
                static_cast<int>(variation), 1e6 * as_recorded.pressure_shift, 1e6 * early.pressure_shift,
                1e6 * early.pressure_shift_std);
  }
}

// A shifted reading stays within each stretch of the grid and loses no sample: beside a NaN pressure (a gap
// in its messages) and at a restart of the time base (a discontinuity 1 s later) each sample keeps its own
// value instead of taking the NaN or blending the two stretches, and the period is the stretches' own 1 ms,
// not the ends' mean over the jump; elsewhere the reading is the Catmull-Rom of a straight line, exact.
TEST(OutputErrorRefinement, AShiftedReadingKeepsEachStretchAndLosesNoSample) {
  std::vector<GridSample> grid(40);
  for (std::size_t k = 0; k < grid.size(); ++k) {
    GridSample& g = grid[k];
    const bool second = k >= 20;
    g.t = 1e-3 * static_cast<double>(k) + (second ? 1.0 : 0.0);
    g.p = static_cast<float>(1e5 + 1e3 * static_cast<double>(k) + (second ? 5e5 : 0.0));
    g.x = static_cast<float>(0.1 + 1e-3 * static_cast<double>(k));
    g.v = 1.0f;
    g.discontinuity = k == 20;
  }
  grid[10].p = std::numeric_limits<float>::quiet_NaN();
  constexpr double kLater = 0.3e-3;
  const std::vector<GridSample> shifted = timingShifted(grid, grid.size(), kLater, kLater);
  ASSERT_EQ(shifted.size(), grid.size());
  EXPECT_NEAR(shifted[5].p, 1e5 + 1e3 * 5.3, 0.02);
  EXPECT_NEAR(shifted[5].x, 0.1 + 1e-3 * 5.3, 1e-6);
  EXPECT_NEAR(shifted[25].p, 6e5 + 1e3 * 25.3, 0.05) << "the period within the stretches";
  EXPECT_EQ(shifted[9].p, grid[9].p) << "beside the NaN: its own";
  EXPECT_TRUE(std::isnan(shifted[10].p));
  EXPECT_NEAR(shifted[11].p, 1e5 + 1e3 * 11.3, 0.02) << "after the NaN (its neighbour left out)";
  EXPECT_EQ(shifted[19].p, grid[19].p) << "not blended across the restart";
  EXPECT_EQ(shifted[19].x, grid[19].x);
  for (const GridSample& g : shifted) {
    EXPECT_TRUE(std::isfinite(g.x));
  }
  // A shift of nothing reads the grid as it is.
  const std::vector<GridSample> same = timingShifted(grid, grid.size(), 0.0, 0.0);
  for (std::size_t k = 0; k < grid.size(); ++k) {
    EXPECT_EQ(same[k].x, grid[k].x);
    if (std::isfinite(grid[k].p)) {
      EXPECT_EQ(same[k].p, grid[k].p);
    }
  }
}

// A valve overlap near 5 % of the spool on a fast press: the equation-error fit leaves 22-25 times the
// pressure noise in the free run (measured: variations 17, 21, 31, 33), with the dead volume far off, and
// the refinement brings it to 1.2-1.7 times the noise with every parameter within 1.5 %. It was not tried
// beyond 15 times the noise, and those recordings were reported as lacking an effect with the poor start's
// estimate (issue 47). On a small stiff press the same overlaps start within 1.5 times the noise.
TEST(OutputErrorRefinement, AFastPressWithAValveOverlapIsRefinedFromAPoorStart) {
  const std::pair<PressClass, std::uint64_t> presses[] = {{PressClass::kFastMechanical, 17},
                                                          {PressClass::kFastMechanical, 31},
                                                          {PressClass::kFastMechanical, 33},
                                                          {PressClass::kSmallStiff, 31}};
  for (const auto& [press, variation] : presses) {
    SCOPED_TRACE(std::string(pressClassName(press)) + " variation " + std::to_string(variation));
    // Read as the analysis reads these presses: a fast one at 1 ms with its grid on the position's messages
    // (which the simulator stamps 0.3 of a period after the others), a small stiff one at 2 ms.
    const bool fast = press == PressClass::kFastMechanical;
    UniformResampler::Config resampler;
    if (fast) {
      resampler.sample_period = 1e-3;
      resampler.grid_phase = 0.3e-3;
    }
    const die_cushion_ident::testing::Recording r = die_cushion_ident::testing::record(
        pressClassPlant(press, variation, {"valve_overlap"}, 7), 8, resampler);
    IdentificationConfig config = die_cushion_ident::testing::configFor(r.plant, {"valve_overlap"});
    if (fast) {
      config.resampler = resampler;
      config.moving_average_width = 63;
      config.derivative_width = 51;
    }
    const HydraulicModel model =
        HydraulicModel::fromNames(config.geometry, config.effects, config.custom_effects, config.oil);
    const HydraulicEstimate start = fitOnCycles(r.grid, r.strokes, config, INT_MIN, INT_MAX);
    ASSERT_GT(start.updates, 0);
    const OutputErrorFit fit = refineByOutputError(r.grid, model, start.values(), start.standardDeviations(),
                                                   config.min_pressure, OutputErrorOptions());
    if (press == PressClass::kFastMechanical) {
      EXPECT_GT(fit.start_rms, 15.0 * fit.noise) << "the poor start";
    }
    ASSERT_TRUE(fit.improved) << fit.message;
    EXPECT_LT(fit.rms, 2.0 * fit.noise);
    const ParameterVector truth = DieCushionSimulator(r.plant).trueParameters();
    ASSERT_EQ(truth.size(), fit.theta.size());
    for (Eigen::Index i = 0; i < truth.size(); ++i) EXPECT_NEAR(fit.theta(i) / truth(i), 1.0, 0.015) << i;
  }
}
