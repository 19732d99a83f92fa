#pragma once

#include "die_cushion_ident/core/model/effect.h"

namespace die_cushion_ident {

/// Back pressure p_T in the drain path (return filter, cooler, long return line): the drain edge sees p -
/// p_T.
class TankPressure final : public Effect {
 public:
  std::unique_ptr<Effect> clone() const override { return std::make_unique<TankPressure>(*this); }
  std::string name() const override { return "tank_pressure"; }
  std::string explanation() const override {
    return "back pressure in the drain line: the valve drains less than expected at low chamber pressure";
  }
  ParameterInfo parameter() const override { return {"tank_pressure", "Pa", 3e5, 0.0, 50e5}; }
  /// At most half the supply pressure: beyond, the valve could not drain the cushion at all.
  ParameterInfo parameterFor(const CylinderGeometry& g) const override {
    ParameterInfo info = parameter();
    info.upper_bound = 0.5 * g.supply_pressure;
    return info;
  }
  Coupling coupling() const override { return Coupling::kValveShape; }
  void shapeValvePort(double y, double theta, ValvePort& port, ValvePort& derivative) const override {
    if (y > 0.0) {
      port.pressure_drop -= theta;
      derivative.pressure_drop = -1.0;
    }
  }
};

}  // namespace die_cushion_ident
