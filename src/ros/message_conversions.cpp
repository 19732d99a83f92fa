#include "message_conversions.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace die_cushion_ident {

FrequencyResponse toFrequencyResponseMsg(const std::vector<FrequencyResponsePoint>& points,
                                         const ServoValveFit& fit, const std::string& state,
                                         const ros::Time& stamp) {
  FrequencyResponse msg;
  msg.header.stamp = stamp;
  msg.state = state;
  for (const auto& p : points) {
    msg.frequency.push_back(p.frequency);
    msg.re.push_back(p.re);
    msg.im.push_back(p.im);
    msg.magnitude.push_back(p.magnitude);
    msg.phase.push_back(p.phase);
    msg.magnitude_std.push_back(p.magnitude_std);
    msg.phase_std.push_back(p.phase_std);
    msg.convergence.push_back(p.convergence);
    msg.harmonic_distortion.push_back(p.harmonic_distortion);
    msg.unexplained_share.push_back(p.unexplained_share);
    msg.distorted.push_back(p.distorted);
  }
  if (!fit.success || points.empty()) return msg;
  const double f_low = points.front().frequency, f_high = points.back().frequency;
  double previous = 0.0;
  for (int i = 0; i <= 100; ++i) {
    const double f = f_low * std::pow(f_high / f_low, i / 100.0);
    const auto g = servoValveResponse(fit.parameters, f);
    const double phase = i == 0 ? std::arg(g) : previous + wrapAngle(std::arg(g) - previous);
    previous = phase;
    msg.fit_frequency.push_back(f);
    msg.fit_magnitude.push_back(std::abs(g));
    msg.fit_phase.push_back(phase);
  }
  return msg;
}

ValveModel toValveModelMsg(const ServoValveFit& fit, const ros::Time& stamp) {
  ValveModel msg;
  msg.header.stamp = stamp;
  msg.success = fit.success;
  msg.message = fit.message;
  msg.natural_frequency = fit.parameters.natural_frequency;
  msg.natural_frequency_std = fit.natural_frequency_std;
  msg.damping = fit.parameters.damping;
  msg.damping_std = fit.damping_std;
  msg.gain = fit.parameters.gain;
  msg.gain_std = fit.gain_std;
  msg.dead_time = fit.parameters.dead_time;
  msg.dead_time_std = fit.dead_time_std;
  msg.magnitude_residual_rms = fit.magnitude_residual_rms;
  msg.phase_residual_rms = fit.phase_residual_rms;
  msg.reduced_chi_square = fit.reduced_chi_square;
  msg.points_used = fit.points_used;
  msg.points_rejected = fit.points_rejected;
  return msg;
}

sensor_msgs::FluidPressure toFluidPressureMsg(const StreamSample& sample, const ros::Time& stamp) {
  sensor_msgs::FluidPressure msg;
  msg.header.stamp = stamp;
  msg.header.frame_id = kCushionFrame;
  msg.fluid_pressure = sample.first;
  return msg;
}

sensor_msgs::Temperature toTemperatureMsg(const StreamSample& sample, const ros::Time& stamp) {
  sensor_msgs::Temperature msg;
  msg.header.stamp = stamp;
  msg.header.frame_id = kCushionFrame;
  msg.temperature = sample.first;
  msg.variance = 0.0;  // unknown
  return msg;
}

StreamSample fromTemperatureMsg(const sensor_msgs::Temperature& msg) {
  StreamSample sample;
  sample.stamp = msg.header.stamp.toSec();
  sample.first = msg.temperature;
  sample.second = std::numeric_limits<double>::quiet_NaN();
  return sample;
}

sensor_msgs::JointState toJointStateMsg(const StreamSample& sample, const ros::Time& stamp,
                                        const SimulatedJoints& joints) {
  sensor_msgs::JointState msg;
  msg.header.stamp = stamp;
  msg.header.frame_id = kCushionFrame;
  msg.name = joints.names;
  const bool velocity = std::isfinite(sample.second);
  for (const auto& joint : joints.names) {
    const bool cushion = joint == joints.cushion, ram = joint == "ram";
    const double scale = cushion || ram ? 1.0 : 0.1;
    const double shift = ram && !cushion ? -0.3 : 0.0;
    msg.position.push_back(scale * sample.first + shift);
    if (velocity) msg.velocity.push_back(scale * sample.second);
  }
  return msg;
}

ValveSignal toValveSignalMsg(const StreamSample& sample, const ros::Time& stamp) {
  ValveSignal msg;
  msg.header.stamp = stamp;
  msg.header.frame_id = kCushionFrame;
  msg.voltage = sample.first;
  msg.spool_position = sample.second;
  return msg;
}

ParameterEstimate toParameterEstimateMsg(const HydraulicModel& model, const std::vector<double>& values,
                                         const std::vector<double>& stds, const ros::Time& stamp) {
  ParameterEstimate msg;
  msg.header.stamp = stamp;
  msg.effects = model.effectNames();
  for (const auto& info : model.parameterInfos()) {
    msg.names.push_back(info.name);
    msg.units.push_back(info.unit);
  }
  msg.values = values;
  msg.standard_deviations = stds;
  msg.bulk_modulus = values.at(HydraulicModel::kBulkModulus);
  msg.bulk_modulus_std = stds.at(HydraulicModel::kBulkModulus);
  msg.valve_flow_gain = values.at(HydraulicModel::kValveFlowGain);
  msg.valve_flow_gain_std = stds.at(HydraulicModel::kValveFlowGain);
  msg.dead_volume = values.at(HydraulicModel::kDeadVolume);
  msg.dead_volume_std = stds.at(HydraulicModel::kDeadVolume);
  return msg;
}

// The message's phase constants are the core's StrokePhase values: the cast below relies on it.
static_assert(ModelComparison::PHASE_REST == static_cast<int>(StrokePhase::kRest) &&
                  ModelComparison::PHASE_IMPACT == static_cast<int>(StrokePhase::kImpact) &&
                  ModelComparison::PHASE_DRAWING == static_cast<int>(StrokePhase::kDrawing) &&
                  ModelComparison::PHASE_BOTTOM_HOLD == static_cast<int>(StrokePhase::kBottomHold) &&
                  ModelComparison::PHASE_RELEASE == static_cast<int>(StrokePhase::kRelease) &&
                  ModelComparison::PHASE_RETURN == static_cast<int>(StrokePhase::kReturn) &&
                  kStrokePhaseCount == 6,
              "msg/ModelComparison.msg's PHASE_* differ from StrokePhase");

ModelComparison toModelComparisonMsg(const GridSample& sample, double modelled_pressure, StrokePhase phase,
                                     double simulation_error_rms, double equation_error_rms,
                                     const ros::Time& stamp) {
  ModelComparison msg;
  msg.header.stamp = stamp;
  msg.measured_pressure = sample.p;
  msg.modelled_pressure = modelled_pressure;
  msg.residual = sample.p - modelled_pressure;
  msg.simulation_error_rms = simulation_error_rms;
  msg.equation_error_rms = equation_error_rms;
  msg.position = sample.x;
  msg.velocity = sample.v;
  msg.spool_position = sample.y;
  msg.phase = static_cast<std::uint8_t>(phase);
  msg.phase_name = strokePhaseName(phase);
  return msg;
}

bool isComputed(const ModelComparison& msg) {
  return std::isfinite(msg.modelled_pressure) && std::isfinite(msg.measured_pressure) &&
         std::isfinite(msg.position) && std::isfinite(msg.velocity) && std::isfinite(msg.spool_position) &&
         std::isfinite(msg.simulation_error_rms) && std::isfinite(msg.equation_error_rms);
}

std::string jointNames(const sensor_msgs::JointState& msg) {
  std::string names;
  for (const auto& n : msg.name) names += (names.empty() ? "'" : ", '") + n + "'";
  return names.empty() ? std::string("(no names)") : names;
}

JointSelector::Result JointSelector::select(const sensor_msgs::JointState& msg, StreamSample* sample) {
  std::size_t index = 0;
  if (!joint_name_.empty()) {
    const auto it = std::find(msg.name.begin(), msg.name.end(), joint_name_);
    if (it == msg.name.end()) {
      problem_ = "joint '" + joint_name_ + "' is not in the JointState; it holds " + jointNames(msg) +
                 " (set joint_name to one of them)";
      return Result::kJointMissing;
    }
    index = static_cast<std::size_t>(it - msg.name.begin());
  } else if (msg.position.size() > 1 && ambiguity_.empty()) {
    ambiguity_ = "the position topic holds " + std::to_string(msg.position.size()) + " joints (" +
                 jointNames(msg) + ") and no joint_name is configured: position[0]" +
                 (msg.name.empty() ? std::string() : " ('" + msg.name[0] + "')") +
                 " is taken as the cushion; set joint_name if that is wrong";
  }
  if (index >= msg.position.size()) {
    problem_ = msg.position.empty() ? "JointState without position"
                                    : "JointState names joint '" + joint_name_ + "' but has only " +
                                          std::to_string(msg.position.size()) + " positions";
    return Result::kNoPosition;
  }
  sample->stamp = msg.header.stamp.toSec();
  sample->first = msg.position[index];
  sample->second =
      index < msg.velocity.size() ? msg.velocity[index] : std::numeric_limits<double>::quiet_NaN();
  return Result::kSelected;
}

}  // namespace die_cushion_ident
