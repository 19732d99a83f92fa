#include "die_cushion_ident/core/model/oil_temperature_law.h"

#include <cmath>

namespace die_cushion_ident {

namespace {
// 1 + alpha dT is held above this: an early estimate of alpha far off, at an oil far from T0, must not make
// the capacitance negative or infinite.
constexpr double kLeastStiffnessRatio = 0.2;
}  // namespace

void OilTemperatureLaw::compressibility(double celsius, double alpha, double* factor, double* slope) const {
  const double dT = std::isfinite(celsius) ? celsius - origin() : 0.0;
  const double ratio = 1.0 + alpha * dT;
  if (!(ratio >= kLeastStiffnessRatio)) {
    *factor = 1.0 / kLeastStiffnessRatio;
    *slope = 0.0;
    return;
  }
  *factor = 1.0 / ratio;
  *slope = -dT / (ratio * ratio);
}

namespace {
constexpr double kZeroCelsius = 273.15;  // [K]
}  // namespace

double OilTemperatureLaw::laminarFlowRatio(double from, double to, double* per_beta) const {
  if (!std::isfinite(from) || !std::isfinite(to)) {
    if (per_beta) *per_beta = 0.0;
    return 1.0;
  }
  // Arrhenius: ln(G(to) / G(from)) = E (1/from_K - 1/to_K), E = beta T_ref,K^2 (its slope at T_ref is beta).
  const double reference = reference_temperature + kZeroCelsius;
  const double span = reference * reference * (1.0 / (from + kZeroCelsius) - 1.0 / (to + kZeroCelsius));
  const double ratio = std::exp(leakage_coefficient * span);
  if (per_beta) *per_beta = ratio * span;
  return ratio;
}

}  // namespace die_cushion_ident
