#include "die_cushion_ident/core/adequacy/implausible_parameters.h"

#include <cmath>
#include <cstdio>

#include "die_cushion_ident/core/util/formatted.h"

namespace die_cushion_ident {

std::vector<std::string> implausibleParameters(const HydraulicModel& model, const HydraulicEstimate& estimate,
                                               double sigmas, std::vector<std::string>* uncertain) {
  std::vector<std::string> problems;
  const auto& infos = model.parameterInfos();
  for (std::size_t i = 0; i < infos.size() && i < estimate.parameters.size(); ++i) {
    const double value = estimate.parameters[i].value, std = estimate.parameters[i].std;
    const bool positive_required = i == HydraulicModel::kBulkModulus || i == HydraulicModel::kValveFlowGain;
    const double low = infos[i].lower_bound, high = infos[i].upper_bound;
    if (std::isfinite(value) && value >= low && value <= high && !(positive_required && value <= 0.0))
      continue;
    const std::string text =
        formatted(FMT_STRING("{} = {:.4g} +/- {:.2g} {} is outside its physical range [{:.3g}, {:.3g}]"),
                  infos[i].name, value, std, infos[i].unit, low, high);
    // Outside, but within its uncertainty of the range: the data do not pin it down, which is no fault.
    const double distance = value < low ? low - value : value - high;
    const bool consistent = std::isfinite(value) && std::isfinite(std) && distance <= sigmas * std &&
                            !(positive_required && value <= 0.0);
    if (consistent) {
      if (uncertain) uncertain->push_back(text);
    } else {
      problems.push_back(text);
    }
  }
  return problems;
}

}  // namespace die_cushion_ident
