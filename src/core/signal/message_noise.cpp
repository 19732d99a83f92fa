#include "die_cushion_ident/core/signal/message_noise.h"

#include <cmath>

namespace die_cushion_ident {

namespace {
// A gap longer than this is a pause (or a loop), not the topic's rate.
constexpr double kLongestInterval = 1.0;  // [s]
// Grid samples closer than this many message intervals are often interpolated from a common message: the
// resampler's cubic reads four (UniformResampler), so samples up to 4 intervals apart (less the stamps'
// jitter) share one.
constexpr double kSharedBelow = 3.8;

// The noise variance a sample holds, in units of a message's, a fraction w of the way between two messages
// of a cubic through four (Catmull-Rom's weights on even stamps; the stamps' jitter changes them little).
double cubicShare(double w) {
  const double w2 = w * w, w3 = w2 * w;
  const double before = 0.5 * (-w3 + 2.0 * w2 - w), from = 0.5 * (3.0 * w3 - 5.0 * w2 + 2.0);
  const double to = 0.5 * (-3.0 * w3 + 4.0 * w2 + w), after = 0.5 * (w3 - w2);
  return before * before + from * from + to * to + after * after;
}
// More grid points between two messages than this are a grid far finer than any sensor: not followed.
constexpr double kMostGridPoints = 1e5;
}  // namespace

void MessageNoise::add(double stamp, double value) {
  if (!std::isfinite(stamp) || !std::isfinite(value)) return;
  if (!(stamp > last_stamp_)) {
    if (std::isfinite(last_stamp_)) run_ = 0;  // stamps back or repeated: the differences start over
  } else if (stamp - last_stamp_ <= kLongestInterval) {
    interval_sum_ += stamp - last_stamp_;
    ++intervals_;
    addGridShares(last_stamp_ - grid_offset_, stamp - grid_offset_);
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

void MessageNoise::followGrid(double period, double stamp_offset, double phase) {
  grid_period_ = period > 0.0 ? period : 0.0;
  // The grid's points t_k = k period + phase are met as the points k period of stamps moved by the phase.
  grid_offset_ = (std::isfinite(stamp_offset) ? stamp_offset : 0.0) + (std::isfinite(phase) ? phase : 0.0);
  share_sum_ = 0.0;
  shares_ = 0;
}

void MessageNoise::addGridShares(double from, double to) {
  if (!(grid_period_ > 0.0)) return;
  // The grid points t_k = k * period (as UniformResampler computes them, its phase in the offset) in (from,
  // to], each counted once: the simulator's stamps lie on grid points often, and a quotient that rounds
  // across an integer counted such a point twice or not at all. A point on a message's stamp holds that
  // message alone (w = 1). Counted with an integer: stamps far from 0 (a fuzzed 1e20 s) leave k * period
  // unable to step.
  double first = std::floor(from / grid_period_) + 1.0, last = std::floor(to / grid_period_);
  if (!(last - first <= kMostGridPoints && first - last <= 2.0)) return;
  if (first * grid_period_ <= from) first += 1.0;
  if ((first - 1.0) * grid_period_ > from) first -= 1.0;
  if (last * grid_period_ > to) last -= 1.0;
  if ((last + 1.0) * grid_period_ <= to) last += 1.0;
  if (!(last >= first)) return;
  const long points = static_cast<long>(last - first) + 1;
  for (long i = 0; i < points; ++i) {
    const double w = ((first + static_cast<double>(i)) * grid_period_ - from) / (to - from);
    share_sum_ += cubicShare(w);
    ++shares_;
  }
}

double MessageNoise::gridShare() const {
  return shares_ > 0 ? std::sqrt(share_sum_ / static_cast<double>(shares_)) : 1.0;
}

double MessageNoise::forGrid(double sample_period) const {
  const double interval = meanInterval();
  const double sigma = noise_.sigma();
  if (!std::isfinite(interval) || !std::isfinite(sigma) || !(sample_period < kSharedBelow * interval))
    return 0.0;
  return sample_period == grid_period_ ? sigma * gridShare() : sigma;
}

}  // namespace die_cushion_ident
