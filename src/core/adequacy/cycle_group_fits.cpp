#include "die_cushion_ident/core/adequacy/cycle_group_fits.h"

#include <algorithm>

#include "die_cushion_ident/core/adequacy/held_out_test.h"
#include "die_cushion_ident/core/util/parallel_for.h"

namespace die_cushion_ident {

CycleGroupFits::CycleGroupFits(const std::vector<GridSample>& grid, const StrokeSegmentation& strokes,
                               const IdentificationConfig& config, int groups, int jobs) {
  const int g_count = std::min(groups, strokes.cycles);
  if (g_count < 4) return;
  estimates_.resize(static_cast<std::size_t>(g_count));
  first_.resize(estimates_.size());
  parallelFor(estimates_.size(), jobs, [&](std::size_t g) {
    const int group = static_cast<int>(g);
    first_[g] = group * strokes.cycles / g_count;
    const int last = (group + 1) * strokes.cycles / g_count - 1;
    estimates_[g] = fitOnCycles(grid, strokes, config, first_[g], last);
  });
  const std::size_t n = estimates_.front().parameters.size();
  valid_ = n > 0 && std::all_of(estimates_.begin(), estimates_.end(), [&](const HydraulicEstimate& e) {
             return e.updates > 0 && e.parameters.size() == n;
           });
}

}  // namespace die_cushion_ident
