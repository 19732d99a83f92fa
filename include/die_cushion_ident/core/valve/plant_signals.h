#pragma once

#include <limits>
#include <string>

#include "die_cushion_ident/core/signal/velocity_from_position.h"
#include "die_cushion_ident/core/valve/instant.h"
#include "die_cushion_ident/core/valve/valve_sweep.h"

namespace die_cushion_ident {

/// The latest plant signals the valve's interlocks read, from the raw messages, and whether they can be
/// trusted. A signal's age is the steady time since its last message *arrived*, not a difference of stamps:
/// a dead bus ages everything within the timeout whatever the stamps said (stamps ahead of the clock once
/// added their lead to the time a dead bus went unnoticed: a sweep ran on for 1.2 s with drives stamping 1 s
/// ahead). The stamps are still compared with the clock they arrive on: a topic stamped beyond
/// `max_clock_offset` ahead of or behind it (drive clocks off the node's, a stopped /clock, a queue of old
/// messages) is named in PlantCondition::clock_problem until a message within the tolerance arrives.
class PlantSignals {
 public:
  /// `max_clock_offset` [s]: the stamps' tolerance against the receiving clock (sweep_max_clock_offset).
  explicit PlantSignals(double max_clock_offset = SweepLimits().max_clock_offset);

  /// A pressure message [s, Pa]; a non-finite value is not a reading (its arrival does not refresh the age).
  void pressure(double stamp, double value, Instant arrival);
  /// A position message [s, m]: the velocity for "at rest" is a least-squares slope over 20 ms of stamps (a
  /// difference of two messages would turn position noise into motion), also where the topic has none.
  void position(double stamp, double x, Instant arrival);
  /// A valve message [s] with its measured spool (NaN: not measured; the message still shows the amplifier
  /// is alive).
  void valve(double stamp, double spool, Instant arrival);

  /// The plant's condition at `now`.
  PlantCondition at(Instant now) const;
  /// [s] steady time of the last measured spool's arrival (very negative: never).
  double spoolArrival() const { return spool_arrival_; }

 private:
  enum Topic { kPressure, kPosition, kValve, kTopics };
  /// Keeps how far `stamp` lies from the clock at `arrival`.
  void stamped(Topic topic, double stamp, Instant arrival);

  double max_clock_offset_;
  double pressure_ = std::numeric_limits<double>::quiet_NaN();
  double pressure_arrival_ = -1e18, position_arrival_ = -1e18, valve_arrival_ = -1e18, spool_arrival_ = -1e18;
  double clock_offset_[kTopics] = {0.0, 0.0, 0.0};  // [s] stamp - clock at arrival, of the last message
  CausalVelocity velocity_;
};

}  // namespace die_cushion_ident
