#include "die_cushion_ident/core/estimation/estimate_scatter.h"

#include <algorithm>
#include <cmath>

namespace die_cushion_ident {

EstimateScatter::EstimateScatter(double horizon)
    : keep_(1.0 - 1.0 / std::max(horizon, 2.0)), enough_(0.1 * std::max(horizon, 2.0)) {}

void EstimateScatter::add(const ParameterVector& estimate) {
  if (!estimate.allFinite()) return;
  if (mean_.size() != estimate.size()) {
    reset();
    mean_ = ParameterVector::Zero(estimate.size());
    squares_ = ParameterVector::Zero(estimate.size());
  }
  // West's weighted update of the mean and the sum of squared deviations, both forgetting by keep_.
  weight_ = keep_ * weight_ + 1.0;
  const ParameterVector deviation = estimate - mean_;
  mean_ += deviation / weight_;
  squares_ = keep_ * squares_ + deviation.cwiseProduct(estimate - mean_);
}

ParameterVector EstimateScatter::stds() const {
  if (!(weight_ >= enough_)) return ParameterVector::Zero(mean_.size());
  return (squares_ / weight_).cwiseMax(0.0).cwiseSqrt();
}

void EstimateScatter::reset() {
  weight_ = 0.0;
  mean_.resize(0);
  squares_.resize(0);
}

}  // namespace die_cushion_ident
