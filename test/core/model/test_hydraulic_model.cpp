#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "die_cushion_ident/core/model/hydraulic_model.h"

using namespace die_cushion_ident;

namespace {
HydraulicModel fullModel() {
  return HydraulicModel::fromNames(CylinderGeometry{},
                                   {"leakage", "entrained_air", "valve_overlap", "tank_pressure"},
                                   {"relief=max(p - 150e5, 0)"});
}

ParameterVector truthFor(const HydraulicModel& m) {
  ParameterVector p(m.parameterCount());
  p << 1.3e9, 6e-6, 3e-3, 1.5e-11, 3e-4, 0.03, 6e5, 2e-12;
  return p;
}
}  // namespace

TEST(HydraulicModel, RejectsInvalidGeometryAndDuplicateEffects) {
  CylinderGeometry g;
  g.piston_area = 0.0;
  EXPECT_THROW(HydraulicModel::fromNames(g, {}), std::invalid_argument);
  g = {};
  g.supply_pressure = std::nan("");
  EXPECT_THROW(HydraulicModel::fromNames(g, {}), std::invalid_argument);
  EXPECT_THROW(HydraulicModel::fromNames({}, {"leakage", "leakage"}), std::invalid_argument);
}

TEST(HydraulicModel, ParametersHavePhysicalNamesAndUnits) {
  const auto m = fullModel();
  ASSERT_EQ(m.parameterCount(), 8);
  EXPECT_EQ(m.parameterInfos()[0].name, "bulk_modulus");
  EXPECT_EQ(m.parameterInfos()[0].unit, "Pa");
  EXPECT_EQ(m.parameterInfos()[1].name, "valve_flow_gain");
  EXPECT_EQ(m.parameterInfos()[2].name, "dead_volume");
  EXPECT_EQ(m.parameterInfos()[2].unit, "m^3");
  EXPECT_EQ(m.parameterInfos()[7].name, "relief_theta");
}

TEST(HydraulicModel, CoefficientsAndPhysicalParametersRoundTripWithAConsistentJacobian) {
  const auto m = fullModel();
  const ParameterVector truth = truthFor(m);
  const ParameterVector c = m.coefficientsFromPhysical(truth);
  CovarianceMatrix J;
  const ParameterVector back = m.physicalFromCoefficients(c, &J);
  for (int i = 0; i < m.parameterCount(); ++i) EXPECT_NEAR(back(i) / truth(i), 1.0, 1e-12) << i;
  for (int j = 0; j < m.parameterCount(); ++j) {
    ParameterVector c2 = c;
    const double h = 1e-6 * std::abs(c(j));
    c2(j) += h;
    const ParameterVector numeric = (m.physicalFromCoefficients(c2) - back) / h;
    for (int i = 0; i < m.parameterCount(); ++i) {
      EXPECT_NEAR(J(i, j), numeric(i), 1e-4 * std::abs(numeric(i)) + 1e-12 * std::abs(J(i, i)))
          << i << "," << j;
    }
  }
}

TEST(HydraulicModel, RegressionColumnsReproduceTheVolumeBalanceAtTheTruth) {
  // A v = sum_j c_j (a_j dp/dt + g_j) must hold exactly wherever dp/dt comes from the simulation form.
  const auto m = fullModel();
  const ParameterVector truth = truthFor(m);
  const ParameterVector c = m.coefficientsFromPhysical(truth);
  std::mt19937_64 rng(9);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int k = 0; k < 1000; ++k) {
    HydraulicSignals s;
    s.p = 2e5 + 200e5 * u(rng);
    s.x = 0.2 * u(rng);
    s.v = -0.3 + 0.6 * u(rng);
    s.y = -1.0 + 2.0 * u(rng);
    s.V = m.chamberVolume(s.x, truth(HydraulicModel::kDeadVolume));
    if (s.y > 0 && s.p < truth(6) + 1e5) continue;  // drain edge below tank pressure: model excluded there
    s.dp = m.pressureRate(s, truth);
    double a[kMaxParameters], g[kMaxParameters];
    m.regressionColumns(s, truth, a, g);
    double rhs = 0.0;
    for (int j = 0; j < m.parameterCount(); ++j) rhs += c(j) * (a[j] * s.dp + g[j]);
    const double lhs = m.geometry().piston_area * s.v;
    EXPECT_NEAR(rhs, lhs, 1e-9 * (std::abs(lhs) + 1e-3)) << "sample " << k;
  }
}

TEST(HydraulicModel, ValveFlowFollowsTheContractsOrifice) {
  const auto m = HydraulicModel::fromNames({}, {});
  ParameterVector p(3);
  p << 1.2e9, 6e-6, 3e-3;
  HydraulicSignals s;
  s.p = 100e5;
  s.y = 0.5;
  EXPECT_NEAR(m.valveFlow(s, p), 6e-6 * 0.5 * std::sqrt(100e5), 1e-15) << "y > 0 drains to tank";
  s.y = -0.5;
  EXPECT_NEAR(m.valveFlow(s, p), -6e-6 * 0.5 * std::sqrt(120e5 - 100e5), 1e-15) << "y < 0 feeds from supply";
  s.p = 130e5;
  EXPECT_DOUBLE_EQ(m.valveFlow(s, p), 0.0) << "no feed above supply pressure";
  s.x = 0.1;
  EXPECT_NEAR(m.capacitance(s, p), (3e-3 + 0.05 * 0.15) / 1.2e9, 1e-20);
}
