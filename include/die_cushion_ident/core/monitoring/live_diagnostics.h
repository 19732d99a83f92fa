#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>

#include "die_cushion_ident/core/control/valve_supervisor.h"
#include "die_cushion_ident/core/estimation/hydraulic_identifier.h"
#include "die_cushion_ident/core/estimation/topic_delay_estimator.h"
#include "die_cushion_ident/core/monitoring/health_report.h"
#include "die_cushion_ident/core/monitoring/live_model_monitor.h"
#include "die_cushion_ident/core/signal/uniform_resampler.h"
#include "die_cushion_ident/core/valve/step_response.h"
#include "die_cushion_ident/core/valve/valve_experiments.h"
#include "die_cushion_ident/core/valve/valve_sweep.h"

namespace die_cushion_ident {

// The live node's diagnostics as pure functions from core state to a HealthReport: each decides its level
// and words from what it is given, so that every branch is tested without a roscore and the node only
// copies the report into diagnostic_updater.

/// All inputs silent this long [s of ROS time] is an error; shorter silences are scheduling, not a fault
/// (a 25 ms stall of a simulation at 40x real time is 1 s of stamps).
constexpr double kInputSilenceLimit = 1.0;
/// RLS updates before an estimate is judged against its physical range (about one stroke).
constexpr std::uint64_t kUpdatesBeforeJudgement = 100;
/// A relative std above this is "converging", not "converged".
constexpr double kConvergedRelativeStd = 0.1;
/// An estimate outside its physical range by more than this many stds is implausible, not uncertain.
constexpr double kImplausibleSigmas = 3.0;

/// What the node knows of one input topic.
struct InputState {
  InputStream stream = InputStream::kPressure;
  std::string topic;                   ///< resolved name
  StreamHealth health;                 ///< the resampler's statistics
  double now = 0.0;                    ///< [s] ROS time
  std::uint64_t rejected = 0;          ///< messages the node or the resampler did not use
  std::string last_rejection;          ///< why the last one was not used
  bool new_wild_stamps = false;        ///< wild stamps since the last report
  double all_inputs_silent_for = 0.0;  ///< [s] since the newest message of any input
  double spool_age = 1e18;             ///< [s] since the last finite spool position (valve topic only)
};

/// [s] of ROS time since the newest message of any input; infinite before the first.
double allInputsSilentFor(const UniformResampler& resampler, double now);

/// Rate, counts and jitter of a topic; ERROR when silent, stale, every message rejected or its clock jumped.
HealthReport inputHealth(const InputState& input);

/// What the node knows of the optional oil temperature topic.
struct OilTemperatureState {
  std::string topic;           ///< resolved name
  OilTemperatureInput input;   ///< its checks and statistics
  double now = 0.0;            ///< [s] ROS time
  std::string last_rejection;  ///< why the last message was not used
  bool model_uses_it = false;  ///< the model has the effect oil_temperature
};

/// The oil temperature topic: OK and its latest value while it arrives (or, not received, where the model
/// does not need it: the topic is optional); WARN when messages were rejected, it fell silent for longer than
/// it holds, or the model needs it and none came.
HealthReport oilTemperatureHealth(const OilTemperatureState& state);

/// The estimates with their stds; ERROR when one is not finite or outside its parameter's physical range
/// (ParameterInfo bounds, the same check as analyze_bag's) by more than kImplausibleSigmas stds.
HealthReport estimatorHealth(const HydraulicModel& model, const HydraulicEstimate& estimate);

/// The sweep's progress, or the valve model in use and how well the last successful sweep's fit
/// (`last_fit`) explains its points; WARN where the last finished sweep's own fit (`last_sweep`) failed.
HealthReport valveHealth(const ValveSweep& sweep, const ServoValveParameters& model_in_use,
                         const ServoValveFit& last_sweep, const ServoValveFit& last_fit);

/// [s] how long a refused valve experiment keeps the experiments' diagnostic at WARN.
constexpr double kRecentRefusal = 30.0;
/// Which output holds the valve (an experiment, the feed-forward), the supervision's view of the inputs and
/// the clock, the last refusal and why, how the last experiment ended, and the last fault the supervisor
/// acted on with the time the valve took to its safe value; WARN for kRecentRefusal after a refusal and
/// while the clock or an input cannot be trusted during an experiment.
HealthReport valveExperimentsHealth(const ValveSupervisor& supervisor, Instant now);
/// What the feed-forward sends and why, the supervisor's limits on it; WARN while it is blocked with a
/// set-point streaming.
HealthReport feedForwardOutputHealth(const ValveSupervisor& supervisor);

/// The free-run error overall and per stroke phase against the warn / error limits [Pa], the live ranking's
/// conclusion, and why nothing is compared yet when nothing is.
HealthReport adequacyHealth(const LiveModelMonitor& monitor, double equation_error_rms, double warn_error,
                            double error_error);

/// What the node knows of the topics' timing.
struct TimingState {
  std::array<double, kInputStreamCount> applied_delays{};  ///< [s]
  std::string joint_name;                                  ///< configured; "" = default
  std::uint64_t derived_velocity_samples = 0;
  double velocity_delay = 0.0;  ///< [s] latency of the velocity stage
  std::string joint_ambiguity;  ///< "" unless the joint could not be told apart
  bool delays_configured = false;
  std::optional<TopicDelayEstimate> estimate;
  std::uint64_t time_base_restarts = 0;  ///< the stamps jumped back and the identification restarted
  double since_restart = 1e18;           ///< [s of stamps] since the last of them
};
/// Stamps that jumped back (rosbag play --loop, a driver restarted) are WARNed about for this long [s of
/// stamps] after the restart, so that a user watching the diagnostics sees why the estimates started over.
constexpr double kRestartWarnFor = 60.0;
/// The topics' clock offsets; WARN when they are large (corrected, but the user should fix the stamping)
/// and for kRestartWarnFor after the stamps jumped back.
HealthReport timingHealth(const TimingState& timing);

/// The last step test: t63 and the sampling it allows; WARN when sample_period exceeds 0.1 t63 or the test
/// failed.
HealthReport stepTestHealth(const std::optional<StepResponse>& response, const std::string& status,
                            bool failed, double sample_period);

}  // namespace die_cushion_ident
