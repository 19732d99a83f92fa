#pragma once

#include <string>

#include "die_cushion_ident/core/model/hydraulic_model.h"

namespace die_cushion_ident {

/// The feed-forward's limits in the cell.
struct FeedForwardInterlockLimits {
  double max_voltage = 10.0;  ///< [V] the command never leaves [-max_voltage, max_voltage]
  /// [V/s] the command's fastest change: switching on or off and a new model ramp instead of stepping
  /// (a step to 0 V under a PI that had integrated against the feed-forward is a pressure jolt).
  double slew_rate = 100.0;
  /// [1/s] an identified parameter's fastest relative change: the live estimate's jumps (a converging RLS,
  /// a forgetting factor after a model change) reach the valve no faster than this.
  double parameter_rate = 0.5;
  /// A sweep's valve gain [1/V] is used only with the reference gain's sign and within [1/band, band] times
  /// it (the reference: the configured ~valve_gain, else the first sweep's).
  double valve_gain_band = 2.0;
  /// [V] changes of the wanted command smaller than this are not passed on (hysteresis): inside a valve's
  /// overlap the inverse jumps between the two edges of the dead band on the noise of its inputs.
  double hysteresis = 0.02;
};

/// The safety layer between PressureFeedForward and the valve (issue 28). The feed-forward is the model
/// turned round; with a sign reversed (a valve flow gain or a bulk modulus below zero from a converging
/// estimator, a sweep fitted to the wrong sign) it becomes positive feedback on the pressure. This class
///  - refuses parameters whose signs make the inverse non-monotonic (bulk modulus, flow gain, dead volume
///    must be > 0; every parameter finite) and a valve gain of the wrong sign or far from the reference;
///  - follows accepted parameters at a bounded relative rate;
///  - passes the command on with hysteresis, at a bounded slew rate, never beyond the voltage limit, and
///    ramps to 0 V when withdrawn.
class FeedForwardInterlock {
 public:
  /// `reference_valve_gain` [1/V]: the configured gain, or NaN (the first accepted gain becomes it). Throws
  /// std::invalid_argument for limits that are not positive and finite.
  FeedForwardInterlock(const FeedForwardInterlockLimits& limits, double reference_valve_gain);

  /// "" where `physical` (model order) and `valve_gain` may drive the valve, else why not.
  std::string check(const ParameterVector& physical, double valve_gain) const;
  /// Takes `valve_gain` as the reference where there was none (after check() accepted it).
  void acceptValveGain(double valve_gain);
  /// The parameters to use `dt` [s] after the last call: `identified` itself the first time (or after
  /// restart()), else each moved toward it by at most parameter_rate * dt of its own magnitude.
  const ParameterVector& follow(const ParameterVector& identified, double dt);
  /// Parameters taken afresh at the next follow() (the model's parameter set changed).
  void restart() { following_ = false; }
  /// The command to send `dt` [s] after the last: `wanted` [V] (NaN: withdrawn, towards 0 V) through the
  /// hysteresis, the slew-rate limit and the voltage limit.
  double output(double wanted, double dt);
  double lastOutput() const { return output_; }
  const FeedForwardInterlockLimits& limits() const { return limits_; }

 private:
  FeedForwardInterlockLimits limits_;
  double reference_gain_;
  ParameterVector parameters_;
  bool following_ = false;
  double output_ = 0.0;
  double held_wanted_ = 0.0;  // the last wanted command passed through the hysteresis
};

}  // namespace die_cushion_ident
