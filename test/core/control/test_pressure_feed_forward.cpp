// Issue 13 (paper, Fig. 19): the identified model as a feed-forward next to the PI pressure controller.
// On random simulated plants the PI controller alone, PI plus the identified model's feed-forward, and PI
// plus a deliberately wrong model's feed-forward track the drawing pressure; the identified one at least
// three times better than PI alone, and better than the wrong ones.
#include <gtest/gtest.h>

#include <climits>
#include <cmath>
#include <cstdio>
#include <memory>
#include <random>

#include "die_cushion_ident/core/adequacy/held_out_test.h"
#include "die_cushion_ident/core/control/pressure_feed_forward.h"
#include "simulation_fixtures.h"

namespace die_cushion_ident {
namespace {

double drawingTrackingError(const SimulatorConfig& plant,
                            std::shared_ptr<const PressureFeedForward> feed_forward,
                            bool nominal_velocity_feed_forward = false) {
  return drawingPressureErrorRms(plant, std::move(feed_forward), nominal_velocity_feed_forward, 3);
}

TEST(PressureFeedForward, TheIdentifiedModelTracksTheDrawingPressureThreeTimesBetterThanPiAlone) {
  const std::vector<std::vector<std::string>> models = {{}, {"leakage"}, {"entrained_air"}};
  for (std::uint64_t seed : {41, 42, 43}) {
    const auto& effects = models[seed % models.size()];
    SCOPED_TRACE("seed " + std::to_string(seed));
    const SimulatorConfig plant = testing::randomPlant(seed, effects);
    // Identified from a recording made with the press's own controller.
    const testing::Recording recording = testing::record(plant, 6);
    const std::vector<GridSample>& grid = recording.grid;
    const StrokeSegmentation& strokes = recording.strokes;
    const IdentificationConfig config = testing::configFor(plant, effects);
    const HydraulicEstimate estimate = fitOnCycles(grid, strokes, config, INT_MIN, INT_MAX);
    const HydraulicModel model = HydraulicModel::fromNames(config.geometry, effects);
    ParameterVector theta(model.parameterCount());
    for (int i = 0; i < model.parameterCount(); ++i) theta(i) = estimate.parameters[i].value;
    // The valve model as a sweep identifies it (README: natural frequency within 1 %, dead time 0.1 ms).
    const auto with = [&](const ParameterVector& parameters) {
      return std::make_shared<const PressureFeedForward>(model, parameters, plant.valve,
                                                         plant.controller.max_voltage);
    };
    const double pi_alone = drawingTrackingError(plant, nullptr);
    const double press_default = drawingTrackingError(plant, nullptr, true);
    const double identified = drawingTrackingError(plant, with(theta));
    ParameterVector soft = theta, weak = theta;
    soft(HydraulicModel::kBulkModulus) *= 1.5;
    weak(HydraulicModel::kValveFlowGain) *= 1.5;
    const double wrong_bulk_modulus = drawingTrackingError(plant, with(soft));
    const double wrong_flow_gain = drawingTrackingError(plant, with(weak));
    std::printf(
        "seed %llu: drawing pressure error rms: PI alone %.2f bar, PI + nominal velocity feed-forward "
        "%.2f bar, PI + identified model %.2f bar (%.1fx better than PI alone); bulk modulus +50 %% "
        "%.2f bar, flow gain +50 %% %.2f bar\n",
        static_cast<unsigned long long>(seed), pi_alone * 1e-5, press_default * 1e-5, identified * 1e-5,
        pi_alone / identified, wrong_bulk_modulus * 1e-5, wrong_flow_gain * 1e-5);
    EXPECT_GE(pi_alone, 3.0 * identified);
    EXPECT_GT(wrong_bulk_modulus, identified);
    EXPECT_GT(wrong_flow_gain, identified);
  }
}

TEST(PressureFeedForward, NeverCommandsOutsideTheValveRangeAndIgnoresNonFiniteInput) {
  const SimulatorConfig plant = testing::randomPlant(7);
  const HydraulicModel model = HydraulicModel::fromNames(plant.geometry, {});
  const PressureFeedForward ff(model, model.nominalParameters(), plant.valve, 4.0);
  for (double p : {-1e7, 0.0, 50e5, 150e5, 1e9}) {
    for (double dp : {-1e12, -1e8, 0.0, 1e8, 1e12}) {
      for (double v : {-50.0, -0.2, 0.0, 0.2, 50.0}) {
        const double u = ff.command(p, dp, 0.1, v);
        EXPECT_TRUE(std::isfinite(u)) << p << " " << dp << " " << v;
        EXPECT_LE(std::abs(u), 4.0) << p << " " << dp << " " << v;
      }
    }
  }
  std::string refusal;
  EXPECT_TRUE(std::isnan(ff.command(std::nan(""), 0.0, 0.1, 0.1, &refusal))) << "no command, not 0 V";
  EXPECT_NE(refusal.find("not finite"), std::string::npos) << refusal;
  EXPECT_TRUE(std::isnan(ff.command(100e5, INFINITY, 0.1, 0.1)));
  ServoValveParameters no_gain = plant.valve;
  no_gain.gain = 0.0;
  EXPECT_THROW(PressureFeedForward(model, model.nominalParameters(), no_gain, 4.0), std::invalid_argument);
  EXPECT_THROW(PressureFeedForward(model, model.nominalParameters(), plant.valve, 0.0),
               std::invalid_argument);
}

// The inverse is exact: the spool opening it gives makes the model's own pressure rate equal the request.
TEST(PressureFeedForward, TheSpoolOpeningReproducesTheRequestedPressureRate) {
  const SimulatorConfig plant = testing::randomPlant(8, {"leakage", "valve_overlap"});
  const HydraulicModel model = HydraulicModel::fromNames(plant.geometry, {"leakage", "valve_overlap"});
  ParameterVector theta = model.nominalParameters();
  theta(HydraulicModel::kFirstEffect) = 2e-11;
  theta(HydraulicModel::kFirstEffect + 1) = 0.03;
  const PressureFeedForward ff(model, theta, plant.valve, 10.0);
  for (double dp : {-5e8, -1e7, 0.0, 1e7, 5e8}) {
    HydraulicSignals s;
    s.p = 120e5;
    s.x = 0.1;
    s.v = 0.2;
    s.y = ff.spoolOpening(s.p, dp, s.x, s.v);
    s.V = model.chamberVolume(s.x, theta(HydraulicModel::kDeadVolume));
    if (std::abs(s.y) >= 1.0) continue;  // beyond the valve's range
    EXPECT_NEAR(model.pressureRate(s, theta), dp, 1e-6 * std::max(std::abs(dp), 1e6)) << dp;
  }
}

// Issue 45: inside a valve's overlap the exact inverse jumps between the band's edges, 2 y_0 / K at once; at
// rest with a noisy velocity the command swung about +-0.2 V at the grid rate (2 % overlap, K = 0.1 1/V).
// Across the band the opening is interpolated: continuous, monotonic, through the middle at zero flow.
TEST(PressureFeedForward, InsideTheOverlapTheOpeningIsInterpolatedSoNoiseDoesNotChatter) {
  for (std::uint64_t seed : {11, 12}) {
    const SimulatorConfig plant = testing::randomPlant(seed, {"valve_overlap"});
    const HydraulicModel model = HydraulicModel::fromNames(plant.geometry, {"valve_overlap"});
    ParameterVector theta = model.nominalParameters();
    theta(HydraulicModel::kFirstEffect) = 0.02;
    ServoValveParameters valve = plant.valve;
    valve.gain = 0.1;
    const PressureFeedForward ff(model, theta, valve, 10.0);
    // At rest, holding 50 bar: the velocity's noise (0.1 mm/s, the simulator's JointState velocity) is all
    // that asks for flow.
    std::mt19937 random(seed);
    std::normal_distribution<double> noise(0.0, 1e-4);
    double lo = INFINITY, hi = -INFINITY, previous = NAN;
    for (int k = 0; k < 2000; ++k) {
      const double u = ff.command(50e5, 0.0, 0.1, noise(random));
      ASSERT_TRUE(std::isfinite(u));
      lo = std::min(lo, u);
      hi = std::max(hi, u);
      previous = u;
    }
    (void)previous;
    std::printf("seed %llu: at rest the command spans %.3f V (the overlap's own jump is %.2f V)\n",
                static_cast<unsigned long long>(seed), hi - lo, 2 * 0.02 / 0.1);
    EXPECT_LT(hi - lo, 0.1) << "the command's span at rest, against 0.4 V of the exact inverse's jump";
    // Monotonic and continuous through the band: more wanted outflow, more opening.
    double y_before = -INFINITY;
    for (double v = -0.01; v <= 0.01; v += 1e-5) {
      const double y = ff.spoolOpening(50e5, 0.0, 0.1, v);
      EXPECT_GE(y, y_before - 1e-12);
      if (std::isfinite(y_before)) {
        EXPECT_LT(y - y_before, 0.01) << "no jump at v = " << v;
      }
      y_before = y;
    }
    EXPECT_NEAR(ff.spoolOpening(50e5, 0.0, 0.1, 0.0), 0.0, 1e-9) << "zero flow: the band's middle";
    // Beyond the band the inverse is exact again.
    HydraulicSignals s;
    s.p = 50e5;
    s.x = 0.1;
    s.v = 0.3;
    s.y = ff.spoolOpening(s.p, 0.0, s.x, s.v);
    s.V = model.chamberVolume(s.x, theta(HydraulicModel::kDeadVolume));
    EXPECT_NEAR(model.pressureRate(s, theta), 0.0, 1e3);
  }
}

// Issue 45: positive feedback was reachable through what the sign check did not cover. A custom term in
// p*dp that makes the chamber's compliance negative at the operating point gives no command; a preview of
// the position beyond the stroke is taken at the stroke's end (the chamber's volume never below the dead
// volume).
TEST(PressureFeedForward, ANegativeComplianceGivesNoCommandAndThePreviewStaysWithinTheStroke) {
  const SimulatorConfig plant = testing::randomPlant(13);
  const HydraulicModel model = HydraulicModel::fromNames(plant.geometry, {}, {"stiff=p*dp"});
  ParameterVector theta = model.nominalParameters();
  const double V = model.chamberVolume(0.1, theta(HydraulicModel::kDeadVolume));
  // C = V / K' + theta * p: negative at 100 bar for theta below -V / (K' p).
  theta(HydraulicModel::kFirstEffect) = -2.0 * V / (theta(HydraulicModel::kBulkModulus) * 100e5);
  const PressureFeedForward ff(model, theta, plant.valve, 10.0);
  std::string refusal;
  EXPECT_TRUE(std::isnan(ff.command(100e5, 1e8, 0.1, 0.1, &refusal)));
  EXPECT_NE(refusal.find("compliance"), std::string::npos) << refusal;
  EXPECT_TRUE(std::isfinite(ff.command(10e5, 1e8, 0.1, 0.1))) << "positive at 10 bar: a command";

  const HydraulicModel base = HydraulicModel::fromNames(plant.geometry, {});
  const PressureFeedForward inverse(base, base.nominalParameters(), plant.valve, 10.0);
  const double s = plant.geometry.stroke_length;
  EXPECT_DOUBLE_EQ(inverse.spoolOpening(80e5, 2e8, s + 0.5, 0.0), inverse.spoolOpening(80e5, 2e8, s, 0.0));
  EXPECT_DOUBLE_EQ(inverse.spoolOpening(80e5, 2e8, -0.5, 0.0), inverse.spoolOpening(80e5, 2e8, 0.0, 0.0));
}

// The set-point's rate is the slope over a window, bounded: two set-points 10 us apart gave 1e9 Pa/s.
TEST(PressureReference, TheRateComesFromAWindowAndIsBounded) {
  SetpointLimits limits;
  PressureReference reference(limits);
  // A ramp at 1e8 Pa/s every 1 ms, then a set-point 10 us after the last with 10 bar of noise on it.
  for (int k = 0; k <= 30; ++k) reference.push(10.0 + 0.001 * k, 50e5 + 1e8 * 0.001 * k, 1.0 + 0.001 * k);
  reference.push(10.03001, 50e5 + 1e8 * 0.03 + 10e5, 1.03001);
  const auto now = reference.at({1.031, 10.031}, 0.0);
  ASSERT_TRUE(now.has_value());
  EXPECT_LT(std::abs(now->rate - 1e8), 0.5e8) << "the window's slope, not the last pair's 1e11 Pa/s";
  PressureReference jumpy(limits);
  jumpy.push(10.0, 0.0, 1.0);
  jumpy.push(10.00001, 100e5, 1.00001);
  const auto jumped = jumpy.at({1.00002, 10.00002}, 0.01);
  ASSERT_TRUE(jumped.has_value());
  EXPECT_EQ(jumped->rate, 0.0) << "10 us of set-points tell no rate";
  PressureReference steep(limits);
  for (int k = 0; k <= 20; ++k) steep.push(10.0 + 0.001 * k, 1e11 * 0.001 * k, 1.0 + 0.001 * k);
  EXPECT_DOUBLE_EQ(steep.at({1.02, 10.02}, 0.0)->rate, limits.max_rate);
}

// Staleness on both sides and on both clocks; the extrapolation never reaches beyond the set-point's age.
TEST(PressureReference, AStampAheadOfTheClockOrAnOldOneOrALateArrivalIsNotUsed) {
  SetpointLimits limits;
  limits.max_age = 0.05;
  limits.max_clock_offset = 0.1;
  PressureReference reference(limits);
  reference.push(20.0, 50e5, 1.0);  // stamped 10 s ahead of the clock (a cell controller's clock, a loop)
  std::string why;
  EXPECT_FALSE(reference.at({1.001, 10.0}, 0.0, &why).has_value());
  EXPECT_NE(why.find("ahead of the clock"), std::string::npos) << why;
  EXPECT_FALSE(reference.at({1.001, 20.2}, 0.0, &why).has_value());
  EXPECT_NE(why.find("stale"), std::string::npos) << why;
  EXPECT_FALSE(reference.at({1.2, 20.0}, 0.0, &why).has_value()) << "arrived 200 ms ago";
  EXPECT_NE(why.find("lost"), std::string::npos) << why;
  EXPECT_TRUE(reference.at({1.01, 20.01}, 0.004).has_value());
  // A stream that starts again a minute back (a bag played again) restarts the reference.
  EXPECT_EQ(reference.push(19.0, 50e5, 1.02), PressureReference::Push::kNotAdvancing);
  EXPECT_EQ(reference.push(-40.0, 60e5, 1.03), PressureReference::Push::kRestarted);
  const auto restarted = reference.at({1.031, -39.999}, 0.0);
  ASSERT_TRUE(restarted.has_value());
  EXPECT_DOUBLE_EQ(restarted->ahead(), 60e5);
}

}  // namespace
}  // namespace die_cushion_ident
