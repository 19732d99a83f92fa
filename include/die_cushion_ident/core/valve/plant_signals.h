#pragma once

#include <limits>

#include "die_cushion_ident/core/signal/velocity_from_position.h"
#include "die_cushion_ident/core/valve/valve_sweep.h"

namespace die_cushion_ident {

/// The latest plant signals the valve experiments' interlocks read, from the raw messages, and how old they
/// are. Each signal's age is taken against the newest input stamp, plus the time all inputs have been silent
/// once that exceeds kInputSilenceTolerance. Against the clock alone, messages queued behind a burst looked
/// stale: under /use_sim_time a simulator catching up after a stall advances /clock, which ROS applies at
/// once, ahead of the measurements still in the callback queue (live_sweep aborted at 73-86 ms, pressure or
/// spool, on a loaded 2-core machine). A dead sensor still ages while the others keep coming; a dead bus ages
/// everything once its silence passes the tolerance; a signal never received is infinitely old.
class PlantSignals {
 public:
  /// [s] how long all inputs may be silent (against the clock) before every signal counts as stale.
  static constexpr double kInputSilenceTolerance = 0.2;

  /// A pressure message [s, Pa]; a non-finite value is not a reading (its stamp does not refresh the age).
  void pressure(double stamp, double value);
  /// A position message [s, m]: the velocity for "at rest" is a least-squares slope over 20 ms (a
  /// difference of two messages would turn position noise into motion), also where the topic has none.
  void position(double stamp, double x) { velocity_.push(stamp, x); }
  /// A valve message [s] with its measured spool (NaN: not measured, no refresh).
  void spool(double stamp, double spool);

  /// The plant's condition at `now` [s] (the clock).
  PlantCondition at(double now) const;
  /// [s] the last measured spool's stamp (very negative: never).
  double spoolStamp() const { return spool_stamp_; }

 private:
  double pressure_ = std::numeric_limits<double>::quiet_NaN();
  double pressure_stamp_ = -1e18;
  double spool_stamp_ = -1e18;
  CausalVelocity velocity_;
};

}  // namespace die_cushion_ident
