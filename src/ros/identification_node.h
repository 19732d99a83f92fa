#pragma once

#include <diagnostic_updater/diagnostic_updater.h>
#include <ros/callback_queue.h>
#include <ros/ros.h>
#include <sensor_msgs/FluidPressure.h>
#include <sensor_msgs/JointState.h>

#include <atomic>
#include <deque>
#include <future>
#include <limits>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include "die_cushion_ident/AbortSweep.h"
#include "die_cushion_ident/Reset.h"
#include "die_cushion_ident/SetEffects.h"
#include "die_cushion_ident/StartStepTest.h"
#include "die_cushion_ident/StartSweep.h"
#include "die_cushion_ident/ValveSignal.h"
#include "die_cushion_ident/core/monitoring/health_report.h"
#include "die_cushion_ident/core/monitoring/live_identification.h"
#include "die_cushion_ident/core/valve/step_response.h"
#include "die_cushion_ident/core/valve/valve_experiments.h"
#include "die_cushion_ident/core/signal/velocity_from_position.h"
#include "feed_forward_publisher.h"
#include "message_conversions.h"
#include "ros_parameters.h"

namespace die_cushion_ident {

/// The ROS face of the identification, shared by the nodelet and the standalone node: subscribes to the
/// three input topics, runs the core pipeline on message stamps, publishes estimates, the model comparison
/// and the valve sweep's results, offers the services and reports diagnostics. All core state is guarded
/// by one mutex, so a multi-threaded nodelet manager may call back concurrently.
class IdentificationNode {
 public:
  /// Throws std::invalid_argument with every invalid parameter listed. `name` prefixes the diagnostics: the
  /// nodelet's own name inside a manager (two identification nodelets must not collide), else the node's.
  IdentificationNode(ros::NodeHandle nh, ros::NodeHandle pnh, const std::string& name = ros::this_node::getName());
  /// Aborts a running sweep ("shutdown") and sends the valve back to its offset.
  ~IdentificationNode();
  /// True while a sweep or a step test commands the valve (the owner then takes callbacks more often).
  bool valveExperimentRunning() const;

 private:
  void onPressure(const sensor_msgs::FluidPressure::ConstPtr& msg);
  void onPosition(const sensor_msgs::JointState::ConstPtr& msg);
  void onValve(const ValveSignal::ConstPtr& msg);
  void push(InputStream stream, const StreamSample& sample);
  void onGridSample(const GridSample& g, const HydraulicIdentifier& identifier,
                    const std::optional<LiveRanking>& ranking);
  void onIdentificationStep(const HydraulicIdentifier& identifier);

  /// Supervises the experiment that holds the valve and sends its command; stops once it handed back.
  void onExperimentTimer(const ros::TimerEvent&);
  void startExperimentTimer();
  void publishSweepCommand(double voltage);
  void publishFrequencyResponse();
  void finishSweep();
  PlantCondition plantCondition(double now) const;

  bool startSweep(StartSweep::Request& request, StartSweep::Response& response);
  bool abortSweep(AbortSweep::Request& request, AbortSweep::Response& response);
  bool startStepTest(StartStepTest::Request& request, StartStepTest::Response& response);
  /// The step test's end: its status, and when to time the pressure's answer.
  void stepTestEnded();
  /// Times the pressure's answer once the grid holds the whole step (findStepResponses on the window).
  void analyzeStepTest(double grid_time);
  void diagnoseStepTest(diagnostic_updater::DiagnosticStatusWrapper& status);
  bool setEffects(SetEffects::Request& request, SetEffects::Response& response);
  bool reset(Reset::Request& request, Reset::Response& response);

  void publishRanking(const LiveRanking& ranking);

  void diagnoseInput(diagnostic_updater::DiagnosticStatusWrapper& status, InputStream stream);
  void diagnoseEstimator(diagnostic_updater::DiagnosticStatusWrapper& status);
  void diagnoseValve(diagnostic_updater::DiagnosticStatusWrapper& status);
  void diagnoseExperiments(diagnostic_updater::DiagnosticStatusWrapper& status);
  void diagnoseAdequacy(diagnostic_updater::DiagnosticStatusWrapper& status);
  void diagnoseTiming(diagnostic_updater::DiagnosticStatusWrapper& status);

  ros::NodeHandle nh_, pnh_;
  SweepLimits limits_;
  NodeSettings settings_;

  mutable std::mutex mutex_;
  // The identification, model comparison, ranking, settings survey and clock offsets, free of ROS.
  std::unique_ptr<LiveIdentification> live_;
  std::uint64_t generation_ = 0;  // live_'s pipeline generation the feed-forward has seen
  // The sweep and the step test, one at a time, behind the same interlocks; the feed-forward pauses for them.
  ValveExperiments experiments_{SweepLimits()};
  ros::Timer experiment_timer_;  // runs while an experiment holds the valve (until it handed it back)
  ServoValveFit last_valve_fit_;
  bool step_test_reported_ = true;  // the ended step test's status is set
  double step_analysis_due_ = std::numeric_limits<double>::infinity();  // grid time to time the answer
  std::optional<StepResponse> last_step_response_;
  std::string step_status_ = "no step test run (~start_step_test)";
  bool step_failed_ = false;  // aborted, or its answer could not be timed
  bool sweep_reported_ = false;  // the ended sweep's results have been published
  std::size_t published_points_ = 0;

  // Latest plant signals for the sweep's safety checks: values and their stamps [s].
  double pressure_ = std::numeric_limits<double>::quiet_NaN(), pressure_stamp_ = -1e18;
  CausalVelocity velocity_;  // of the raw position messages, for "at rest"
  JointSelector joints_;
  bool ambiguity_reported_ = false;
  double spool_stamp_ = -1e18;
  ros::Time last_diagnostics_;  // when the diagnostics last ran (a later time earlier: the clock jumped back)
  /// [s] how long all inputs may be silent (against the clock) before every signal counts as stale.
  static constexpr double kInputSilenceTolerance = 0.2;
  std::uint64_t rejected_[kInputStreamCount] = {0, 0, 0};
  std::uint64_t wild_reported_[kInputStreamCount] = {0, 0, 0};  // wild stamps at the last diagnostic
  std::string last_rejection_[kInputStreamCount];

  ros::Subscriber pressure_sub_, position_sub_, valve_sub_;
  ros::Publisher ranking_pub_;

  ros::Publisher estimate_pub_, comparison_pub_, response_pub_, valve_model_pub_, command_pub_, markers_pub_;
  std::string frame_id_ = "die_cushion";
  std::uint64_t steps_since_markers_ = 0;
  ros::ServiceServer start_srv_, abort_srv_, effects_srv_, reset_srv_, step_srv_;
  std::unique_ptr<FeedForwardPublisher> feed_forward_;
  diagnostic_updater::Updater updater_;
  ros::Timer diagnostic_timer_;
};

/// Takes the node's callbacks in batches every 5 ms (at most 20 ms of ROS time when a simulation runs faster
/// than real time; every 0.2 ms while a sweep commands the valve) until `stop` or shutdown, instead of waking
/// up for each of the 3000 messages per second: the estimates run on stamps, so batching costs nothing but
/// saves most of roscpp's per-message thread hand-overs.
void spinBatched(ros::CallbackQueue& queue, const IdentificationNode& node, const std::atomic<bool>& stop);

}  // namespace die_cushion_ident
