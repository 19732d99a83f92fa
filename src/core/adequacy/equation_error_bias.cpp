#include "die_cushion_ident/core/adequacy/equation_error_bias.h"

#include <algorithm>
#include <climits>
#include <cmath>
#include <limits>

#include "die_cushion_ident/core/adequacy/held_out_test.h"

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
  // The free run where it runs (NaN where it anchors), in place of each measured pressure.
  std::vector<float> modelled(window.size(), std::numeric_limits<float>::quiet_NaN());
  freeRunSquaredErrors(window, 0, window.size(), model, theta, config.min_pressure, nullptr, &modelled);
  for (std::size_t i = 0; i < window.size(); ++i) {
    if (std::isfinite(modelled[i]) && std::isfinite(window[i].p)) window[i].p = modelled[i];
  }
  bias.own_free_run = fitOnCycles(window, strokes, config, INT_MIN, INT_MAX);
  const auto size = static_cast<std::size_t>(theta.size());
  if (bias.measured.updates == 0 || bias.own_free_run.updates == 0 ||
      bias.measured.parameters.size() != size || bias.own_free_run.parameters.size() != size)
    return std::nullopt;
  return bias;
}

}  // namespace die_cushion_ident
