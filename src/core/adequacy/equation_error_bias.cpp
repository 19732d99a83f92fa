#include "die_cushion_ident/core/adequacy/equation_error_bias.h"

#include <algorithm>
#include <climits>
#include <cmath>

#include "die_cushion_ident/core/adequacy/held_out_test.h"
#include "die_cushion_ident/core/fits/free_run_pressure.h"

namespace die_cushion_ident {

HydraulicEstimate equationErrorOfOwnFreeRun(const std::vector<GridSample>& grid,
                                            const StrokeSegmentation& strokes,
                                            const IdentificationConfig& config, const HydraulicModel& model,
                                            const ParameterVector& theta, std::size_t samples) {
  std::vector<GridSample> modelled(
      grid.begin(), grid.begin() + static_cast<std::ptrdiff_t>(std::min(samples, grid.size())));
  // Run over the measured grid (the free run reads the next sample's inputs), written to the copy.
  FreeRunPressure free_run(model, config.min_pressure);
  for (std::size_t i = 0; i < modelled.size(); ++i) {
    const double p = free_run.step(grid[i], theta, i + 1 < grid.size() ? &grid[i + 1] : nullptr);
    if (std::isfinite(p) && !free_run.anchoredThisStep() && std::isfinite(grid[i].p)) modelled[i].p = p;
  }
  // The strokes' ranges reach past the copy's end; the fit stops at it.
  return fitOnCycles(modelled, strokes, config, INT_MIN, INT_MAX);
}

}  // namespace die_cushion_ident
