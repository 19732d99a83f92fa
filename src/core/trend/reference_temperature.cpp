#include "die_cushion_ident/core/trend/reference_temperature.h"

#include <cmath>

namespace die_cushion_ident {

std::vector<ParameterAtTemperature> parametersAtTemperature(const HydraulicModel& model,
                                                            const HydraulicEstimate& estimate,
                                                            const OilTemperatureLaw& law, double from,
                                                            double to) {
  std::vector<ParameterAtTemperature> carried;
  const double dT = to - from;
  // The bulk modulus's coefficient: the model's identified one, combined with the configured one by their
  // inverse variances, or the configured one alone.
  double alpha = law.bulk_modulus_coefficient, alpha_std = law.bulk_modulus_coefficient_std;
  bool identified = false;
  const int k_oil = model.oilStateParameter();
  if (k_oil >= 0 && static_cast<std::size_t>(k_oil) < estimate.parameters.size()) {
    const IdentifiedParameter& fitted = estimate.parameters[k_oil];
    if (std::isfinite(fitted.value) && fitted.std > 0.0 && std::isfinite(fitted.std)) {
      const double w_fit = 1.0 / (fitted.std * fitted.std);
      const double w_law = alpha_std > 0.0 ? 1.0 / (alpha_std * alpha_std) : 0.0;
      alpha = (w_fit * fitted.value + w_law * law.bulk_modulus_coefficient) / (w_fit + w_law);
      alpha_std = 1.0 / std::sqrt(w_fit + w_law);
      identified = true;
    }
  }
  for (int i = 0; i < model.parameterCount() && static_cast<std::size_t>(i) < estimate.parameters.size();
       ++i) {
    const IdentifiedParameter& p = estimate.parameters[i];
    ParameterAtTemperature c;
    c.name = p.name;
    c.unit = p.unit;
    c.value = p.value;
    c.recording = p.std;
    c.law = "unchanged";
    const bool laminar =
        i >= HydraulicModel::kFirstEffect &&
        model.effect(i - HydraulicModel::kFirstEffect).coupling() == Effect::Coupling::kAdditive &&
        model.effect(i - HydraulicModel::kFirstEffect).laminarFlow();
    if (i == HydraulicModel::kBulkModulus) {
      const double ratio = 1.0 + alpha * dT;
      c.value = p.value * ratio;
      const double from_alpha = p.value * dT * alpha_std;
      c.recording = std::hypot(ratio * p.std, identified ? from_alpha : 0.0);
      c.coefficients = identified ? 0.0 : std::abs(from_alpha);
      c.law = "bulk modulus law";
    } else if (i == k_oil) {
      const double ratio = 1.0 + alpha * dT;
      c.value = alpha / ratio;
      c.recording = alpha_std / (ratio * ratio);
      c.law = "bulk modulus law";
    } else if (laminar) {
      double per_beta = 0.0;
      const double factor = law.laminarFlowRatio(from, to, &per_beta);
      c.value = p.value * factor;
      c.recording = factor * p.std;
      c.coefficients = std::abs(p.value * per_beta) * law.leakage_coefficient_std;
      c.law = "viscosity law";
    }
    c.std = std::hypot(c.recording, c.coefficients);
    carried.push_back(c);
  }
  return carried;
}

}  // namespace die_cushion_ident
