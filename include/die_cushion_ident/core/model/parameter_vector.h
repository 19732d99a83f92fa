#pragma once

#include <Eigen/Dense>

namespace die_cushion_ident {

/// Largest parameter vector the models and estimators handle: base model (3) + every library effect (4) +
/// custom ones; vectors and matrices of parameters live on the stack at this size.
constexpr int kMaxParameters = 16;

/// A model's parameters (physical or regression coefficients), and their covariance.
using ParameterVector = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kMaxParameters, 1>;
using CovarianceMatrix =
    Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kMaxParameters, kMaxParameters>;

}  // namespace die_cushion_ident
