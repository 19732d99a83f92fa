#include "die_cushion_ident/core/control/feed_forward_output.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace die_cushion_ident {

FeedForwardOutput::FeedForwardOutput(const FeedForwardOutputLimits& limits) : limits_(limits) {
  const auto positive = [](double v) { return v > 0.0 && std::isfinite(v); };
  if (!positive(limits.max_voltage) || !positive(limits.slew_rate) || !positive(limits.max_step_interval) ||
      !(limits.hysteresis >= 0.0 && std::isfinite(limits.hysteresis))) {
    throw std::invalid_argument(
        "feed-forward output: voltage limit, slew rate and step interval must be > 0, the hysteresis >= 0");
  }
}

double FeedForwardOutput::next(double wanted, double now) {
  double target = 0.0;
  if (std::isfinite(wanted)) {
    // Small changes are held, so the inverse's input noise does not reach the valve.
    if (std::abs(wanted - held_wanted_) > limits_.hysteresis || wanted == 0.0) held_wanted_ = wanted;
    target = std::clamp(held_wanted_, -limits_.max_voltage, limits_.max_voltage);
  } else {
    held_wanted_ = 0.0;
  }
  // The first command (0 V was on the adder before it), a steady clock that went back (it does not) or a
  // non-finite time: no change at all.
  const bool first = last_time_ < -1e17;
  const double elapsed = std::isfinite(now) && !first ? now - last_time_ : 0.0;
  const double dt = std::clamp(elapsed, 0.0, limits_.max_step_interval);
  const double step = limits_.slew_rate * dt;
  output_ = std::clamp(output_ + std::clamp(target - output_, -step, step), -limits_.max_voltage,
                       limits_.max_voltage);
  if (std::isfinite(now)) last_time_ = now;
  return output_;
}

}  // namespace die_cushion_ident
