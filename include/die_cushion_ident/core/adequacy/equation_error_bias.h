#pragma once

#include <cstddef>
#include <optional>
#include <vector>

#include "die_cushion_ident/core/adequacy/model_assessment.h"
#include "die_cushion_ident/core/fits/parameter_uncertainty.h"

namespace die_cushion_ident {

/// The equation-error fit (fitOnCycles) over the first `samples` grid samples, the ones the free run's
/// refinement reads, twice: to the measurement, and to what the model run free from `theta` makes of the
/// same inputs without the pressure sensor's noise (each sample's pressure replaced by the free run's
/// wherever it runs; the measurement is kept where it anchors, below min_pressure). Their difference is the
/// equation-error fit's disagreement with the refined model net of its own bias at that model (the filtered
/// derivative's windows against the plant's fastest transients, which the free run does not share): the
/// method part of the stds (combineUncertainty). Both fits over the same samples, so that on a recording
/// longer than them the shorter fit's scatter is not taken for a disagreement. Null where either fit took no
/// update (a window of the press at rest: the fit would be its prior).
std::optional<EquationErrorBias> equationErrorBias(const std::vector<GridSample>& grid,
                                                   const StrokeSegmentation& strokes,
                                                   const IdentificationConfig& config,
                                                   const HydraulicModel& model, const ParameterVector& theta,
                                                   std::size_t samples);

}  // namespace die_cushion_ident
