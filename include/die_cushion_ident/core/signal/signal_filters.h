#pragma once

#include <cstddef>
#include <vector>

#include "die_cushion_ident/core/signal/sliding_window_sum.h"

namespace die_cushion_ident {

/// Centred moving average of odd width b over a vector signal:
///   f_k = (1/b) * sum_{j=0}^{b-1} u_{k-j},  which estimates u at k - (b-1)/2 (group delay (b-1)/2 samples).
class MovingAverageFilter {
 public:
  MovingAverageFilter(std::size_t width, std::size_t dimension);
  /// Pushes one sample; returns true once the window is full and `output()` is valid.
  bool push(const double* values);
  bool push(double value) { return push(&value); }
  const std::vector<double>& output() const { return output_; }
  double output(std::size_t channel) const { return output_[channel]; }
  std::size_t delaySamples() const { return (window_.width() - 1) / 2; }
  void clear() { window_.clear(); }

 private:
  SlidingWindowSum window_;
  std::vector<double> output_;
};

/// Symmetrical derivative of odd width d at sample period dt [s]:
///   f'_k = (u_k - u_{k-d+1}) / ((d-1) * dt),  centred at k - (d-1)/2 (group delay (d-1)/2 samples).
/// Equals (1/((d-1)dt)) times the sum of the d-1 increments in the window, which is how the integral
/// form of the volume balance uses it.
class SymmetricDerivative {
 public:
  SymmetricDerivative(std::size_t width, std::size_t dimension, double sample_period_s);
  bool push(const double* values);
  bool push(double value) { return push(&value); }
  const std::vector<double>& output() const { return output_; }
  double output(std::size_t channel) const { return output_[channel]; }
  std::size_t delaySamples() const { return (width_ - 1) / 2; }
  void clear();

 private:
  std::size_t width_;
  std::size_t dimension_;
  double inverse_span_s_;
  std::vector<double> ring_;
  std::vector<double> output_;
  std::size_t head_ = 0;
  std::size_t count_ = 0;
};

/// Fixed delay of a vector signal by `delay` samples, so that unfiltered signals line up with filtered ones.
class DelayLine {
 public:
  DelayLine(std::size_t delay, std::size_t dimension);
  /// Pushes one sample; returns true once `output()` holds the sample from `delay` pushes ago.
  bool push(const double* values);
  const double* output() const { return output_.data(); }
  double output(std::size_t channel) const { return output_[channel]; }
  void clear();

 private:
  std::size_t delay_;
  std::size_t dimension_;
  std::vector<double> ring_;
  std::vector<double> output_;
  std::size_t head_ = 0;
  std::size_t count_ = 0;
};

}  // namespace die_cushion_ident
