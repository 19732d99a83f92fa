#pragma once

#include <cstddef>
#include <vector>

namespace die_cushion_ident {

/// Sum of the last `width` values of a vector-valued signal, O(dimension) per sample.
///
/// A running sum (add the newest, subtract the oldest) drifts without bound over long runs
/// (shared/NUMERICS.md: 3e-4 bar/s after 1e7 samples). The sum is therefore recomputed
/// exactly from the stored window every `exact_refresh_interval` samples, which bounds the
/// rounding error at a few ulps of the window contents for a small amortised cost.
class SlidingWindowSum {
 public:
  SlidingWindowSum(std::size_t width, std::size_t dimension, std::size_t exact_refresh_interval = 4096);

  /// Adds one sample of `dimension()` values; the oldest leaves once the window is full.
  void push(const double* values);
  void push(double value) { push(&value); }

  /// Sum over the samples in the window (fewer than width() until full()).
  const double* sum() const { return sum_.data(); }
  double sum(std::size_t channel) const { return sum_[channel]; }

  bool full() const { return count_ == width_; }
  std::size_t count() const { return count_; }
  std::size_t width() const { return width_; }
  std::size_t dimension() const { return dimension_; }
  void clear();

 private:
  void recomputeExactly();

  std::size_t width_;
  std::size_t dimension_;
  std::size_t exact_refresh_interval_;
  std::vector<double> ring_;  // width_ rows of dimension_ values
  std::vector<double> sum_;
  std::size_t head_ = 0;  // row the next sample goes to
  std::size_t count_ = 0;
  std::size_t pushes_since_refresh_ = 0;
};

}  // namespace die_cushion_ident
