#include "balance_cost.h"

namespace die_cushion_ident::topic_delay_detail {

Signals prepare(const std::vector<GridSample>& grid, std::size_t n, const IdentificationConfig& config) {
  Signals s;
  s.p.assign(n, NAN);
  s.x.assign(n, NAN);
  s.y.assign(n, NAN);
  for (std::size_t i = 0; i < n; ++i) {
    const GridSample& g = grid[i];
    if (!g.complete || g.discontinuity) continue;  // a restart of the time base is a gap for the shifts
    s.x[i] = g.x;
    s.y[i] = g.y;
    if (g.p >= config.min_pressure && std::abs(g.y) <= config.max_spool_opening) s.p[i] = g.p;
  }
  return s;
}

// The channels averaged over `width` samples centred on each (NaN spreads): the coarse map's view, whose
// basins are as wide as its step (a fast press's impact and valve make them narrower than 4 ms otherwise).
Signals smoothedSignals(const Signals& s, std::size_t width) {
  const auto smooth = [&](const std::vector<float>& c) {
    std::vector<float> out(c.size(), NAN);
    const std::size_t half = width / 2;
    for (std::size_t i = half; i + half < c.size(); ++i) {
      double sum = 0.0;
      for (std::size_t j = i - half; j <= i + half; ++j) sum += c[j];
      out[i] = static_cast<float>(sum / (2 * half + 1));
    }
    return out;
  };
  return {smooth(s.p), smooth(s.x), smooth(s.y)};
}

}  // namespace die_cushion_ident::topic_delay_detail
