#include "die_cushion_ident/core/control/feed_forward_interlock.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "die_cushion_ident/core/util/formatted.h"

namespace die_cushion_ident {

FeedForwardInterlock::FeedForwardInterlock(const FeedForwardInterlockLimits& limits,
                                           double configured_valve_gain)
    : limits_(limits), configured_gain_(configured_valve_gain) {
  const auto positive = [](double v) { return v > 0.0 && std::isfinite(v); };
  if (!positive(limits.parameter_rate) || !positive(limits.max_lead) ||
      !(limits.valve_gain_band >= 1.0 && std::isfinite(limits.valve_gain_band))) {
    throw std::invalid_argument(
        "feed-forward interlock: parameter rate and longest lead must be > 0, the valve gain band >= 1");
  }
  if (!(std::isfinite(configured_gain_) && configured_gain_ != 0.0)) configured_gain_ = NAN;
}

std::string FeedForwardInterlock::checkParameters(const HydraulicModel& model,
                                                  const ParameterVector& physical,
                                                  const ParameterVector& stds,
                                                  ParameterVector* usable) const {
  if (physical.size() != model.parameterCount() || stds.size() != physical.size()) {
    return "the parameters do not fit the model";
  }
  if (!physical.allFinite()) return "an identified parameter is not finite";
  constexpr double kStds = 3.0;  // beyond its range by more than this many stds: not the estimator's noise
  const auto& infos = model.parameterInfos();
  ParameterVector inside = physical;
  for (int i = 0; i < model.parameterCount(); ++i) {
    const ParameterInfo& info = infos[i];
    // Bulk modulus, flow gain and dead volume strictly positive: at zero the inverse loses its sign.
    if (i < HydraulicModel::kFirstEffect && !(physical(i) > 0.0)) {
      return info.name + formatted(FMT_STRING(" = {:.3g} "), physical(i)) + info.unit +
             " is not positive: the inverse would turn the pressure's error the wrong way";
    }
    const double slack = std::isfinite(stds(i)) ? kStds * std::abs(stds(i)) : 0.0;
    if (physical(i) < info.lower_bound - slack || physical(i) > info.upper_bound + slack) {
      return info.name + formatted(FMT_STRING(" = {:.3g} "), physical(i)) + info.unit +
             formatted(FMT_STRING(" (std {:.2g})"), stds(i)) + " lies outside its physical range [" +
             formatted(FMT_STRING("{:.3g}, "), info.lower_bound) +
             formatted(FMT_STRING("{:.3g}] "), info.upper_bound) + info.unit + " by more than 3 stds";
    }
    inside(i) = std::clamp(physical(i), info.lower_bound, info.upper_bound);
  }
  if (usable) *usable = inside;
  return "";
}

namespace {
double referenceGain(double configured, const std::optional<ServoValveParameters>& swept) {
  return std::isfinite(configured) ? configured : swept ? swept->gain : NAN;
}
}  // namespace

std::string FeedForwardInterlock::checkValve(const ServoValveParameters& valve, bool from_sweep) const {
  if (!(std::isfinite(valve.gain) && valve.gain != 0.0)) return "the valve gain is not finite and non-zero";
  const double reference = referenceGain(configured_gain_, swept_);
  if (std::isfinite(reference)) {
    if ((valve.gain > 0.0) != (reference > 0.0)) {
      return formatted(
          FMT_STRING("the valve gain {:.3g} 1/V has the opposite sign of the reference {:.3g} 1/V"),
          valve.gain, reference);
    }
    const double ratio = valve.gain / reference;
    if (ratio > limits_.valve_gain_band || ratio < 1.0 / limits_.valve_gain_band) {
      return formatted(
          FMT_STRING("the valve gain {:.3g} 1/V is more than {:.3g} times off the reference {:.3g} 1/V"),
          valve.gain, limits_.valve_gain_band, reference);
    }
  }
  if (!from_sweep) return "";
  using S = ValveSanity;
  if (!(valve.natural_frequency >= S::kMinNaturalFrequency &&
        valve.natural_frequency <= S::kMaxNaturalFrequency)) {
    return formatted(FMT_STRING("the valve's natural frequency {:.3g} Hz lies outside [{:g}, "),
                     valve.natural_frequency, S::kMinNaturalFrequency) +
           formatted(FMT_STRING("{:g}] Hz"), S::kMaxNaturalFrequency);
  }
  if (!(valve.damping >= S::kMinDamping && valve.damping <= S::kMaxDamping)) {
    return formatted(FMT_STRING("the valve's damping {:.3g} lies outside [{:g}, "), valve.damping,
                     S::kMinDamping) +
           formatted(FMT_STRING("{:g}]"), S::kMaxDamping);
  }
  if (!(valve.dead_time >= 0.0 && valve.dead_time <= S::kMaxDeadTime)) {
    return formatted(FMT_STRING("the valve's dead time {:.3g} s lies outside [0, {:g}] s"), valve.dead_time,
                     S::kMaxDeadTime);
  }
  if (!(valve.lowFrequencyDelay() <= limits_.max_lead)) {
    return formatted(
               FMT_STRING(
                   "the valve's lag (dead time + 2 D / w0) {:.1f} ms is longer than the lead allowed, "),
               valve.lowFrequencyDelay() * 1e3) +
           formatted(FMT_STRING("{:.1f} ms (feed_forward_max_lead)"), limits_.max_lead * 1e3);
  }
  return "";
}

bool FeedForwardInterlock::offerSweptValve(const ServoValveParameters& valve, std::string* refusal) {
  const std::string why = checkValve(valve, true);
  if (refusal) *refusal = why;
  if (!why.empty()) return false;
  swept_ = valve;
  return true;
}

std::optional<ServoValveParameters> FeedForwardInterlock::valve() const {
  if (swept_) return swept_;
  if (!std::isfinite(configured_gain_)) return std::nullopt;
  ServoValveParameters configured;
  configured.gain = configured_gain_;
  configured.dead_time = 0.0;  // no lag known: no lead
  configured.natural_frequency = std::numeric_limits<double>::infinity();
  return configured;
}

const ParameterVector& FeedForwardInterlock::follow(const HydraulicModel& model,
                                                    const ParameterVector& identified, double dt) {
  if (identified.size() != model.parameterCount()) {
    throw std::invalid_argument("feed-forward interlock: the parameters do not fit the model");
  }
  std::vector<std::string> names;
  for (const auto& info : model.parameterInfos()) names.push_back(info.name);
  if (names_.empty()) {
    parameters_ = identified;
    names_ = names;
    return parameters_;
  }
  if (names != names_) {
    // A new model: what both share continues, a new effect starts absent (0 is every effect's neutral value).
    ParameterVector mapped = ParameterVector::Zero(static_cast<Eigen::Index>(names.size()));
    for (std::size_t i = 0; i < names.size(); ++i) {
      const auto old = std::find(names_.begin(), names_.end(), names[i]);
      if (old != names_.end()) mapped(static_cast<Eigen::Index>(i)) = parameters_(old - names_.begin());
    }
    parameters_ = mapped;
    names_ = names;
  }
  const double step = limits_.parameter_rate * std::clamp(std::isfinite(dt) ? dt : 0.0, 0.0, 0.1);
  for (Eigen::Index i = 0; i < identified.size(); ++i) {
    // A parameter near zero (an effect's) moves by its target's magnitude as well, so it can leave zero.
    const double scale = std::max(std::abs(parameters_(i)), std::abs(identified(i)));
    const double change = std::clamp(identified(i) - parameters_(i), -step * scale, step * scale);
    parameters_(i) += change;
  }
  return parameters_;
}

}  // namespace die_cushion_ident
