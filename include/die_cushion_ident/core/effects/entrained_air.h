#pragma once

#include <algorithm>

#include "die_cushion_ident/core/effect.h"

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
  double capacitancePerUnit(const HydraulicSignals& s) const override {
    // Absolute pressure cannot fall below vapour pressure; the floor keeps the term finite in cavitation.
    const double absolute = std::max(s.p + kAtmosphericPressure, 2000.0);
    return kAtmosphericPressure / (absolute * absolute);
  }
};

}  // namespace die_cushion_ident
