#include "die_cushion_ident/core/fits/parameter_uncertainty.h"

#include <algorithm>
#include <cmath>

namespace die_cushion_ident {

double ParameterUncertainty::combined() const {
  // The sandwich and the jackknife estimate the same variance: pooled where the jackknife ran.
  const double statistical =
      cycles > 0.0 ? std::sqrt(0.5 * (regression * regression + cycles * cycles)) : regression;
  return std::hypot(statistical, method);
}

std::vector<ParameterUncertainty> combineUncertainty(const HydraulicEstimate& equation_error,
                                                     const std::optional<OutputErrorFit>& refined,
                                                     const HydraulicEstimate* jackknife,
                                                     HydraulicEstimate* reported) {
  std::vector<ParameterUncertainty> parts(reported->parameters.size());
  const bool refined_used = refined && refined->improved;
  for (std::size_t k = 0; k < parts.size(); ++k) {
    const auto i = static_cast<Eigen::Index>(k);
    ParameterUncertainty& u = parts[k];
    u.regression = reported->parameters[k].std;
    if (jackknife && k < jackknife->parameters.size() && std::isfinite(jackknife->parameters[k].std)) {
      u.cycles = jackknife->parameters[k].std;
    }
    if (refined_used && k < equation_error.parameters.size() && i < refined->theta.size()) {
      const double difference = refined->theta(i) - equation_error.parameters[k].value;
      if (std::isfinite(difference)) u.method = std::abs(difference) / std::sqrt(3.0);
    }
    reported->parameters[k].std = u.combined();
  }
  return parts;
}

}  // namespace die_cushion_ident
