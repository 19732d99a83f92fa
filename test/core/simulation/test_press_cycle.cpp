#include <gtest/gtest.h>

#include <cmath>

#include "die_cushion_ident/core/simulation/press_cycle.h"

using namespace die_cushion_ident;

TEST(PressCycleProgram, RejectsImpossiblePrograms) {
  PressCycleConfig c;
  c.drawing_depth = 0.001;
  EXPECT_THROW(PressCycleProgram{c}, std::invalid_argument);
  c = {};
  c.drawing_speed = 0.0;
  EXPECT_THROW(PressCycleProgram{c}, std::invalid_argument);
  c = {};
  c.release_time = 0.0;
  EXPECT_THROW(PressCycleProgram{c}, std::invalid_argument);
}

TEST(PressCycleProgram, StrokeIsContinuousReachesTheDepthAndReturnsToTheTop) {
  PressCycleProgram program({});
  const double T = program.cycleDuration();
  double max_x = 0.0, previous_x = 0.0;
  const double dt = 1e-4;
  for (double t = 0.0; t < 2 * T; t += dt) {
    const auto point = program.at(t);
    EXPECT_LE(std::abs(point.x - previous_x), 0.3 * dt * 1.01 + 1e-12) << "no jumps in position at t = " << t;
    // Velocity must be the derivative of position (the simulator relies on it for A v).
    const auto later = program.at(t + 1e-6);
    if (later.cycle == point.cycle) {
      EXPECT_NEAR((later.x - point.x) / 1e-6, point.v, 1e-3) << t;
    }
    previous_x = point.x;
    max_x = std::max(max_x, point.x);
  }
  EXPECT_NEAR(max_x, 0.2, 1e-9);
  EXPECT_NEAR(program.at(T - 1e-9).x, 0.0, 1e-6) << "back at the upper end when the cycle ends";
  EXPECT_EQ(program.at(T + 0.1).cycle, 1);
}

TEST(PressCycleProgram, PhasesComeInTheStrokesOrder) {
  PressCycleProgram program({});
  std::vector<StrokePhase> seen;
  for (double t = 0.0; t < program.cycleDuration(); t += 1e-3) {
    const auto phase = program.at(t).phase;
    if (seen.empty() || seen.back() != phase) seen.push_back(phase);
  }
  const std::vector<StrokePhase> expected{StrokePhase::kRest,    StrokePhase::kImpact,
                                          StrokePhase::kDrawing, StrokePhase::kBottomHold,
                                          StrokePhase::kRelease, StrokePhase::kReturn};
  EXPECT_EQ(seen, expected);
  EXPECT_STREQ(strokePhaseName(StrokePhase::kBottomHold), "bottom_hold");
}
