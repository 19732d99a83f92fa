#include "die_cushion_ident/core/adequacy/equation_error_bias.h"

#include <algorithm>
#include <climits>
#include <cmath>

#include "die_cushion_ident/core/adequacy/held_out_test.h"
#include "die_cushion_ident/core/fits/free_run_pressure.h"

namespace die_cushion_ident {

std::optional<EquationErrorBias> equationErrorBias(const std::vector<GridSample>& grid,
                                                   const StrokeSegmentation& strokes,
                                                   const IdentificationConfig& config,
                                                   const HydraulicModel& model, const ParameterVector& theta,
                                                   std::size_t samples) {
  std::vector<GridSample> window(grid.begin(),
                                 grid.begin() + static_cast<std::ptrdiff_t>(std::min(samples, grid.size())));
  EquationErrorBias bias;
  // The strokes' ranges reach past the window's end; the fit stops at it.
  bias.measured = fitOnCycles(window, strokes, config, INT_MIN, INT_MAX);
  // Run over the measured grid (the free run reads the next sample's inputs), written to the window.
  FreeRunPressure free_run(model, config.min_pressure);
  for (std::size_t i = 0; i < window.size(); ++i) {
    const double p = free_run.step(grid[i], theta, i + 1 < grid.size() ? &grid[i + 1] : nullptr);
    if (std::isfinite(p) && !free_run.anchoredThisStep() && std::isfinite(grid[i].p)) window[i].p = p;
  }
  bias.own_free_run = fitOnCycles(window, strokes, config, INT_MIN, INT_MAX);
  const auto size = static_cast<std::size_t>(theta.size());
  if (bias.measured.updates == 0 || bias.own_free_run.updates == 0 ||
      bias.measured.parameters.size() != size || bias.own_free_run.parameters.size() != size)
    return std::nullopt;
  return bias;
}

}  // namespace die_cushion_ident
