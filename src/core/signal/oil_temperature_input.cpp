#include "die_cushion_ident/core/signal/oil_temperature_input.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace die_cushion_ident {

namespace {
// A temperature sensor's noise and resolution: a step of this much is allowed whatever the interval.
constexpr double kSensorAllowance = 1.0;  // [K]
// Messages at a new level that confirm a jump (the one that jumped and this many after it).
constexpr std::size_t kConfirmingMessages = 3;
}  // namespace

OilTemperatureInput::PushResult OilTemperatureInput::push(double stamp, double celsius, double time_base) {
  StreamHealth& h = health_;
  ++h.received;
  if (!std::isfinite(stamp) || !std::isfinite(celsius)) {
    ++h.non_finite;
    return PushResult::kNonFinite;
  }
  if (!(celsius >= config_.min_plausible && celsius <= config_.max_plausible)) {
    ++h.implausible;
    return PushResult::kImplausible;
  }
  if (std::isfinite(time_base) && std::abs(stamp - time_base) > config_.max_age) {
    ++h.wild_stamps;
    h.last_wild_offset = stamp - time_base;
    return PushResult::kHeld;  // not taken (no other topic confirms this time base)
  }
  if (std::isfinite(last_stamp_)) {
    if (stamp == last_stamp_) {
      ++h.duplicates;
      return PushResult::kDuplicate;
    }
    if (stamp < last_stamp_) {
      ++h.out_of_order;
      return PushResult::kOutOfOrder;
    }
    const double allowed = config_.max_rate * (stamp - last_stamp_) + kSensorAllowance;
    if (std::abs(celsius - last_value_) > allowed) {
      // A jump: taken once the messages after it stay at the new level (a wrong first value, a sensor
      // replugged), else each is an implausible value.
      const bool continues =
          !jump_.empty() && std::abs(celsius - jump_.back().second) <=
                                config_.max_rate * (stamp - jump_.back().first) + kSensorAllowance;
      if (!continues) jump_.clear();
      jump_.emplace_back(stamp, celsius);
      if (jump_.size() < kConfirmingMessages) {
        ++h.implausible;
        ++jumps_;
        return PushResult::kImplausible;
      }
      // Confirmed: the level before it ends here; the jump's own messages were counted as rejected.
      messages_.clear();
      jump_.clear();
      accept(stamp, celsius, time_base);
      return PushResult::kAccepted;
    }
  }
  jump_.clear();
  accept(stamp, celsius, time_base);
  return PushResult::kAccepted;
}

void OilTemperatureInput::accept(double stamp, double celsius, double time_base) {
  StreamHealth& h = health_;
  if (std::isfinite(last_stamp_)) {
    const double interval = stamp - last_stamp_;
    const double n = static_cast<double>(++h.intervals);
    const double delta = interval - h.mean_interval;
    h.mean_interval += delta / n;
    h.interval_m2 += delta * (interval - h.mean_interval);
    h.interval_std = n > 1.0 ? std::sqrt(std::max(h.interval_m2 / n, 0.0)) : 0.0;
    h.max_interval = std::max(h.max_interval, interval);
    if (interval > config_.gap) ++h.gaps;
  }
  ++h.accepted;
  h.last_stamp = stamp;
  h.stale = false;
  messages_.emplace_back(stamp, celsius);
  sum_ += celsius;
  lowest_ = std::isnan(lowest_) ? celsius : std::min(lowest_, celsius);
  highest_ = std::isnan(highest_) ? celsius : std::max(highest_, celsius);
  if (std::isfinite(time_base)) {
    offset_sum_ += stamp - time_base;
    ++offsets_;
  }
  last_stamp_ = stamp;
  last_value_ = celsius;
}

namespace {
template <typename Messages>
double temperatureAt(const Messages& messages, double t, double max_age) {
  constexpr double kNone = std::numeric_limits<double>::quiet_NaN();
  if (messages.empty() || !std::isfinite(t)) return kNone;
  // The first message at or after t.
  const auto after =
      std::lower_bound(messages.begin(), messages.end(), t,
                       [](const std::pair<double, double>& m, double time) { return m.first < time; });
  if (after == messages.end()) {
    const auto& newest = messages.back();
    return t - newest.first <= max_age ? newest.second : kNone;
  }
  if (after == messages.begin()) return after->first - t <= max_age ? after->second : kNone;
  const auto before = after - 1;
  const double span = after->first - before->first;
  // Across a silence longer than twice max_age nothing is known in between: each side holds max_age.
  if (span > 2.0 * max_age) {
    if (t - before->first <= max_age) return before->second;
    return after->first - t <= max_age ? after->second : kNone;
  }
  const double w = (t - before->first) / span;
  return before->second + w * (after->second - before->second);
}
}  // namespace

double OilTemperatureInput::peek(double t) const { return temperatureAt(messages_, t, config_.max_age); }

double OilTemperatureInput::heldAt(const std::vector<std::pair<double, double>>& messages, double t,
                                   double max_age) {
  return temperatureAt(messages, t, max_age);
}

double OilTemperatureInput::at(double t) {
  // Keep one message at or before t - max_age: the line back to it is still needed.
  while (messages_.size() >= 2 && messages_[1].first <= t - config_.max_age) messages_.pop_front();
  return peek(t);
}

void OilTemperatureInput::restart() {
  messages_.clear();
  jump_.clear();
  last_stamp_ = last_value_ = kNaN;
}

}  // namespace die_cushion_ident
