#pragma once

#include <vector>

#include "die_cushion_ident/core/estimation/recursive_least_squares.h"

namespace die_cushion_ident {

/// The long-run covariance of a least-squares fit's scores g_t = phi_t e_t when successive errors are
/// correlated (overlapping regression windows, model error): Newey-West with Bartlett weights
/// w_l = 1 - l / (L + 1) up to L steps apart, exponentially forgotten as the RLS forgets,
///
///   S_N = lambda^2 S_{N-1} + g_N g_N^T + sum_{l=1..L} w_l lambda^l (g_N g_{N-l}^T + g_{N-l} g_N^T),
///
/// so that P S P is the covariance of the (exponentially weighted) estimate whose information matrix is
/// P^-1 (doc/equations.md, "Uncertainty"). Positive semi-definite by construction of the Bartlett kernel.
class NeweyWestCovariance {
 public:
  NeweyWestCovariance(int parameters, int lags, double forgetting_factor);

  /// The score of an identification step that updated the estimator.
  void add(const ParameterVector& score);
  /// A step without an update: it keeps the lag spacing in time, adds nothing and forgets nothing.
  void skip();
  void reset();

  const CovarianceMatrix& scoreCovariance() const { return S_; }
  int lags() const { return lags_; }

 private:
  void push(const ParameterVector& score);

  int lags_;
  double lambda_;
  CovarianceMatrix S_;
  std::vector<ParameterVector> recent_;  // ring of the last `lags` scores (zero for skipped steps)
  int newest_ = 0;                       // index of the newest in the ring
  int stored_ = 0;                       // scores in the ring, up to `lags`
};

}  // namespace die_cushion_ident
