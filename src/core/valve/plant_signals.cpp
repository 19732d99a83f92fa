#include "die_cushion_ident/core/valve/plant_signals.h"

#include <algorithm>
#include <cmath>

namespace die_cushion_ident {

void PlantSignals::pressure(double stamp, double value) {
  if (!std::isfinite(value)) return;
  pressure_ = value;
  pressure_stamp_ = stamp;
}

void PlantSignals::spool(double stamp, double spool) {
  if (std::isfinite(spool)) spool_stamp_ = stamp;
}

PlantCondition PlantSignals::at(double now) const {
  PlantCondition c;
  const double newest = std::max(pressure_stamp_, spool_stamp_);
  const double silence = now - newest;
  const double silent_for = silence > kInputSilenceTolerance ? silence : 0.0;
  c.pressure = pressure_;
  c.pressure_age = newest - pressure_stamp_ + silent_for;
  c.velocity = velocity_.velocity();
  c.spool_age = newest - spool_stamp_ + silent_for;
  return c;
}

}  // namespace die_cushion_ident
