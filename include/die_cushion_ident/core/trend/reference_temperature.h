#pragma once

#include <string>
#include <vector>

#include "die_cushion_ident/core/estimation/hydraulic_identifier.h"
#include "die_cushion_ident/core/model/hydraulic_model.h"
#include "die_cushion_ident/core/model/oil_temperature_law.h"

namespace die_cushion_ident {

/// A parameter carried to another oil temperature, with what its std is made of [its unit]:
/// std = sqrt(recording^2 + coefficients^2).
struct ParameterAtTemperature {
  std::string name, unit;
  double value = 0.0;
  double std = 0.0;
  /// From the recording's own uncertainty (its std, and an identified temperature coefficient's): differs
  /// from recording to recording. What a trend over recordings standardises by.
  double recording = 0.0;
  /// From the configured coefficients' uncertainty: the same error in every recording at the same
  /// temperature, a line in the temperature over many (analyze_trend regresses it out over its baseline).
  double coefficients = 0.0;
  /// "bulk modulus law", "viscosity law" or "unchanged": how it was carried.
  std::string law;
};

/// The estimate's parameters, which hold at the oil temperature `from` [degC] (the model's temperature
/// origin, the recording's mean), carried to `to` [degC] by the oil's law (OilTemperatureLaw;
/// doc/equations.md):
///  - bulk_modulus K'(to) = K'(from) (1 + alpha (to - from)), with alpha the model's identified coefficient
///    where it has the oil_temperature effect (combined with the configured one by their inverse variances:
///    a recording that barely warms pins it down poorly) and the configured one otherwise;
///  - a laminar leakage (leakage_conductance) by the viscosity's Arrhenius law, G(to) = G(from) exp(E
///  (1/from_K
///    - 1/to_K)), its slope beta at the reference temperature configured;
///  - the temperature coefficient itself, alpha(to) = alpha / (1 + alpha (to - from)) (relative to K'(to));
///  - everything else unchanged (the valve's orifice flow, volumes, overlap, back pressure barely depend on
///    the oil's temperature over 25-60 degC).
std::vector<ParameterAtTemperature> parametersAtTemperature(const HydraulicModel& model,
                                                            const HydraulicEstimate& estimate,
                                                            const OilTemperatureLaw& law, double from,
                                                            double to);

}  // namespace die_cushion_ident
