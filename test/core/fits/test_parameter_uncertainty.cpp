// combineUncertainty: how the parts of a reported std combine (doc/equations.md, "What analyze_bag reports").
// Analytic cases; the calibration over simulated recordings is test_press_classes'
// StandardDeviationsAreCalibratedOverClassesSensorsAndEffects (scripts/uncertainty_calibration).
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <optional>

#include "die_cushion_ident/core/fits/parameter_uncertainty.h"

namespace die_cushion_ident {
namespace {

HydraulicEstimate estimate(double value, double std) {
  HydraulicEstimate e;
  e.parameters.push_back({"bulk_modulus", "Pa", value, std});
  return e;
}

OutputErrorFit freeRun(double value, double std, bool improved = true) {
  OutputErrorFit fit;
  fit.improved = improved;
  fit.theta = ParameterVector::Constant(1, value);
  fit.std = ParameterVector::Constant(1, std);
  return fit;
}

// A refinement not kept: its search reached `value`, the estimate's free run had run `start_rms` against
// the pressure noise `noise`.
OutputErrorFit refinementNotKept(double value, double start_rms, double noise) {
  OutputErrorFit fit = freeRun(value, 9e6, false);
  fit.start_rms = start_rms;
  fit.noise = noise;
  return fit;
}

// Without a jackknife or a refinement the fit's own std is all there is.
TEST(ParameterUncertainty, TheFitsOwnStdAloneWithoutJackknifeOrRefinement) {
  const HydraulicEstimate equation_error = estimate(1e9, 4e6);
  HydraulicEstimate reported = equation_error;
  const auto parts = combineUncertainty(equation_error, std::nullopt, nullptr, &reported);
  ASSERT_EQ(parts.size(), 1u);
  EXPECT_DOUBLE_EQ(parts[0].regression, 4e6);
  EXPECT_DOUBLE_EQ(parts[0].cycles, 0.0);
  EXPECT_DOUBLE_EQ(parts[0].free_run, 0.0);
  EXPECT_DOUBLE_EQ(parts[0].method, 0.0);
  EXPECT_DOUBLE_EQ(reported.parameters[0].std, 4e6);
}

// The sandwich and the cycle jackknife estimate the same variance: pooled, u^2 = (3^2 + 4^2) / 2.
TEST(ParameterUncertainty, SandwichAndCycleJackknifePooled) {
  const HydraulicEstimate equation_error = estimate(1e9, 3e6);
  const HydraulicEstimate jackknife = estimate(1e9, 4e6);
  HydraulicEstimate reported = equation_error;
  combineUncertainty(equation_error, std::nullopt, &jackknife, &reported);
  EXPECT_NEAR(reported.parameters[0].std, std::sqrt(12.5) * 1e6, 1.0);
}

// A non-finite jackknife std (a replicate that failed) is no part: the sandwich alone.
TEST(ParameterUncertainty, NonFiniteJackknifeIgnored) {
  const HydraulicEstimate equation_error = estimate(1e9, 3e6);
  const HydraulicEstimate jackknife = estimate(1e9, std::numeric_limits<double>::quiet_NaN());
  HydraulicEstimate reported = equation_error;
  const auto parts = combineUncertainty(equation_error, std::nullopt, &jackknife, &reported);
  EXPECT_DOUBLE_EQ(parts[0].cycles, 0.0);
  EXPECT_DOUBLE_EQ(reported.parameters[0].std, 3e6);
}

// The free run's sandwich is the reported estimator's own: where it exceeds the equation error's pooled std
// it is taken whole, not pooled with the equation error's jackknife (that diluted it); the method's part
// |theta_free_run - theta_equation| / sqrt(3) adds in quadrature.
TEST(ParameterUncertainty, LargerFreeRunStdTakenWholeAndMethodAdded) {
  const HydraulicEstimate equation_error = estimate(1e9, 3e6);
  const HydraulicEstimate jackknife = estimate(1e9, 3e6);
  const std::optional<OutputErrorFit> refined = freeRun(1e9 + std::sqrt(3.0) * 4e6, 6e6);
  HydraulicEstimate reported = estimate(refined->theta(0), 6e6);  // max of the two sandwiches
  const auto parts = combineUncertainty(equation_error, refined, &jackknife, &reported);
  EXPECT_DOUBLE_EQ(parts[0].regression, 3e6) << "the equation-error fit's sandwich, whatever reported held";
  EXPECT_DOUBLE_EQ(parts[0].free_run, 6e6);
  EXPECT_NEAR(parts[0].method, 4e6, 1.0);
  EXPECT_NEAR(reported.parameters[0].std, std::hypot(6e6, 4e6), 1.0);
}

// The equation error's own bias at the refined model (its fit to the model's own noise-free free run) is no
// disagreement of the estimators: a difference it accounts for leaves no method part, and only what is left
// of the difference beyond it counts.
TEST(ParameterUncertainty, TheEquationErrorsOwnBiasIsNoMethodPart) {
  const HydraulicEstimate equation_error = estimate(0.95e9, 3e6);  // 5 % low, as on a fast press
  const std::optional<OutputErrorFit> refined = freeRun(1e9, 6e6);
  HydraulicEstimate reported = estimate(1e9, 6e6);
  const auto whole = combineUncertainty(equation_error, refined, nullptr, &reported);
  EXPECT_NEAR(whole[0].method, 5e7 / std::sqrt(3.0), 1.0) << "without the own free run's fit: all of d";
  const EquationErrorBias own_bias{equation_error, estimate(0.95e9, 0.0)};
  const auto net = combineUncertainty(equation_error, refined, nullptr, &reported, false, &own_bias);
  EXPECT_DOUBLE_EQ(net[0].method, 0.0);
  EXPECT_NEAR(reported.parameters[0].std, 6e6, 1.0);
  const EquationErrorBias part_of_it{equation_error, estimate(0.97e9, 0.0)};  // 2e7 not its own
  const auto rest = combineUncertainty(equation_error, refined, nullptr, &reported, false, &part_of_it);
  EXPECT_NEAR(rest[0].method, 2e7 / std::sqrt(3.0), 1.0);
}

// Fits over fewer samples than the whole recording scatter more: the scatter their difference is allowed is
// the pool scaled by the window fit's std over the whole fit's (here 2: a pool of 3e6 becomes 6e6, and with a
// free run of 1e6 the difference's own scatter is sqrt(35) 1e6).
TEST(ParameterUncertainty, TheWindowsScatterIsItsOwn) {
  const HydraulicEstimate equation_error = estimate(1e9, 3e6);
  const std::optional<OutputErrorFit> refined = freeRun(1e9, 1e6);
  HydraulicEstimate reported = estimate(1e9, 1e6);
  const EquationErrorBias window{estimate(1.0e9, 6e6), estimate(1.0e9 + 8e6, 0.0)};
  const auto parts = combineUncertainty(equation_error, refined, nullptr, &reported, true, &window);
  EXPECT_NEAR(parts[0].method, std::sqrt(64.0 - 35.0) * 1e6 / std::sqrt(3.0), 1.0);
}

// A free run more precise than the equation error leaves the pooled std where one of its inputs carries an
// error no part holds (a configured valve model, a derived velocity: doc/equations.md).
TEST(ParameterUncertainty, SmallerFreeRunStdLeavesThePool) {
  const HydraulicEstimate equation_error = estimate(1e9, 3e6);
  const HydraulicEstimate jackknife = estimate(1e9, 4e6);
  const std::optional<OutputErrorFit> refined = freeRun(1e9, 1e6);
  HydraulicEstimate reported = estimate(1e9, 3e6);
  combineUncertainty(equation_error, refined, &jackknife, &reported);
  EXPECT_NEAR(reported.parameters[0].std, std::sqrt(12.5) * 1e6, 1.0);
}

// Where every input of the free run is measured or carries its own uncertainty, the free run's sandwich
// alone is the statistical part, however much wider the equation error's pool is; the valve model's part
// adds in quadrature with the method's (the estimators' difference beyond the
// scatter the pool has over the free run: Hausman).
TEST(ParameterUncertainty, WithItsInputsKnownTheFreeRunStandsAloneWithTheirParts) {
  const HydraulicEstimate equation_error = estimate(1e9, 3e6);
  const HydraulicEstimate jackknife = estimate(1e9, 4e6);
  // The estimators differ by 3.5e6, of which the pool's scatter beyond the free run's explains
  // sqrt(12.5e12 - 1e12): the method's part is the rest, sqrt(12.25e12 - 11.5e12) / sqrt(3) = 0.5e6.
  std::optional<OutputErrorFit> refined = freeRun(1e9 + 3.5e6, 1e6);
  refined->input_std["valve_model"] = ParameterVector::Constant(1, 2e6);
  HydraulicEstimate reported = estimate(refined->theta(0), 3e6);
  const auto parts = combineUncertainty(equation_error, refined, &jackknife, &reported, true);
  EXPECT_TRUE(parts[0].free_run_inputs_known);
  EXPECT_DOUBLE_EQ(parts[0].valve_model, 2e6);
  EXPECT_NEAR(parts[0].method, 0.5e6, 1.0);
  EXPECT_NEAR(reported.parameters[0].std, std::sqrt(1.0 + 0.25 + 4.0) * 1e6, 1.0);
  // The same inputs not all known: the pool bounds the statistical part, the inputs' parts still add.
  reported = estimate(refined->theta(0), 3e6);
  combineUncertainty(equation_error, refined, &jackknife, &reported, false);
  EXPECT_NEAR(reported.parameters[0].std, std::sqrt(12.5 + 0.25 + 4.0) * 1e6, 1.0);
}

// A refinement not kept because the estimate's free run stays 5 times the pressure noise: the equation
// error's std scaled by that ratio (misfit = u sqrt(5^2 - 1)); neither the free run's std nor a method's
// part.
TEST(ParameterUncertainty, RefinementNotKeptForAModelErrorScalesTheStd) {
  const HydraulicEstimate equation_error = estimate(1e9, 3e6);
  const std::optional<OutputErrorFit> refined = refinementNotKept(1.1e9, 5e5, 1e5);  // not kept: not compared
  HydraulicEstimate reported = equation_error;
  const auto parts = combineUncertainty(equation_error, refined, nullptr, &reported);
  EXPECT_DOUBLE_EQ(parts[0].free_run, 0.0);
  EXPECT_DOUBLE_EQ(parts[0].method, 0.0);
  EXPECT_NEAR(parts[0].misfit, 3e6 * std::sqrt(24.0), 1.0);
  EXPECT_NEAR(reported.parameters[0].std, 5.0 * 3e6, 1.0);
}

// A refinement that was not kept because its free run did not fall (already at the noise) contributes
// nothing.
TEST(ParameterUncertainty, RefinementNotKeptAtTheNoiseIsNoPart) {
  const HydraulicEstimate equation_error = estimate(1e9, 3e6);
  const std::optional<OutputErrorFit> refined = refinementNotKept(1.1e9, 0.98e5, 1e5);
  HydraulicEstimate reported = equation_error;
  const auto parts = combineUncertainty(equation_error, refined, nullptr, &reported);
  EXPECT_DOUBLE_EQ(parts[0].misfit, 0.0);
  EXPECT_DOUBLE_EQ(parts[0].free_run, 0.0);
  EXPECT_DOUBLE_EQ(parts[0].method, 0.0);
  EXPECT_DOUBLE_EQ(reported.parameters[0].std, 3e6);
}

}  // namespace
}  // namespace die_cushion_ident
