// Issue 13 (paper, §5.1): the filter-width study on the simulator reproduces the paper's findings for the
// filtered-derivative form (the bias changes with the widths; the std falls as the moving average widens).
// The integral form keeps flow gain within 1 % and bulk modulus and dead volume within 2 % at every width
// (before the spool-noise correction at the port's kink, doc/equations.md, the dead volume was biased +1 to
// +5 % here, growing with the widths), far below the derivative form's 12-61 %. A reduced grid for the
// suite; study_settings runs the full one.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "die_cushion_ident/core/settings/settings_study.h"
#include "simulation_fixtures.h"

namespace die_cushion_ident {
namespace {

const SettingsStudyPoint& find(const std::vector<SettingsStudyPoint>& points, RegressionForm form, int b, int d,
                               const std::string& parameter) {
  for (const auto& p : points) {
    if (p.form == form && p.moving_average_width == b && p.derivative_width == d && p.parameter == parameter &&
        p.sample_period == 0.002) {
      return p;
    }
  }
  throw std::runtime_error("no such point");
}

TEST(SettingsStudy, ReproducesThePapersFindingsAndMeasuresTheIntegralFormsBias) {
  const SimulatorConfig plant = testing::randomPlant(61);
  const IdentificationConfig base = testing::configFor(plant, {});
  SettingsStudyOptions options;
  options.moving_average_widths = {1, 31};
  options.derivative_widths = {5, 25};
  options.sample_periods = {0.002};
  options.seeds = 8;
  options.cycles = 6;
  const auto points = runSettingsStudy(plant, base, options);
  for (const auto& p : points) {
    std::printf("%-10s b %2d d %2d %-16s bias %+7.2f %%  std %6.2f %%\n", regressionFormName(p.form),
                p.moving_average_width, p.derivative_width, p.parameter.c_str(), 100 * p.bias, 100 * p.std);
    if (p.form == RegressionForm::kIntegral) {
      const double bound = p.parameter == "valve_flow_gain" ? 0.01 : 0.02;
      EXPECT_LT(std::abs(p.bias), bound) << p.parameter << " b " << p.moving_average_width << " d " << p.derivative_width;
      const auto& paper = find(points, RegressionForm::kDerivative, p.moving_average_width, p.derivative_width, p.parameter);
      if (p.parameter == "dead_volume") {
        EXPECT_LT(std::abs(p.bias), 0.25 * std::abs(paper.bias)) << p.parameter;
      }
    }
  }
  const auto derivative = RegressionForm::kDerivative;
  // The bias of the paper's form moves with the widths by more than the seeds' scatter.
  const auto& narrow = find(points, derivative, 1, 5, "bulk_modulus");
  const auto& wide = find(points, derivative, 31, 25, "bulk_modulus");
  EXPECT_GT(std::abs(wide.bias - narrow.bias), 2.0 * (narrow.std + wide.std) / std::sqrt(options.seeds));
  // Its std falls as the moving average widens (at the same derivative width).
  EXPECT_LT(find(points, derivative, 31, 5, "dead_volume").std, find(points, derivative, 1, 5, "dead_volume").std);
  const std::string advice = recommendSettings(points, base);
  EXPECT_NE(advice.find("Integral form"), std::string::npos) << advice;
  EXPECT_NE(advice.find("set moving_average_width"), std::string::npos) << advice;
}

}  // namespace
}  // namespace die_cushion_ident
