// The feed-forward's last stage (issue 45): on the steady clock, so that no gap in the grid, the stamps or
// /clock turns into a step on the cell controller's adder.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "die_cushion_ident/core/control/feed_forward_output.h"

namespace die_cushion_ident {
namespace {

FeedForwardOutputLimits limits(double slew_rate = 100.0) {
  FeedForwardOutputLimits l;
  l.slew_rate = slew_rate;
  l.max_step_interval = 0.01;
  return l;
}

TEST(FeedForwardOutput, SwitchingOnAndOffRampsInsteadOfStepping) {
  FeedForwardOutput output(limits());
  EXPECT_DOUBLE_EQ(output.next(5.0, 1.0), 0.0) << "the first command: 0 V was on the adder before it";
  double u = 0.0;
  for (int k = 1; k <= 10; ++k) u = output.next(5.0, 1.0 + 0.002 * k);
  EXPECT_NEAR(u, 2.0, 1e-12) << "10 steps of 2 ms at 100 V/s";
  for (int k = 11; k <= 210; ++k) output.next(5.0, 1.0 + 0.002 * k);
  EXPECT_DOUBLE_EQ(output.last(), 5.0);
  EXPECT_NEAR(output.next(NAN, 1.422), 4.8, 1e-9) << "withdrawn: towards 0 V, not a step";
  for (int k = 1; k <= 100; ++k) u = output.next(NAN, 1.422 + 0.002 * k);
  EXPECT_DOUBLE_EQ(u, 0.0);
}

// Issue 45: the slew limit was slew x min(dt, 1 s) in stamp time: after 0.1-1 s of silence the first
// message could step to 0 V or to the limit. Now a gap moves the command by at most slew x 10 ms.
TEST(FeedForwardOutput, AGapProducesNoStep) {
  FeedForwardOutput output(limits());
  for (int k = 0; k <= 500; ++k) output.next(4.0, 0.002 * k);
  ASSERT_DOUBLE_EQ(output.last(), 4.0);
  EXPECT_NEAR(output.next(NAN, 1.0 + 0.5), 3.0, 1e-12) << "0.5 s of silence: one step of 10 ms, 1 V";
  EXPECT_NEAR(output.next(-4.0, 1.0 + 1.5), 2.0, 1e-12);
  EXPECT_NEAR(output.next(-4.0, NAN), 2.0, 1e-12) << "a time that is no time: no change";
}

TEST(FeedForwardOutput, SmallChangesInsideTheHysteresisAreHeldAndTheLimitHolds) {
  FeedForwardOutputLimits l = limits(1e6);
  l.hysteresis = 0.05;
  l.max_voltage = 3.0;
  FeedForwardOutput output(l);
  output.next(1.0, 0.0);
  EXPECT_DOUBLE_EQ(output.next(1.0, 0.002), 1.0);
  for (double wanted : {1.03, 0.98, 1.04, 0.97}) EXPECT_DOUBLE_EQ(output.next(wanted, 0.004), 1.0);
  EXPECT_DOUBLE_EQ(output.next(1.2, 0.006), 1.2);
  EXPECT_DOUBLE_EQ(output.next(50.0, 0.008), 3.0);
  EXPECT_DOUBLE_EQ(output.next(-50.0, 0.010), -3.0);
}

TEST(FeedForwardOutput, InvalidLimitsAreRefused) {
  for (double bad : std::vector<double>{0.0, -1.0, NAN, INFINITY}) {
    FeedForwardOutputLimits l;
    l.slew_rate = bad;
    EXPECT_THROW(FeedForwardOutput{l}, std::invalid_argument) << bad;
    l = FeedForwardOutputLimits();
    l.max_step_interval = bad;
    EXPECT_THROW(FeedForwardOutput{l}, std::invalid_argument) << bad;
  }
}

}  // namespace
}  // namespace die_cushion_ident
