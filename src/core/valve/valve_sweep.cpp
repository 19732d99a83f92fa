#include "die_cushion_ident/core/valve/valve_sweep.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include "die_cushion_ident/core/util/formatted.h"

namespace die_cushion_ident {

namespace {

struct LimitKey {
  const char* key;
  double SweepLimits::*field;
};

const LimitKey kLimitKeys[] = {
    {"sweep_max_amplitude", &SweepLimits::max_amplitude},
    {"sweep_min_voltage", &SweepLimits::min_voltage},
    {"sweep_max_voltage", &SweepLimits::max_voltage},
    {"sweep_max_pressure", &SweepLimits::max_pressure},
    {"sweep_max_rest_velocity", &SweepLimits::max_rest_velocity},
    {"sweep_signal_timeout", &SweepLimits::signal_timeout},
    {"sweep_command_period", &SweepLimits::command_period},
    {"sweep_max_duration", &SweepLimits::max_duration},
    {"sweep_max_distortion", &SweepLimits::max_distortion},
    {"step_max_pressure", &SweepLimits::step_max_pressure},
    {"sweep_max_clock_offset", &SweepLimits::max_clock_offset},
};

}  // namespace

std::vector<double> SweepRequest::defaultFrequencies() {
  std::vector<double> frequencies;
  for (int f = 10; f <= 160; f += 10) frequencies.push_back(f);
  return frequencies;
}

double SweepRequest::durationAt(double frequency) const {
  const double settle = std::max(settle_periods / frequency, settle_time);
  const double periods = std::max(integration_periods, std::ceil(min_integration_time * frequency));
  return settle + periods / frequency;
}

double SweepRequest::totalDuration() const {
  double total = 0.0;
  for (double f : frequencies) total += durationAt(f);
  return total;
}

std::vector<std::string> SweepLimits::validate() const {
  std::vector<std::string> problems;
  const auto require = [&](const char* key, double value, bool ok, const char* allowed) {
    if (!ok)
      problems.push_back(std::string(key) + " = " + formatted(FMT_STRING("{:g}"), value) +
                         " is invalid: allowed " + allowed);
  };
  require("sweep_max_amplitude", max_amplitude, std::isfinite(max_amplitude) && max_amplitude > 0.0, "> 0 V");
  require("sweep_min_voltage", min_voltage, std::isfinite(min_voltage), "a finite voltage");
  require("sweep_max_voltage", max_voltage, std::isfinite(max_voltage) && max_voltage > min_voltage,
          "finite and > sweep_min_voltage");
  require("sweep_max_pressure", max_pressure, std::isfinite(max_pressure) && max_pressure > 0.0, "> 0 Pa");
  require("sweep_max_rest_velocity", max_rest_velocity,
          std::isfinite(max_rest_velocity) && max_rest_velocity > 0.0, "> 0 m/s");
  require("sweep_signal_timeout", signal_timeout, std::isfinite(signal_timeout) && signal_timeout > 0.0,
          "> 0 s");
  require("sweep_command_period", command_period,
          std::isfinite(command_period) && command_period >= 1e-4 && command_period <= 0.1, "[1e-4, 0.1] s");
  require("sweep_max_duration", max_duration, std::isfinite(max_duration) && max_duration > 0.0, "> 0 s");
  require("sweep_max_distortion", max_distortion, std::isfinite(max_distortion) && max_distortion > 0.0,
          "> 0");
  require("step_max_pressure", step_max_pressure, std::isfinite(step_max_pressure) && step_max_pressure > 0.0,
          "> 0 Pa");
  require("sweep_max_clock_offset", max_clock_offset,
          std::isfinite(max_clock_offset) && max_clock_offset >= 1e-3 && max_clock_offset <= 3600.0,
          "[1e-3, 3600] s");
  return problems;
}

std::vector<std::string> sweepLimitKeys() {
  std::vector<std::string> keys;
  for (const auto& k : kLimitKeys) keys.push_back(k.key);
  return keys;
}

bool setSweepLimit(SweepLimits& limits, const std::string& key, double value) {
  for (const auto& k : kLimitKeys) {
    if (key == k.key) {
      limits.*k.field = value;
      return true;
    }
  }
  return false;
}

double sweepLimitValue(const SweepLimits& limits, const std::string& key) {
  for (const auto& k : kLimitKeys) {
    if (key == k.key) return limits.*k.field;
  }
  return std::numeric_limits<double>::quiet_NaN();
}

namespace {
constexpr long kMinSweepFrequencies = 5;
}  // namespace

std::string checkSweepRequest(const SweepRequest& r, const SweepLimits& limits) {
  if (r.frequencies.empty()) return "no frequencies requested";
  if (r.frequencies.size() > 1000) return "more than 1000 frequencies requested";
  for (double f : r.frequencies) {
    if (!std::isfinite(f) || f <= 0.0)
      return formatted(FMT_STRING("frequency {:g} Hz is invalid: allowed > 0 Hz"), f);
    if (f > limits.maxFrequency()) {
      return formatted(FMT_STRING("frequency {:g} Hz is above {:g} Hz, a quarter of the valve command rate "
                                  "(fewer than 4 commands per "
                                  "period; Nyquist is {:g} Hz)"),
                       f, limits.maxFrequency(), 0.5 / limits.command_period);
    }
  }
  if (!std::isfinite(r.amplitude) || r.amplitude <= 0.0)
    return formatted(FMT_STRING("amplitude {:g} V is invalid: allowed > 0 V"), r.amplitude);
  if (r.amplitude > limits.max_amplitude) {
    return formatted(FMT_STRING("amplitude {:g} V is above the limit sweep_max_amplitude = {:g} V"),
                     r.amplitude, limits.max_amplitude);
  }
  if (!std::isfinite(r.offset)) return "offset is not finite";
  if (r.offset - r.amplitude < limits.min_voltage || r.offset + r.amplitude > limits.max_voltage) {
    return formatted(
        FMT_STRING(
            "offset {:g} V +/- amplitude leaves the command range [{:g}, {:g}] V (sweep_min/max_voltage)"),
        r.offset, limits.min_voltage, limits.max_voltage);
  }
  if (!std::isfinite(r.settle_periods) || r.settle_periods < 0.0)
    return formatted(FMT_STRING("settle_periods {:g} is invalid: allowed >= 0"), r.settle_periods);
  if (!std::isfinite(r.settle_time) || r.settle_time < 0.0)
    return formatted(FMT_STRING("settle_time {:g} s is invalid: allowed >= 0 s"), r.settle_time);
  if (!std::isfinite(r.integration_periods) || r.integration_periods < 1.0 || r.integration_periods > 1e5)
    return formatted(FMT_STRING("integration_periods {:g} is invalid: allowed [1, 1e5]"),
                     r.integration_periods);
  if (!std::isfinite(r.min_integration_time) || r.min_integration_time < 0.0 ||
      r.min_integration_time > 3600.0)
    return formatted(FMT_STRING("min_integration_time {:g} s is invalid: allowed [0, 3600] s"),
                     r.min_integration_time);
  if (r.totalDuration() > limits.max_duration) {
    return formatted(FMT_STRING("the sweep would take {:.1f} s, longer than sweep_max_duration = {:g} s"),
                     r.totalDuration(), limits.max_duration);
  }
  {
    // The fit of natural frequency, damping, gain and dead time needs five distinct points: refuse now
    // rather than sweep for minutes and fail at the end.
    std::vector<double> distinct(r.frequencies);
    std::sort(distinct.begin(), distinct.end());
    const auto size = std::unique(distinct.begin(), distinct.end()) - distinct.begin();
    if (size < kMinSweepFrequencies) {
      return formatted(
          FMT_STRING("{:g} distinct frequencies requested: the valve model's fit needs at least 5"),
          static_cast<double>(size));
    }
  }
  return "";
}

const char* sweepStateName(ValveSweep::State state) {
  switch (state) {
    case ValveSweep::State::kIdle:
      return "idle";
    case ValveSweep::State::kRunning:
      return "running";
    case ValveSweep::State::kFinished:
      return "finished";
    case ValveSweep::State::kAborted:
      return "aborted";
  }
  return "unknown";
}

ValveSweep::ValveSweep(const SweepLimits& limits) : limits_(limits) {
  const auto problems = limits.validate();
  if (!problems.empty()) throw std::invalid_argument(problems.front());
}

double ValveSweep::currentFrequency() const {
  if (index_ < 0 || index_ >= static_cast<int>(request_.frequencies.size())) return 0.0;
  return request_.frequencies[index_];
}

namespace {

/// Why the inputs the interlocks read cannot be trusted now ("" when they can): a stamp off the clock, the
/// pressure or the position lost (no message within sweep_signal_timeout of steady time) or not finite.
std::string inputsLostReason(const PlantCondition& plant, const SweepLimits& limits) {
  if (!plant.clock_problem.empty()) return plant.clock_problem;
  if (!(plant.pressure_age <= limits.signal_timeout) || !std::isfinite(plant.pressure)) {
    return formatted(
        FMT_STRING(
            "the chamber pressure is lost (no finite reading for {:.0f} ms, limit {:.0f} ms): the pressure "
            "limit cannot be checked"),
        std::min(plant.pressure_age, 1e9) * 1e3, limits.signal_timeout * 1e3);
  }
  if (!(plant.position_age <= limits.signal_timeout)) {
    return formatted(
        FMT_STRING(
            "the cushion's position is lost (no reading for {:.0f} ms, limit {:.0f} ms): rest cannot be "
            "confirmed"),
        std::min(plant.position_age, 1e9) * 1e3, limits.signal_timeout * 1e3);
  }
  return "";
}

}  // namespace

std::string atRestRefusal(const PlantCondition& plant, const SweepLimits& limits, const std::string& tests) {
  if (const std::string lost = inputsLostReason(plant, limits); !lost.empty()) return lost;
  if (plant.pressure > limits.max_pressure) {
    return formatted(
        FMT_STRING(
            "the chamber pressure {:.4g} bar is above the sweep limit {:.1f} bar (sweep_max_pressure)"),
        plant.pressure * 1e-5, limits.max_pressure * 1e-5);
  }
  if (!std::isfinite(plant.velocity)) return "the cushion velocity is unknown, so rest cannot be confirmed";
  if (std::abs(plant.velocity) > limits.max_rest_velocity) {
    return formatted(FMT_STRING("the cushion is moving ({:.4g} m/s; at rest below {:g} m/s): "),
                     plant.velocity, limits.max_rest_velocity) +
           tests + " run only at rest";
  }
  return "";
}

std::string restLostReason(const PlantCondition& plant, const SweepLimits& limits, double max_pressure,
                           const std::string& bound) {
  if (const std::string lost = inputsLostReason(plant, limits); !lost.empty()) return lost;
  if (plant.pressure > max_pressure) {
    return formatted(FMT_STRING("chamber pressure {:.4g} bar over "), plant.pressure * 1e-5) + bound +
           formatted(FMT_STRING(" {:.1f} bar"), max_pressure * 1e-5);
  }
  if (!std::isfinite(plant.velocity)) return "the cushion velocity is no longer known";
  if (std::abs(plant.velocity) > limits.max_rest_velocity) {
    return formatted(FMT_STRING("the cushion started moving ({:.4g} m/s)"), plant.velocity);
  }
  return "";
}

std::string durationExceeded(Instant started, Instant now, double expected, double max_duration) {
  const double steady = now.steady - started.steady, clock = now.clock - started.clock;
  if (steady > max_duration) {
    return formatted(FMT_STRING("it ran {:.1f} s (steady clock), beyond sweep_max_duration = {:g} s"), steady,
                     max_duration);
  }
  const double allowed = std::min(2.0 * expected + 5.0, max_duration);
  if (clock > allowed) {
    return formatted(FMT_STRING("it ran {:.1f} s, more than twice its expected {:.1f} s plus 5 s"), clock,
                     expected);
  }
  return "";
}

std::string ValveSweep::start(const SweepRequest& request, Instant now, const PlantCondition& plant) {
  if (running()) {
    return formatted(FMT_STRING("a sweep is already running (frequency {:g} of {:g}); abort it first"),
                     index_ + 1.0, static_cast<double>(request_.frequencies.size()));
  }
  const std::string invalid = checkSweepRequest(request, limits_);
  if (!invalid.empty()) return invalid;
  if (!std::isfinite(now.clock) || !std::isfinite(now.steady)) return "the clock is not valid";
  const std::string not_at_rest = atRestRefusal(plant, limits_, "sweeps");
  if (!not_at_rest.empty()) return not_at_rest;
  if (!(plant.spool_age <= limits_.signal_timeout)) {
    return "no measured spool position on the valve topic (stale or NaN): the sweep correlates the spool";
  }
  request_ = request;
  std::sort(request_.frequencies.begin(), request_.frequencies.end());
  started_ = now;
  state_ = State::kRunning;
  abort_reason_.clear();
  index_ = 0;
  segment_pending_ = true;
  estimator_.reset();
  points_.clear();
  fit_ = ServoValveFit();
  offset_owed_ = false;
  return "";
}

void ValveSweep::supervise(Instant now, const PlantCondition& plant) {
  if (!running()) return;
  if (const std::string overrun =
          durationExceeded(started_, now, request_.totalDuration(), limits_.max_duration);
      !overrun.empty()) {
    abort("the sweep did not finish: " + overrun);
  } else if (const std::string lost = restLostReason(plant, limits_, limits_.max_pressure, "the sweep limit");
             !lost.empty()) {
    abort(lost);
  } else if (!(plant.spool_age <= limits_.signal_timeout)) {
    abort(formatted(FMT_STRING("the spool signal is lost (no measured spool for {:.0f} ms, limit {:.0f} ms)"),
                    std::min(plant.spool_age, 1e9) * 1e3, limits_.signal_timeout * 1e3));
  }
}

void ValveSweep::addValveSample(double t, double voltage, double spool) {
  if (!running()) return;
  if (!std::isfinite(spool)) {
    abort("spool position not finite (NaN/Inf) on the valve topic");
    return;
  }
  if (!std::isfinite(voltage) || !std::isfinite(t)) {
    abort("valve voltage or stamp not finite on the valve topic");
    return;
  }
  if (segment_pending_) return;
  if (!estimator_) {
    // The window is placed on the valve topic's own stamps, counted from its first message at this
    // frequency: the echo and the spool it correlates are stamped by the drive, whose clock may be off the
    // node's by a constant (within sweep_max_clock_offset) without moving the window off the transient.
    const double f = currentFrequency();
    const double settle = std::max(request_.settle_periods / f, request_.settle_time);
    const double periods =
        std::max(request_.integration_periods, std::ceil(request_.min_integration_time * f));
    FrequencyPointEstimator::Options options;
    options.command_hold = std::isnan(command_hold_) ? limits_.command_period : command_hold_;
    options.sample_rate = 1.0 / limits_.command_period;
    options.max_distortion = limits_.max_distortion;
    estimator_ = std::make_unique<FrequencyPointEstimator>(f, t + settle, periods, options);
  }
  if (estimator_->add(t, voltage, spool)) finishFrequency();
}

void ValveSweep::beginFrequency(double now) {
  segment_start_ = now;
  estimator_.reset();  // made at the frequency's first valve message
  segment_pending_ = false;
}

void ValveSweep::finishFrequency() {
  points_.push_back(estimator_->result());
  unwrapPhases(&points_);
  ++index_;
  segment_pending_ = true;
  if (index_ < static_cast<int>(request_.frequencies.size())) return;
  if (fit_on_finish_) fit_ = fitServoValve(points_);
  end(State::kFinished, "");
}

std::optional<double> ValveSweep::command(double now) {
  const auto bounded = [&](double u) { return std::clamp(u, limits_.min_voltage, limits_.max_voltage); };
  if (running() && !std::isfinite(now)) abort("the clock is not finite");
  if (running()) {
    if (segment_pending_) beginFrequency(now);
    const double u = request_.offset +
                     request_.amplitude * std::sin(2.0 * M_PI * currentFrequency() * (now - segment_start_));
    return bounded(u);
  }
  if (offset_owed_) {
    offset_owed_ = false;
    return bounded(request_.offset);
  }
  return std::nullopt;
}

double ValveSweep::commandAt(double t) const {
  if (!running() || segment_pending_) return request_.offset;
  const double u =
      request_.offset + request_.amplitude * std::sin(2.0 * M_PI * currentFrequency() * (t - segment_start_));
  return std::clamp(u, limits_.min_voltage, limits_.max_voltage);
}

void ValveSweep::abort(const std::string& reason) {
  if (!running()) return;
  end(State::kAborted, reason.empty() ? "aborted" : reason);
}

void ValveSweep::end(State state, const std::string& reason) {
  state_ = state;
  abort_reason_ = reason;
  estimator_.reset();
  offset_owed_ = true;
}

}  // namespace die_cushion_ident
