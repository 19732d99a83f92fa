// Acceptance of the valve identification (issue 3) on the simulated cushion at rest: spool noise 0.002,
// natural frequency 50-120 Hz, damping 0.5-0.9, dead time 1-3 ms. Every refusal and abort path.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "sweep_fixtures.h"

namespace die_cushion_ident {
namespace {

using testing::cushionAtRest;
using testing::randomValve;
using testing::SweepRig;

void expectCommandsWithin(const SweepRig& rig, const SweepLimits& limits) {
  for (double u : rig.commands()) {
    ASSERT_TRUE(std::isfinite(u));
    ASSERT_GE(u, limits.min_voltage);
    ASSERT_LE(u, limits.max_voltage);
  }
}

TEST(ValveSweep, IdentifiesRandomValvesWithinTheAcceptanceBounds) {
  for (std::uint64_t seed = 1; seed <= 6; ++seed) {
    const auto truth = randomValve(seed);
    SweepRig rig(cushionAtRest(truth, seed), SweepLimits());
    ASSERT_EQ(rig.start(), "");
    rig.runToEnd();
    ASSERT_EQ(rig.sweep().state(), ValveSweep::State::kFinished) << rig.sweep().abortReason();
    const auto& fit = rig.sweep().fit();
    ASSERT_TRUE(fit.success) << fit.message;
    const auto& p = fit.parameters;
    SCOPED_TRACE("seed " + std::to_string(seed) + ": f0 " + std::to_string(truth.natural_frequency) + " D " +
                 std::to_string(truth.damping) + " K " + std::to_string(truth.gain) + " Td " +
                 std::to_string(truth.dead_time));
    EXPECT_NEAR(p.natural_frequency / truth.natural_frequency, 1.0, 0.03);
    EXPECT_NEAR(p.damping / truth.damping, 1.0, 0.10);
    EXPECT_NEAR(p.gain / truth.gain, 1.0, 0.02);
    EXPECT_NEAR(p.dead_time, truth.dead_time, 0.3e-3);
    // The reported uncertainty is honest: the error is within 4 std.
    EXPECT_LT(std::abs(p.natural_frequency - truth.natural_frequency), 4 * fit.natural_frequency_std + 1e-9);
    EXPECT_LT(std::abs(p.dead_time - truth.dead_time), 4 * fit.dead_time_std + 1e-9);
    ASSERT_EQ(rig.sweep().points().size(), 16u);
    for (const auto& point : rig.sweep().points()) {
      EXPECT_FALSE(point.distorted) << point.frequency << " Hz";
      // Re/Im converged: the change over the second half is what the noise explains (|G - G_half| has the
      // std of G itself, phase_std in relative terms; 4 std is the 99.97 % point of its Rayleigh law).
      EXPECT_LT(point.convergence, 0.01 + 4 * point.phase_std) << point.frequency << " Hz";
      EXPECT_GE(point.history.size(), 9u);
    }
    expectCommandsWithin(rig, SweepLimits());
    EXPECT_DOUBLE_EQ(rig.commands().back(), 0.0);  // back at the offset
  }
}

TEST(ValveSweep, FlagsSpoolVelocitySaturationByTheQualityFigure) {
  auto truth = randomValve(3);
  // [1/s]: at 1 V the low frequencies stay linear, from about 30 Hz the spool speed 2 pi f |G| 1 V exceeds
  // it.
  truth.max_spool_velocity = 25.0;
  SweepRig rig(cushionAtRest(truth, 3), SweepLimits());
  SweepRequest request;
  request.amplitude = 1.0;
  request.offset = 0.3;  // drains a little on average, so the chamber does not pump up to the limit
  ASSERT_EQ(rig.start(request), "");
  rig.runToEnd();
  ASSERT_EQ(rig.sweep().state(), ValveSweep::State::kFinished) << rig.sweep().abortReason();
  int distorted = 0;
  for (const auto& point : rig.sweep().points()) {
    const double spool_speed =
        2 * M_PI * point.frequency * std::abs(servoValveResponse(truth, point.frequency)) * request.amplitude;
    if (spool_speed > 1.3 * truth.max_spool_velocity) {
      EXPECT_TRUE(point.distorted) << point.frequency << " Hz, distortion " << point.harmonic_distortion;
    }
    if (spool_speed < 0.9 * truth.max_spool_velocity) {
      EXPECT_FALSE(point.distorted) << point.frequency << " Hz";
    }
    if (point.distorted) ++distorted;
  }
  EXPECT_GE(distorted, 3);
  EXPECT_LE(distorted, 14);
  EXPECT_EQ(rig.sweep().fit().points_rejected, distorted);
}

TEST(ValveSweep, RefusesInvalidRequestsWithAReason) {
  SweepRig rig(cushionAtRest(randomValve(1), 1), SweepLimits());
  const auto refusal = [&](auto change) {
    SweepRequest request;
    change(request);
    return rig.start(request);
  };
  EXPECT_NE(refusal([](SweepRequest& r) { r.frequencies.clear(); }).find("no frequencies"),
            std::string::npos);
  EXPECT_NE(refusal([](SweepRequest& r) {
              r.frequencies = {-5, 10, 20, 30, 40};
            }).find("> 0 Hz"),
            std::string::npos);
  EXPECT_NE(refusal([](SweepRequest& r) {
              r.frequencies = {NAN, 10, 20, 30, 40};
            }).find("invalid"),
            std::string::npos);
  EXPECT_NE(refusal([](SweepRequest& r) {
              r.frequencies = {600, 10, 20, 30, 40};
            }).find("Nyquist"),
            std::string::npos);
  // Hostile-input review: a 3-frequency sweep was accepted and failed minutes later in the fit.
  EXPECT_NE(refusal([](SweepRequest& r) {
              r.frequencies = {10, 20, 30};
            }).find("at least 5"),
            std::string::npos);
  EXPECT_NE(refusal([](SweepRequest& r) {
              r.frequencies = {10, 10, 10, 10, 20};
            }).find("at least 5"),
            std::string::npos);
  EXPECT_NE(refusal([](SweepRequest& r) { r.amplitude = 0; }).find("amplitude"), std::string::npos);
  EXPECT_NE(refusal([](SweepRequest& r) { r.amplitude = 5; }).find("sweep_max_amplitude"), std::string::npos);
  EXPECT_NE(refusal([](SweepRequest& r) { r.amplitude = INFINITY; }).find("amplitude"), std::string::npos);
  EXPECT_NE(refusal([](SweepRequest& r) { r.offset = 9.8; }).find("command range"), std::string::npos);
  EXPECT_NE(refusal([](SweepRequest& r) { r.offset = NAN; }).find("offset"), std::string::npos);
  EXPECT_NE(refusal([](SweepRequest& r) { r.integration_periods = 0; }).find("integration_periods"),
            std::string::npos);
  EXPECT_NE(refusal([](SweepRequest& r) { r.settle_time = -1; }).find("settle_time"), std::string::npos);
  EXPECT_NE(refusal([](SweepRequest& r) { r.min_integration_time = 400; }).find("sweep_max_duration"),
            std::string::npos);
  EXPECT_EQ(rig.sweep().state(), ValveSweep::State::kIdle);
  EXPECT_FALSE(rig.tick().has_value());  // a refused sweep commands nothing
}

TEST(ValveSweep, RefusesUnsafePlantStates) {
  SweepLimits limits;
  {
    SweepRig rig(cushionAtRest(randomValve(1), 1), limits);
    rig.overridePressure(100e5);
    EXPECT_NE(rig.start().find("above the sweep limit"), std::string::npos);
  }
  {
    SimulatorConfig moving = cushionAtRest(randomValve(1), 1);
    moving.cycle = PressCycleConfig();
    moving.cycle.rest_time = 0.0;  // the ram is already on its way
    SweepRig rig(moving, limits);
    for (int i = 0; i < 30; ++i) rig.tick();  // 60 ms into the stroke, before the impact
    EXPECT_NE(rig.start().find("moving"), std::string::npos) << rig.start();
  }
  {
    SimulatorConfig no_spool = cushionAtRest(randomValve(1), 1);
    no_spool.sensors.measure_spool = false;
    SweepRig rig(no_spool, limits);
    for (int i = 0; i < 100; ++i) rig.tick();
    EXPECT_NE(rig.start().find("spool"), std::string::npos);
  }
  {
    SweepRig rig(cushionAtRest(randomValve(1), 1), limits);
    rig.overridePressure(NAN);
    EXPECT_NE(rig.start().find("pressure is lost"), std::string::npos);
  }
  {
    SweepRig rig(cushionAtRest(randomValve(1), 1), limits);
    ASSERT_EQ(rig.start(), "");
    EXPECT_NE(rig.start().find("already running"), std::string::npos);
  }
}

// Each abort ends the sweep with its reason, returns the command to the offset on the very next tick and
// then commands nothing; no command ever leaves the configured bounds.
TEST(ValveSweep, EveryAbortReturnsTheValveToItsOffset) {
  SweepLimits limits;
  limits.min_voltage = -0.6;
  limits.max_voltage = 0.8;
  struct Fault {
    const char* expected_reason;
    std::function<void(SweepRig&)> inject;
  };
  const std::vector<Fault> faults = {
      {"aborted by request", [](SweepRig& r) { r.sweep().abort("aborted by request"); }},
      {"shutdown", [](SweepRig& r) { r.sweep().abort("shutdown"); }},
      {"not finite", [](SweepRig& r) { r.overrideSpool(NAN); }},
      {"spool signal is lost", [](SweepRig& r) { r.dropValveMessages(true); }},
      {"over the sweep limit", [](SweepRig& r) { r.overridePressure(90e5); }},
      {"pressure is lost", [](SweepRig& r) { r.overridePressure(INFINITY); }},
  };
  for (const auto& fault : faults) {
    SCOPED_TRACE(fault.expected_reason);
    SweepRig rig(cushionAtRest(randomValve(2), 2), limits);
    SweepRequest request;
    request.offset = 0.1;
    request.amplitude = 0.5;
    ASSERT_EQ(rig.start(request), "");
    for (int i = 0; i < 1500; ++i) rig.tick();  // into the second frequency
    ASSERT_TRUE(rig.sweep().running());
    fault.inject(rig);
    for (int i = 0; i < 100 && rig.sweep().running(); ++i) rig.tick();
    ASSERT_EQ(rig.sweep().state(), ValveSweep::State::kAborted);
    EXPECT_NE(rig.sweep().abortReason().find(fault.expected_reason), std::string::npos)
        << rig.sweep().abortReason();
    const auto back = rig.tick();
    ASSERT_TRUE(back.has_value());
    EXPECT_DOUBLE_EQ(*back, 0.1);
    EXPECT_FALSE(rig.tick().has_value());
    expectCommandsWithin(rig, limits);
    EXPECT_GE(rig.sweep().points().size(), 1u);  // what was measured before the abort is kept
  }
}

TEST(ValveSweep, AbortsWhenTheCushionStartsMovingAndOnANonFiniteClock) {
  SimulatorConfig plant = cushionAtRest(randomValve(4), 4);
  plant.cycle = PressCycleConfig();
  plant.cycle.rest_time = 0.3;  // the press strokes 0.3 s into the sweep
  SweepRig rig(plant, SweepLimits());
  ASSERT_EQ(rig.start(), "");
  rig.runToEnd(5.0);
  EXPECT_EQ(rig.sweep().state(), ValveSweep::State::kAborted);
  EXPECT_NE(rig.sweep().abortReason().find("moving"), std::string::npos) << rig.sweep().abortReason();

  SweepRig clock(cushionAtRest(randomValve(4), 4), SweepLimits());
  ASSERT_EQ(clock.start(), "");
  const auto u = clock.sweep().command(NAN);
  ASSERT_TRUE(u.has_value());
  EXPECT_DOUBLE_EQ(*u, 0.0);
  EXPECT_EQ(clock.sweep().state(), ValveSweep::State::kAborted);
}

TEST(SweepLimits, ValidationNamesTheKeyAndTheAllowedRange) {
  SweepLimits limits;
  EXPECT_TRUE(limits.validate().empty());
  EXPECT_TRUE(setSweepLimit(limits, "sweep_max_amplitude", -1.0));
  EXPECT_TRUE(setSweepLimit(limits, "sweep_max_voltage", -20.0));
  EXPECT_TRUE(setSweepLimit(limits, "sweep_command_period", NAN));
  EXPECT_FALSE(setSweepLimit(limits, "sweep_bogus", 1.0));
  const auto problems = limits.validate();
  ASSERT_EQ(problems.size(), 3u);
  EXPECT_NE(problems[0].find("sweep_max_amplitude = -1 is invalid: allowed > 0 V"), std::string::npos);
  EXPECT_NE(problems[1].find("sweep_max_voltage"), std::string::npos);
  EXPECT_THROW(ValveSweep{limits}, std::invalid_argument);
  EXPECT_EQ(sweepLimitKeys().size(), 11u);  // with step_max_pressure and sweep_max_clock_offset
}

}  // namespace
}  // namespace die_cushion_ident

namespace die_cushion_ident {
namespace {

// Issue 16: the valve's reported stds mean what they say. Over random valves (simulated sweeps through the
// sweep rig, spool noise 0.002), |estimate - truth| / std has its median within 0.5-0.9 (0.67 for a
// Gaussian) and is almost never above 4. The suite runs 60 valves; DCI_CALIBRATION_VALVES=200 the full
// measurement (scripts/false_alarms).
TEST(ValveSweep, ReportedStandardDeviationsAreCalibratedOverRandomValves) {
  const char* configured = std::getenv("DCI_CALIBRATION_VALVES");
  const int valves = configured ? std::atoi(configured) : 60;
  std::vector<double> ratios;
  std::vector<double> per_parameter[4];
  for (int i = 0; i < valves; ++i) {
    const std::uint64_t seed = 500 + static_cast<std::uint64_t>(i);
    const auto truth = randomValve(seed);
    SweepRig rig(cushionAtRest(truth, seed), SweepLimits());
    ASSERT_EQ(rig.start(), "");
    rig.runToEnd();
    const auto& fit = rig.sweep().fit();
    ASSERT_TRUE(fit.success) << fit.message;
    const auto& p = fit.parameters;
    const double r[4] = {std::abs(p.natural_frequency - truth.natural_frequency) / fit.natural_frequency_std,
                         std::abs(p.damping - truth.damping) / fit.damping_std,
                         std::abs(p.gain - truth.gain) / fit.gain_std,
                         std::abs(p.dead_time - truth.dead_time) / fit.dead_time_std};
    for (int k = 0; k < 4; ++k) {
      ratios.push_back(r[k]);
      per_parameter[k].push_back(r[k]);
    }
    if (std::getenv("DCI_CALIBRATION_VERBOSE"))
      std::printf("  valve %llu f0 %.1f D %.2f: %.2f %.2f %.2f %.2f  chi2 %.2f\n",
                  static_cast<unsigned long long>(seed), truth.natural_frequency, truth.damping, r[0], r[1],
                  r[2], r[3], fit.reduced_chi_square);
  }
  const auto median = [](std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
  };
  const double above4 =
      static_cast<double>(std::count_if(ratios.begin(), ratios.end(), [](double r) { return r > 4.0; })) /
      ratios.size();
  std::printf(
      "valve |estimate - truth| / std over %d valves: median %.2f (natural frequency %.2f, damping %.2f, "
      "gain %.2f, dead time %.2f), %.1f %% above 4\n",
      valves, median(ratios), median(per_parameter[0]), median(per_parameter[1]), median(per_parameter[2]),
      median(per_parameter[3]), 100 * above4);
  EXPECT_GE(median(ratios), 0.5);
  EXPECT_LE(median(ratios), 0.9);
  EXPECT_LT(above4, 0.01);
}

}  // namespace
}  // namespace die_cushion_ident
