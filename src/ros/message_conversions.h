#pragma once

#include <ros/time.h>

#include <string>
#include <vector>

#include "die_cushion_ident/FrequencyResponse.h"
#include "die_cushion_ident/ModelComparison.h"
#include "die_cushion_ident/ParameterEstimate.h"
#include "die_cushion_ident/ValveModel.h"
#include "die_cushion_ident/ValveSignal.h"
#include "die_cushion_ident/core/model/hydraulic_model.h"
#include "die_cushion_ident/core/signal/uniform_resampler.h"
#include "die_cushion_ident/core/simulation/press_cycle.h"
#include "die_cushion_ident/core/valve/servo_valve_fit.h"
#include "sensor_msgs/FluidPressure.h"
#include "sensor_msgs/JointState.h"
#include "sensor_msgs/Temperature.h"

namespace die_cushion_ident {

/// The measured points and, when the fit succeeded, the fitted curve on a fine log grid across the measured
/// band with its phase unwrapped like the points'. Shared by the node and analyze_bag.
FrequencyResponse toFrequencyResponseMsg(const std::vector<FrequencyResponsePoint>& points,
                                         const ServoValveFit& fit, const std::string& state,
                                         const ros::Time& stamp);

ValveModel toValveModelMsg(const ServoValveFit& fit, const ros::Time& stamp);

/// The model's effects, parameter names and units with `values` and `stds` (model order), the base
/// parameters also as named fields. Counters and the equation error are left for the caller. Shared by the
/// node's ~estimate, analyze_bag's series and the simulator's ~truth.
ParameterEstimate toParameterEstimateMsg(const HydraulicModel& model, const std::vector<double>& values,
                                         const std::vector<double>& stds, const ros::Time& stamp);

/// One sample of measured against modelled (free-run) pressure with the signals and the stroke phase.
ModelComparison toModelComparisonMsg(const GridSample& sample, double modelled_pressure, StrokePhase phase,
                                     double simulation_error_rms, double equation_error_rms,
                                     const ros::Time& stamp);

/// Every figure of the comparison was computed (the model runs, the signals are there): only such messages
/// are published or recorded.
bool isComputed(const ModelComparison& msg);

/// The frame of the cushion's sensor messages and markers.
constexpr const char* kCushionFrame = "die_cushion";

/// Where the simulated press's position topic puts its joints: the cushion's own, and others a cell's
/// joint_states would carry next to it (shared/CONTRACT.md).
struct SimulatedJoints {
  std::vector<std::string> names = {"cushion"};
  std::string cushion = "cushion";
};

// A simulated measurement as a press publishes it, shared by the simulator node and simulate_bag so that a
// recorded bag and the live topics are the same messages.
sensor_msgs::FluidPressure toFluidPressureMsg(const StreamSample& sample, const ros::Time& stamp);
/// The oil's temperature (sample.first, degC: sensor_msgs/Temperature has it in degC, and so does the core).
sensor_msgs::Temperature toTemperatureMsg(const StreamSample& sample, const ros::Time& stamp);
/// A Temperature message as the core takes it: stamp [s] and temperature [degC] (no conversion).
StreamSample fromTemperatureMsg(const sensor_msgs::Temperature& msg);
/// Positions (and velocities where the sample has one) of every joint: the cushion's is the sample's; the
/// ram rides 0.3 m above it and any other joint follows at a tenth of its stroke.
sensor_msgs::JointState toJointStateMsg(const StreamSample& sample, const ros::Time& stamp,
                                        const SimulatedJoints& joints = SimulatedJoints());
ValveSignal toValveSignalMsg(const StreamSample& sample, const ros::Time& stamp);

/// Picks the cushion's joint out of a JointState (shared/CONTRACT.md): the joint named `joint_name`, or,
/// with no name configured, the message's only joint, else position[0] (ambiguous: say so once). Its
/// velocity is taken where the message carries one, else NaN (derived from the position downstream).
class JointSelector {
 public:
  enum class Result { kSelected, kNoPosition, kJointMissing };

  explicit JointSelector(std::string joint_name = "") : joint_name_(std::move(joint_name)) {}

  /// Fills `sample` (stamp, x, v) from the message.
  Result select(const sensor_msgs::JointState& msg, StreamSample* sample);
  /// Why the last message was not used, in words (names the joints it holds).
  const std::string& problem() const { return problem_; }
  /// True once a message with several joints was read without a configured joint_name (position[0] used);
  /// `ambiguity()` says which joints it held.
  bool ambiguous() const { return !ambiguity_.empty(); }
  const std::string& ambiguity() const { return ambiguity_; }
  const std::string& jointName() const { return joint_name_; }

 private:
  std::string joint_name_;
  std::string problem_;
  std::string ambiguity_;
};

/// "a, b, c" (or "(no names)") for messages that list joints.
std::string jointNames(const sensor_msgs::JointState& msg);

}  // namespace die_cushion_ident
