#pragma once

#include <limits>
#include <optional>
#include <string>

#include "die_cushion_ident/core/valve/valve_step_test.h"
#include "die_cushion_ident/core/valve/valve_sweep.h"

namespace die_cushion_ident {

/// The one owner of the valve command for experiments: a sine sweep (ValveSweep) or a step test
/// (ValveStepTest), never both at once, each behind the same interlocks (SweepLimits: the cushion at rest,
/// a fresh pressure below its limit, commands within the voltage limits), each with the same abort and
/// hand-back path (the command returns to the experiment's offset once). While one runs, or its hand-back
/// is still to be sent, the feed-forward is paused: its command would add to the experiment's on the cell
/// controller's adder. A start that is refused says why, and the refusal is kept for the diagnostics.
class ValveExperiments {
 public:
  enum class Kind { kNone, kSweep, kStepTest };

  explicit ValveExperiments(const SweepLimits& limits);
  /// How long the amplifier holds each command [s] (ValveSweep::setCommandHold).
  void setCommandHold(double seconds) { sweep_.setCommandHold(seconds); }
  /// ValveSweep::setFitOnFinish.
  void setSweepFitOnFinish(bool fit) { sweep_.setFitOnFinish(fit); }

  /// Empty when started, else why not (another experiment running, or the experiment's own interlocks).
  std::string startSweep(const SweepRequest& request, Instant now, const PlantCondition& plant);
  std::string startStepTest(const StepTestRequest& request, Instant now, const PlantCondition& plant);
  /// Aborts whichever runs, its command back to its offset; what was aborted, in words ("" when nothing).
  std::string abort(const std::string& reason);

  /// The interlocks and the duration limit of whichever runs, on the plant's condition now.
  void supervise(Instant now, const PlantCondition& plant);
  /// The command to send at `clock` [s]: the running experiment's, or its offset once after it ended or was
  /// aborted; nothing when no experiment holds the valve.
  std::optional<double> command(double clock);
  /// A valve message, for the sweep's correlation.
  void addValveSample(double t, double voltage, double spool);

  Kind running() const;
  /// "a valve sweep", "a step test" or "": what holds the valve (the feed-forward's pause reason).
  std::string holder() const;
  /// An experiment runs or its hand-back is still to be sent: the valve is not the feed-forward's.
  bool holdsValve() const { return holding() != Kind::kNone; }

  const ValveSweep& sweep() const { return sweep_; }
  const ValveStepTest& stepTest() const { return step_test_; }
  /// The last refused start: what was asked, why it was refused, and when [s, steady] (NaN: none yet).
  const std::string& lastRefusal() const { return last_refusal_; }
  double lastRefusalTime() const { return last_refusal_time_; }
  /// What ended last ("valve sweep finished", "step test aborted: ...").
  const std::string& lastEnd() const { return last_end_; }
  /// Keeps a refusal decided outside (another output holds the valve) as lastRefusal(); returns `reason`.
  std::string refuse(Kind kind, const std::string& reason, Instant now);

 private:
  /// The experiment that runs or still owes its offset (each keeps that itself).
  Kind holding() const;
  /// Notes how `before`, running before an operation, ended if it no longer runs.
  void noteEndOf(Kind before);

  ValveSweep sweep_;
  ValveStepTest step_test_;
  std::string last_refusal_, last_end_;
  double last_refusal_time_ = std::numeric_limits<double>::quiet_NaN();
};

}  // namespace die_cushion_ident
