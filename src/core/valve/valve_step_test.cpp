#include "die_cushion_ident/core/valve/valve_step_test.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "die_cushion_ident/core/util/formatted.h"

namespace die_cushion_ident {

std::string ValveStepTest::start(StepTestRequest request, Instant now, const PlantCondition& plant) {
  if (running()) return "a step test is already running; abort it first";
  const StepTestRequest defaults;
  if (request.step == 0.0) request.step = defaults.step;
  if (request.duration == 0.0) request.duration = defaults.duration;
  if (request.settle == 0.0) request.settle = defaults.settle;
  if (!std::isfinite(request.offset) || !std::isfinite(request.step) || !std::isfinite(request.duration) ||
      !std::isfinite(request.settle)) {
    return "the request holds a value that is not finite";
  }
  if (std::abs(request.step) > limits_.max_amplitude) {
    return formatted(FMT_STRING("step {:.3g} V exceeds sweep_max_amplitude {:.3g} V"), request.step,
                     limits_.max_amplitude);
  }
  for (double u : {request.offset, request.offset + request.step}) {
    if (u < limits_.min_voltage || u > limits_.max_voltage) {
      return formatted(
                 FMT_STRING(
                     "the command {:.3g} V would leave [sweep_min_voltage, sweep_max_voltage] = [{:.3g}, "),
                 u, limits_.min_voltage) +
             formatted(FMT_STRING("{:.3g}] V"), limits_.max_voltage);
    }
  }
  if (!(request.duration > 0.0 && request.duration + request.settle <= limits_.max_duration) ||
      !(request.settle > 0.0)) {
    return formatted(
        FMT_STRING("duration and settle must be > 0 s and together at most sweep_max_duration {:.3g} s"),
        limits_.max_duration);
  }
  if (!std::isfinite(now.clock) || !std::isfinite(now.steady)) return "the clock is not valid";
  const std::string not_at_rest = atRestRefusal(plant, limits_, "step tests");
  if (!not_at_rest.empty()) return not_at_rest;
  if (const std::string lost = amplifierLostReason(plant); !lost.empty()) return lost;
  request_ = request;
  state_ = State::kRunning;
  started_ = now;
  step_time_ = now.clock + request.settle;
  offset_pending_ = false;
  abort_reason_.clear();
  return "";
}

void ValveStepTest::supervise(Instant now, const PlantCondition& plant) {
  if (!running()) return;
  std::string reason =
      durationExceeded(started_, now, request_.settle + request_.duration, limits_.max_duration);
  if (!reason.empty()) reason = "the step test did not end: " + reason;
  if (reason.empty()) reason = restLostReason(plant, limits_, limits_.step_max_pressure, "step_max_pressure");
  if (reason.empty()) reason = amplifierLostReason(plant);
  if (!reason.empty()) abort(reason);
}

std::string ValveStepTest::amplifierLostReason(const PlantCondition& plant) const {
  // The step test measures the pressure, not the spool; but a valve topic that fell silent means the
  // amplifier that applies the command may be gone, and a missing spool where one was measured a fault.
  if (!(plant.valve_age <= limits_.signal_timeout)) {
    return formatted(
        FMT_STRING(
            "the valve topic is lost (no message for {:.0f} ms, limit {:.0f} ms): the amplifier's echo is "
            "missing"),
        std::min(plant.valve_age, 1e9) * 1e3, limits_.signal_timeout * 1e3);
  }
  if (std::isfinite(plant.spool_age) && plant.spool_age > limits_.signal_timeout) {
    return formatted(
        FMT_STRING("the spool signal is lost (measured before, none for {:.0f} ms, limit {:.0f} ms)"),
        std::min(plant.spool_age, 1e9) * 1e3, limits_.signal_timeout * 1e3);
  }
  return "";
}

void ValveStepTest::abort(const std::string& reason) {
  if (!running()) return;
  state_ = State::kAborted;
  abort_reason_ = reason;
  offset_pending_ = true;
}

std::optional<double> ValveStepTest::command(double now) {
  if (running()) {
    if (now >= step_time_ + request_.duration) {
      state_ = State::kFinished;
      offset_pending_ = false;
      return request_.offset;
    }
    return now >= step_time_ ? request_.offset + request_.step : request_.offset;
  }
  if (offset_pending_) {
    offset_pending_ = false;
    return request_.offset;
  }
  return std::nullopt;
}

}  // namespace die_cushion_ident
