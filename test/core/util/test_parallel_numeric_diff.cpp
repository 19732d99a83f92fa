#include <ceres/ceres.h>
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "die_cushion_ident/core/util/parallel_numeric_diff.h"

namespace die_cushion_ident {
namespace {

// A nonlinear residual of two parameter blocks (3 and 1 unknowns), like the free run's: every residual
// depends on every unknown.
struct Curve {
  int n;
  bool operator()(double const* const* x, double* out) const {
    for (int i = 0; i < n; ++i) {
      const double t = 0.01 * i;
      out[i] =
          x[0][0] * std::exp(-x[0][1] * t) * std::sin(40.0 * (t - x[1][0])) + x[0][2] * t * t - std::cos(t);
    }
    return true;
  }
};

template <ceres::NumericDiffMethodType kMethod>
void expectSameJacobianAsCeres(int jobs) {
  constexpr int kResiduals = 500;
  ceres::NumericDiffOptions options;
  options.relative_step_size = 1e-4;
  ceres::DynamicNumericDiffCostFunction<Curve, kMethod> reference(new Curve{kResiduals},
                                                                  ceres::TAKE_OWNERSHIP, options);
  ParallelNumericDiffCost<Curve, kMethod> parallel(Curve{kResiduals}, options, jobs);
  for (ceres::DynamicCostFunction* f : {static_cast<ceres::DynamicCostFunction*>(&reference),
                                        static_cast<ceres::DynamicCostFunction*>(&parallel)}) {
    f->AddParameterBlock(3);
    f->AddParameterBlock(1);
    f->SetNumResiduals(kResiduals);
  }
  // One unknown at 0: Ceres's step falls back to sqrt(epsilon) there.
  const double a[3] = {1.3, 2.0, 0.0}, shift[1] = {0.004};
  const double* parameters[2] = {a, shift};
  std::vector<double> r_ref(kResiduals), r_par(kResiduals);
  std::vector<double> ja_ref(3 * kResiduals), js_ref(kResiduals), ja_par(3 * kResiduals), js_par(kResiduals);
  double* j_ref[2] = {ja_ref.data(), js_ref.data()};
  double* j_par[2] = {ja_par.data(), js_par.data()};
  ASSERT_TRUE(reference.Evaluate(parameters, r_ref.data(), j_ref));
  ASSERT_TRUE(parallel.Evaluate(parameters, r_par.data(), j_par));
  EXPECT_EQ(r_ref, r_par);
  EXPECT_EQ(ja_ref, ja_par);  // bit for bit: the same steps, the same arithmetic, row major
  EXPECT_EQ(js_ref, js_par);
  // Only the blocks asked for are filled.
  double* only_first[2] = {ja_par.data(), nullptr};
  ASSERT_TRUE(parallel.Evaluate(parameters, r_par.data(), only_first));
  EXPECT_EQ(ja_ref, ja_par);
}

TEST(ParallelNumericDiffCost, ForwardDifferencesEqualCeresOnOneAndTwoThreads) {
  expectSameJacobianAsCeres<ceres::FORWARD>(1);
  expectSameJacobianAsCeres<ceres::FORWARD>(2);
}

TEST(ParallelNumericDiffCost, CentralDifferencesEqualCeres) { expectSameJacobianAsCeres<ceres::CENTRAL>(2); }

TEST(ParallelNumericDiffCost, AFailedEvaluationFailsTheJacobian) {
  struct FailsAboveOne {
    bool operator()(double const* const* x, double* out) const {
      out[0] = x[0][0];
      return x[0][0] <= 1.0;
    }
  };
  ceres::NumericDiffOptions options;
  ParallelNumericDiffCost<FailsAboveOne, ceres::FORWARD> cost(FailsAboveOne{}, options, 2);
  cost.AddParameterBlock(1);
  cost.SetNumResiduals(1);
  const double x[1] = {1.0};  // the forward step crosses 1
  const double* parameters[1] = {x};
  double residual = 0.0, jacobian = 0.0;
  double* jacobians[1] = {&jacobian};
  EXPECT_TRUE(cost.Evaluate(parameters, &residual, nullptr));
  EXPECT_FALSE(cost.Evaluate(parameters, &residual, jacobians));
}

}  // namespace
}  // namespace die_cushion_ident
