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
#include "die_cushion_ident/core/analysis/effect_ranking.h"
#include "die_cushion_ident/core/analysis/free_run_pressure.h"
#include "die_cushion_ident/core/estimation/identification_pipeline.h"
#include "die_cushion_ident/core/analysis/stroke_phase_classifier.h"
#include "die_cushion_ident/core/signal/topic_delay_estimator.h"
#include "die_cushion_ident/core/valve/step_response.h"
#include "die_cushion_ident/core/valve/valve_step_test.h"
#include "die_cushion_ident/core/valve/valve_sweep.h"
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
  /// True while a sweep commands the valve (the owner then takes callbacks more often).
  bool sweepRunning() const;

 private:
  void onPressure(const sensor_msgs::FluidPressure::ConstPtr& msg);
  void onPosition(const sensor_msgs::JointState::ConstPtr& msg);
  void onValve(const ValveSignal::ConstPtr& msg);
  void push(InputStream stream, const StreamSample& sample);
  void rebuildPipeline();
  void onGridSample(const GridSample& g, const HydraulicIdentifier& identifier);
  void onIdentificationStep(const HydraulicIdentifier& identifier);

  void onSweepTimer(const ros::TimerEvent&);
  void publishSweepCommand(double voltage);
  void publishFrequencyResponse();
  void finishSweep();
  PlantCondition plantCondition(double now) const;

  bool startSweep(StartSweep::Request& request, StartSweep::Response& response);
  bool abortSweep(AbortSweep::Request& request, AbortSweep::Response& response);
  bool startStepTest(StartStepTest::Request& request, StartStepTest::Response& response);
  void onStepTimer(const ros::TimerEvent&);
  /// Times the pressure's answer once the grid holds the whole step (findStepResponses on the window).
  void analyzeStepTest(double grid_time);
  void diagnoseStepTest(diagnostic_updater::DiagnosticStatusWrapper& status);
  bool setEffects(SetEffects::Request& request, SetEffects::Response& response);
  bool reset(Reset::Request& request, Reset::Response& response);

  // The ranking (and the formula search) take up to seconds on a long window: they run on their own thread
  // on a copy of the window, so that neither the input callbacks nor the sweep's supervision wait for them;
  // the result is published from the first grid sample after it is ready. A rebuilt pipeline bumps the
  // generation, and a ranking started before is dropped.
  struct RankingJob {
    EffectRankingResult result;
    int cycles = 0;
    double seconds = 0.0;  // wall-clock duration
    int generation = 0;
  };
  /// Starts a ranking on the current window unless one is running; publishes a finished one.
  void rankEffects();
  void collectRanking();
  void publishRanking(RankingJob job);

  /// ROS time since the newest message of any input [s].
  double allInputsSilentFor() const;
  void diagnoseInput(diagnostic_updater::DiagnosticStatusWrapper& status, InputStream stream);
  void diagnoseEstimator(diagnostic_updater::DiagnosticStatusWrapper& status);
  void diagnoseValve(diagnostic_updater::DiagnosticStatusWrapper& status);
  void diagnoseAdequacy(diagnostic_updater::DiagnosticStatusWrapper& status);
  void diagnoseTiming(diagnostic_updater::DiagnosticStatusWrapper& status);
  /// Estimates the topics' clock offsets on the ranking window once (unless configured); a significant
  /// offset is applied after the current message (the pipeline is rebuilt, so not from its own callback).
  void estimateTopicDelays(const std::vector<GridSample>& grid);
  void applyPendingTopicDelays();

  ros::NodeHandle nh_, pnh_;
  IdentificationConfig config_;
  SweepLimits limits_;
  NodeSettings settings_;

  mutable std::mutex mutex_;
  std::unique_ptr<IdentificationPipeline> pipeline_;
  std::unique_ptr<FreeRunPressure> free_run_;
  StrokePhaseClassifier classifier_;
  ValveSweep sweep_;
  ros::Timer sweep_timer_;
  bool sweep_commanding_ = false;  // the sweep timer runs (until the offset has been sent)
  ServoValveFit last_valve_fit_;
  ValveStepTest step_test_{SweepLimits()};
  ros::Timer step_timer_;
  double step_analysis_due_ = std::numeric_limits<double>::infinity();  // grid time to time the answer
  std::optional<StepResponse> last_step_response_;
  std::string step_status_ = "no step test run (~start_step_test)";
  bool sweep_reported_ = false;  // the ended sweep's results have been published
  std::size_t published_points_ = 0;

  // Latest comparison values (grid rate), published at the identification rate.
  GridSample last_grid_;
  double modelled_pressure_ = 0.0;
  double residual_square_mean_ = 0.0;  // exponentially weighted over ~5 s of free-run samples
  std::uint64_t residual_samples_ = 0;
  StrokePhase phase_ = StrokePhase::kRest;
  double phase_square_error_[kStrokePhaseCount] = {0, 0, 0, 0, 0, 0};  // per phase, same weighting
  const char* comparison_blocker_ = "";  // why the last grid sample could not be compared ("" = it could)

  // Latest plant signals for the sweep's safety checks: values and their stamps [s].
  double pressure_ = std::numeric_limits<double>::quiet_NaN(), pressure_stamp_ = -1e18;
  CausalVelocity velocity_;  // of the raw position messages, for "at rest"
  JointSelector joints_;
  bool ambiguity_reported_ = false;
  double spool_stamp_ = -1e18;
  std::uint64_t rejected_[kInputStreamCount] = {0, 0, 0};
  std::uint64_t wild_reported_[kInputStreamCount] = {0, 0, 0};  // wild stamps at the last diagnostic
  std::string last_rejection_[kInputStreamCount];

  ros::Subscriber pressure_sub_, position_sub_, valve_sub_;
  // Clock offsets between the topics: configured, or estimated once from the data.
  std::optional<TopicDelayEstimate> delay_estimate_;
  bool delays_pending_ = false;
  // The last grid samples for the live effect ranking, and its latest result.
  std::deque<GridSample> window_;
  double last_ranking_time_ = -1e18;
  std::optional<EffectRankingResult> ranking_;
  std::future<RankingJob> ranking_job_;
  int ranking_generation_ = 0;
  double last_ranking_seconds_ = std::numeric_limits<double>::quiet_NaN();
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
