// The messages a press publishes and the node reads (shared/CONTRACT.md), built and picked apart as the
// simulator, simulate_bag, the node and analyze_bag do it.
#include <gtest/gtest.h>

#include <cmath>

#include "die_cushion_ident/EffectRanking.h"
#include "die_cushion_ident/core/adequacy/verdict.h"
#include "die_cushion_ident/core/valve/valve_sweep.h"
#include "message_conversions.h"

using namespace die_cushion_ident;

namespace {

StreamSample position(double x, double v) {
  StreamSample s;
  s.stamp = 12.5;
  s.first = x;
  s.second = v;
  return s;
}

}  // namespace

TEST(MessageConversions, SensorMessagesCarryTheSampleInSIUnits) {
  const ros::Time stamp(1.7e9 + 0.25);
  StreamSample pressure;
  pressure.first = 123.4e5;
  const sensor_msgs::FluidPressure p = toFluidPressureMsg(pressure, stamp);
  EXPECT_EQ(p.fluid_pressure, 123.4e5) << "Pa, as FluidPressure defines it";
  EXPECT_EQ(p.header.stamp, stamp);
  EXPECT_EQ(p.header.frame_id, kCushionFrame);

  StreamSample valve;
  valve.first = -0.5;
  valve.second = NAN;
  const ValveSignal u = toValveSignalMsg(valve, stamp);
  EXPECT_EQ(u.voltage, -0.5);
  EXPECT_TRUE(std::isnan(u.spool_position)) << "not measured: NaN, as the contract says";
}

// A cell's joint_states: the cushion among the ram and the blank holder. The configured joint is found by
// name wherever it stands; position and velocity come from its own index.
TEST(MessageConversions, TheConfiguredJointIsPickedByName) {
  SimulatedJoints joints;
  joints.names = {"ram", "cushion", "holder"};
  const sensor_msgs::JointState msg = toJointStateMsg(position(0.12, -0.2), ros::Time(3.0), joints);
  ASSERT_EQ(msg.position.size(), 3u);
  EXPECT_NEAR(msg.position[0], 0.12 - 0.3, 1e-12) << "the ram rides 0.3 m above the cushion";
  EXPECT_NEAR(msg.position[2], 0.012, 1e-12) << "the holder moves a tenth of the stroke";

  JointSelector selector("cushion");
  StreamSample picked;
  ASSERT_EQ(selector.select(msg, &picked), JointSelector::Result::kSelected);
  EXPECT_EQ(picked.first, 0.12);
  EXPECT_EQ(picked.second, -0.2);
  EXPECT_EQ(picked.stamp, 3.0);
  EXPECT_FALSE(selector.ambiguous());
}

TEST(MessageConversions, AMissingJointIsNamedWithTheJointsTheMessageHolds) {
  SimulatedJoints joints;
  joints.names = {"ram", "holder"};
  joints.cushion = "holder";
  JointSelector selector("cushion");
  StreamSample picked;
  EXPECT_EQ(selector.select(toJointStateMsg(position(0.1, 0.0), ros::Time(1.0), joints), &picked),
            JointSelector::Result::kJointMissing);
  EXPECT_NE(selector.problem().find("'ram', 'holder'"), std::string::npos) << selector.problem();
}

// No joint_name and several joints: position[0] is taken, and it is said once which joints there were.
TEST(MessageConversions, SeveralJointsWithoutANameAreAmbiguousAndSaySo) {
  SimulatedJoints joints;
  joints.names = {"ram", "cushion"};
  JointSelector selector;
  StreamSample picked;
  ASSERT_EQ(selector.select(toJointStateMsg(position(0.1, 0.05), ros::Time(1.0), joints), &picked),
            JointSelector::Result::kSelected);
  EXPECT_NEAR(picked.first, 0.1 - 0.3, 1e-12) << "position[0], the ram's";
  EXPECT_TRUE(selector.ambiguous());
  EXPECT_NE(selector.ambiguity().find("position[0] ('ram')"), std::string::npos) << selector.ambiguity();

  JointSelector single;
  ASSERT_EQ(single.select(toJointStateMsg(position(0.1, 0.05), ros::Time(1.0)), &picked),
            JointSelector::Result::kSelected);
  EXPECT_FALSE(single.ambiguous()) << "one joint needs no name";
}

// A linear encoder publishes positions only: the velocity is NaN (derived downstream), and a message
// without positions is refused, not read as 0.
TEST(MessageConversions, PositionOnlyAndEmptyMessages) {
  const sensor_msgs::JointState encoder = toJointStateMsg(position(0.08, NAN), ros::Time(2.0));
  EXPECT_TRUE(encoder.velocity.empty());
  JointSelector selector;
  StreamSample picked;
  ASSERT_EQ(selector.select(encoder, &picked), JointSelector::Result::kSelected);
  EXPECT_TRUE(std::isnan(picked.second));

  sensor_msgs::JointState empty;
  empty.name = {"cushion"};
  JointSelector named("cushion");
  EXPECT_EQ(named.select(empty, &picked), JointSelector::Result::kNoPosition);
  EXPECT_EQ(named.problem(), "JointState without position");
}

TEST(MessageConversions, AComparisonIsPublishedOnlyWhereEveryFigureWasComputed) {
  GridSample g;
  g.p = 100e5f;
  g.x = 0.1f;
  g.v = -0.2f;
  g.y = 0.05f;
  ModelComparison msg = toModelComparisonMsg(g, 98e5, StrokePhase::kDrawing, 1.5e5, 2e6, ros::Time(1.0));
  EXPECT_NEAR(msg.residual, 2e5, 1.0) << "measured minus modelled";
  EXPECT_EQ(msg.phase_name, strokePhaseName(StrokePhase::kDrawing));
  EXPECT_TRUE(isComputed(msg));
  msg = toModelComparisonMsg(g, NAN, StrokePhase::kDrawing, 1.5e5, 2e6, ros::Time(1.0));
  EXPECT_FALSE(isComputed(msg)) << "the free run had no value";
}

TEST(MessageConversions, TheEstimateNamesEveryParameterWithItsUnit) {
  const HydraulicModel model = HydraulicModel::fromNames(CylinderGeometry(), {"leakage"}, {});
  const std::vector<double> values = {1.4e9, 6e-6, 3e-3, 1e-12}, stds = {2e7, 1e-7, 1e-4, 1e-13};
  const ParameterEstimate msg = toParameterEstimateMsg(model, values, stds, ros::Time(1.0));
  ASSERT_EQ(msg.names.size(), 4u);
  EXPECT_EQ(msg.names[0], "bulk_modulus");
  EXPECT_EQ(msg.units[0], "Pa");
  EXPECT_EQ(msg.effects, std::vector<std::string>{"leakage"});
  EXPECT_EQ(msg.bulk_modulus, 1.4e9);
  EXPECT_EQ(msg.dead_volume_std, 1e-4);
}

// The names the node publishes in ~effect_ranking's verdicts and ~frequency_response's state are the
// constants the messages declare (a subscriber compares against those); the phase numbers are checked at
// compile time.
TEST(MessageConversions, PublishedNamesAreTheMessagesConstants) {
  EXPECT_EQ(verdictName(Verdict::kMissing), EffectRanking::VERDICT_MISSING);
  EXPECT_EQ(verdictName(Verdict::kNotNeeded), EffectRanking::VERDICT_NOT_NEEDED);
  EXPECT_EQ(verdictName(Verdict::kInconclusive), EffectRanking::VERDICT_INCONCLUSIVE);
  EXPECT_EQ(sweepStateName(ValveSweep::State::kRunning), FrequencyResponse::STATE_RUNNING);
  EXPECT_EQ(sweepStateName(ValveSweep::State::kFinished), FrequencyResponse::STATE_FINISHED);
  EXPECT_EQ(sweepStateName(ValveSweep::State::kAborted), FrequencyResponse::STATE_ABORTED);
  GridSample g;
  const ModelComparison drawing =
      toModelComparisonMsg(g, 0.0, StrokePhase::kDrawing, 0.0, 0.0, ros::Time(1.0));
  EXPECT_EQ(drawing.phase, ModelComparison::PHASE_DRAWING);
  EXPECT_EQ(drawing.phase_name, "drawing");
}
