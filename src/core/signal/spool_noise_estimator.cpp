#include "die_cushion_ident/core/signal/spool_noise_estimator.h"

#include <boost/accumulators/accumulators.hpp>
#include <boost/accumulators/statistics/median.hpp>
#include <boost/accumulators/statistics/stats.hpp>
#include <cmath>
#include <limits>

namespace die_cushion_ident {

namespace acc = boost::accumulators;

struct SpoolNoiseEstimator::Median {
  acc::accumulator_set<double, acc::stats<acc::tag::median(acc::with_p_square_quantile)>> values;
};

SpoolNoiseEstimator::SpoolNoiseEstimator() : median_(std::make_unique<Median>()) {}
SpoolNoiseEstimator::~SpoolNoiseEstimator() = default;
SpoolNoiseEstimator::SpoolNoiseEstimator(SpoolNoiseEstimator&&) noexcept = default;
SpoolNoiseEstimator& SpoolNoiseEstimator::operator=(SpoolNoiseEstimator&&) noexcept = default;

void SpoolNoiseEstimator::add(double previous, double current, double next) {
  const double second_difference = next - 2.0 * current + previous;
  if (!std::isfinite(second_difference)) return;
  median_->values(std::abs(second_difference));
  ++count_;
}

double SpoolNoiseEstimator::sigma() const {
  if (count_ < 32) return std::numeric_limits<double>::infinity();
  // median |N(0, 6 sigma^2)| = 0.6745 sqrt(6) sigma
  return acc::median(median_->values) / (0.6744897501960817 * std::sqrt(6.0));
}

}  // namespace die_cushion_ident
