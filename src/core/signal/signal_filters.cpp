#include "die_cushion_ident/core/signal/signal_filters.h"

#include <algorithm>
#include <stdexcept>

namespace die_cushion_ident {

namespace {
void requireOddWidth(std::size_t width, const char* what) {
  if (width == 0 || width % 2 == 0) {
    throw std::invalid_argument(std::string(what) + ": width must be odd and at least 1");
  }
}
}  // namespace

MovingAverageFilter::MovingAverageFilter(std::size_t width, std::size_t dimension)
    : window_((requireOddWidth(width, "MovingAverageFilter"), width), dimension), output_(dimension, 0.0) {}

bool MovingAverageFilter::push(const double* values) {
  window_.push(values);
  if (!window_.full()) return false;
  const double scale = 1.0 / static_cast<double>(window_.width());
  for (std::size_t c = 0; c < output_.size(); ++c) output_[c] = window_.sum(c) * scale;
  return true;
}

SymmetricDerivative::SymmetricDerivative(std::size_t width, std::size_t dimension, double sample_period_s)
    : width_(width), dimension_(dimension), ring_(width * dimension, 0.0), output_(dimension, 0.0) {
  requireOddWidth(width, "SymmetricDerivative");
  if (width < 3) throw std::invalid_argument("SymmetricDerivative: width must be at least 3");
  if (!(sample_period_s > 0.0)) throw std::invalid_argument("SymmetricDerivative: sample period must be > 0");
  inverse_span_s_ = 1.0 / (static_cast<double>(width - 1) * sample_period_s);
}

bool SymmetricDerivative::push(const double* values) {
  // The row at head_ holds the oldest sample u_{k-d+1} once the ring is full.
  double* row = &ring_[head_ * dimension_];
  const bool full = (count_ + 1 >= width_);
  for (std::size_t c = 0; c < dimension_; ++c) row[c] = values[c];
  head_ = (head_ + 1 == width_) ? 0 : head_ + 1;
  if (count_ < width_) ++count_;
  if (!full) return false;
  const double* oldest = &ring_[head_ * dimension_];  // u_{k-d+1}
  for (std::size_t c = 0; c < dimension_; ++c) output_[c] = (values[c] - oldest[c]) * inverse_span_s_;
  return true;
}

void SymmetricDerivative::clear() {
  std::fill(ring_.begin(), ring_.end(), 0.0);
  head_ = 0;
  count_ = 0;
}

DelayLine::DelayLine(std::size_t delay, std::size_t dimension)
    : delay_(delay), dimension_(dimension), ring_((delay + 1) * dimension, 0.0), output_(dimension, 0.0) {}

bool DelayLine::push(const double* values) {
  double* row = &ring_[head_ * dimension_];
  for (std::size_t c = 0; c < dimension_; ++c) row[c] = values[c];
  head_ = (head_ + 1 == delay_ + 1) ? 0 : head_ + 1;
  if (count_ <= delay_) ++count_;
  if (count_ <= delay_) return false;
  const double* oldest = &ring_[head_ * dimension_];  // written delay_ pushes ago
  std::copy(oldest, oldest + dimension_, output_.begin());
  return true;
}

void DelayLine::clear() {
  std::fill(ring_.begin(), ring_.end(), 0.0);
  head_ = 0;
  count_ = 0;
}

}  // namespace die_cushion_ident
