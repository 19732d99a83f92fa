#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <cmath>
#include <random>

#include "die_cushion_ident/core/estimation/newey_west_covariance.h"

using die_cushion_ident::CovarianceMatrix;
using die_cushion_ident::NeweyWestCovariance;
using die_cushion_ident::ParameterVector;

namespace {

ParameterVector score(double a, double b) {
  ParameterVector g(2);
  g << a, b;
  return g;
}

}  // namespace

// Without lags it is the forgotten sum of the scores' outer products: S_N = lambda^2 S_{N-1} + g g^T.
TEST(NeweyWestCovariance, WithoutLagsTheForgottenSumOfOuterProducts) {
  NeweyWestCovariance s(2, 0, 0.9);
  const ParameterVector g1 = score(1.0, 2.0), g2 = score(-3.0, 0.5);
  s.add(g1);
  s.add(g2);
  const CovarianceMatrix expected = 0.81 * g1 * g1.transpose() + g2 * g2.transpose();
  EXPECT_TRUE(s.scoreCovariance().isApprox(expected, 1e-12)) << s.scoreCovariance();
}

// A skipped step keeps the spacing: the scores on either side of it are two steps apart (Bartlett weight
// 1 - 2 / (L + 1)), and nothing is forgotten for it.
TEST(NeweyWestCovariance, ASkippedStepKeepsTheLagSpacing) {
  NeweyWestCovariance s(2, 2, 1.0);
  const ParameterVector g1 = score(1.0, 0.0), g2 = score(0.0, 1.0);
  s.add(g1);
  s.skip();
  s.add(g2);
  const CovarianceMatrix expected =
      g1 * g1.transpose() + g2 * g2.transpose() + (1.0 / 3.0) * (g2 * g1.transpose() + g1 * g2.transpose());
  EXPECT_TRUE(s.scoreCovariance().isApprox(expected, 1e-12)) << s.scoreCovariance();
  s.reset();
  EXPECT_EQ(s.scoreCovariance().norm(), 0.0);
}

// Scores correlated from step to step (an MA(1): g_t = e_t + theta e_{t-1}): S / N is the long-run variance
// sigma^2 (1 + theta^2 + 2 theta w_1), w_1 = 1 - 1 / (L + 1), not the plain variance sigma^2 (1 + theta^2)
// the stds without it assumed.
TEST(NeweyWestCovariance, CorrelatedScoresGiveTheLongRunVariance) {
  constexpr int kLags = 10;
  constexpr double kTheta = 0.8;
  NeweyWestCovariance s(1, kLags, 1.0);
  std::mt19937 rng(5);
  std::normal_distribution<double> e(0.0, 1.0);
  double previous = e(rng);
  constexpr int kSteps = 200000;
  for (int t = 0; t < kSteps; ++t) {
    const double now = e(rng);
    ParameterVector g(1);
    g << now + kTheta * previous;
    s.add(g);
    previous = now;
  }
  const double long_run = 1.0 + kTheta * kTheta + 2.0 * kTheta * (1.0 - 1.0 / (kLags + 1.0));
  EXPECT_NEAR(s.scoreCovariance()(0, 0) / kSteps, long_run, 0.03 * long_run);
  EXPECT_GT(s.scoreCovariance()(0, 0) / kSteps, 1.3 * (1.0 + kTheta * kTheta));
}

// The Bartlett kernel keeps S positive semi-definite whatever the scores.
TEST(NeweyWestCovariance, StaysPositiveSemiDefinite) {
  NeweyWestCovariance s(3, 6, 0.998);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int t = 0; t < 5000; ++t) {
    ParameterVector g(3);
    g << u(rng), 1e3 * u(rng), (t % 2 ? 1.0 : -1.0) * 1e-3;  // scaled very differently, one alternating
    if (t % 7 == 0) {
      s.skip();
    } else {
      s.add(g);
    }
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(s.scoreCovariance());
  EXPECT_GE(eigen.eigenvalues().minCoeff(), -1e-9 * eigen.eigenvalues().maxCoeff());
}
