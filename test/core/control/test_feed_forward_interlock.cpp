// Issue 28: the feed-forward behind interlocks. A property test over random sequences of live estimates
// (signs flipped, NaN, jumps of orders of magnitude), valve gains, set-points and withdrawals: the command
// never leaves the voltage limit, never changes faster than the slew rate, and whatever parameters reach
// the inverse keep it monotonic (more wanted pressure rise -> less outflow: the loop with the PI never
// gains positive feedback).
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "die_cushion_ident/core/control/feed_forward_interlock.h"
#include "die_cushion_ident/core/control/pressure_feed_forward.h"

namespace die_cushion_ident {
namespace {

CylinderGeometry geometry() {
  CylinderGeometry g;
  g.piston_area = 0.05;
  g.stroke_length = 0.2;
  g.supply_pressure = 2e7;
  return g;
}

TEST(FeedForwardInterlock, RefusesParametersThatWouldReverseTheInverse) {
  FeedForwardInterlock interlock({}, 0.1);
  ParameterVector good(3);
  good << 1.4e9, 6e-6, 3e-3;
  EXPECT_EQ(interlock.check(good, 0.1), "");
  for (int i = 0; i < 3; ++i) {
    ParameterVector bad = good;
    bad(i) = -bad(i);
    EXPECT_NE(interlock.check(bad, 0.1).find("not positive"), std::string::npos) << i;
    bad(i) = NAN;
    EXPECT_NE(interlock.check(bad, 0.1).find("not finite"), std::string::npos) << i;
  }
  EXPECT_NE(interlock.check(good, -0.1).find("opposite sign"), std::string::npos);
  EXPECT_NE(interlock.check(good, 0.5).find("times off"), std::string::npos);
  EXPECT_EQ(interlock.check(good, 0.15), "") << "within the band of the reference";
  // Without a configured gain the first accepted one becomes the reference.
  FeedForwardInterlock open({}, NAN);
  EXPECT_EQ(open.check(good, -0.2), "");
  open.acceptValveGain(-0.2);
  EXPECT_NE(open.check(good, 0.2).find("opposite sign"), std::string::npos);
}

TEST(FeedForwardInterlock, SwitchingOnAndOffRampsInsteadOfStepping) {
  FeedForwardInterlockLimits limits;
  limits.slew_rate = 100.0;
  FeedForwardInterlock interlock(limits, 0.1);
  double u = 0.0;
  for (int k = 0; k < 10; ++k) u = interlock.output(5.0, 0.002);
  EXPECT_NEAR(u, 2.0, 1e-12) << "10 steps of 2 ms at 100 V/s";
  for (int k = 0; k < 200; ++k) interlock.output(5.0, 0.002);
  EXPECT_DOUBLE_EQ(interlock.lastOutput(), 5.0);
  EXPECT_NEAR(interlock.output(NAN, 0.002), 4.8, 1e-12) << "withdrawn: towards 0 V, not a step";
  for (int k = 0; k < 100; ++k) u = interlock.output(NAN, 0.002);
  EXPECT_DOUBLE_EQ(u, 0.0);
}

TEST(FeedForwardInterlock, SmallChangesInsideTheHysteresisAreHeld) {
  FeedForwardInterlockLimits limits;
  limits.hysteresis = 0.05;
  limits.slew_rate = 1e6;
  FeedForwardInterlock interlock(limits, 0.1);
  EXPECT_DOUBLE_EQ(interlock.output(1.0, 0.002), 1.0);
  // The inverse jumping between the overlap's edges on its inputs' noise: the output does not follow.
  for (double wanted : {1.03, 0.98, 1.04, 0.97}) EXPECT_DOUBLE_EQ(interlock.output(wanted, 0.002), 1.0);
  EXPECT_DOUBLE_EQ(interlock.output(1.2, 0.002), 1.2);
}

TEST(FeedForwardInterlock, ParametersFollowTheEstimateAtABoundedRate) {
  FeedForwardInterlockLimits limits;
  limits.parameter_rate = 0.5;
  FeedForwardInterlock interlock(limits, 0.1);
  ParameterVector a(3), b(3);
  a << 1e9, 6e-6, 3e-3;
  b << 4e9, 6e-6, 3e-4;
  EXPECT_EQ(interlock.follow(a, 0.002), a) << "taken as they are at first";
  const ParameterVector after = interlock.follow(b, 0.1);
  EXPECT_NEAR(after(0), 1e9 + 0.05 * 4e9, 1.0) << "5 % of the larger magnitude in 0.1 s";
  EXPECT_NEAR(after(2), 3e-3 - 0.05 * 3e-3, 1e-12);
  for (int k = 0; k < 200; ++k) interlock.follow(b, 0.1);
  EXPECT_EQ(interlock.follow(b, 0.1), b) << "it gets there";
}

// The property: any sequence, nothing unsafe reaches the valve.
TEST(FeedForwardInterlock, NoSequenceOfEstimatesAndSetPointsReversesOrExceedsTheCommand) {
  const HydraulicModel model = HydraulicModel::fromNames(geometry(), {"valve_overlap"});
  std::mt19937_64 random(28);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const auto wild = [&](double typical) {
    const double r = unit(random);
    if (r < 0.05) return std::numeric_limits<double>::quiet_NaN();
    if (r < 0.15) return -typical * std::pow(10.0, 3.0 * unit(random) - 1.0);
    if (r < 0.2) return 0.0;
    return typical * std::pow(10.0, 2.0 * unit(random) - 1.0);
  };
  int checked_monotonic = 0, refused = 0;
  for (int sequence = 0; sequence < 200; ++sequence) {
    FeedForwardInterlockLimits limits;
    limits.max_voltage = 1.0 + 9.0 * unit(random);
    limits.slew_rate = 10.0 + 500.0 * unit(random);
    FeedForwardInterlock interlock(limits, unit(random) < 0.5 ? 0.1 : NAN);
    double previous = 0.0;
    for (int step = 0; step < 300; ++step) {
      const double dt = 0.0005 + 0.01 * unit(random);
      ParameterVector identified(4);
      identified << wild(1.5e9), wild(6e-6), wild(3e-3), wild(0.03);
      const double valve_gain = wild(0.1);
      const std::string refusal = interlock.check(identified, valve_gain);
      double wanted = NAN;
      if (refusal.empty()) {
        interlock.acceptValveGain(valve_gain);
        const ParameterVector& used = interlock.follow(identified, dt);
        ASSERT_EQ(interlock.check(used, valve_gain), "") << "what follows accepted estimates stays acceptable";
        ServoValveParameters valve;
        valve.gain = valve_gain;
        PressureFeedForward inverse(model, used, valve, limits.max_voltage);
        const double p = 2e6 + 1.5e7 * unit(random), dp = 2e8 * (unit(random) - 0.5);
        const double x = 0.2 * unit(random), v = unit(random) - 0.3;
        wanted = inverse.command(p, dp, x, v);
        // Monotonic: a faster wanted pressure rise never opens the valve further (in spool terms).
        const double y = inverse.spoolOpening(p, dp, x, v), y_more = inverse.spoolOpening(p, dp + 1e7, x, v);
        EXPECT_LE(y_more, y + 1e-12) << "sequence " << sequence << " step " << step;
        ++checked_monotonic;
      } else {
        ++refused;
      }
      const double u = interlock.output(unit(random) < 0.05 ? NAN : wanted, dt);
      ASSERT_LE(std::abs(u), limits.max_voltage + 1e-12);
      ASSERT_LE(std::abs(u - previous), limits.slew_rate * dt + 1e-9) << "sequence " << sequence;
      previous = u;
    }
  }
  std::printf("%d estimates passed to the inverse and checked monotonic, %d refused\n", checked_monotonic, refused);
  EXPECT_GT(checked_monotonic, 3000);
  EXPECT_GT(refused, 3000);
}

}  // namespace
}  // namespace die_cushion_ident
