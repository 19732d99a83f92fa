#include "die_cushion_ident/core/control/feed_forward_interlock.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "die_cushion_ident/core/util/formatted.h"

namespace die_cushion_ident {

FeedForwardInterlock::FeedForwardInterlock(const FeedForwardInterlockLimits& limits, double reference_valve_gain)
    : limits_(limits), reference_gain_(reference_valve_gain) {
  const auto positive = [](double v) { return v > 0.0 && std::isfinite(v); };
  if (!positive(limits.max_voltage) || !positive(limits.slew_rate) || !positive(limits.parameter_rate) ||
      !(limits.valve_gain_band >= 1.0 && std::isfinite(limits.valve_gain_band)) ||
      !(limits.hysteresis >= 0.0 && std::isfinite(limits.hysteresis))) {
    throw std::invalid_argument("feed-forward interlock: voltage limit, slew rate and parameter rate must be > 0, "
                                "the valve gain band >= 1 and the hysteresis >= 0");
  }
  if (!(std::isfinite(reference_gain_) && reference_gain_ != 0.0)) reference_gain_ = NAN;
}

std::string FeedForwardInterlock::check(const ParameterVector& physical, double valve_gain) const {
  constexpr int kSigned = 3;  // bulk modulus, valve flow gain, dead volume: model order
  if (physical.size() < kSigned || !physical.allFinite()) return "an identified parameter is not finite";
  static const char* kNames[kSigned] = {"bulk modulus", "valve flow gain", "dead volume"};
  for (int i = 0; i < kSigned; ++i) {
    if (!(physical(i) > 0.0)) {
      return std::string("the ") + kNames[i] + formatted(" is %.3g: not positive, the inverse would turn the "
                                                           "pressure's error the wrong way", physical(i));
    }
  }
  if (!(std::isfinite(valve_gain) && valve_gain != 0.0)) return "the valve gain is not finite and non-zero";
  if (std::isfinite(reference_gain_)) {
    if ((valve_gain > 0.0) != (reference_gain_ > 0.0)) {
      return formatted("the valve gain %.3g 1/V has the opposite sign of the reference %.3g 1/V", valve_gain,
                       reference_gain_);
    }
    const double ratio = valve_gain / reference_gain_;
    if (ratio > limits_.valve_gain_band || ratio < 1.0 / limits_.valve_gain_band) {
      return formatted("the valve gain %.3g 1/V is more than %.3g times off the reference %.3g 1/V", valve_gain,
                       limits_.valve_gain_band, reference_gain_);
    }
  }
  return "";
}

void FeedForwardInterlock::acceptValveGain(double valve_gain) {
  if (!std::isfinite(reference_gain_) && std::isfinite(valve_gain) && valve_gain != 0.0) reference_gain_ = valve_gain;
}

const ParameterVector& FeedForwardInterlock::follow(const ParameterVector& identified, double dt) {
  if (!following_ || parameters_.size() != identified.size()) {
    parameters_ = identified;
    following_ = true;
    return parameters_;
  }
  const double step = limits_.parameter_rate * std::clamp(dt, 0.0, 1.0);
  for (Eigen::Index i = 0; i < identified.size(); ++i) {
    // A parameter near zero (an effect's) moves by its target's magnitude as well, so it can leave zero.
    const double scale = std::max(std::abs(parameters_(i)), std::abs(identified(i)));
    const double change = std::clamp(identified(i) - parameters_(i), -step * scale, step * scale);
    parameters_(i) += change;
  }
  return parameters_;
}

double FeedForwardInterlock::output(double wanted, double dt) {
  double target = 0.0;
  if (std::isfinite(wanted)) {
    // Hysteresis on the wanted command: small changes are held, so the overlap's two edges do not chatter.
    if (std::abs(wanted - held_wanted_) > limits_.hysteresis || wanted == 0.0) held_wanted_ = wanted;
    target = std::clamp(held_wanted_, -limits_.max_voltage, limits_.max_voltage);
  } else {
    held_wanted_ = 0.0;
  }
  const double step = limits_.slew_rate * std::clamp(std::isfinite(dt) ? dt : 0.0, 0.0, 1.0);
  output_ = std::clamp(output_ + std::clamp(target - output_, -step, step), -limits_.max_voltage, limits_.max_voltage);
  return output_;
}

}  // namespace die_cushion_ident
