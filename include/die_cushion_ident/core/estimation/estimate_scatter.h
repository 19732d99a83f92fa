#pragma once

#include <cstdint>

#include "die_cushion_ident/core/model/parameter_vector.h"

namespace die_cushion_ident {

/// How far a forgetting estimator's estimate scatters over many press cycles: the exponentially weighted
/// variance of the estimate around its own long-run mean, over about `horizon` identification steps (many
/// times the estimator's memory). The regression's Newey-West sandwich sees the correlation of rows a few
/// windows apart; an error correlated over whole strokes (a model error that repeats in every cycle, the
/// phases exciting the parameters in turn) moves the estimate from cycle to cycle, and shows here. On four
/// press classes the live stds alone covered 88-90 % of the errors at 1.96 std (median |error| / std
/// 0.85-0.89); with the larger of the two, 90-94 % (0.74-0.79): doc/equations.md, "Uncertainty".
/// A constant bias of the estimator shows in neither. Constant memory.
class EstimateScatter {
 public:
  /// `horizon` [identification steps] the long-run mean's memory; the scatter is reported once the weight
  /// of the steps seen reaches `horizon` / 10.
  explicit EstimateScatter(double horizon);

  void add(const ParameterVector& estimate);
  /// Each parameter's standard deviation of the scatter; zeros until enough steps are in.
  ParameterVector stds() const;
  void reset();

 private:
  double keep_;    // 1 - 1 / horizon
  double enough_;  // weight from which the scatter is reported
  double weight_ = 0.0;
  ParameterVector mean_, squares_;
};

}  // namespace die_cushion_ident
