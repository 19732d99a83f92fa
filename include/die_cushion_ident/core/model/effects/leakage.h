#pragma once

#include "die_cushion_ident/core/model/effect.h"

namespace die_cushion_ident {

/// Laminar leakage out of the chamber (worn piston seal, valve internal leakage): Q_extra += G_L * p.
class Leakage final : public Effect {
 public:
  std::unique_ptr<Effect> clone() const override { return std::make_unique<Leakage>(*this); }
  std::string name() const override { return "leakage"; }
  std::string explanation() const override {
    return "laminar leakage out of the chamber (piston seal or valve), a flow proportional to pressure";
  }
  ParameterInfo parameter() const override {
    // 1e-11 m^3/(s Pa): 6 l/min at 100 bar.
    return {"leakage_conductance", "m^3/(s*Pa)", 1e-11, 0.0, 1e-8};
  }
  /// At most a leak that empties the swept volume A s in one second at the supply pressure (for the
  /// default cushion 1e-9 m^3/(s Pa), 630 l/min at 100 bar).
  ParameterInfo parameterFor(const CylinderGeometry& g) const override {
    ParameterInfo info = parameter();
    info.upper_bound = g.piston_area * g.stroke_length / g.supply_pressure;
    return info;
  }
  double outflowPerUnit(const HydraulicSignals& s) const override { return s.p; }
  /// Through the seal's gap: it follows the oil's viscosity (effect oil_temperature).
  bool laminarFlow() const override { return true; }
};

}  // namespace die_cushion_ident
