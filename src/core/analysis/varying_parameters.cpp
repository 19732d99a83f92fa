// Whether a parameter changes over the recording: Cochran's Q over groups of press cycles fitted alone
// (offline_analysis.h says how it is judged).
#include <boost/math/distributions/chi_squared.hpp>
#include <cmath>

#include "die_cushion_ident/core/adequacy/cycle_group_fits.h"
#include "die_cushion_ident/core/analysis/offline_analysis.h"
#include "die_cushion_ident/core/util/formatted.h"

namespace die_cushion_ident {

std::vector<std::string> parametersThatVaryOverTheRecording(const std::vector<GridSample>& grid,
                                                            const StrokeSegmentation& strokes,
                                                            const IdentificationConfig& config,
                                                            const HydraulicEstimate& estimate, int groups,
                                                            int jobs) {
  return parametersThatVaryOverTheRecording(CycleGroupFits(grid, strokes, config, groups, jobs), estimate);
}

std::vector<std::string> parametersThatVaryOverTheRecording(const CycleGroupFits& groups,
                                                            const HydraulicEstimate& estimate) {
  std::vector<std::string> found;
  const std::size_t n = estimate.parameters.size();
  if (!groups.valid() || n == 0 || groups.estimate(0).parameters.size() != n) return found;
  const int g_count = groups.size();
  std::vector<HydraulicEstimate> fits;
  for (int g = 0; g < g_count; ++g) fits.push_back(groups.estimate(g));
  const boost::math::chi_squared_distribution<double> chi_square(g_count - 1);
  for (std::size_t k = 0; k < n; ++k) {
    const IdentifiedParameter& p = estimate.parameters[k];
    // Cochran's Q: the groups' own estimates around their weighted mean, in units of their own stds.
    double weights = 0.0, weighted = 0.0;
    for (const auto& f : fits) {
      const double w = 1.0 / (f.parameters[k].std * f.parameters[k].std);
      weights += w;
      weighted += w * f.parameters[k].value;
    }
    const double mean = weighted / weights;
    double q = 0.0;
    for (const auto& f : fits) q += std::pow((f.parameters[k].value - mean) / f.parameters[k].std, 2);
    if (!std::isfinite(q)) continue;
    const double p_value = boost::math::cdf(boost::math::complement(chi_square, q));
    const double scatter = std::sqrt(q / (g_count - 1.0));  // how many times their noise the groups disagree
    if (!(p_value < kVariationSignificance) || !(scatter > kVariationScatter)) continue;
    // Drift or scatter: the first half of the groups against the second, each a weighted mean.
    double halves[2] = {0.0, 0.0}, half_weights[2] = {0.0, 0.0};
    for (int g = 0; g < g_count; ++g) {
      const int h = 2 * g < g_count ? 0 : 1;
      const double w = 1.0 / std::pow(fits[g].parameters[k].std, 2);
      half_weights[h] += w;
      halves[h] += w * fits[g].parameters[k].value;
    }
    const double before = halves[0] / half_weights[0], after = halves[1] / half_weights[1];
    // The part of Q that one step between the halves explains.
    const double q_between = std::pow(after - before, 2) / (1.0 / half_weights[0] + 1.0 / half_weights[1]);
    if (q_between > 0.5 * q) {
      found.push_back(formatted(
          FMT_STRING(
              "{} drifts over the recording: {:.3g} {} in the first half of the press cycles, {:.3g} in the "
              "second ({} groups of cycles fitted alone disagree {:.1f} times more than their stds say, "
              "p = {:.2g}): the plant changed while it was recorded (air drawn in, the oil warming, a seal "
              "wearing) or an effect the model lacks grows with time; {:.3g} is an average"),
          p.name, before, p.unit, after, g_count, scatter, p_value, p.value));
    } else {
      found.push_back(formatted(
          FMT_STRING(
              "{} varies from stroke to stroke: {} groups of press cycles fitted alone disagree {:.1f} "
              "times more than their stds say (p = {:.2g}), without a drift: the model misses an effect "
              "that weighs differently from stroke to stroke; treat the std of {:.3g} {} as {:.2g}"),
          p.name, g_count, scatter, p_value, p.value, p.unit, scatter * p.std));
    }
  }
  return found;
}

}  // namespace die_cushion_ident
