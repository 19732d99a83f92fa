#pragma once

#include <diagnostic_updater/diagnostic_updater.h>
#include <ros/ros.h>
#include <sensor_msgs/FluidPressure.h>
#include <sensor_msgs/JointState.h>
#include <sensor_msgs/Temperature.h>

#include <memory>
#include <mutex>
#include <string>

#include "die_cushion_ident/Reset.h"
#include "die_cushion_ident/SetEffects.h"
#include "die_cushion_ident/ValveSignal.h"
#include "die_cushion_ident/core/monitoring/live_identification.h"
#include "feed_forward_publisher.h"
#include "live_publishers.h"
#include "live_thresholds.h"
#include "message_conversions.h"
#include "ros_parameters.h"
#include "supervised_valve.h"
#include "valve_experiment_services.h"

namespace die_cushion_ident {

/// The ROS face of the identification, shared by the nodelet and the standalone node: subscribes to the
/// three input topics and hands their messages to the core's LiveIdentification (on message stamps) and to
/// the SupervisedValve (as they arrive); its results go out through LivePublishers, the valve experiments
/// through ValveExperimentServices, the feed-forward through FeedForwardPublisher, and everything that drives
/// the valve through the SupervisedValve with its own watchdog; the services ~set_effects and ~reset and the
/// diagnostics are its own. The identification's state is guarded by one mutex, so a multi-threaded nodelet
/// manager may call back concurrently; the valve's supervision has a mutex of its own, taken after it.
class IdentificationNode {
 public:
  /// Throws std::invalid_argument with every invalid parameter listed. `name` prefixes the diagnostics: the
  /// nodelet's own name inside a manager (two identification nodelets must not collide), else the node's.
  IdentificationNode(ros::NodeHandle nh, ros::NodeHandle pnh,
                     const std::string& name = ros::this_node::getName());
  /// True while a sweep or a step test commands the valve (the owner then takes callbacks more often).
  bool valveExperimentRunning() const { return valve_->experimentHoldsValve(); }

 private:
  void onPressure(const sensor_msgs::FluidPressure::ConstPtr& msg);
  void onPosition(const sensor_msgs::JointState::ConstPtr& msg);
  void onValve(const ValveSignal::ConstPtr& msg);
  /// The optional oil temperature (degC, as the message and the core have it).
  void onOilTemperature(const sensor_msgs::Temperature::ConstPtr& msg);
  void push(InputStream stream, const StreamSample& sample);
  void reject(InputStream stream, const std::string& why);
  void onGridSample(const GridSample& g, const HydraulicIdentifier& identifier,
                    const std::optional<LiveRanking>& ranking);
  bool setEffects(SetEffects::Request& request, SetEffects::Response& response);
  bool reset(Reset::Request& request, Reset::Response& response);
  void addDiagnostics();
  void diagnoseInput(diagnostic_updater::DiagnosticStatusWrapper& status, InputStream stream);

  ros::NodeHandle nh_, pnh_;
  SweepLimits limits_;
  NodeSettings settings_;

  mutable std::mutex mutex_;
  // The identification, model comparison, ranking, settings survey and clock offsets, free of ROS.
  std::unique_ptr<LiveIdentification> live_;
  std::uint64_t generation_ = 0;  // live_'s pipeline generation the feed-forward has seen
  JointSelector joints_;
  bool ambiguity_reported_ = false;
  std::uint64_t rejected_[kInputStreamCount] = {0, 0, 0};
  std::uint64_t wild_reported_[kInputStreamCount] = {0, 0, 0};  // wild stamps at the last diagnostic
  std::string last_rejection_[kInputStreamCount];
  std::string last_oil_rejection_;

  // Everything that drives the valve, with its watchdog; destroyed after the services that use it, it sends
  // the valve back to its offset ("shutdown") and ramps the feed-forward out.
  std::unique_ptr<SupervisedValve> valve_;
  std::unique_ptr<FeedForwardPublisher> feed_forward_;
  std::unique_ptr<LivePublishers> publishers_;
  std::unique_ptr<ValveExperimentServices> experiments_;
  diagnostic_updater::Updater updater_;
  ros::Time last_diagnostics_;  // when the diagnostics last ran (a later time earlier: the clock jumped back)
  ros::Timer diagnostic_timer_;
  std::unique_ptr<LiveThresholds> thresholds_;  // dynamic_reconfigure of settings_'s live thresholds
  // Last: shut down first, so that no callback reaches a member already destroyed.
  ros::Subscriber pressure_sub_, position_sub_, valve_sub_, oil_temperature_sub_;
  ros::ServiceServer effects_srv_, reset_srv_;
};

}  // namespace die_cushion_ident
