#include <gtest/gtest.h>

#include <cmath>

#include "die_cushion_ident/core/model/effect_library.h"
#include "die_cushion_ident/core/model/effects/custom_flow_effect.h"
#include "die_cushion_ident/core/model/hydraulic_model.h"
#include "die_cushion_ident/core/model/oil_temperature_law.h"

using namespace die_cushion_ident;

TEST(EffectLibrary, NamesAreTheContractsNames) {
  const std::vector<std::string> expected{"leakage", "entrained_air", "valve_overlap", "tank_pressure",
                                          "oil_temperature"};
  EXPECT_EQ(libraryEffectNames(), expected);
  for (const auto& name : expected) {
    const auto effect = makeLibraryEffect(name);
    EXPECT_EQ(effect->name(), name);
    EXPECT_FALSE(effect->explanation().empty());
    EXPECT_FALSE(effect->parameter().unit.empty());
  }
  EXPECT_EQ(makeLibraryEffect("leakage")->parameter().name, "leakage_conductance");
  EXPECT_EQ(makeLibraryEffect("entrained_air")->parameter().name, "air_volume");
  EXPECT_EQ(makeLibraryEffect("valve_overlap")->parameter().name, "valve_overlap");
  EXPECT_EQ(makeLibraryEffect("tank_pressure")->parameter().name, "tank_pressure");
  EXPECT_EQ(makeLibraryEffect("oil_temperature")->parameter().name, "bulk_modulus_temperature_coefficient");
  EXPECT_EQ(makeLibraryEffect("oil_temperature")->parameter().unit, "1/K");
  // Only the oil's temperature reads the optional topic: the ranking offers it only where a recording has it.
  for (const auto& name : expected) {
    EXPECT_EQ(makeLibraryEffect(name)->needsOilTemperature(), name == "oil_temperature") << name;
  }
}

TEST(EffectLibrary, UnknownNameListsTheKnownOnes) {
  try {
    makeLibraryEffect("leakge");
    FAIL() << "a typo must not pass silently";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("leakage"), std::string::npos);
  }
}

TEST(Effects, LeakageIsLaminar) {
  HydraulicSignals s;
  s.p = 100e5;
  EXPECT_DOUBLE_EQ(makeLibraryEffect("leakage")->outflowPerUnit(s), 100e5);
}

TEST(Effects, EntrainedAirIsIsothermal) {
  const auto air = makeLibraryEffect("entrained_air");
  HydraulicSignals s;
  s.p = 0.0;
  EXPECT_NEAR(air->capacitancePerUnit(s), 1.0 / kAtmosphericPressure, 1e-18) << "at 0 bar gauge: 1/p_atm";
  s.p = 100e5;
  const double abs_p = 100e5 + kAtmosphericPressure;
  EXPECT_NEAR(air->capacitancePerUnit(s), kAtmosphericPressure / (abs_p * abs_p), 1e-24);
  s.p = -2e5;  // below vacuum (cavitation in the data): finite, not a division by zero
  EXPECT_TRUE(std::isfinite(air->capacitancePerUnit(s)));
}

TEST(Effects, ValveOverlapIsADeadBandWithItsSlope) {
  const auto overlap = makeLibraryEffect("valve_overlap");
  ValvePort port{0.5, 1e7}, d;
  overlap->shapeValvePort(0.5, 0.03, port, d);
  EXPECT_DOUBLE_EQ(port.opening, 0.47);
  EXPECT_DOUBLE_EQ(d.opening, -1.0);
  port = {-0.5, 1e7};
  overlap->shapeValvePort(-0.5, 0.03, port, d);
  EXPECT_DOUBLE_EQ(port.opening, -0.47);
  EXPECT_DOUBLE_EQ(d.opening, 1.0);
  port = {0.02, 1e7};
  overlap->shapeValvePort(0.02, 0.03, port, d);
  EXPECT_DOUBLE_EQ(port.opening, 0.0) << "inside the dead band no oil flows";
  EXPECT_DOUBLE_EQ(d.opening, 0.0);
}

TEST(Effects, TankPressureActsOnTheDrainEdgeOnly) {
  const auto tank = makeLibraryEffect("tank_pressure");
  ValvePort port{0.5, 50e5}, d;
  tank->shapeValvePort(0.5, 6e5, port, d);
  EXPECT_DOUBLE_EQ(port.pressure_drop, 44e5);
  EXPECT_DOUBLE_EQ(d.pressure_drop, -1.0);
  port = {-0.5, 70e5};
  d = {};
  tank->shapeValvePort(-0.5, 6e5, port, d);
  EXPECT_DOUBLE_EQ(port.pressure_drop, 70e5) << "the supply edge does not see the tank";
  EXPECT_DOUBLE_EQ(d.pressure_drop, 0.0);
}

TEST(CustomFlowEffect, EvaluatesTheExpressionOfTheNamedSignals) {
  CustomFlowEffect relief("relief_valve", "max(p - 180e5, 0) * (v >= 0)");
  HydraulicSignals s;
  s.p = 190e5;
  s.v = 0.1;
  EXPECT_DOUBLE_EQ(relief.outflowPerUnit(s), 10e5);
  s.p = 170e5;
  EXPECT_DOUBLE_EQ(relief.outflowPerUnit(s), 0.0);
  EXPECT_EQ(relief.name(), "relief_valve");
  EXPECT_EQ(relief.parameter().name, "relief_valve_theta");
  CustomFlowEffect all("all_signals", "p + dp + x + v + u + y + V + t");
  HydraulicSignals a{1, 2, 3, 4, 5, 6, 7, 8};
  // Affine in dp: the dp part is a capacitance (1 per unit), the flow is the rest.
  EXPECT_DOUBLE_EQ(all.outflowPerUnit(a) + all.capacitancePerUnit(a) * a.dp, 36.0);
  EXPECT_DOUBLE_EQ(all.capacitancePerUnit(a), 1.0);
}

// A term in dp means the same in the fit, the free run and the simulator: a compliance that the model's
// pressure rate includes (issue 12; before, the rate was evaluated with dp = 0 and the term vanished).
TEST(CustomFlowEffect, ATermAffineInThePressureRateIsACapacitance) {
  const CylinderGeometry geometry;
  const HydraulicModel plain = HydraulicModel::fromNames(geometry, {});
  const HydraulicModel with = HydraulicModel::fromNames(geometry, {}, {"accumulator=dp*(p>50e5)"});
  ParameterVector theta(with.parameterCount());
  theta.head(3) = plain.nominalParameters();
  theta(3) = 2e-12;  // [m^3/Pa] above 50 bar
  HydraulicSignals s;
  s.p = 100e5;
  s.v = 0.1;
  s.y = 0.3;
  s.x = 0.1;
  s.V = with.chamberVolume(s.x, theta(HydraulicModel::kDeadVolume));
  const double c0 = plain.capacitance(s, plain.nominalParameters());
  EXPECT_NEAR(with.capacitance(s, theta), c0 + 2e-12, 1e-24);
  EXPECT_NEAR(with.pressureRate(s, theta), plain.pressureRate(s, plain.nominalParameters()) * c0 / (c0 + 2e-12),
              1e-9 * std::abs(plain.pressureRate(s, plain.nominalParameters())));
  EXPECT_FALSE(with.effect(0).outflowDependsOnPressureRate());
  s.p = 20e5;  // below the precharge: no extra compliance
  EXPECT_NEAR(with.capacitance(s, theta), plain.capacitance(s, plain.nominalParameters()), 1e-24);
}

TEST(CustomFlowEffect, ATermNonlinearInThePressureRateIsSolvedFor) {
  const CylinderGeometry geometry;
  const HydraulicModel model = HydraulicModel::fromNames(geometry, {}, {"damper=abs(dp)"});
  ParameterVector theta(model.parameterCount());
  theta.head(3) = HydraulicModel::fromNames(geometry, {}).nominalParameters();
  theta(3) = 1e-12;
  EXPECT_TRUE(model.effect(0).outflowDependsOnPressureRate());
  HydraulicSignals s;
  s.p = 100e5;
  s.v = 0.2;
  s.y = 0.1;
  s.x = 0.1;
  const double r = model.pressureRate(s, theta);
  ASSERT_TRUE(std::isfinite(r));
  s.dp = r;  // the solved rate balances the volume flows
  const double balance = model.capacitance(s, theta) * r + model.valveFlow(s, theta) +
                         model.extraOutflow(s, theta) - geometry.piston_area * s.v;
  EXPECT_NEAR(balance, 0.0, 1e-12 * geometry.piston_area * std::abs(s.v));
}

TEST(CustomFlowEffect, ClonesAreIndependent) {
  CustomFlowEffect original("q", "2 * p");
  const auto copy = original.clone();
  HydraulicSignals s;
  s.p = 3.0;
  EXPECT_DOUBLE_EQ(copy->outflowPerUnit(s), 6.0);
  EXPECT_DOUBLE_EQ(original.outflowPerUnit(s), 6.0);
}

TEST(CustomFlowEffect, BadInputGivesAClearError) {
  EXPECT_THROW(CustomFlowEffect("relief", "max(p - , 0)"), std::invalid_argument);
  EXPECT_THROW(CustomFlowEffect("relief", "pressure * 2"), std::invalid_argument) << "unknown signal";
  EXPECT_THROW(CustomFlowEffect("leakage", "p"), std::invalid_argument) << "library names are taken";
  EXPECT_THROW(CustomFlowEffect("2bad", "p"), std::invalid_argument);
  EXPECT_THROW(CustomFlowEffect("", "p"), std::invalid_argument);
  try {
    CustomFlowEffect("relief", "pressure * 2");
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("pressure"), std::string::npos) << e.what();
  }
}

TEST(CustomFlowEffect, ParsesNameEqualsExpression) {
  const auto e = parseCustomEffect("relief=max(p-180e5,0)");
  EXPECT_EQ(e->name(), "relief");
  EXPECT_EQ(e->expression(), "max(p-180e5,0)");
  EXPECT_THROW(parseCustomEffect("relief"), std::invalid_argument);
  EXPECT_THROW(parseCustomEffect("=p"), std::invalid_argument);
  EXPECT_THROW(parseCustomEffect("relief="), std::invalid_argument);
}

TEST(CustomFlowEffect, NonFiniteValuesDoNotLeakIntoTheEstimator) {
  // Finite everywhere the expression is probed, infinite at x = 0.05 m: the rare point reads as no flow.
  CustomFlowEffect e("inverse", "1 / (x - 0.05)");
  HydraulicSignals s;
  s.x = 0.05;
  EXPECT_DOUBLE_EQ(e.outflowPerUnit(s), 0.0);
}

// Terms that would be reported as "fitted" at their initial value, or wreck the estimator, are refused at
// once with the point of the operating range that shows the problem (hostile-input review).
TEST(CustomFlowEffect, TermsThatCannotBeAFlowAreRefusedWithTheReason) {
  const struct {
    const char* expression;
    const char* reason;
  } cases[] = {{"1/(p-p)", "evaluates to"},         {"log(0)", "evaluates to"},
               {"exp(p)", "evaluates to inf"},       {"0", "0 everywhere"},
               {"(p>100e5)?1e300:0", "evaluates to 1e+300"}, {"1/x", "evaluates to inf at p = 0 Pa"}};
  for (const auto& c : cases) {
    try {
      CustomFlowEffect e("bad", c.expression);
      ADD_FAILURE() << c.expression << " was accepted";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(c.reason), std::string::npos) << c.expression << ": " << e.what();
    }
  }
  EXPECT_NO_THROW(CustomFlowEffect("constant", "1")) << "a constant flow is a model (q0), not a fault";
  EXPECT_NO_THROW(CustomFlowEffect("compressibility", "p*dp"));
}

// The oil's temperature (issue 46): K'(T) = K'(T0) (1 + alpha (T - T0)) and a laminar leakage
// G(T) = G(T0) exp(beta (T - T0)), T in degC; without a temperature nothing changes.
TEST(OilTemperature, TheBulkModulusAndALaminarLeakageFollowTheOilsLaw) {
  OilTemperatureLaw law;  // reference 40 degC, alpha -0.004 /K, beta 0.045 /K
  const HydraulicModel model =
      HydraulicModel::fromNames(CylinderGeometry(), {"leakage", "oil_temperature"}, {}, law);
  ASSERT_EQ(model.oilStateParameter(), HydraulicModel::kFirstEffect + 1);
  ParameterVector theta(5);
  theta << 1.2e9, 6e-6, 3e-3, 1.5e-11, -0.004;
  HydraulicSignals s;
  s.p = 100e5;
  s.x = 0.1;
  s.V = model.chamberVolume(s.x, theta(2));
  const double cold = model.capacitance(s, theta), cold_leak = model.extraOutflow(s, theta);
  EXPECT_DOUBLE_EQ(cold, s.V / 1.2e9) << "no temperature measured: the model holds at its origin";
  EXPECT_DOUBLE_EQ(cold_leak, 1.5e-11 * 100e5);
  s.T = 60.0;  // 20 K above the origin
  EXPECT_NEAR(model.capacitance(s, theta), s.V / (1.2e9 * (1.0 - 0.004 * 20.0)), 1e-9 * cold)
      << "the bulk modulus 8 % lower at 20 K warmer";
  // Arrhenius with the slope 4.5 %/K at 40 degC: exp(0.045 313.15^2 (1/313.15 - 1/333.15)) = 2.33.
  EXPECT_NEAR(model.extraOutflow(s, theta),
              cold_leak * std::exp(0.045 * 313.15 * 313.15 * (1 / 313.15 - 1 / 333.15)), 1e-12 * cold_leak)
      << "the leakage 2.33-fold at 20 K warmer (the viscosity's Arrhenius law)";
  EXPECT_NEAR(std::log(law.laminarFlowRatio(39.99, 40.01)) / 0.02, 0.045, 1e-6)
      << "its slope at 40 degC is beta";
  s.T = 40.0;
  EXPECT_NEAR(model.capacitance(s, theta), cold, 1e-12 * cold) << "at the origin the factors are 1";
  // The same plant without the effect ignores the temperature.
  const HydraulicModel plain = HydraulicModel::fromNames(CylinderGeometry(), {"leakage"}, {}, law);
  s.T = 60.0;
  EXPECT_DOUBLE_EQ(plain.capacitance(s, theta.head(4)), s.V / 1.2e9);
  EXPECT_DOUBLE_EQ(plain.extraOutflow(s, theta.head(4)), cold_leak);
}

// The regression columns reproduce the balance exactly at the linearisation point, the coefficient alpha/K'
// maps back to alpha with its Jacobian, and away from the point the error is second order in alpha's.
TEST(OilTemperature, RegressionColumnsAreExactAtTheirLinearisationPoint) {
  OilTemperatureLaw law;
  law.temperature_origin = 47.0;
  const HydraulicModel model =
      HydraulicModel::fromNames(CylinderGeometry(), {"leakage", "oil_temperature"}, {}, law);
  ParameterVector theta(5);
  theta << 1.1e9, 6e-6, 2.5e-3, 1.0e-11, -0.0045;
  const ParameterVector c = model.coefficientsFromPhysical(theta);
  EXPECT_NEAR(c(4), -0.0045 / 1.1e9, 1e-25) << "the effect's coefficient is alpha / K'";
  CovarianceMatrix J;
  const ParameterVector back = model.physicalFromCoefficients(c, &J);
  for (int i = 0; i < 5; ++i) EXPECT_NEAR(back(i), theta(i), 1e-12 * std::abs(theta(i)) + 1e-30);
  // The Jacobian of alpha against a finite difference in 1/K' and alpha/K'.
  for (int j : {0, 4}) {
    ParameterVector moved = c;
    moved(j) *= 1.0 + 1e-6;
    const double numeric = (model.physicalFromCoefficients(moved)(4) - theta(4)) / (moved(j) - c(j));
    EXPECT_NEAR(J(4, j), numeric, 1e-4 * std::abs(numeric)) << "d alpha / d c_" << j;
  }
  const auto balance = [&](const ParameterVector& point, double T) {
    HydraulicSignals s;
    s.p = 80e5;
    s.x = 0.07;
    s.y = 0.3;
    s.T = T;
    s.V = model.chamberVolume(s.x, point(2));
    double a[kMaxParameters], g[kMaxParameters];
    model.regressionColumns(s, point, a, g);
    const double dp = 3e7;  // [Pa/s]
    double flow = 0.0;
    for (int j = 0; j < 5; ++j) flow += c(j) * (a[j] * dp + g[j]);
    return flow -
           (model.capacitance(s, theta) * dp + model.valveFlow(s, theta) + model.extraOutflow(s, theta));
  };
  const double scale = model.capacitance(HydraulicSignals{0, 80e5, 0, 0.07, 0, 0, 0.3, 0.0032}, theta) * 3e7;
  for (double T : {25.0, 47.0, 60.0}) {
    EXPECT_NEAR(balance(theta, T), 0.0, 1e-12 * scale) << "at the fixed point, T = " << T << " degC";
  }
  ParameterVector off = theta;
  off(4) = -0.0035;  // 0.1 %/K off
  const double first = std::abs(balance(off, 60.0));
  off(4) = -0.0040;  // half as far
  const double second = std::abs(balance(off, 60.0));
  EXPECT_GT(first, 0.0);
  EXPECT_NEAR(second / first, 0.25, 0.05)
      << "second order in alpha's error: half as far, a quarter the error";
}

// Laminar leakage only: a custom flow keeps its own law, and the oil's law stays finite for any alpha an
// early estimate may pass through.
TEST(OilTemperature, OnlyLaminarFlowsFollowTheViscosityAndTheLawStaysFinite) {
  OilTemperatureLaw law;
  double factor = 0.0, slope = 0.0;
  law.compressibility(140.0, -0.02, &factor, &slope);  // 1 + alpha dT = -1: held
  EXPECT_TRUE(std::isfinite(factor) && factor > 0.0) << factor;
  law.compressibility(std::nan(""), -0.004, &factor, &slope);
  EXPECT_EQ(factor, 1.0);
  EXPECT_EQ(slope, 0.0);
  EXPECT_EQ(law.laminarFlowFactor(std::nan("")), 1.0);
  const HydraulicModel model =
      HydraulicModel::fromNames(CylinderGeometry(), {"oil_temperature"}, {"drain=p"}, law);
  ParameterVector theta(5);
  theta << 1.2e9, 6e-6, 3e-3, -0.004, 1e-11;
  HydraulicSignals s;
  s.p = 100e5;
  s.T = 60.0;
  EXPECT_DOUBLE_EQ(model.extraOutflow(s, theta), 1e-11 * 100e5) << "a custom flow's law is its own";
  EXPECT_THROW(HydraulicModel::fromNames(CylinderGeometry(), {"oil_temperature", "oil_temperature"}),
               std::invalid_argument);
}
