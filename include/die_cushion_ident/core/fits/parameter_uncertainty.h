#pragma once

#include <optional>
#include <vector>

#include "die_cushion_ident/core/estimation/hydraulic_identifier.h"
#include "die_cushion_ident/core/fits/output_error_refinement.h"

namespace die_cushion_ident {

/// What a reported parameter's standard uncertainty is made of [its unit]:
/// u = sqrt((regression^2 + cycles^2) / 2 + method^2) (doc/equations.md, "Uncertainty"):
///  - `regression`: the fit's own, the Newey-West sandwich of the equation-error fit, or the free run's
///    cluster-robust sandwich where the refinement was used and that is larger;
///  - `cycles`: the delete-a-group jackknife over press cycles (applyCycleJackknife): the cycles are the
///    independent units, so the errors' correlation over a stroke and a model error that differs from
///    stroke to stroke are in it. It and `regression` estimate the same variance and are pooled (0: the
///    jackknife could not run, `regression` alone);
///  - `method`: where the free run refined the equation-error estimate, |theta_free_run - theta_equation| /
///    sqrt(3): two estimators, each consistent with the right model, that weigh the inputs' errors
///    differently (the filtered derivative and its windows against the integrated model's timing); their
///    difference bounds the bias that neither std sees, taken as a rectangular distribution of that half
///    width (GUM, type B).
/// Over 250 recordings of every press class x sensor configuration x effect (scripts/uncertainty_calibration)
/// the regression part alone had median |error| / std 0.80 and 84 % of the errors within 1.96 std; the
/// combination 0.55-0.56 and 94 %.
struct ParameterUncertainty {
  double regression = 0.0;
  double cycles = 0.0;
  double method = 0.0;
  double combined() const;
};

/// The parts for every parameter of `reported` (model order), and its stds set to their combination.
/// `equation_error`: the equation-error fit on the whole recording; `refined`: its free-run refinement when
/// run (its theta is `reported`'s when improved); `jackknife`: the same fit with the cycle jackknife's stds,
/// or null where the recording has too few cycles.
std::vector<ParameterUncertainty> combineUncertainty(const HydraulicEstimate& equation_error,
                                                     const std::optional<OutputErrorFit>& refined,
                                                     const HydraulicEstimate* jackknife,
                                                     HydraulicEstimate* reported);

}  // namespace die_cushion_ident
