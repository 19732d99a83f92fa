#pragma once

#include "die_cushion_ident/core/model/effect.h"
#include "die_cushion_ident/core/model/oil_temperature_law.h"

namespace die_cushion_ident {

/// The oil's temperature as a physical effect (OilTemperatureLaw): the bulk modulus follows it linearly,
/// K'(T) = K'(T0) (1 + alpha (T - T0)), so the oil's compressibility V/K' takes the factor
/// 1 / (1 + alpha (T - T0)); a laminar leakage follows the oil's viscosity, G(T) = G(T0) exp(beta (T - T0)).
/// Its parameter is alpha [1/K], identified (relinearised like a valve shape: its coefficient is alpha / K');
/// beta is the configured one. T is the measured oil temperature [degC]; where none is measured, the effect
/// does nothing.
class OilTemperature final : public Effect {
 public:
  explicit OilTemperature(const OilTemperatureLaw& law = OilTemperatureLaw()) : law_(law) {}
  std::unique_ptr<Effect> clone() const override { return std::make_unique<OilTemperature>(*this); }
  std::string name() const override { return "oil_temperature"; }
  std::string explanation() const override;
  std::string explanationFor(double alpha) const override;
  /// Starts at the configured coefficient; physically the effective bulk modulus falls as the oil warms
  /// (mineral oil about -0.5 %/K, less with the hoses' compliance); a little room above 0 for the fit's
  /// noise on a recording that barely warms.
  ParameterInfo parameter() const override {
    return {"bulk_modulus_temperature_coefficient", "1/K", law_.bulk_modulus_coefficient, -0.02, 0.002};
  }
  Coupling coupling() const override { return Coupling::kOilState; }
  bool needsOilTemperature() const override { return true; }
  void compressibility(const HydraulicSignals& s, double alpha, double* factor,
                       double* slope) const override {
    law_.compressibility(s.T, alpha, factor, slope);
  }
  double laminarFlowFactor(const HydraulicSignals& s) const override { return law_.laminarFlowFactor(s.T); }
  const OilTemperatureLaw& law() const { return law_; }

 private:
  OilTemperatureLaw law_;
};

}  // namespace die_cushion_ident
