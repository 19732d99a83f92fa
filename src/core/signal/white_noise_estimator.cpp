#include "die_cushion_ident/core/signal/white_noise_estimator.h"

#include <boost/accumulators/accumulators.hpp>
#include <boost/accumulators/statistics/median.hpp>
#include <boost/accumulators/statistics/stats.hpp>
#include <algorithm>
#include <cmath>

namespace die_cushion_ident {

namespace acc = boost::accumulators;

struct WhiteNoiseEstimator::Median {
  acc::accumulator_set<double, acc::stats<acc::tag::median(acc::with_p_square_quantile)>> values;
};

WhiteNoiseEstimator::WhiteNoiseEstimator(long stride) : median_(std::make_unique<Median>()), stride_(std::max(1L, stride)) {}
WhiteNoiseEstimator::~WhiteNoiseEstimator() = default;
WhiteNoiseEstimator::WhiteNoiseEstimator(WhiteNoiseEstimator&&) noexcept = default;
WhiteNoiseEstimator& WhiteNoiseEstimator::operator=(WhiteNoiseEstimator&&) noexcept = default;

namespace {
// Every second difference while the estimate forms, then one in `stride`: the noise is the sensor's, and a
// quarter of an hour's samples pin its median far finer than the 3-sigma band it sets (the P-square update
// was 6 % of analyze_bag's time, paid in every batch fit).
constexpr long kDense = 256;
}  // namespace

void WhiteNoiseEstimator::add(double previous, double current, double next) {
  const double second_difference = next - 2.0 * current + previous;
  if (!std::isfinite(second_difference)) return;
  if (offered_++ >= kDense && offered_ % stride_ != 0) return;
  median_->values(std::abs(second_difference));
  ++count_;
  // median |N(0, 6 sigma^2)| = 0.6745 sqrt(6) sigma
  if (count_ >= 32) sigma_ = acc::median(median_->values) / (0.6744897501960817 * std::sqrt(6.0));
}

double WhiteNoiseEstimator::sigma() const { return sigma_; }

}  // namespace die_cushion_ident
