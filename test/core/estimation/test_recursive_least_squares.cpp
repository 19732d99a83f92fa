#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "die_cushion_ident/core/estimation/recursive_least_squares.h"

using namespace die_cushion_ident;

namespace {
RecursiveLeastSquares makeRls(int n, double lambda, bool bound = true, double p0 = 1e4) {
  RecursiveLeastSquares::Options o;
  o.forgetting_factor = lambda;
  o.bound_covariance = bound;
  return RecursiveLeastSquares(ParameterVector::Ones(n), CovarianceMatrix::Identity(n, n) * p0, o);
}

bool symmetricPositiveDefinite(const CovarianceMatrix& P) {
  return P.allFinite() && P.isApprox(P.transpose(), 0.0) && P.llt().info() == Eigen::Success;
}
}  // namespace

TEST(RecursiveLeastSquares, RejectsForgettingFactorOutsideZeroToOne) {
  EXPECT_THROW(makeRls(3, 0.0), std::invalid_argument);
  EXPECT_THROW(makeRls(3, 1.0001), std::invalid_argument);
  EXPECT_THROW(makeRls(3, std::nan("")), std::invalid_argument);
  EXPECT_NO_THROW(makeRls(3, 1.0));
}

TEST(RecursiveLeastSquares, RejectsCovarianceThatIsNotPositiveDefinite) {
  RecursiveLeastSquares::Options o;
  CovarianceMatrix P = CovarianceMatrix::Identity(2, 2);
  P(1, 1) = -1.0;
  EXPECT_THROW(RecursiveLeastSquares(ParameterVector::Ones(2), P, o), std::invalid_argument);
  EXPECT_THROW(RecursiveLeastSquares(ParameterVector::Ones(3), CovarianceMatrix::Identity(2, 2), o),
               std::invalid_argument);
}

TEST(RecursiveLeastSquares, NonFiniteInputIsRejectedAndChangesNothing) {
  auto rls = makeRls(2, 0.998);
  ParameterVector phi(2);
  phi << 1.0, std::nan("");
  EXPECT_EQ(rls.update(phi, 1.0), RecursiveLeastSquares::UpdateStatus::kRejectedNonFinite);
  phi << 1.0, 2.0;
  EXPECT_EQ(rls.update(phi, std::numeric_limits<double>::infinity()),
            RecursiveLeastSquares::UpdateStatus::kRejectedNonFinite);
  EXPECT_EQ(rls.updates(), 0u);
  EXPECT_TRUE(rls.parameters().isApprox(ParameterVector::Ones(2)));
}

TEST(RecursiveLeastSquares, RecoversParametersFromNoiseFreeData) {
  auto rls = makeRls(4, 1.0);
  ParameterVector truth(4);
  truth << 2.0, -3.0, 0.5, 7.0;
  std::mt19937_64 rng(1);
  std::normal_distribution<double> n(0.0, 1.0);
  for (int k = 0; k < 200; ++k) {
    ParameterVector phi(4);
    for (int i = 0; i < 4; ++i) phi(i) = n(rng);
    rls.update(phi, phi.dot(truth));
  }
  EXPECT_LT((rls.parameters() - truth).norm(), 1e-5)
      << "noise-free LS is exact up to the prior's weight (1e-4)";
}

TEST(RecursiveLeastSquares, StaysSymmetricPositiveDefiniteOverAMillionForgettingUpdates) {
  // NUMERICS.md: the asymmetric form went NaN after ~366,000 updates with lambda = 0.998.
  auto rls = makeRls(4, 0.998);
  ParameterVector truth(4);
  truth << 1.5, 0.7, -2.0, 3.0;
  std::mt19937_64 rng(2);
  std::normal_distribution<double> n(0.0, 1.0);
  for (int k = 0; k < 1'000'000; ++k) {
    ParameterVector phi(4);
    phi << n(rng), 1e-3 * n(rng), n(rng), 1e3 * n(rng);  // badly scaled on purpose
    rls.update(phi, phi.dot(truth) + 0.01 * n(rng));
  }
  EXPECT_TRUE(symmetricPositiveDefinite(rls.covariance()));
  EXPECT_EQ(rls.covarianceResets(), 0u);
  EXPECT_LT((rls.parameters() - truth).cwiseAbs().maxCoeff(), 0.5)
      << "estimate must still track after 1e6 steps";
  EXPECT_NEAR(rls.parameters()(3), 3.0, 1e-4);
}

TEST(RecursiveLeastSquares, CovarianceBoundPreventsWindupOverAMillionUnexcitedSteps) {
  auto rls = makeRls(3, 0.998);
  ParameterVector truth(3);
  truth << 1.0, 2.0, 3.0;
  std::mt19937_64 rng(4);
  std::normal_distribution<double> n(0.0, 1.0);
  for (int k = 0; k < 2000; ++k) {
    ParameterVector phi(3);
    phi << n(rng), n(rng), n(rng);
    rls.update(phi, phi.dot(truth));
  }
  const ParameterVector before = rls.parameters();
  // No excitation: every forgetting step inflates P by 1/lambda. (Noise-only regressors are a different
  // matter, errors in variables: HydraulicIdentifier keeps them out with its excitation dead zone.)
  for (int k = 0; k < 1'000'000; ++k) rls.update(ParameterVector::Zero(3), 0.0);
  EXPECT_TRUE(symmetricPositiveDefinite(rls.covariance()));
  EXPECT_LE(rls.covariance().diagonal().maxCoeff(), 1e4 * (1 + 1e-12)) << "P must never exceed P0";
  EXPECT_LT((rls.parameters() - before).norm(), 1e-12) << "no burst: estimates stay where the data left them";
  // Excitation returns: the estimator must still converge, without a burst.
  for (int k = 0; k < 3000; ++k) {
    ParameterVector phi(3);
    phi << n(rng), n(rng), n(rng);
    rls.update(phi, phi.dot(truth));
  }
  EXPECT_LT((rls.parameters() - truth).norm(), 1e-6);
}

TEST(RecursiveLeastSquares, WithoutTheBoundTheCovarianceWindsUp) {
  // Shows that the remedy is needed at all: P grows as lambda^-k without excitation.
  auto rls = makeRls(2, 0.998, /*bound=*/false, 1.0);
  for (int k = 0; k < 20000; ++k) rls.update(ParameterVector::Zero(2), 0.0);
  EXPECT_GT(rls.covariance()(0, 0), 1e17) << "0.998^-20000 = 2.4e17";
}

TEST(RecursiveLeastSquares, TracksAStepWithForgetting) {
  auto rls = makeRls(2, 0.99);
  ParameterVector truth(2);
  truth << 1.0, 1.0;
  std::mt19937_64 rng(5);
  std::normal_distribution<double> n(0.0, 1.0);
  for (int k = 0; k < 2000; ++k) {
    if (k == 1000) truth(0) = 2.0;
    ParameterVector phi(2);
    phi << n(rng), n(rng);
    rls.update(phi, phi.dot(truth));
  }
  EXPECT_NEAR(rls.parameters()(0), 2.0, 1e-3) << "old data keep a weight of 0.99^1000 = 4e-5";
}

TEST(RecursiveLeastSquares, ResidualVarianceEstimatesTheNoise) {
  auto rls = makeRls(2, 1.0);
  std::mt19937_64 rng(6);
  std::normal_distribution<double> n(0.0, 1.0);
  for (int k = 0; k < 20000; ++k) {
    ParameterVector phi(2);
    phi << n(rng), n(rng);
    rls.update(phi, phi.sum() + 0.1 * n(rng));
  }
  EXPECT_NEAR(std::sqrt(rls.residualVariance()), 0.1, 0.005) << "sigma of 0.1 within 5 %";
}
