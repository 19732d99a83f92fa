#pragma once

#include <Eigen/Dense>
#include <cstdint>

#include "die_cushion_ident/core/model/parameter_vector.h"

namespace die_cushion_ident {

/// Recursive least squares with exponential forgetting for  z_k = phi_k^T theta + e_k.
///
///   e_k     = z_k - phi_k^T theta_{k-1}                     (a-priori error)
///   u       = P_{k-1} phi_k,   s = lambda + phi_k^T u
///   theta_k = theta_{k-1} + u e_k / s
///   P_k     = (P_{k-1} - u u^T / s) / lambda, computed in Joseph form (symmetric, positive definite)
///
/// Covariance bound (the anti-windup remedy): forgetting inflates P by 1/lambda per update in every
/// direction the data do not excite, so with lambda = 0.998 and no excitation P grows as 1.002^k and the
/// estimates burst when excitation returns. After each update every diagonal element is kept at or below
/// its initial value by the congruence P <- S P S with S = diag(min(1, sqrt(P0_ii / P_ii))), which keeps P
/// symmetric positive definite and means "never less certain than before the first sample". The caller
/// additionally skips updates that carry no information (see HydraulicIdentifier's excitation dead zone).
class RecursiveLeastSquares {
 public:
  struct Options {
    double forgetting_factor = 0.998;  ///< lambda in (0, 1]
    bool bound_covariance = true;      ///< keep P_ii <= P0_ii (anti-windup)
  };

  enum class UpdateStatus { kUpdated, kRejectedNonFinite, kCovarianceReset };

  RecursiveLeastSquares(const ParameterVector& initial_parameters, const CovarianceMatrix& initial_covariance,
                        const Options& options);

  /// One update with regressor phi and measurement z; non-finite input is rejected and changes nothing.
  UpdateStatus update(const ParameterVector& regressor, double measurement);

  /// Restarts from the initial parameters and covariance.
  void reset();

  const ParameterVector& parameters() const { return theta_; }
  const ParameterVector& initialParameters() const { return theta0_; }
  const CovarianceMatrix& covariance() const { return P_; }
  /// Exponentially weighted variance of the normalised a-priori error e^2 / (1 + phi^T P phi / lambda),
  /// an estimate of the equation-error variance sigma^2; sigma^2 * P estimates the parameter covariance.
  double residualVariance() const { return residual_variance_; }
  double lastPriorError() const { return last_prior_error_; }
  std::uint64_t updates() const { return updates_; }
  std::uint64_t covarianceResets() const { return covariance_resets_; }
  int size() const { return static_cast<int>(theta_.size()); }
  const Options& options() const { return options_; }

 private:
  void boundCovariance();

  Options options_;
  ParameterVector theta0_;
  CovarianceMatrix P0_;
  ParameterVector theta_;
  CovarianceMatrix P_;
  double residual_variance_ = 0.0;
  double residual_weight_ = 0.0;
  double last_prior_error_ = 0.0;
  std::uint64_t updates_ = 0;
  std::uint64_t covariance_resets_ = 0;
};

}  // namespace die_cushion_ident
