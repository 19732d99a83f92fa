#include "die_cushion_ident/core/control/valve_supervisor.h"

#include <algorithm>
#include <cmath>

#include "die_cushion_ident/core/util/formatted.h"

namespace die_cushion_ident {

namespace {
const char* const kFeedForward = "the feed-forward";
constexpr double kClockBackTolerance = 1e-3;  // [s] a clock that went back further than this jumped
}  // namespace

ValveSupervisor::ValveSupervisor(const SweepLimits& limits, const FeedForwardOutputLimits& feed_forward)
    : limits_(limits), signals_(limits.max_clock_offset), experiments_(limits), output_(feed_forward) {
  // The sweep's model fit is not the supervisor's: it would hold up the hand-back and the watchdog (a sweep
  // of 530 frequencies took 68-105 ms to fit).
  experiments_.setSweepFitOnFinish(false);
}

double ValveSupervisor::watchPeriod(const SweepLimits& limits) {
  return std::clamp(0.1 * limits.signal_timeout, 1e-3, 5e-3);
}

void ValveSupervisor::valve(double stamp, double voltage, double spool, Instant arrival) {
  signals_.valve(stamp, spool, arrival);
  experiments_.addValveSample(stamp, voltage, spool);
}

PlantCondition ValveSupervisor::condition(Instant now) const {
  PlantCondition plant = signals_.at(now);
  if (!clock_problem_.empty()) plant.clock_problem = clock_problem_;
  return plant;
}

std::string ValveSupervisor::startSweep(const SweepRequest& request, Instant now) {
  return startExperiment(ValveExperiments::Kind::kSweep, now, [&](const PlantCondition& plant) {
    return experiments_.startSweep(request, now, plant);
  });
}

std::string ValveSupervisor::startStepTest(const StepTestRequest& request, Instant now) {
  return startExperiment(ValveExperiments::Kind::kStepTest, now, [&](const PlantCondition& plant) {
    return experiments_.startStepTest(request, now, plant);
  });
}

std::string ValveSupervisor::startExperiment(ValveExperiments::Kind kind, Instant now,
                                             const std::function<std::string(const PlantCondition&)>& start) {
  if (feedForwardEngaged()) return experiments_.refuse(kind, feedForwardHoldsValve(), now);
  const std::string refusal = start(condition(now));
  if (refusal.empty()) command_sent_ = now.steady;  // the command path is watched from now on
  return refusal;
}

std::string ValveSupervisor::feedForwardHoldsValve() const {
  return formatted(
      FMT_STRING(
          "the feed-forward adds {:.3f} V to the valve command; switch it off first (~enable_feed_forward "
          "false) and wait for its ramp to 0 V"),
      output_.last());
}

std::string ValveSupervisor::abortExperiment(const std::string& reason, Instant) {
  return experiments_.abort(reason);
}

void ValveSupervisor::superviseExperiment(Instant now, bool from_watchdog) {
  const ValveExperiments::Kind before = experiments_.running();
  if (before == ValveExperiments::Kind::kNone) return;
  const std::string holder = experiments_.holder();
  if (from_watchdog && now.steady - command_sent_ > limits_.signal_timeout) {
    experiments_.abort(formatted(
        FMT_STRING("no command was sent for {:.0f} ms (limit {:.0f} ms): the command timer stalled (a "
                   "stopped /clock, a blocked node)"),
        (now.steady - command_sent_) * 1e3, limits_.signal_timeout * 1e3));
  } else {
    experiments_.supervise(now, condition(now));
  }
  if (experiments_.running() == ValveExperiments::Kind::kNone) {
    const bool aborted = experiments_.lastEnd().find(" aborted: ") != std::string::npos;
    if (aborted) noteFault(holder, experiments_.lastEnd(), now);
  }
}

std::optional<double> ValveSupervisor::experimentCommand(Instant now) {
  // A moment on no steady time refreshes nothing: the watchdog stops the experiment if it lasts.
  if (!std::isfinite(now.steady)) return std::nullopt;
  superviseExperiment(now, false);
  const std::optional<double> u = experiments_.command(now.clock);
  if (u) command_sent_ = now.steady;
  if (u && !experiments_.holdsValve()) noteSafe(now, false);
  return u;
}

std::string ValveSupervisor::enableFeedForward(bool enable, Instant) {
  if (enable == enabled_)
    return enable ? "the feed-forward is on already" : "the feed-forward is off already";
  enabled_ = enable;
  if (enable)
    return "the feed-forward is on: it ramps in at the next grid sample where everything it needs is there";
  return formatted(FMT_STRING("the feed-forward is off: it ramps from {:.3f} V to 0 V"), output_.last()) +
         formatted(FMT_STRING(" at {:g} V/s"), output_.limits().slew_rate);
}

std::string ValveSupervisor::feedForwardBlocker(const PlantCondition& plant, Instant now) const {
  if (!enabled_) return "switched off (~enable_feed_forward)";
  if (experiments_.holdsValve()) return experiments_.holder() + " holds the valve";
  if (!plant.clock_problem.empty()) return plant.clock_problem;
  const double timeout = limits_.signal_timeout;
  if (!(plant.pressure_age <= timeout)) {
    return formatted(FMT_STRING("the pressure is lost (no finite reading for {:.0f} ms, "),
                     std::min(plant.pressure_age, 1e9) * 1e3) +
           formatted(FMT_STRING("limit {:.0f} ms)"), timeout * 1e3);
  }
  if (!(plant.position_age <= timeout)) {
    return formatted(FMT_STRING("the position is lost (no reading for {:.0f} ms, "),
                     std::min(plant.position_age, 1e9) * 1e3) +
           formatted(FMT_STRING("limit {:.0f} ms)"), timeout * 1e3);
  }
  if (!(now.steady - ff_updated_ <= timeout)) {
    return formatted(FMT_STRING("no grid sample for {:.0f} ms "),
                     std::min(now.steady - ff_updated_, 1e9) * 1e3) +
           formatted(FMT_STRING("(limit {:.0f} ms): the identification stalled"), timeout * 1e3);
  }
  return "";
}

std::optional<double> ValveSupervisor::sendFeedForward(double wanted, Instant now) {
  if (!std::isfinite(wanted) && zero_sent_) return std::nullopt;  // resting at 0 V
  const double u = output_.next(wanted, now.steady);
  zero_sent_ = u == 0.0;
  if (zero_sent_) noteSafe(now, true);
  return u;
}

std::optional<double> ValveSupervisor::feedForward(double wanted, const std::string& why, Instant now) {
  // A grid sample at no steady time at all is none (an infinite one would hide a stalled grid for good).
  if (!std::isfinite(now.steady)) return std::nullopt;
  ff_updated_ = now.steady;
  if (const std::string blocker = feedForwardBlocker(condition(now), now); !blocker.empty()) {
    return blockFeedForward(blocker, now);
  }
  ff_blocked_ = false;
  ff_reason_ = std::isfinite(wanted) ? "" : why;
  return sendFeedForward(wanted, now);
}

std::optional<double> ValveSupervisor::blockFeedForward(const std::string& blocker, Instant now) {
  // A fault the first time it blocks a feed-forward on the valve (switching it off is no fault).
  if (!ff_blocked_ && feedForwardEngaged() && enabled_) noteFault(kFeedForward, blocker, now);
  ff_blocked_ = true;
  ff_reason_ = blocker;
  return sendFeedForward(NAN, now);
}

void ValveSupervisor::watchClock(Instant now) {
  if (!last_watch_) {
    clock_advanced_ = now.steady;
    return;
  }
  const double advanced = now.clock - last_watch_->clock;
  if (advanced > 0.0 && std::isfinite(advanced)) clock_advanced_ = now.steady;
  if (advanced < -kClockBackTolerance) {
    // The sweep's sine and the step test's timing run on this clock: what they measured no longer fits.
    clock_jump_ = formatted(FMT_STRING("the clock jumped back by {:.3f} s (a bag played again, a clock set)"),
                            -advanced);
    clock_trusted_from_ = now.steady + 2.0 * limits_.signal_timeout;
  }
  if (now.steady - clock_advanced_ > limits_.signal_timeout) {
    clock_problem_ = formatted(FMT_STRING("the clock has not advanced for {:.0f} ms (a stopped /clock?)"),
                               (now.steady - clock_advanced_) * 1e3);
  } else if (now.steady < clock_trusted_from_) {
    clock_problem_ = clock_jump_;
  } else {
    clock_problem_.clear();
  }
}

ValveSupervisor::Commands ValveSupervisor::watch(Instant now) {
  if (!std::isfinite(now.steady)) return {};
  watchClock(now);
  last_watch_ = now;
  Commands out;
  superviseExperiment(now, true);
  if (experiments_.holdsValve() && experiments_.running() == ValveExperiments::Kind::kNone) {
    // The offset owed, from here: the command timer may be what stalled.
    out.valve_command = experiments_.command(now.clock);
    if (out.valve_command) noteSafe(now, false);
  }
  if (!zero_sent_) {
    if (const std::string blocker = feedForwardBlocker(condition(now), now); !blocker.empty()) {
      out.feed_forward = blockFeedForward(blocker, now);
    }
  }
  return out;
}

void ValveSupervisor::noteFault(const std::string& output, const std::string& reason, Instant now) {
  SupervisionFault fault;
  fault.output = output;
  fault.reason = reason;
  fault.detected = now.steady;
  last_fault_ = fault;
}

void ValveSupervisor::noteSafe(Instant now, bool feed_forward) {
  if (!last_fault_ || !std::isnan(last_fault_->safe_after)) return;
  if ((last_fault_->output == kFeedForward) != feed_forward) return;
  last_fault_->safe_after = now.steady - last_fault_->detected;
}

std::string ValveSupervisor::feedForwardState() const {
  const double u = output_.last();
  if (ff_reason_.empty()) return formatted(FMT_STRING("{:.3f} V: the identified model's feed-forward"), u);
  if (u != 0.0) return formatted(FMT_STRING("ramping out, {:.3f} V: "), u) + ff_reason_;
  return "0 V: " + ff_reason_;
}

}  // namespace die_cushion_ident
