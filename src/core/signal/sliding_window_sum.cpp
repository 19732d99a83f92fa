#include "die_cushion_ident/core/signal/sliding_window_sum.h"

#include <algorithm>
#include <stdexcept>

namespace die_cushion_ident {

SlidingWindowSum::SlidingWindowSum(std::size_t width, std::size_t dimension,
                                   std::size_t exact_refresh_interval)
    : width_(width),
      dimension_(dimension),
      exact_refresh_interval_(std::max<std::size_t>(exact_refresh_interval, 1)),
      ring_(width * dimension, 0.0),
      sum_(dimension, 0.0) {
  if (width == 0 || dimension == 0) {
    throw std::invalid_argument("SlidingWindowSum: width and dimension must be at least 1");
  }
}

void SlidingWindowSum::push(const double* values) {
  double* row = &ring_[head_ * dimension_];
  const bool evicting = (count_ == width_);
  for (std::size_t c = 0; c < dimension_; ++c) {
    if (evicting) sum_[c] -= row[c];
    row[c] = values[c];
    sum_[c] += values[c];
  }
  head_ = (head_ + 1 == width_) ? 0 : head_ + 1;
  if (!evicting) ++count_;
  if (++pushes_since_refresh_ >= exact_refresh_interval_) recomputeExactly();
}

void SlidingWindowSum::recomputeExactly() {
  pushes_since_refresh_ = 0;
  std::fill(sum_.begin(), sum_.end(), 0.0);
  // Rows that were never written hold zeros, so summing the whole ring is exact either way.
  for (std::size_t r = 0; r < width_; ++r) {
    const double* row = &ring_[r * dimension_];
    for (std::size_t c = 0; c < dimension_; ++c) sum_[c] += row[c];
  }
}

void SlidingWindowSum::clear() {
  std::fill(ring_.begin(), ring_.end(), 0.0);
  std::fill(sum_.begin(), sum_.end(), 0.0);
  head_ = 0;
  count_ = 0;
  pushes_since_refresh_ = 0;
}

}  // namespace die_cushion_ident
