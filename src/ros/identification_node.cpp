#include "identification_node.h"

#include <chrono>
#include <cmath>
#include <sstream>
#include <thread>

#include "cushion_markers.h"
#include "die_cushion_ident/EffectRanking.h"
#include "die_cushion_ident/FrequencyResponse.h"
#include "die_cushion_ident/ModelComparison.h"
#include "die_cushion_ident/ParameterEstimate.h"
#include "die_cushion_ident/ValveModel.h"
#include "die_cushion_ident/core/util/formatted.h"
#include "die_cushion_ident/core/monitoring/live_diagnostics.h"
#include "message_conversions.h"

namespace die_cushion_ident {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

const char* pushResultText(UniformResampler::PushResult result) {
  switch (result) {
    case UniformResampler::PushResult::kNonFinite:
      return "non-finite stamp or value";
    case UniformResampler::PushResult::kDuplicate:
      return "duplicate stamp";
    case UniformResampler::PushResult::kOutOfOrder:
      return "stamp older than the previous one";
    case UniformResampler::PushResult::kImplausible:
      return "value outside the physically plausible range";
    default:
      return "";
  }
}

/// Copies a core health report into a diagnostic_updater status (HealthLevel has diagnostic_msgs' values).
void fill(diagnostic_updater::DiagnosticStatusWrapper& status, const HealthReport& report) {
  status.summary(static_cast<unsigned char>(report.level), report.message);
  for (const auto& [key, value] : report.values) status.add(key, value);
}

}  // namespace

IdentificationNode::IdentificationNode(ros::NodeHandle nh, ros::NodeHandle pnh, const std::string& name)
    : nh_(nh), pnh_(pnh), updater_(nh, pnh, name) {
  IdentificationConfig config;
  const auto problems = loadParameters(pnh_, &config, &limits_, &settings_);
  if (!problems.empty()) throw std::invalid_argument("invalid parameters:\n  " + joined(problems, "\n  "));
  experiments_ = ValveExperiments(limits_);
  experiments_.setCommandHold(config.valve_command_hold);
  joints_ = JointSelector(settings_.joint_name);
  feed_forward_ = std::make_unique<FeedForwardPublisher>(
      nh_, pnh_, settings_.valve_gain, settings_.feed_forward_max_age, limits_.min_voltage, limits_.max_voltage,
      settings_.feed_forward_slew_rate, settings_.feed_forward_parameter_rate);
  LiveIdentificationSettings live;
  live.monitor.ranking_window = settings_.effect_ranking_window;
  live.monitor.ranking_period = settings_.effect_ranking_period;
  live.choose_settings = settings_.choose_settings;
  live.survey_seconds = settings_.survey_seconds;
  live.configured = configuredKeys(pnh_);
  live_ = std::make_unique<LiveIdentification>(config, live);
  live_->setCallbacks(
      [this](const GridSample& g, const HydraulicIdentifier& identifier, const std::optional<LiveRanking>& ranking) {
        onGridSample(g, identifier, ranking);
      },
      [this](const HydraulicIdentifier& identifier) { onIdentificationStep(identifier); });
  generation_ = live_->generation();

  estimate_pub_ = pnh_.advertise<ParameterEstimate>("estimate", 10);
  comparison_pub_ = pnh_.advertise<ModelComparison>("model_comparison", 10);
  response_pub_ = pnh_.advertise<FrequencyResponse>("frequency_response", 1, true);
  valve_model_pub_ = pnh_.advertise<ValveModel>("valve_model", 1, true);
  command_pub_ = nh_.advertise<ValveSignal>("valve_command", 10);
  markers_pub_ = pnh_.advertise<visualization_msgs::MarkerArray>("markers", 2);
  ranking_pub_ = pnh_.advertise<die_cushion_ident::EffectRanking>("effect_ranking", 1, true);
  pnh_.param("frame_id", frame_id_, frame_id_);

  // The estimates run on stamps, so pressure and position may arrive batched (Nagle: fewer wake-ups and
  // system calls); the valve topic feeds the sweep's safety checks and must not wait.
  pressure_sub_ = nh_.subscribe("pressure", 1000, &IdentificationNode::onPressure, this);
  position_sub_ = nh_.subscribe("position", 1000, &IdentificationNode::onPosition, this);
  valve_sub_ =
      nh_.subscribe("valve", 1000, &IdentificationNode::onValve, this, ros::TransportHints().tcpNoDelay());

  start_srv_ = pnh_.advertiseService("start_sweep", &IdentificationNode::startSweep, this);
  abort_srv_ = pnh_.advertiseService("abort_sweep", &IdentificationNode::abortSweep, this);
  effects_srv_ = pnh_.advertiseService("set_effects", &IdentificationNode::setEffects, this);
  reset_srv_ = pnh_.advertiseService("reset", &IdentificationNode::reset, this);
  step_srv_ = pnh_.advertiseService("start_step_test", &IdentificationNode::startStepTest, this);

  updater_.setHardwareID("die_cushion");
  for (InputStream stream : {InputStream::kPressure, InputStream::kPosition, InputStream::kValve}) {
    updater_.add(
        std::string("input ") + inputStreamName(stream),
        [this, stream](diagnostic_updater::DiagnosticStatusWrapper& s) { diagnoseInput(s, stream); });
  }
  updater_.add("estimator", this, &IdentificationNode::diagnoseEstimator);
  updater_.add("valve model", this, &IdentificationNode::diagnoseValve);
  updater_.add("model adequacy", this, &IdentificationNode::diagnoseAdequacy);
  updater_.add("input timing", this, &IdentificationNode::diagnoseTiming);
  updater_.add("settings", [this](diagnostic_updater::DiagnosticStatusWrapper& s) {
    std::lock_guard<std::mutex> lock(mutex_);
    fill(s, live_->settingsHealth());
  });
  updater_.add("step test", this, &IdentificationNode::diagnoseStepTest);
  updater_.add("valve experiments", this, &IdentificationNode::diagnoseExperiments);
  updater_.add("feed-forward", [this](diagnostic_updater::DiagnosticStatusWrapper& s) { feed_forward_->diagnose(s); });
  // diagnostic_updater waits for ROS time to reach its next period: after the clock jumps back (rosbag play
  // --loop) it would stay silent for a whole loop, right when the restart needs telling. Forced then.
  diagnostic_timer_ = nh_.createTimer(ros::Duration(0.1), [this](const ros::TimerEvent&) {
    const ros::Time now = ros::Time::now();
    if (now < last_diagnostics_) {
      updater_.force_update();
    } else {
      updater_.update();
    }
    last_diagnostics_ = now;
  });

  ROS_INFO_STREAM("die_cushion_ident: identifying "
                  << joined(live_->pipeline().identifier().model().effectNames(), ", ")
                  << (config.effects.empty() && config.custom_effects.empty() ? "base model" : "") << " on "
                  << nh_.resolveName("pressure") << ", " << nh_.resolveName("position") << ", "
                  << nh_.resolveName("valve"));
}

IdentificationNode::~IdentificationNode() {
  std::lock_guard<std::mutex> lock(mutex_);
  experiments_.abort("shutdown");
  if (const auto u = experiments_.command(ros::Time::now().toSec())) publishSweepCommand(*u);
}

bool IdentificationNode::valveExperimentRunning() const {
  std::lock_guard<std::mutex> lock(mutex_);
  // A step test's interlocks are as time-critical as a sweep's: both want the fine spin.
  return experiments_.holdsValve();
}

// ---- inputs ----

void IdentificationNode::onPressure(const sensor_msgs::FluidPressure::ConstPtr& msg) {
  std::lock_guard<std::mutex> lock(mutex_);
  const double stamp = msg->header.stamp.toSec();
  if (std::isfinite(msg->fluid_pressure)) {
    pressure_ = msg->fluid_pressure;
    pressure_stamp_ = stamp;
  }
  push(InputStream::kPressure, {stamp, msg->fluid_pressure, kNaN});
}

void IdentificationNode::onPosition(const sensor_msgs::JointState::ConstPtr& msg) {
  std::lock_guard<std::mutex> lock(mutex_);
  const int s = static_cast<int>(InputStream::kPosition);
  StreamSample sample;
  const JointSelector::Result result = joints_.select(*msg, &sample);
  if (result != JointSelector::Result::kSelected) {
    ++rejected_[s];
    last_rejection_[s] = joints_.problem();
    ROS_WARN_THROTTLE(5.0, "die_cushion_ident: position message rejected: %s", joints_.problem().c_str());
    return;
  }
  if (joints_.ambiguous() && !ambiguity_reported_) {
    ambiguity_reported_ = true;
    ROS_WARN("die_cushion_ident: %s", joints_.ambiguity().c_str());
  }
  // The safety check needs a velocity even when the topic carries none: a least-squares slope over 20 ms
  // (a difference of two messages would turn position noise into motion).
  velocity_.push(sample.stamp, sample.first);
  push(InputStream::kPosition, sample);
}

void IdentificationNode::onValve(const ValveSignal::ConstPtr& msg) {
  std::lock_guard<std::mutex> lock(mutex_);
  const double stamp = msg->header.stamp.toSec();
  if (std::isfinite(msg->spool_position)) spool_stamp_ = stamp;
  push(InputStream::kValve, {stamp, msg->voltage, msg->spool_position});
  if (experiments_.running() != ValveExperiments::Kind::kSweep) return;
  experiments_.addValveSample(stamp, msg->voltage, msg->spool_position);
  if (experiments_.sweep().points().size() != published_points_) publishFrequencyResponse();
  if (!experiments_.sweep().running()) finishSweep();
}

void IdentificationNode::push(InputStream stream, const StreamSample& sample) {
  const auto result = live_->push(stream, sample);
  for (const LiveEvent& e : live_->takeEvents()) {
    if (e.level == HealthLevel::kOk) {
      ROS_INFO("die_cushion_ident: %s", e.text.c_str());
    } else {
      ROS_WARN("die_cushion_ident: %s", e.text.c_str());
    }
  }
  // A new pipeline (settings, offsets or model changed): the feed-forward ramps its parameters in again.
  if (live_->generation() != generation_) {
    generation_ = live_->generation();
    feed_forward_->modelChanged();
  }
  if (result == UniformResampler::PushResult::kHeld || result == UniformResampler::PushResult::kAccepted ||
      result == UniformResampler::PushResult::kRestarted) {
    // Held: a stamp far off the time base, until the other topics confirm the jump (counted as wild by the
    // resampler when they do not).
    return;
  }
  const int s = static_cast<int>(stream);
  ++rejected_[s];
  last_rejection_[s] = pushResultText(result);
  ROS_WARN_THROTTLE(5.0, "die_cushion_ident: %s message rejected: %s", inputStreamName(stream),
                    pushResultText(result));
}

// ---- identification and model comparison ----

void IdentificationNode::onGridSample(const GridSample& g, const HydraulicIdentifier& identifier,
                                      const std::optional<LiveRanking>& ranking) {
  if (ranking) publishRanking(*ranking);
  analyzeStepTest(g.t);
  // The feed-forward pauses while an experiment holds the valve (its command would add to the experiment's
  // on the cell controller's adder).
  feed_forward_->update(g, identifier.model(), identifier.physicalParameters(), live_->monitor().estimatorStarted(),
                        last_valve_fit_.success ? &last_valve_fit_.parameters : nullptr, experiments_.holder());
}

void IdentificationNode::onIdentificationStep(const HydraulicIdentifier& identifier) {
  // rviz needs no more than 10 Hz.
  const bool markers =
      markers_pub_.getNumSubscribers() > 0 && ++steps_since_markers_ * live_->config().identification_period >= 0.1;
  const bool estimate = estimate_pub_.getNumSubscribers() > 0;
  const bool comparison = comparison_pub_.getNumSubscribers() > 0;
  if (!markers && !estimate && !comparison) return;  // the estimate costs allocations: only when wanted
  const HydraulicEstimate e = identifier.estimate();
  const ros::Time stamp(std::max(e.t, 0.0));
  if (estimate) {
    const ParameterVector values = e.values(), stds = e.standardDeviations();
    ParameterEstimate msg = toParameterEstimateMsg(identifier.model(), {values.data(), values.data() + values.size()},
                                                   {stds.data(), stds.data() + stds.size()}, stamp);
    msg.equation_error_rms = e.equation_error_rms;
    msg.updates = e.updates;
    msg.skipped_unexcited = e.skipped_unexcited;
    msg.skipped_invalid = e.skipped_invalid;
    estimate_pub_.publish(msg);
  }
  const LiveModelMonitor& monitor = live_->monitor();
  if (markers) {
    steps_since_markers_ = 0;
    CushionView view;
    view.position = monitor.lastSample().x;
    view.pressure = monitor.lastSample().p;
    view.simulation_error = monitor.simulationErrorRms();
    view.phase = monitor.phase();
    markers_pub_.publish(cushionMarkers(live_->config().geometry, view, e, frame_id_, stamp));
  }
  if (comparison) {
    const GridSample& g = monitor.lastSample();
    const ModelComparison msg =
        toModelComparisonMsg(g, monitor.modelledPressure(), monitor.phase(), monitor.simulationErrorRms(),
                             e.equation_error_rms, ros::Time(std::max(g.t, 0.0)));
    // Only what was computed: while the model cannot run, the adequacy diagnostic says why instead.
    if (isComputed(msg)) comparison_pub_.publish(msg);
  }
}

void IdentificationNode::publishRanking(const LiveRanking& ranking) {
  ROS_DEBUG("die_cushion_ident: effect ranking took %.3f s on its own thread", ranking.seconds);
  const EffectRankingResult& result = ranking.result;
  die_cushion_ident::EffectRanking msg;
  msg.header.stamp = ros::Time(std::max(live_->monitor().lastSample().t, 0.0));
  msg.cycles = ranking.cycles;
  for (const auto& c : result.candidates) {
    msg.effects.push_back(c.effect);
    msg.error_reduction.push_back(c.error_reduction);
    msg.verdicts.push_back(verdictName(c.verdict));
    msg.explanations.push_back(c.explanation);
  }
  msg.held_out_error_rms = result.base_error_rms;
  msg.best_error_rms = result.best_error_rms;
  msg.noise_rms = result.noise_rms;
  msg.residual_unexplained = result.residual_unexplained;
  for (const auto& step : result.steps) {
    msg.steps.push_back(step.add);
    msg.step_error_rms.push_back(step.held_out_error_rms);
  }
  for (const auto& p : result.proposals) {
    msg.proposals.push_back(p.spec());
    msg.proposal_error_reduction.push_back(p.error_reduction);
    msg.proposal_verdicts.push_back(verdictName(p.verdict));
    msg.proposal_explanations.push_back(p.explanation);
  }
  msg.conclusion = result.conclusion;
  ranking_pub_.publish(msg);
}

// ---- step test (paper, section 5.2) ----

bool IdentificationNode::startStepTest(StartStepTest::Request& req, StartStepTest::Response& res) {
  std::lock_guard<std::mutex> lock(mutex_);
  StepTestRequest request;
  request.offset = req.offset;
  request.step = req.step;
  request.duration = req.duration;
  request.settle = req.settle;
  const double now = ros::Time::now().toSec();
  const std::string refusal = experiments_.startStepTest(request, now, plantCondition(now));
  const ValveStepTest& test = experiments_.stepTest();
  res.success = refusal.empty();
  res.message = res.success ? formatted("step test started: %g V", test.request().step) +
                                  formatted(" from %g V", test.request().offset)
                            : "step test refused: " + refusal;
  if (!res.success) {
    ROS_WARN("die_cushion_ident: %s", res.message.c_str());
    return true;
  }
  step_status_ = "running";
  step_failed_ = false;
  step_test_reported_ = false;
  startExperimentTimer();
  ROS_INFO("die_cushion_ident: %s", res.message.c_str());
  return true;
}

void IdentificationNode::stepTestEnded() {
  if (step_test_reported_ || experiments_.stepTest().running()) return;
  step_test_reported_ = true;
  const ValveStepTest& test = experiments_.stepTest();
  if (test.state() == ValveStepTest::State::kAborted) {
    step_failed_ = true;
    step_status_ = "aborted: " + test.abortReason();
    ROS_WARN("die_cushion_ident: step test %s", step_status_.c_str());
  } else {
    step_status_ = "finished; timing the pressure's answer";
    step_analysis_due_ = test.stepTime() + test.request().duration + 0.2;
  }
}

void IdentificationNode::analyzeStepTest(double grid_time) {
  if (!(grid_time >= step_analysis_due_)) return;
  step_analysis_due_ = std::numeric_limits<double>::infinity();
  const std::vector<GridSample> grid(live_->monitor().window().begin(), live_->monitor().window().end());
  for (const StepResponse& r : findStepResponses(grid)) {
    if (std::abs(r.start - experiments_.stepTest().stepTime()) > 0.05) continue;
    last_step_response_ = r;
    step_failed_ = false;
    step_status_ = formatted("t63 %.1f ms", r.t63 * 1e3);
    ROS_INFO("die_cushion_ident: step test: %.1f -> %.1f bar, t63 %.1f ms (sample_period at most %.2f ms)",
             r.initial_pressure * 1e-5, r.final_pressure * 1e-5, r.t63 * 1e3, r.recommendedMaxSamplingTime() * 1e3);
    return;
  }
  step_failed_ = true;
  step_status_ = "the pressure's answer could not be timed (it did not settle, changed less than 2 bar, or "
                 "the cushion moved)";
}

void IdentificationNode::diagnoseStepTest(diagnostic_updater::DiagnosticStatusWrapper& status) {
  std::lock_guard<std::mutex> lock(mutex_);
  fill(status, stepTestHealth(last_step_response_, step_status_, step_failed_, live_->config().resampler.sample_period));
}

// ---- valve sweep ----

PlantCondition IdentificationNode::plantCondition(double now) const {
  // Each signal's age against the newest input stamp, plus the time all inputs have been silent once that
  // exceeds kInputSilenceTolerance. Against the clock alone, messages queued behind a burst looked stale:
  // under /use_sim_time a simulator catching up after a stall advances /clock, which ROS applies at once,
  // ahead of the measurements still in the callback queue (live_sweep aborted at 73-86 ms, pressure or
  // spool, on a loaded 2-core machine). A dead sensor still ages while the others keep coming; a dead bus
  // ages everything once its silence passes the tolerance; a signal never received is infinitely old.
  PlantCondition c;
  const double newest = std::max(pressure_stamp_, spool_stamp_);
  const double silence = now - newest;
  const double silent_for = silence > kInputSilenceTolerance ? silence : 0.0;
  c.pressure = pressure_;
  c.pressure_age = newest - pressure_stamp_ + silent_for;
  c.velocity = velocity_.velocity();
  c.spool_age = newest - spool_stamp_ + silent_for;
  return c;
}

void IdentificationNode::startExperimentTimer() {
  // Commands at twice the valve rate, so that every valve update finds a fresh one despite scheduling jitter.
  experiment_timer_ =
      nh_.createTimer(ros::Duration(0.5 * limits_.command_period), &IdentificationNode::onExperimentTimer, this);
}

void IdentificationNode::onExperimentTimer(const ros::TimerEvent&) {
  std::lock_guard<std::mutex> lock(mutex_);
  const double now = ros::Time::now().toSec();
  experiments_.supervise(now, plantCondition(now));
  if (const auto u = experiments_.command(now)) publishSweepCommand(*u);
  if (experiments_.running() != ValveExperiments::Kind::kNone) return;
  if (!sweep_reported_) finishSweep();
  stepTestEnded();
  if (!experiments_.holdsValve()) experiment_timer_.stop();  // the offset has been sent
}

void IdentificationNode::publishSweepCommand(double voltage) {
  ValveSignal msg;
  msg.header.stamp = ros::Time::now();
  msg.voltage = voltage;
  msg.spool_position = kNaN;
  command_pub_.publish(msg);
}

void IdentificationNode::publishFrequencyResponse() {
  const ValveSweep& sweep = experiments_.sweep();
  published_points_ = sweep.points().size();
  response_pub_.publish(
      toFrequencyResponseMsg(sweep.points(), sweep.fit(), sweepStateName(sweep.state()), ros::Time::now()));
}

void IdentificationNode::finishSweep() {
  if (sweep_reported_) return;
  sweep_reported_ = true;
  publishFrequencyResponse();
  const ValveSweep& sweep = experiments_.sweep();
  const ServoValveFit& fit = sweep.fit();
  ValveModel msg = toValveModelMsg(fit, ros::Time::now());
  if (sweep.state() == ValveSweep::State::kAborted) {
    msg.success = false;
    msg.message = "sweep aborted: " + sweep.abortReason();
    ROS_WARN("die_cushion_ident: %s", msg.message.c_str());
  } else {
    if (fit.success) {
      last_valve_fit_ = fit;
      live_->setValveModel(fit.parameters);
      ROS_INFO("die_cushion_ident: valve identified: %.1f Hz, damping %.2f, gain %.4f 1/V, dead time %.2f ms",
               fit.parameters.natural_frequency, fit.parameters.damping, fit.parameters.gain,
               fit.parameters.dead_time * 1e3);
    } else {
      ROS_WARN("die_cushion_ident: valve fit failed: %s", fit.message.c_str());
    }
  }
  valve_model_pub_.publish(msg);
}

// ---- services ----

bool IdentificationNode::startSweep(StartSweep::Request& req, StartSweep::Response& res) {
  std::lock_guard<std::mutex> lock(mutex_);
  SweepRequest request;
  if (!req.frequencies.empty()) request.frequencies = req.frequencies;
  if (req.amplitude != 0.0) request.amplitude = req.amplitude;
  request.offset = req.offset;
  if (req.settle_periods != 0.0) request.settle_periods = req.settle_periods;
  if (req.integration_periods != 0.0) request.integration_periods = req.integration_periods;
  const double now = ros::Time::now().toSec();
  const std::string refusal = experiments_.startSweep(request, now, plantCondition(now));
  res.success = refusal.empty();
  if (!res.success) {
    res.message = "sweep refused: " + refusal;
    ROS_WARN("die_cushion_ident: %s", res.message.c_str());
    return true;
  }
  res.expected_duration = experiments_.sweep().request().totalDuration();
  res.message = "sweep started: " + std::to_string(request.frequencies.size()) + " frequencies, about " +
                formatted("%.1f", res.expected_duration) + " s";
  sweep_reported_ = false;
  published_points_ = 0;
  startExperimentTimer();
  ROS_INFO("die_cushion_ident: %s", res.message.c_str());
  return true;
}

bool IdentificationNode::abortSweep(AbortSweep::Request&, AbortSweep::Response& res) {
  std::lock_guard<std::mutex> lock(mutex_);
  // Whichever experiment holds the valve: the sweep or the step test.
  res.message = experiments_.abort("aborted by request (~abort_sweep)");
  res.success = !res.message.empty();
  if (!res.success) res.message = "no sweep or step test is running";
  return true;
}

bool IdentificationNode::setEffects(SetEffects::Request& req, SetEffects::Response& res) {
  std::lock_guard<std::mutex> lock(mutex_);
  const std::vector<std::string> problems = live_->setEffects(req.effects, req.custom_effects);
  if (!problems.empty()) {
    res.success = false;
    res.message = "effects refused: " + joined(problems, "; ");
    return true;
  }
  for (const auto& info : live_->pipeline().identifier().model().parameterInfos())
    res.parameters.push_back(info.name);
  res.success = true;
  res.message = "model now: " + joined(res.parameters, ", ") + "; the estimator restarted";
  ROS_INFO("die_cushion_ident: %s", res.message.c_str());
  return true;
}

bool IdentificationNode::reset(Reset::Request&, Reset::Response& res) {
  std::lock_guard<std::mutex> lock(mutex_);
  live_->restart();
  res.success = true;
  res.message = "identification restarted from the initial values";
  return true;
}

// ---- diagnostics ----

void IdentificationNode::diagnoseInput(diagnostic_updater::DiagnosticStatusWrapper& status,
                                       InputStream stream) {
  std::lock_guard<std::mutex> lock(mutex_);
  const int s = static_cast<int>(stream);
  InputState input;
  input.stream = stream;
  input.topic = nh_.resolveName(inputStreamName(stream));
  input.health = live_->pipeline().resampler().health(stream);
  input.now = ros::Time::now().toSec();
  input.rejected = rejected_[s];
  input.last_rejection = last_rejection_[s];
  // Wild stamps since the last report: the topic's clock jumped while the others' did not.
  input.new_wild_stamps = input.health.wild_stamps > wild_reported_[s];
  wild_reported_[s] = input.health.wild_stamps;
  input.all_inputs_silent_for = allInputsSilentFor(live_->pipeline().resampler(), input.now);
  input.spool_age = input.now - spool_stamp_;
  fill(status, inputHealth(input));
}

void IdentificationNode::diagnoseEstimator(diagnostic_updater::DiagnosticStatusWrapper& status) {
  std::lock_guard<std::mutex> lock(mutex_);
  const HydraulicIdentifier& identifier = live_->pipeline().identifier();
  fill(status, estimatorHealth(identifier.model(), identifier.estimate()));
}

void IdentificationNode::diagnoseValve(diagnostic_updater::DiagnosticStatusWrapper& status) {
  std::lock_guard<std::mutex> lock(mutex_);
  fill(status, valveHealth(experiments_.sweep(), live_->config().valve, last_valve_fit_));
}

void IdentificationNode::diagnoseExperiments(diagnostic_updater::DiagnosticStatusWrapper& status) {
  std::lock_guard<std::mutex> lock(mutex_);
  fill(status, valveExperimentsHealth(experiments_, feed_forward_->engaged(), ros::Time::now().toSec()));
}

void IdentificationNode::diagnoseAdequacy(diagnostic_updater::DiagnosticStatusWrapper& status) {
  std::lock_guard<std::mutex> lock(mutex_);
  fill(status, adequacyHealth(live_->monitor(), live_->pipeline().identifier().estimate().equation_error_rms,
                              settings_.adequacy_warn_error, settings_.adequacy_error_error));
}

void IdentificationNode::diagnoseTiming(diagnostic_updater::DiagnosticStatusWrapper& status) {
  std::lock_guard<std::mutex> lock(mutex_);
  TimingState timing = live_->timing();
  timing.joint_name = settings_.joint_name;
  if (joints_.ambiguous()) timing.joint_ambiguity = joints_.ambiguity();
  fill(status, timingHealth(timing));
}

void spinBatched(ros::CallbackQueue& queue, const IdentificationNode& node, const std::atomic<bool>& stop) {
  // Batches are 5 ms of wall time, but at most 20 ms of ROS time: when a simulation runs 40x faster than
  // real time under /use_sim_time, 5 ms of wall time are 200 ms of stamps and the inputs would look stale.
  double speed = 1.0;  // ROS time per wall time, smoothed
  double last_ros = ros::Time::now().toSec();
  auto last_wall = std::chrono::steady_clock::now();
  while (ros::ok() && !stop) {
    queue.callAvailable();
    const auto wall = std::chrono::steady_clock::now();
    const double ros_now = ros::Time::now().toSec();
    const double elapsed = std::chrono::duration<double>(wall - last_wall).count();
    if (elapsed > 0.05) {
      speed += 0.5 * (std::max(ros_now - last_ros, 0.0) / elapsed - speed);
      last_ros = ros_now;
      last_wall = wall;
    }
    const double batch = node.valveExperimentRunning() ? 2e-4 : std::clamp(0.02 / std::max(speed, 1e-3), 2e-4, 5e-3);
    std::this_thread::sleep_for(std::chrono::duration<double>(batch));
  }
}

}  // namespace die_cushion_ident
