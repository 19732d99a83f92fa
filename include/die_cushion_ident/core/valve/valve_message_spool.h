#pragma once

#include <cstdint>
#include <limits>

#include "die_cushion_ident/core/signal/uniform_resampler.h"
#include "die_cushion_ident/core/valve/servo_valve.h"

namespace die_cushion_ident {

/// The valve model run on the valve topic's messages: each message's voltage is held by the amplifier until
/// the next one, and the spool the model predicts at each stamp goes into `second` where the spool is not
/// measured (NaN), and into StreamSample::third (the free run's spool) where the model drives the free run. Exact for the model (ServoValve: RK4 at 0.1 ms,
/// the dead time not rounded), at the valve's own message rate rather than the grid's. Restarts at the
/// measured spool (else where it was) after a gap longer than `max_gap` or a backward jump.
class ValveMessageSpool {
 public:
  ValveMessageSpool(const ServoValveParameters& valve, double max_gap, bool drives_free_run);
  /// Fills `valve`'s third (and its second where NaN); messages with a non-finite stamp or voltage are left
  /// alone (the resampler rejects them).
  void process(StreamSample* valve);
  /// A new valve model (a sweep identified it) from the next message on.
  void setValve(const ServoValveParameters& valve);
  /// Whether the model's spool drives the free run (StreamSample::third) from the next message on.
  void setDrivesFreeRun(bool drives_free_run) { drives_free_run_ = drives_free_run; }
  void reset();
  /// Messages whose spool the model stood in for (not measured) since construction (a reset keeps the count).
  std::uint64_t predicted() const { return predicted_; }

 private:
  ServoValve model_;
  double max_gap_;
  bool drives_free_run_;
  double last_stamp_ = -std::numeric_limits<double>::infinity();
  double last_voltage_ = 0.0;
  double last_measured_ = 0.0;
  bool running_ = false;
  std::uint64_t predicted_ = 0;
};

}  // namespace die_cushion_ident
