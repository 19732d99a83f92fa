#include "die_cushion_ident/core/valve/plant_signals.h"

#include <cmath>

#include "die_cushion_ident/core/util/formatted.h"

namespace die_cushion_ident {

namespace {
const char* const kTopicNames[] = {"pressure", "position", "valve"};
}  // namespace

PlantSignals::PlantSignals(double max_clock_offset) : max_clock_offset_(max_clock_offset) {}

void PlantSignals::stamped(Topic topic, double stamp, Instant arrival) {
  // A non-finite stamp cannot be placed on any clock: infinitely off.
  const double offset = stamp - arrival.clock;
  clock_offset_[topic] = std::isfinite(offset) ? offset : std::numeric_limits<double>::infinity();
}

void PlantSignals::pressure(double stamp, double value, Instant arrival) {
  stamped(kPressure, stamp, arrival);
  // An arrival at no time at all refreshes nothing (an infinite one would keep a signal fresh for good).
  if (!std::isfinite(value) || !std::isfinite(arrival.steady)) return;
  pressure_ = value;
  pressure_arrival_ = arrival.steady;
}

void PlantSignals::position(double stamp, double x, Instant arrival) {
  stamped(kPosition, stamp, arrival);
  if (!std::isfinite(x) || !std::isfinite(stamp) || !std::isfinite(arrival.steady)) return;
  velocity_.push(stamp, x);
  position_arrival_ = arrival.steady;
}

void PlantSignals::valve(double stamp, double spool, Instant arrival) {
  stamped(kValve, stamp, arrival);
  if (!std::isfinite(arrival.steady)) return;
  valve_arrival_ = arrival.steady;
  if (std::isfinite(spool)) spool_arrival_ = arrival.steady;
}

PlantCondition PlantSignals::at(Instant now) const {
  PlantCondition c;
  c.pressure = pressure_;
  c.pressure_age = now.steady - pressure_arrival_;
  c.position_age = now.steady - position_arrival_;
  c.velocity = velocity_.velocity();
  c.valve_age = now.steady - valve_arrival_;
  c.spool_age = now.steady - spool_arrival_;
  for (int topic = 0; topic < kTopics; ++topic) {
    const double offset = clock_offset_[topic];
    if (std::abs(offset) <= max_clock_offset_) continue;
    c.clock_problem =
        std::string("the ") + kTopicNames[topic] + " topic's stamps are " +
        (std::isfinite(offset)
             ? formatted(FMT_STRING("{:.3f} s "), std::abs(offset)) + (offset > 0 ? "ahead of" : "behind")
             : std::string("not finite against")) +
        formatted(FMT_STRING(" the clock (tolerance {:g} s, sweep_max_clock_offset)"), max_clock_offset_);
    break;
  }
  return c;
}

}  // namespace die_cushion_ident
