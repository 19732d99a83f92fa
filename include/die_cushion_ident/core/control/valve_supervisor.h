#pragma once

#include <functional>
#include <limits>
#include <optional>
#include <string>

#include "die_cushion_ident/core/control/feed_forward_output.h"
#include "die_cushion_ident/core/valve/instant.h"
#include "die_cushion_ident/core/valve/plant_signals.h"
#include "die_cushion_ident/core/valve/valve_experiments.h"

namespace die_cushion_ident {

/// A fault the supervisor acted on, and how long the valve took to reach its safe value.
struct SupervisionFault {
  std::string reason;
  std::string output;  ///< what it stopped: "a valve sweep", "a step test", "the feed-forward"
  double detected = std::numeric_limits<double>::quiet_NaN();  ///< [s] steady time
  /// [s] steady time from the detection to the safe value sent (the experiment's offset, the feed-forward
  /// at 0 V); NaN while it ramps.
  double safe_after = std::numeric_limits<double>::quiet_NaN();
};

/// The one owner of everything the node sends to the valve (issue 45): the valve experiments (sweep, step
/// test: ValveExperiments) on `valve_command` and the feed-forward on `~feed_forward`, which the cell
/// controller adds to its PI output. One at a time: an experiment is refused while the feed-forward adds a
/// voltage, and the feed-forward stays at 0 V while an experiment holds the valve.
///
/// Supervision runs on the steady clock, independent of /clock and of the messages' stamps: watch(), called
/// every few milliseconds of steady time by a thread of its own, stops an experiment (its offset at once)
/// and ramps the feed-forward out (at its slew rate) when
///  - an input has not *arrived* within sweep_signal_timeout (a dead bus, a dead sensor), or arrived stamped
///    beyond sweep_max_clock_offset off the clock (PlantSignals);
///  - the clock jumped back (trusted again two timeouts later) or has not advanced for sweep_signal_timeout
///    (a stopped /clock: the experiment's command timer, on that clock, stops with it); a leap forward is
///    told by the stamps, which stay behind it (PlantSignals), or, where they leap too, harmless;
///  - an experiment's command has not been sent for sweep_signal_timeout (the command path stalled), or it
///    runs beyond its duration limit;
///  - the feed-forward has had no grid sample for sweep_signal_timeout, or was switched off.
/// The valve is at its safe value within signal_timeout plus one watch period of the fault for an
/// experiment, and the feed-forward begins its ramp then, at 0 V |u| / slew_rate later (doc/hardening.md).
class ValveSupervisor {
 public:
  /// Throws std::invalid_argument for invalid limits.
  ValveSupervisor(const SweepLimits& limits, const FeedForwardOutputLimits& feed_forward);
  /// [s] how often watch() must run: a tenth of sweep_signal_timeout, within [1, 5] ms.
  static double watchPeriod(const SweepLimits& limits);
  /// How long the amplifier holds each command [s] (ValveSweep::setCommandHold).
  void setCommandHold(double seconds) { experiments_.setCommandHold(seconds); }

  // --- Inputs, as they arrive ---
  void pressure(double stamp, double value, Instant arrival) { signals_.pressure(stamp, value, arrival); }
  void position(double stamp, double x, Instant arrival) { signals_.position(stamp, x, arrival); }
  /// A valve message: its arrival for the interlocks, its samples for a running sweep's correlation.
  void valve(double stamp, double voltage, double spool, Instant arrival);

  // --- The valve experiments (one at a time, not while the feed-forward adds a voltage) ---
  /// Empty when started, else why not.
  std::string startSweep(const SweepRequest& request, Instant now);
  std::string startStepTest(const StepTestRequest& request, Instant now);
  /// Aborts whichever experiment runs; what was aborted, in words ("" when nothing ran).
  std::string abortExperiment(const std::string& reason, Instant now);
  /// The experiment's command at `now` (the command timer, on the clock), after its interlocks at `now`:
  /// its own command while it runs, its offset once after it ended; nothing when none holds the valve.
  std::optional<double> experimentCommand(Instant now);

  // --- The feed-forward ---
  /// Switched off it ramps out and stays at 0 V until switched on again; returns what was done, in words.
  std::string enableFeedForward(bool enable, Instant now);
  /// A grid sample's wanted feed-forward [V] (NaN: none; `why` says why). Returns the command to send now
  /// (nothing: silent, the last command sent was 0 V).
  std::optional<double> feedForward(double wanted, const std::string& why, Instant now);

  /// What to send now, from the watchdog.
  struct Commands {
    std::optional<double> valve_command;
    std::optional<double> feed_forward;
  };
  /// The watchdog's tick (every few ms of steady time): the clocks, the inputs, the durations, the command
  /// paths; the commands that bring the valve to its safe value when something failed.
  Commands watch(Instant now);

  // --- State, for the diagnostics ---
  const ValveExperiments& experiments() const { return experiments_; }
  /// The plant as the interlocks see it at `now`, the clock's own problem included.
  PlantCondition condition(Instant now) const;
  /// An experiment runs or still owes its offset.
  bool experimentHoldsValve() const { return experiments_.holdsValve(); }
  /// The feed-forward's last command [V] and whether it is other than 0 V (the adder carries it).
  double feedForwardOutput() const { return output_.last(); }
  bool feedForwardEngaged() const { return output_.last() != 0.0; }
  bool feedForwardEnabled() const { return enabled_; }
  double feedForwardSlewRate() const { return output_.limits().slew_rate; }
  /// What the feed-forward sends and why, in words ("2.31 V: the identified model's feed-forward").
  std::string feedForwardState() const;
  /// Why the clock cannot be trusted now ("" when it can).
  const std::string& clockProblem() const { return clock_problem_; }
  const std::optional<SupervisionFault>& lastFault() const { return last_fault_; }
  const SweepLimits& limits() const { return limits_; }

 private:
  /// Starts an experiment of `kind` with `start` unless the feed-forward holds the valve.
  std::string startExperiment(ValveExperiments::Kind kind, Instant now,
                              const std::function<std::string(const PlantCondition&)>& start);
  /// The running experiment's interlocks, duration and (from the watchdog) its command path; notes a fault.
  void superviseExperiment(Instant now, bool from_watchdog);
  std::string feedForwardHoldsValve() const;
  /// Why the feed-forward may not drive the valve at `now` ("" when it may), besides its own wanted value.
  std::string feedForwardBlocker(const PlantCondition& plant, Instant now) const;
  /// Watches the clock against the steady one; sets clock_problem_.
  void watchClock(Instant now);
  void noteFault(const std::string& output, const std::string& reason, Instant now);
  /// Notes the moment the output that faulted (the feed-forward or an experiment) reached its safe value.
  void noteSafe(Instant now, bool feed_forward);
  /// The feed-forward blocked by `blocker`: its ramp out, a fault noted the first time.
  std::optional<double> blockFeedForward(const std::string& blocker, Instant now);
  /// Sends the feed-forward's command towards `wanted` (NaN: out); nothing once it rests at 0 V.
  std::optional<double> sendFeedForward(double wanted, Instant now);

  SweepLimits limits_;
  PlantSignals signals_;
  ValveExperiments experiments_;
  FeedForwardOutput output_;
  bool enabled_ = true;
  bool zero_sent_ = true;    // the feed-forward's last command was 0 V (or none was sent)
  bool ff_blocked_ = false;  // the feed-forward's last update was blocked
  std::string ff_reason_ = "no feed-forward wanted yet";
  double ff_updated_ = -1e18;    // [s] steady: the last grid sample's wanted command
  double command_sent_ = -1e18;  // [s] steady: the experiment's last command
  std::optional<Instant> last_watch_;
  double clock_advanced_ = -1e18;      // [s] steady: when the clock last moved forward
  double clock_trusted_from_ = -1e18;  // [s] steady: after a jump, the clock is trusted from then on
  std::string clock_problem_, clock_jump_;
  std::optional<SupervisionFault> last_fault_;
};

}  // namespace die_cushion_ident
