// The optional oil temperature topic (issue 46): what is taken, what is rejected and counted, and what the
// grid holds between and after its slow messages.
#include <gtest/gtest.h>

#include <cmath>

#include "die_cushion_ident/core/signal/oil_temperature_input.h"

namespace die_cushion_ident {
namespace {

using Result = OilTemperatureInput::PushResult;

TEST(OilTemperatureInput, HoldsTheLineBetweenMessagesAndTheLastOneForMaxAge) {
  OilTemperatureInput oil;  // max_age 10 s
  EXPECT_TRUE(std::isnan(oil.peek(0.0))) << "nothing before the first message";
  EXPECT_EQ(oil.push(100.0, 40.0, 100.1), Result::kAccepted);
  EXPECT_EQ(oil.push(101.0, 40.5, 101.1), Result::kAccepted);
  EXPECT_DOUBLE_EQ(oil.peek(100.5), 40.25) << "the line between the two messages";
  EXPECT_DOUBLE_EQ(oil.peek(95.0), 40.0) << "the first message holds back max_age (a grid that starts first)";
  EXPECT_DOUBLE_EQ(oil.peek(110.9), 40.5) << "the last message holds max_age";
  EXPECT_TRUE(std::isnan(oil.peek(111.5))) << "then the temperature is unknown: the topic fell silent";
  EXPECT_DOUBLE_EQ(oil.mean(), 40.25);
  EXPECT_DOUBLE_EQ(oil.lowest(), 40.0);
  EXPECT_DOUBLE_EQ(oil.highest(), 40.5);
  EXPECT_NEAR(oil.meanStampOffset(), -0.1, 1e-12);
  // Across a silence longer than twice max_age, nothing is interpolated in its middle.
  EXPECT_EQ(oil.push(200.0, 50.0, 200.0), Result::kAccepted);
  EXPECT_TRUE(std::isnan(oil.peek(150.0)));
  EXPECT_DOUBLE_EQ(oil.peek(195.0), 50.0);
  EXPECT_EQ(oil.health().gaps, 1u) << "a silence of 99 s is a gap";
  // at() drops what no later grid point needs, and keeps the line back to it.
  EXPECT_DOUBLE_EQ(oil.at(200.0), 50.0);
  EXPECT_DOUBLE_EQ(oil.at(204.0), 50.0);
}

TEST(OilTemperatureInput, BadMessagesAreRejectedCountedAndLoseNothing) {
  OilTemperatureInput oil;
  ASSERT_EQ(oil.push(10.0, 45.0, 10.0), Result::kAccepted);
  EXPECT_EQ(oil.push(10.5, std::nan(""), 10.5), Result::kNonFinite);
  EXPECT_EQ(oil.push(std::nan(""), 45.0, 10.5), Result::kNonFinite);
  EXPECT_EQ(oil.push(11.0, 1e6, 11.0), Result::kImplausible) << "an absurd value";
  EXPECT_EQ(oil.push(11.0, -273.0, 11.0), Result::kImplausible) << "below the plausible range";
  EXPECT_EQ(oil.push(10.0, 45.0, 11.0), Result::kDuplicate);
  EXPECT_EQ(oil.push(9.0, 45.0, 11.0), Result::kOutOfOrder);
  EXPECT_EQ(oil.push(1011.0, 45.0, 11.0), Result::kHeld) << "a stamp 1000 s off the other topics: wild";
  EXPECT_EQ(oil.health().wild_stamps, 1u);
  EXPECT_NEAR(oil.health().last_wild_offset, 1000.0, 1e-9);
  const StreamHealth& h = oil.health();
  EXPECT_EQ(h.non_finite, 2u);
  EXPECT_EQ(h.implausible, 2u);
  EXPECT_EQ(h.accepted, 1u);
  EXPECT_EQ(h.received, 8u);
  EXPECT_DOUBLE_EQ(oil.peek(11.0), 45.0) << "the good message still holds";
  // Stamps a few seconds off the other topics' (another clock) are harmless for a slow oil: taken.
  EXPECT_EQ(oil.push(12.0, 45.1, 16.0), Result::kAccepted);
}

// An oil in a tank cannot jump by 20 K in a second: a lone jump is implausible; a new level that the next
// messages confirm (a first value that was wrong, a sensor replugged) is taken from its third message on.
TEST(OilTemperatureInput, AJumpIsTakenOnlyOnceTheNextMessagesConfirmIt) {
  OilTemperatureInput oil;
  ASSERT_EQ(oil.push(0.0, 40.0, 0.0), Result::kAccepted);
  EXPECT_EQ(oil.push(1.0, 60.0, 1.0), Result::kImplausible) << "a spike";
  EXPECT_EQ(oil.push(2.0, 40.2, 2.0), Result::kAccepted) << "back at the level: the spike was one";
  EXPECT_EQ(oil.jumps(), 1u);
  EXPECT_EQ(oil.push(3.0, 20.0, 3.0), Result::kImplausible);
  EXPECT_EQ(oil.push(4.0, 20.1, 4.0), Result::kImplausible);
  EXPECT_EQ(oil.push(5.0, 20.0, 5.0), Result::kAccepted) << "the third message at the new level confirms it";
  EXPECT_DOUBLE_EQ(oil.peek(5.0), 20.0);
  EXPECT_EQ(oil.push(6.0, 20.5, 6.0), Result::kAccepted);
  // Slow warming within max_rate is never a jump: 2 K/s for 0.5 s plus the sensor's 1 K.
  EXPECT_EQ(oil.push(6.5, 22.4, 6.5), Result::kAccepted);
}

TEST(OilTemperatureInput, ARestartedTimeBaseForgetsTheMessagesButKeepsTheCounts) {
  OilTemperatureInput oil;
  ASSERT_EQ(oil.push(100.0, 40.0, 100.0), Result::kAccepted);
  oil.restart();
  EXPECT_TRUE(std::isnan(oil.peek(100.0)));
  EXPECT_EQ(oil.push(1.0, 41.0, 1.0), Result::kAccepted)
      << "the bag played again: earlier stamps are no step back";
  EXPECT_EQ(oil.health().accepted, 2u);
  std::vector<std::pair<double, double>> messages{{0.0, 30.0}, {2.0, 32.0}};
  EXPECT_DOUBLE_EQ(OilTemperatureInput::heldAt(messages, 1.0, 10.0), 31.0);
  EXPECT_TRUE(std::isnan(OilTemperatureInput::heldAt(messages, 13.0, 10.0)));
  EXPECT_TRUE(std::isnan(OilTemperatureInput::heldAt({}, 1.0, 10.0)));
}

}  // namespace
}  // namespace die_cushion_ident
