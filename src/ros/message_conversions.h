#pragma once

#include <ros/time.h>

#include <string>
#include <vector>

#include "die_cushion_ident/FrequencyResponse.h"
#include "die_cushion_ident/ModelComparison.h"
#include "die_cushion_ident/ParameterEstimate.h"
#include "die_cushion_ident/ValveModel.h"
#include "sensor_msgs/JointState.h"
#include "die_cushion_ident/core/model/hydraulic_model.h"
#include "die_cushion_ident/core/simulation/press_cycle.h"
#include "die_cushion_ident/core/valve/servo_valve_fit.h"
#include "die_cushion_ident/core/signal/uniform_resampler.h"

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
