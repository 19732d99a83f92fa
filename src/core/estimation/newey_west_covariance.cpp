#include "die_cushion_ident/core/estimation/newey_west_covariance.h"

#include <algorithm>

namespace die_cushion_ident {

NeweyWestCovariance::NeweyWestCovariance(int parameters, int lags, double forgetting_factor)
    : lags_(std::max(lags, 0)),
      lambda_(forgetting_factor),
      S_(CovarianceMatrix::Zero(parameters, parameters)),
      recent_(static_cast<std::size_t>(std::max(lags, 1)), ParameterVector::Zero(parameters)) {}

void NeweyWestCovariance::reset() {
  S_.setZero();
  for (auto& g : recent_) g.setZero();
  newest_ = 0;
  stored_ = 0;
}

void NeweyWestCovariance::add(const ParameterVector& score) {
  // The lagged terms sum to g m^T + m g^T with m = sum_l w_l lambda^l g_{N-l}: O(L n + n^2), not O(L n^2).
  ParameterVector lagged = ParameterVector::Zero(score.size());
  double decay = 1.0;
  for (int l = 1; l <= stored_; ++l) {
    decay *= lambda_;
    const ParameterVector& earlier = recent_[static_cast<std::size_t>((newest_ - (l - 1) + lags_) % lags_)];
    lagged.noalias() += ((1.0 - static_cast<double>(l) / (lags_ + 1)) * decay) * earlier;
  }
  S_ *= lambda_ * lambda_;
  S_.noalias() += score * (score + lagged).transpose();
  S_.noalias() += lagged * score.transpose();
  push(score);
}

void NeweyWestCovariance::skip() { push(ParameterVector::Zero(S_.rows())); }

void NeweyWestCovariance::push(const ParameterVector& score) {
  if (lags_ == 0) return;
  newest_ = stored_ == 0 ? 0 : (newest_ + 1) % lags_;
  recent_[static_cast<std::size_t>(newest_)] = score;
  stored_ = std::min(stored_ + 1, lags_);
}

}  // namespace die_cushion_ident
