#pragma once

#include <optional>
#include <string>

#include "die_cushion_ident/core/valve/valve_sweep.h"

namespace die_cushion_ident {

/// A step test: the valve command held at `offset` for `settle` seconds, then `offset + step` for
/// `duration` seconds, then the offset again. A field left at 0 takes its default.
struct StepTestRequest {
  double offset = 0.0;    ///< [V]
  double step = -0.5;     ///< [V] negative opens the supply edge (pressure rises), positive the drain edge
  double duration = 1.5;  ///< [s] the step held
  double settle = 0.3;    ///< [s] the offset held before the step
};

/// Runs a valve command step on a cushion at rest as safely as a sweep (same SweepLimits): refused while
/// the cushion moves, without a fresh pressure, position and valve message or above sweep_max_pressure, or
/// when offset and offset + step leave [sweep_min_voltage, sweep_max_voltage] or the step exceeds
/// sweep_max_amplitude; aborted when the cushion starts moving, an input is lost or off the clock, the
/// pressure exceeds step_max_pressure, a spool measured before is no longer, or the test runs beyond its
/// duration. Ended or aborted, the command returns to the offset. The pressure's answer is timed by
/// findStepResponses on the recording.
class ValveStepTest {
 public:
  enum class State { kIdle, kRunning, kFinished, kAborted };

  explicit ValveStepTest(const SweepLimits& limits) : limits_(limits) {}

  /// Empty when started, else the reason it was refused.
  std::string start(StepTestRequest request, Instant now, const PlantCondition& plant);
  void supervise(Instant now, const PlantCondition& plant);
  void abort(const std::string& reason);
  /// The command to apply now while the test runs (and the offset once after it ended); nothing when idle.
  std::optional<double> command(double now);

  State state() const { return state_; }
  bool running() const { return state_ == State::kRunning; }
  /// Ended, and the offset not yet sent: the next command() hands the valve back.
  bool offsetOwed() const { return offset_pending_; }
  const StepTestRequest& request() const { return request_; }
  double stepTime() const { return step_time_; }  ///< [s] when the step was applied
  const std::string& abortReason() const { return abort_reason_; }

 private:
  SweepLimits limits_;
  StepTestRequest request_;
  State state_ = State::kIdle;
  /// Why the valve's amplifier cannot be trusted to apply the command ("" when it can).
  std::string amplifierLostReason(const PlantCondition& plant) const;

  Instant started_;
  double step_time_ = 0.0;
  bool offset_pending_ = false;  // the offset still has to be sent after the end
  std::string abort_reason_;
};

}  // namespace die_cushion_ident
