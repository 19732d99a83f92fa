#pragma once

#include <limits>
#include <memory>

namespace die_cushion_ident {

/// A sensor's white noise (the spool's, the pressure's), in the signal's unit, estimated on the fly from the
/// median absolute second difference y[k+1] - 2 y[k] + y[k-1] (std sqrt(6) sigma for white noise; the median
/// ignores the signal's own fast moves). A P-square median (Boost.Accumulators): constant memory, no
/// forgetting.
class WhiteNoiseEstimator {
 public:
  /// `stride`: after the first 256 second differences, one in `stride` enters the median.
  explicit WhiteNoiseEstimator(long stride = 4);
  ~WhiteNoiseEstimator();
  WhiteNoiseEstimator(WhiteNoiseEstimator&&) noexcept;
  WhiteNoiseEstimator& operator=(WhiteNoiseEstimator&&) noexcept;

  void add(double previous, double current, double next);
  /// The noise's standard deviation; +infinity until 32 second differences are in.
  double sigma() const;
  /// Second differences the median holds (all of the first 256, then one in `stride`).
  long count() const { return count_; }

 private:
  struct Median;
  std::unique_ptr<Median> median_;
  long stride_ = 4;
  long offered_ = 0;
  long count_ = 0;
  double sigma_ = std::numeric_limits<double>::infinity();
};

}  // namespace die_cushion_ident
