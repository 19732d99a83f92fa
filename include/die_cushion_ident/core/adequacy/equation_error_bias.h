#pragma once

#include <cstddef>
#include <vector>

#include "die_cushion_ident/core/adequacy/model_assessment.h"
#include "die_cushion_ident/core/estimation/hydraulic_identifier.h"

namespace die_cushion_ident {

/// The equation-error fit (fitOnCycles) to what the model run free from `theta` makes of the recording's own
/// inputs, without the pressure sensor's noise: over the first `samples` grid samples, each sample's pressure
/// replaced by the free run's wherever it runs (the measurement is kept where it anchors, below
/// min_pressure). Its difference from `theta` is the equation-error fit's own bias at that model, the
/// filtered derivative's windows against the plant's fastest transients, which the free run does not
/// share; the method part of the stds (combineUncertainty) compares the equation error with this fit
/// instead of with `theta`, so that the bias is not counted as the two estimators' disagreement
/// (doc/equations.md, "What analyze_bag reports").
HydraulicEstimate equationErrorOfOwnFreeRun(const std::vector<GridSample>& grid,
                                            const StrokeSegmentation& strokes,
                                            const IdentificationConfig& config, const HydraulicModel& model,
                                            const ParameterVector& theta, std::size_t samples);

}  // namespace die_cushion_ident
