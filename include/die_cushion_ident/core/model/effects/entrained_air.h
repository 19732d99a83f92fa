#pragma once

#include <algorithm>

#include "die_cushion_ident/core/model/effect.h"

namespace die_cushion_ident {

/// Free air in the oil, compressed isothermally: V_a = V_a0 p_atm / (p + p_atm), so
/// C += -dV_a/dp = V_a0 p_atm / (p + p_atm)^2. Dominant at low pressure (pre-pressure, release, return).
class EntrainedAir final : public Effect {
 public:
  std::unique_ptr<Effect> clone() const override { return std::make_unique<EntrainedAir>(*this); }
  std::string name() const override { return "entrained_air"; }
  std::string explanation() const override {
    return "free air in the oil makes the chamber soft at low pressure (isothermal gas compression)";
  }
  ParameterInfo parameter() const override { return {"air_volume", "m^3", 1e-4, 0.0, 1.0}; }
  /// At most the swept volume A s as free air at atmospheric pressure.
  ParameterInfo parameterFor(const CylinderGeometry& g) const override {
    ParameterInfo info = parameter();
    info.upper_bound = g.piston_area * g.stroke_length;
    return info;
  }
  double capacitancePerUnit(const HydraulicSignals& s) const override {
    const double absolute = absolutePressure(s.p);
    return kAtmosphericPressure / (absolute * absolute);
  }
  /// The air volume per unit V_a0 released between two pressures: p_atm (1/p_from - 1/p_to), absolute.
  bool capacitanceIncrement(const HydraulicSignals& from, const HydraulicSignals& to,
                            double* increment) const override {
    *increment = kAtmosphericPressure * (1.0 / absolutePressure(from.p) - 1.0 / absolutePressure(to.p));
    return true;
  }

 private:
  // Absolute pressure cannot fall below vapour pressure; the floor keeps the term finite in cavitation.
  static double absolutePressure(double gauge) { return std::max(gauge + kAtmosphericPressure, 2000.0); }
};

}  // namespace die_cushion_ident
