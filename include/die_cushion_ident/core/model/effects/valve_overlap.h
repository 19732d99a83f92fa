#pragma once

#include <cmath>

#include "die_cushion_ident/core/model/effect.h"

namespace die_cushion_ident {

/// Positive spool overlap: no flow until the spool has travelled y_0, opening sign(y) * max(|y| - y_0, 0).
class ValveOverlap final : public Effect {
 public:
  std::unique_ptr<Effect> clone() const override { return std::make_unique<ValveOverlap>(*this); }
  std::string name() const override { return "valve_overlap"; }
  std::string explanation() const override {
    return "spool overlap: a dead band around the valve's null in which no oil flows";
  }
  ParameterInfo parameter() const override { return {"valve_overlap", "-", 0.02, 0.0, 0.5}; }
  Coupling coupling() const override { return Coupling::kValveShape; }
  void shapeValvePort(double y, double theta, ValvePort& port, ValvePort& derivative) const override {
    const double sign = (y > 0.0) ? 1.0 : (y < 0.0 ? -1.0 : 0.0);
    const bool open = std::abs(y) > theta;
    port.opening = open ? y - sign * theta : 0.0;
    derivative.opening = open ? -sign : 0.0;
  }
};

}  // namespace die_cushion_ident
