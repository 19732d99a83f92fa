#include "die_cushion_ident/core/signal/message_noise.h"

#include <cmath>

namespace die_cushion_ident {

namespace {
// A gap longer than this is a pause (or a loop), not the topic's rate.
constexpr double kLongestInterval = 1.0;  // [s]
}  // namespace

void MessageNoise::add(double stamp, double value) {
  if (!std::isfinite(stamp) || !std::isfinite(value)) return;
  if (!(stamp > last_stamp_)) {
    if (std::isfinite(last_stamp_)) run_ = 0;  // stamps back or repeated: the differences start over
  } else if (stamp - last_stamp_ <= kLongestInterval) {
    interval_sum_ += stamp - last_stamp_;
    ++intervals_;
  } else {
    run_ = 0;
  }
  last_stamp_ = stamp;
  values_[0] = values_[1];
  values_[1] = values_[2];
  values_[2] = value;
  if (run_ < 3) ++run_;
  if (run_ == 3) noise_.add(values_[0], values_[1], values_[2]);
}

double MessageNoise::meanInterval() const {
  return intervals_ > 0 ? interval_sum_ / static_cast<double>(intervals_)
                        : std::numeric_limits<double>::quiet_NaN();
}

double MessageNoise::forGrid(double sample_period) const {
  const double interval = meanInterval();
  const double sigma = noise_.sigma();
  if (!std::isfinite(interval) || !std::isfinite(sigma) || !gridBetweenMessages(sample_period, interval))
    return 0.0;
  return sigma;
}

}  // namespace die_cushion_ident
