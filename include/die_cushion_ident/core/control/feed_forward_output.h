#pragma once

namespace die_cushion_ident {

/// The feed-forward's last stage before the valve: what may change on the cell controller's adder, and how
/// fast, measured on the steady clock (the valve answers in real time, whatever the stamps or /clock do).
struct FeedForwardOutputLimits {
  double max_voltage = 10.0;  ///< [V] the command never leaves [-max_voltage, max_voltage]
  /// [V/s] the command's fastest change: switching on or off, a new model, a fault ramp instead of stepping
  /// (a step to 0 V under a PI that had integrated against the feed-forward is a pressure jolt).
  double slew_rate = 100.0;
  /// [V] changes of the wanted command smaller than this are not passed on (hysteresis against the noise of
  /// the inverse's inputs).
  double hysteresis = 0.02;
  /// [s] the longest steady interval one change may span: after a gap (a stalled callback, a pause of the
  /// grid) the next command moves at most slew_rate * this, so no gap turns into a step. The supervisor's
  /// watchdog sends a command at least this often while the output ramps.
  double max_step_interval = 0.01;
};

/// The feed-forward's output stage (FeedForwardOutputLimits): hysteresis, the voltage limit, and the slew
/// limit on the steady clock, so that every command differs from the one before by at most
/// slew_rate * min(steady time between them, max_step_interval).
class FeedForwardOutput {
 public:
  /// Throws std::invalid_argument for a limit that is not finite, a voltage limit, slew rate or step
  /// interval <= 0, or a negative hysteresis.
  explicit FeedForwardOutput(const FeedForwardOutputLimits& limits);

  /// The command [V] to send at steady time `now` [s] towards `wanted` [V] (NaN: withdrawn, towards 0 V).
  double next(double wanted, double now);
  /// The last command sent [V] (0 before the first).
  double last() const { return output_; }
  /// [s] steady time of the last command (very negative: none yet).
  double lastTime() const { return last_time_; }
  const FeedForwardOutputLimits& limits() const { return limits_; }

 private:
  FeedForwardOutputLimits limits_;
  double output_ = 0.0;
  double held_wanted_ = 0.0;  // the last wanted command passed through the hysteresis
  double last_time_ = -1e18;
};

}  // namespace die_cushion_ident
