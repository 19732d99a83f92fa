// The press classes the simulator records (PressClass): each a different plant, not the paper's press with
// other numbers: a crank-driven mechanical press, a small stiff chamber, a large soft one. Their programs
// must be physically consistent and their controllers must hold the pressure, or a recording of them would
// test the simulator instead of the analysis.
#include <gtest/gtest.h>

#include <cmath>

#include "die_cushion_ident/core/simulation/press_class.h"

using namespace die_cushion_ident;

TEST(PressClass, NamesParseBack) {
  for (PressClass p : allPressClasses()) {
    PressClass parsed;
    ASSERT_TRUE(parsePressClass(pressClassName(p), &parsed));
    EXPECT_EQ(parsed, p);
  }
  PressClass unused;
  EXPECT_FALSE(parsePressClass("hydraulic", &unused));
  EXPECT_EQ(allPressClasses().size(), static_cast<std::size_t>(kPressClassCount));
}

// The slider-crank: the cushion meets the ram at its drawing speed, its speed falls with the crank angle to
// zero at bottom dead centre, the position is continuous, the velocity its derivative, and it reaches the
// drawing depth.
TEST(PressClass, TheCrankDrawsToTheDepthWithTheVelocityAsThePositionsDerivative) {
  const SimulatorConfig plant = pressClassPlant(PressClass::kFastMechanical);
  ASSERT_EQ(plant.cycle.motion, RamMotion::kCrank);
  const PressCycleProgram program(plant.cycle);
  double deepest = 0.0, fastest = 0.0, previous_x = 0.0;
  for (double t = 0.0; t < program.cycleDuration(); t += 1e-4) {
    const auto point = program.at(t);
    const auto later = program.at(t + 1e-7);
    if (later.cycle == point.cycle) {
      EXPECT_NEAR((later.x - point.x) / 1e-7, point.v, 2e-3 + 1e-3 * std::abs(point.v)) << "at t = " << t;
    }
    EXPECT_LE(std::abs(point.x - previous_x), 0.7 * 1e-4) << "no jump in position at t = " << t;
    previous_x = point.x;
    deepest = std::max(deepest, point.x);
    if (point.phase == StrokePhase::kDrawing) fastest = std::max(fastest, point.v);
  }
  EXPECT_NEAR(deepest, plant.cycle.drawing_depth, 1e-9);
  EXPECT_NEAR(fastest, plant.cycle.drawing_speed, 1e-3) << "the crank's speed when it meets the cushion";
  // At bottom dead centre the speed has fallen to zero.
  double at_bottom = 1.0;
  for (double t = 0.0; t < program.cycleDuration(); t += 1e-4) {
    const auto point = program.at(t);
    if (point.phase == StrokePhase::kBottomHold) at_bottom = std::min(at_bottom, std::abs(point.v));
  }
  EXPECT_NEAR(at_bottom, 0.0, 1e-12);
}

// Every class's press, nominal and drawn, under its own controller: the drawing pressure follows the
// set-point (a controller that could not hold it would make the recording a test of the controller).
TEST(PressClass, EachClassesControllerHoldsTheDrawingPressure) {
  for (PressClass p : allPressClasses()) {
    for (std::uint64_t variation : {0, 3, 7}) {
      SCOPED_TRACE(std::string(pressClassName(p)) + " variation " + std::to_string(variation));
      const SimulatorConfig plant = pressClassPlant(p, variation);
      const double error = drawingPressureErrorRms(plant, nullptr, true, 2);
      EXPECT_LT(error, 0.1 * plant.cycle.drawing_start_pressure) << "Pa rms while drawing";
    }
  }
}

// The classes differ where it matters: the chamber's stiffness, the speed, the valve.
TEST(PressClass, TheClassesSpanTheTimeScalesTheAnalysisMustResolve) {
  const auto time_constant = [](const SimulatorConfig& c) {
    // C / (dQ/dp) at mid-stroke while drawing: 2 p V / (K' A v).
    const double p = 0.5 * (c.cycle.drawing_start_pressure + c.cycle.drawing_end_pressure);
    const double volume = c.parameters.at("dead_volume") +
                          c.geometry.piston_area * (c.geometry.stroke_length - 0.5 * c.cycle.drawing_depth);
    return 2.0 * p * volume / (c.parameters.at("bulk_modulus") * c.geometry.piston_area * c.cycle.drawing_speed);
  };
  const SimulatorConfig slow = pressClassPlant(PressClass::kSlowHydraulic);
  const SimulatorConfig fast = pressClassPlant(PressClass::kFastMechanical);
  const SimulatorConfig small = pressClassPlant(PressClass::kSmallStiff);
  const SimulatorConfig large = pressClassPlant(PressClass::kLargeSoft);
  EXPECT_LT(time_constant(fast), 0.5 * time_constant(slow));
  EXPECT_LT(time_constant(small), time_constant(slow));
  EXPECT_GT(time_constant(large), time_constant(slow));
  EXPECT_LE(fast.cycle.impact_time, 0.005);
  EXPECT_GE(fast.cycle.drawing_speed, 0.4);
  EXPECT_GT(fast.valve.natural_frequency, slow.valve.natural_frequency);
  EXPECT_LT(large.valve.natural_frequency, slow.valve.natural_frequency);
}

// The paper's press at variation 0 is the simulator's default plant, as every earlier test knew it; another
// variation is another press of the same kind.
TEST(PressClass, VariationZeroIsTheNominalPressAndOthersDiffer) {
  const SimulatorConfig nominal = pressClassPlant(PressClass::kSlowHydraulic);
  EXPECT_DOUBLE_EQ(nominal.parameters.at("bulk_modulus"), defaultTrueParameters().at("bulk_modulus"));
  EXPECT_DOUBLE_EQ(nominal.controller.proportional_gain, PressureControllerConfig().proportional_gain);
  const SimulatorConfig other = pressClassPlant(PressClass::kSlowHydraulic, 5);
  EXPECT_NE(other.parameters.at("bulk_modulus"), nominal.parameters.at("bulk_modulus"));
  EXPECT_NE(pressClassPlant(PressClass::kFastMechanical, 5).valve.natural_frequency,
            pressClassPlant(PressClass::kFastMechanical, 6).valve.natural_frequency);
}

// A library effect hidden in a class's plant is sized to the plant (a worn seal passes a share of the drawing
// flow), so that it is as visible on a large press as on a small one.
TEST(PressClass, HiddenEffectsAreSizedToThePlant) {
  const SimulatorConfig small = pressClassPlant(PressClass::kSmallStiff, 0, {"leakage", "entrained_air"});
  const SimulatorConfig large = pressClassPlant(PressClass::kLargeSoft, 0, {"leakage", "entrained_air"});
  const auto leak_share = [](const SimulatorConfig& c) {
    const double p = 0.5 * (c.cycle.drawing_start_pressure + c.cycle.drawing_end_pressure);
    return c.parameters.at("leakage_conductance") * p / (c.geometry.piston_area * c.cycle.drawing_speed);
  };
  EXPECT_NEAR(leak_share(small), 0.015, 1e-9);
  EXPECT_NEAR(leak_share(large), 0.015, 1e-9);
  EXPECT_NEAR(large.parameters.at("air_volume") / (large.geometry.piston_area * large.geometry.stroke_length), 0.024, 1e-12);
}
