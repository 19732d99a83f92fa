#pragma once

#include <optional>
#include <vector>

#include "die_cushion_ident/core/estimation/hydraulic_identifier.h"
#include "die_cushion_ident/core/fits/output_error_refinement.h"

namespace die_cushion_ident {

/// What a reported parameter's standard uncertainty is made of [its unit]:
/// u = sqrt(s^2 + misfit^2 + method^2 + valve_model^2 + clock_offsets^2), s = free_run where the
/// free run's inputs are all known, else max(sqrt((regression^2 + cycles^2) / 2), free_run)
/// (doc/equations.md, "What analyze_bag reports"):
///  - `regression`: the equation-error fit's own, its Newey-West sandwich;
///  - `cycles`: the delete-a-group jackknife over press cycles (applyCycleJackknife): the cycles are the
///    independent units, so the errors' correlation over a stroke and a model error that differs from
///    stroke to stroke are in it. It and `regression` estimate the same variance and are pooled (0: the
///    jackknife could not run, `regression` alone);
///  - `free_run`: where the free run refined the estimate, its cluster-robust sandwich (0 otherwise): the
///    reported estimator's own; where it is larger than the equation error's pooled std it is taken;
///  - `misfit`: where the free run's refinement was not kept because the estimate's free run stays R times
///    the pressure noise (the model lacks something, or an input is off), u_pool sqrt(R^2 - 1): the pooled
///    std scaled by R (Birge's ratio), since the equation-error stds assume the model holds to the noise
///    (0 where the refinement was kept or not tried);
///  - `method`: where the free run refined the equation-error estimate, the part of their difference d their
///    own scatter does not explain, sqrt(max(0, d^2 - (u_pool^2 - free_run^2))) / sqrt(3) (Hausman: where the
///    free run is the efficient estimator, var(d) = u_pool^2 - free_run^2): two estimators, each consistent
///    with the right model, that weigh the inputs' errors differently (the filtered derivative and its
///    windows against the integrated model's timing); the excess bounds the bias that neither std sees,
///    taken as a rectangular distribution of that half width (GUM, type B). Where given, d is the
///    equation-error fits' difference over the refinement's samples, to the measurement and to the refined
///    model's own free run (equationErrorBias): the equation error's own bias at the model (its filter
///    windows against a fast press's impact) is no disagreement of the estimators.
/// Over 250 recordings of every press class x sensor configuration x effect (scripts/uncertainty_calibration,
/// seeds 20261125-20261127, 2026-12-08), pooled over the three draws, each press class had median
/// |error| / std 0.62-0.74 and 94.7-96.0 % within 1.96 std; short: the valve overlap (92.2 %) and the
/// position at 500 Hz (90.0 %, doc/equations.md).
struct ParameterUncertainty {
  double regression = 0.0;
  double cycles = 0.0;
  double free_run = 0.0;
  double misfit = 0.0;
  double method = 0.0;
  /// `valve_model`: where the free run refined the estimate, what the reconstructed input's own uncertainty
  /// makes of it (OutputErrorFit::input_std): the valve model fitted to the operation, whose spool drives the
  /// free run.
  double valve_model = 0.0;
  /// `clock_offsets`: likewise, the topics' common clock offset against the pressure where the offsets were
  /// estimated and applied (IdentificationConfig::common_delay_std); 0 where they were configured or none
  /// was applied.
  double clock_offsets = 0.0;
  /// Every input of the free run is measured or has its uncertainty in valve_model: the free run's sandwich
  /// alone is then the refined estimate's statistical part. Otherwise (a configured valve model drives it)
  /// the equation error's pool bounds it too.
  bool free_run_inputs_known = false;
  /// sqrt((regression^2 + cycles^2) / 2), or regression where the jackknife did not run.
  double equationError() const;
  double combined() const;
};

/// The equation-error fit over the samples the free run's refinement read, to the measurement and to the
/// refined model's own noise-free free run (equationErrorBias): what the method part compares.
struct EquationErrorBias {
  HydraulicEstimate measured;
  HydraulicEstimate own_free_run;
};

/// The parts for every parameter of `reported` (model order), and its stds set to their combination.
/// `equation_error`: the equation-error fit on the whole recording; `refined`: its free-run refinement when
/// run (its theta is `reported`'s when improved); `jackknife`: the same fit with the cycle jackknife's stds,
/// or null where the recording has too few cycles; `bias`: the equation error over the refinement's samples
/// (equationErrorBias), or null: where given, the method part reads d as its two fits' difference instead of
/// the refined theta's from `equation_error`, so that the equation error's own bias is not in it, and the
/// scatter subtracted is the window's (u_pool scaled by the window fit's std over the whole one's).
std::vector<ParameterUncertainty> combineUncertainty(const HydraulicEstimate& equation_error,
                                                     const std::optional<OutputErrorFit>& refined,
                                                     const HydraulicEstimate* jackknife,
                                                     HydraulicEstimate* reported,
                                                     bool free_run_inputs_known = false,
                                                     const EquationErrorBias* bias = nullptr);

}  // namespace die_cushion_ident
