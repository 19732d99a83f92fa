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
#include "die_cushion_ident/core/analysis/formula_search.h"
#include "message_conversions.h"

namespace die_cushion_ident {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
// Weight of a new squared residual in the running means: about one press cycle (2.6 s) of 2 ms samples,
// long enough to average over the phases, short enough to forget the estimator's start.
constexpr double kResidualWeight = 1.0 / 1300.0;
// All inputs silent this long [s of ROS time] is an error; shorter silences are scheduling, not a fault
// (a 25 ms stall of a simulation at 40x real time is 1 s of stamps).
constexpr double kSilenceLimit = 1.0;
// RLS updates (10 ms each, only while excited) before the model comparison counts: about one stroke.
constexpr std::uint64_t kUpdatesBeforeComparison = 100;

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

std::string join(const std::vector<std::string>& items, const char* separator) {
  std::string out;
  for (const auto& item : items) out += (out.empty() ? "" : separator) + item;
  return out;
}

}  // namespace

IdentificationNode::IdentificationNode(ros::NodeHandle nh, ros::NodeHandle pnh, const std::string& name)
    : nh_(nh), pnh_(pnh), sweep_(SweepLimits()), updater_(nh, pnh, name) {
  const auto problems = loadParameters(pnh_, &config_, &limits_, &settings_);
  if (!problems.empty()) throw std::invalid_argument("invalid parameters:\n  " + join(problems, "\n  "));
  sweep_ = ValveSweep(limits_);
  sweep_.setCommandHold(config_.valve_command_hold);
  step_test_ = ValveStepTest(limits_);
  joints_ = JointSelector(settings_.joint_name);
  feed_forward_ = std::make_unique<FeedForwardPublisher>(nh_, pnh_, settings_.valve_gain,
                                                         settings_.feed_forward_max_age, limits_.min_voltage,
                                                         limits_.max_voltage);
  rebuildPipeline();

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
  updater_.add("step test", this, &IdentificationNode::diagnoseStepTest);
  updater_.add("feed-forward", [this](diagnostic_updater::DiagnosticStatusWrapper& s) { feed_forward_->diagnose(s); });
  diagnostic_timer_ =
      nh_.createTimer(ros::Duration(0.1), [this](const ros::TimerEvent&) { updater_.update(); });

  ROS_INFO_STREAM("die_cushion_ident: identifying "
                  << join(pipeline_->identifier().model().effectNames(), ", ")
                  << (config_.effects.empty() && config_.custom_effects.empty() ? "base model" : "") << " on "
                  << nh_.resolveName("pressure") << ", " << nh_.resolveName("position") << ", "
                  << nh_.resolveName("valve"));
}

IdentificationNode::~IdentificationNode() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (step_test_.running()) {
    step_test_.abort("shutdown");
    if (const auto u = step_test_.command(ros::Time::now().toSec())) publishSweepCommand(*u);
  }
  if (!sweep_.running()) return;
  sweep_.abort("shutdown");
  if (const auto u = sweep_.command(ros::Time::now().toSec())) publishSweepCommand(*u);
}

bool IdentificationNode::sweepRunning() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return sweep_commanding_;
}

void IdentificationNode::rebuildPipeline() {
  pipeline_ = std::make_unique<IdentificationPipeline>(config_);
  pipeline_->setGridCallback(
      [this](const GridSample& g, const HydraulicIdentifier& identifier) { onGridSample(g, identifier); });
  pipeline_->setStepCallback(
      [this](const HydraulicIdentifier& identifier) { onIdentificationStep(identifier); });
  free_run_ = std::make_unique<FreeRunPressure>(pipeline_->identifier().model(), config_.min_pressure);
  if (feed_forward_) feed_forward_->modelChanged();
  classifier_.reset();
  window_.clear();
  ranking_.reset();
  ++ranking_generation_;
  last_ranking_time_ = -1e18;
  residual_square_mean_ = 0.0;
  residual_samples_ = 0;
  std::fill(std::begin(phase_square_error_), std::end(phase_square_error_), 0.0);
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
  if (!sweep_.running()) return;
  sweep_.addValveSample(stamp, msg->voltage, msg->spool_position);
  if (sweep_.points().size() != published_points_) publishFrequencyResponse();
  if (!sweep_.running()) finishSweep();
}

void IdentificationNode::push(InputStream stream, const StreamSample& sample) {
  const auto result = pipeline_->push(stream, sample);
  applyPendingTopicDelays();
  if (result == UniformResampler::PushResult::kRestarted) {
    ROS_WARN("die_cushion_ident: %s stamp jumped (bag restarted?): identification restarted",
             inputStreamName(stream));
    free_run_->resync();
    classifier_.reset();
  } else if (result == UniformResampler::PushResult::kHeld) {
    // A stamp far off the time base: held until the other topics confirm the jump; counted as wild by
    // the resampler when they do not.
  } else if (result != UniformResampler::PushResult::kAccepted) {
    const int s = static_cast<int>(stream);
    ++rejected_[s];
    last_rejection_[s] = pushResultText(result);
    ROS_WARN_THROTTLE(5.0, "die_cushion_ident: %s message rejected: %s", inputStreamName(stream),
                      pushResultText(result));
  }
}

// ---- identification and model comparison ----

void IdentificationNode::onGridSample(const GridSample& g, const HydraulicIdentifier& identifier) {
  last_grid_ = g;
  window_.push_back(g);
  const auto capacity =
      static_cast<std::size_t>(settings_.effect_ranking_window / config_.resampler.sample_period);
  while (window_.size() > capacity) window_.pop_front();
  collectRanking();
  if (g.t - last_ranking_time_ >= settings_.effect_ranking_period || g.t < last_ranking_time_) {
    last_ranking_time_ = g.t;
    rankEffects();
  }
  analyzeStepTest(g.t);
  phase_ = classifier_.classify(g);
  modelled_pressure_ = free_run_->step(g, identifier.physicalParameters());
  // What keeps the comparison from running, for the adequacy diagnostic (instead of waiting in silence).
  comparison_blocker_ = !g.complete           ? "a topic is silent or stale (see the input diagnostics)"
                        : !std::isfinite(g.v) ? "no velocity (the position topic carries none and it cannot be "
                                                "derived: positions missing or not finite)"
                        : !std::isfinite(g.y) ? "no spool position (not measured and not predictable)"
                        : g.p < config_.min_pressure
                            ? "the pressure is below min_pressure, where the model is not trusted"
                            : "";
  // The comparison counts once the estimator has seen some excitation; before, the model is its start value.
  const bool estimator_started = identifier.updates() >= kUpdatesBeforeComparison;
  feed_forward_->update(g, identifier.model(), identifier.physicalParameters(), estimator_started,
                        last_valve_fit_.success ? &last_valve_fit_.parameters : nullptr);
  if (estimator_started && std::isfinite(modelled_pressure_) && !free_run_->anchoredThisStep() &&
      std::isfinite(g.p)) {
    const double square = (g.p - modelled_pressure_) * (g.p - modelled_pressure_);
    const double w = std::max(kResidualWeight, 1.0 / static_cast<double>(++residual_samples_));
    residual_square_mean_ += w * (square - residual_square_mean_);
    double& phase_mean = phase_square_error_[static_cast<int>(phase_)];
    phase_mean += kResidualWeight * 5.0 * (square - phase_mean);
  }
}

void IdentificationNode::onIdentificationStep(const HydraulicIdentifier& identifier) {
  // rviz needs no more than 10 Hz.
  const bool markers =
      markers_pub_.getNumSubscribers() > 0 && ++steps_since_markers_ * config_.identification_period >= 0.1;
  const bool estimate = estimate_pub_.getNumSubscribers() > 0;
  const bool comparison = comparison_pub_.getNumSubscribers() > 0;
  if (!markers && !estimate && !comparison) return;  // the estimate costs allocations: only when wanted
  const HydraulicEstimate e = identifier.estimate();
  const ros::Time stamp(std::max(e.t, 0.0));
  if (estimate) {
    std::vector<double> values, stds;
    for (const auto& p : e.parameters) {
      values.push_back(p.value);
      stds.push_back(p.std);
    }
    ParameterEstimate msg = toParameterEstimateMsg(identifier.model(), values, stds, stamp);
    msg.equation_error_rms = e.equation_error_rms;
    msg.updates = e.updates;
    msg.skipped_unexcited = e.skipped_unexcited;
    msg.skipped_invalid = e.skipped_invalid;
    estimate_pub_.publish(msg);
  }
  if (markers) {
    steps_since_markers_ = 0;
    CushionView view;
    view.position = last_grid_.x;
    view.pressure = last_grid_.p;
    view.simulation_error = std::sqrt(residual_square_mean_);
    view.phase = phase_;
    markers_pub_.publish(cushionMarkers(config_.geometry, view, e, frame_id_, stamp));
  }
  if (comparison) {
    const ModelComparison msg =
        toModelComparisonMsg(last_grid_, modelled_pressure_, phase_, std::sqrt(residual_square_mean_),
                             e.equation_error_rms, ros::Time(std::max(last_grid_.t, 0.0)));
    // Only what was computed: while the model cannot run, the adequacy diagnostic says why instead.
    if (isComputed(msg)) comparison_pub_.publish(msg);
  }
}

void IdentificationNode::estimateTopicDelays(const std::vector<GridSample>& grid) {
  if (config_.topicDelaysSet() || delay_estimate_) return;
  TopicDelayEstimate estimate = die_cushion_ident::estimateTopicDelays(grid, config_);
  if (!estimate.valid) return;  // not enough excitation in the window yet: try at the next ranking
  delay_estimate_ = estimate;
  if (!estimate.significant(config_.resampler.sample_period)) return;
  delays_pending_ = true;
}

void IdentificationNode::applyPendingTopicDelays() {
  if (!delays_pending_) return;
  delays_pending_ = false;
  config_.topic_delays = delay_estimate_->delays;
  ROS_WARN("die_cushion_ident: the topics' stamps are offset (position %+.2f ms, valve %+.2f ms against "
           "pressure, estimated from the data): corrected, identification restarted; set ~topic_delays to "
           "fix them",
           config_.topic_delays[1] * 1e3, config_.topic_delays[2] * 1e3);
  rebuildPipeline();
}

void IdentificationNode::rankEffects() {
  if (ranking_job_.valid()) return;  // the previous one is still running: the next period tries again
  std::vector<GridSample> grid(window_.begin(), window_.end());
  estimateTopicDelays(grid);
  ranking_job_ = std::async(std::launch::async, [grid = std::move(grid), config = config_,
                                                 generation = ranking_generation_] {
    const auto started = std::chrono::steady_clock::now();
    RankingJob job;
    job.generation = generation;
    const StrokeSegmentation strokes = segmentStrokes(grid);
    job.cycles = strokes.cycles;
    job.result = die_cushion_ident::rankEffects(grid, strokes, config);
    // The formula search only where structured error is left, as offline without --propose.
    if (job.result.residual_unexplained) addFormulaProposals(grid, strokes, config, &job.result);
    job.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    return job;
  });
}

void IdentificationNode::collectRanking() {
  if (!ranking_job_.valid() || ranking_job_.wait_for(std::chrono::seconds(0)) != std::future_status::ready) return;
  RankingJob job = ranking_job_.get();
  if (job.generation != ranking_generation_) return;  // started before the pipeline was rebuilt
  publishRanking(std::move(job));
}

void IdentificationNode::publishRanking(RankingJob job) {
  last_ranking_seconds_ = job.seconds;
  ROS_DEBUG("die_cushion_ident: effect ranking took %.3f s on its own thread", job.seconds);
  ranking_ = std::move(job.result);
  die_cushion_ident::EffectRanking msg;
  msg.header.stamp = ros::Time(std::max(last_grid_.t, 0.0));
  msg.cycles = job.cycles;
  for (const auto& c : ranking_->candidates) {
    msg.effects.push_back(c.effect);
    msg.error_reduction.push_back(c.error_reduction);
    msg.verdicts.push_back(verdictName(c.verdict));
    msg.explanations.push_back(c.explanation);
  }
  msg.held_out_error_rms = ranking_->base_error_rms;
  msg.best_error_rms = ranking_->best_error_rms;
  msg.noise_rms = ranking_->noise_rms;
  msg.residual_unexplained = ranking_->residual_unexplained;
  for (const auto& step : ranking_->steps) {
    msg.steps.push_back(step.add);
    msg.step_error_rms.push_back(step.held_out_error_rms);
  }
  for (const auto& p : ranking_->proposals) {
    msg.proposals.push_back(p.spec());
    msg.proposal_error_reduction.push_back(p.error_reduction);
    msg.proposal_verdicts.push_back(verdictName(p.verdict));
    msg.proposal_explanations.push_back(p.explanation);
  }
  msg.conclusion = ranking_->conclusion;
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
  const std::string refusal = sweep_.running() ? std::string("a sweep is running")
                                               : step_test_.start(request, now, plantCondition(now));
  res.success = refusal.empty();
  res.message = res.success ? formatted("step test started: %g V", step_test_.request().step) +
                                  formatted(" from %g V", step_test_.request().offset)
                            : "step test refused: " + refusal;
  if (!res.success) {
    ROS_WARN("die_cushion_ident: %s", res.message.c_str());
    return true;
  }
  step_status_ = "running";
  step_timer_ = nh_.createTimer(ros::Duration(0.5 * limits_.command_period), &IdentificationNode::onStepTimer, this);
  ROS_INFO("die_cushion_ident: %s", res.message.c_str());
  return true;
}

void IdentificationNode::onStepTimer(const ros::TimerEvent&) {
  std::lock_guard<std::mutex> lock(mutex_);
  const double now = ros::Time::now().toSec();
  step_test_.supervise(now, plantCondition(now));
  if (const auto u = step_test_.command(now)) publishSweepCommand(*u);
  if (step_test_.running()) return;
  step_timer_.stop();
  if (step_test_.state() == ValveStepTest::State::kAborted) {
    step_status_ = "aborted: " + step_test_.abortReason();
    ROS_WARN("die_cushion_ident: step test %s", step_status_.c_str());
  } else {
    step_status_ = "finished; timing the pressure's answer";
    step_analysis_due_ = step_test_.stepTime() + step_test_.request().duration + 0.2;
  }
}

void IdentificationNode::analyzeStepTest(double grid_time) {
  if (!(grid_time >= step_analysis_due_)) return;
  step_analysis_due_ = std::numeric_limits<double>::infinity();
  const std::vector<GridSample> grid(window_.begin(), window_.end());
  for (const StepResponse& r : findStepResponses(grid)) {
    if (std::abs(r.start - step_test_.stepTime()) > 0.05) continue;
    last_step_response_ = r;
    step_status_ = formatted("t63 %.1f ms", r.t63 * 1e3);
    ROS_INFO("die_cushion_ident: step test: %.1f -> %.1f bar, t63 %.1f ms (sample_period at most %.2f ms)",
             r.initial_pressure * 1e-5, r.final_pressure * 1e-5, r.t63 * 1e3, r.recommendedMaxSamplingTime() * 1e3);
    return;
  }
  step_status_ = "the pressure's answer could not be timed (it did not settle, changed less than 2 bar, or "
                 "the cushion moved)";
}

void IdentificationNode::diagnoseStepTest(diagnostic_updater::DiagnosticStatusWrapper& status) {
  std::lock_guard<std::mutex> lock(mutex_);
  using diagnostic_msgs::DiagnosticStatus;
  if (!last_step_response_) {
    const bool failed = step_status_.rfind("aborted", 0) == 0 || step_status_.rfind("the pressure's", 0) == 0;
    status.summary(failed ? DiagnosticStatus::WARN : DiagnosticStatus::OK, step_status_);
    return;
  }
  const StepResponse& r = *last_step_response_;
  const bool too_slow = config_.resampler.sample_period > r.recommendedMaxSamplingTime();
  status.summary(too_slow ? DiagnosticStatus::WARN : DiagnosticStatus::OK,
                 too_slow ? formatted("sample_period %.4g s exceeds 0.1 t63", config_.resampler.sample_period) +
                                formatted(" = %.4g s: the identification cannot resolve the pressure build-up",
                                          r.recommendedMaxSamplingTime())
                          : step_status_);
  status.add("t63 [s]", r.t63);
  status.add("recommended max sampling time [s]", r.recommendedMaxSamplingTime());
  status.add("step voltage [V]", r.step_voltage);
  status.add("initial pressure [bar]", r.initial_pressure * 1e-5);
  status.add("final pressure [bar]", r.final_pressure * 1e-5);
  status.add("last test", step_status_);
}

// ---- valve sweep ----

PlantCondition IdentificationNode::plantCondition(double now) const {
  PlantCondition c;
  c.pressure = pressure_;
  c.pressure_age = now - pressure_stamp_;
  c.velocity = velocity_.velocity();
  c.spool_age = now - spool_stamp_;
  return c;
}

void IdentificationNode::onSweepTimer(const ros::TimerEvent&) {
  std::lock_guard<std::mutex> lock(mutex_);
  const double now = ros::Time::now().toSec();
  sweep_.supervise(now, plantCondition(now));
  const auto u = sweep_.command(now);
  if (u) publishSweepCommand(*u);
  if (!sweep_.running()) {
    finishSweep();
    if (!u) {  // the offset has been sent
      sweep_timer_.stop();
      sweep_commanding_ = false;
    }
  }
}

void IdentificationNode::publishSweepCommand(double voltage) {
  ValveSignal msg;
  msg.header.stamp = ros::Time::now();
  msg.voltage = voltage;
  msg.spool_position = kNaN;
  command_pub_.publish(msg);
}

void IdentificationNode::publishFrequencyResponse() {
  published_points_ = sweep_.points().size();
  response_pub_.publish(toFrequencyResponseMsg(sweep_.points(), sweep_.fit(), sweepStateName(sweep_.state()),
                                               ros::Time::now()));
}

void IdentificationNode::finishSweep() {
  if (sweep_reported_) return;
  sweep_reported_ = true;
  publishFrequencyResponse();
  const ServoValveFit& fit = sweep_.fit();
  ValveModel msg = toValveModelMsg(fit, ros::Time::now());
  if (sweep_.state() == ValveSweep::State::kAborted) {
    msg.success = false;
    msg.message = "sweep aborted: " + sweep_.abortReason();
    ROS_WARN("die_cushion_ident: %s", msg.message.c_str());
  } else {
    if (fit.success) {
      last_valve_fit_ = fit;
      config_.valve = fit.parameters;  // an unmeasured spool is predicted with the identified valve
      config_.valve.max_spool_velocity = std::numeric_limits<double>::infinity();
      pipeline_->setValveModel(config_.valve);
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
  const std::string refusal = step_test_.running() ? std::string("a step test is running")
                                                    : sweep_.start(request, now, plantCondition(now));
  res.success = refusal.empty();
  if (!res.success) {
    res.message = "sweep refused: " + refusal;
    ROS_WARN("die_cushion_ident: %s", res.message.c_str());
    return true;
  }
  res.expected_duration = sweep_.request().totalDuration();
  res.message = "sweep started: " + std::to_string(request.frequencies.size()) + " frequencies, about " +
                formatted("%.1f", res.expected_duration) + " s";
  sweep_reported_ = false;
  published_points_ = 0;
  // Commands at twice the valve rate, so that every valve update finds a fresh one despite scheduling jitter.
  sweep_timer_ =
      nh_.createTimer(ros::Duration(0.5 * limits_.command_period), &IdentificationNode::onSweepTimer, this);
  sweep_commanding_ = true;
  ROS_INFO("die_cushion_ident: %s", res.message.c_str());
  return true;
}

bool IdentificationNode::abortSweep(AbortSweep::Request&, AbortSweep::Response& res) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (step_test_.running()) {
    step_test_.abort("aborted by request (~abort_sweep)");
    res.success = true;
    res.message = "step test aborted; the valve command returns to " + formatted("%g V", step_test_.request().offset);
    return true;
  }
  res.success = sweep_.running();
  if (!res.success) {
    res.message = "no sweep is running";
    return true;
  }
  sweep_.abort("aborted by request (~abort_sweep)");
  res.message = "sweep aborted; the valve command returns to " + formatted("%g V", sweep_.request().offset);
  return true;
}

bool IdentificationNode::setEffects(SetEffects::Request& req, SetEffects::Response& res) {
  std::lock_guard<std::mutex> lock(mutex_);
  IdentificationConfig changed = config_;
  changed.effects = req.effects;
  changed.custom_effects = req.custom_effects;
  changed.initial_parameters.clear();
  const auto problems = changed.validate();
  if (!problems.empty()) {
    res.success = false;
    res.message = "effects refused: " + join(problems, "; ");
    return true;
  }
  config_ = changed;
  rebuildPipeline();
  for (const auto& info : pipeline_->identifier().model().parameterInfos())
    res.parameters.push_back(info.name);
  res.success = true;
  res.message = "model now: " + join(res.parameters, ", ") + "; the estimator restarted";
  ROS_INFO("die_cushion_ident: %s", res.message.c_str());
  return true;
}

bool IdentificationNode::reset(Reset::Request&, Reset::Response& res) {
  std::lock_guard<std::mutex> lock(mutex_);
  rebuildPipeline();
  res.success = true;
  res.message = "identification restarted from the initial values";
  return true;
}

// ---- diagnostics ----

double IdentificationNode::allInputsSilentFor() const {
  double youngest = std::numeric_limits<double>::infinity();
  const double now = ros::Time::now().toSec();
  for (int s = 0; s < kInputStreamCount; ++s) {
    const StreamHealth& h = pipeline_->resampler().health(static_cast<InputStream>(s));
    if (h.received > 0) youngest = std::min(youngest, now - h.last_stamp);
  }
  return youngest;
}

void IdentificationNode::diagnoseInput(diagnostic_updater::DiagnosticStatusWrapper& status,
                                       InputStream stream) {
  std::lock_guard<std::mutex> lock(mutex_);
  const StreamHealth& h = pipeline_->resampler().health(stream);
  const double age = ros::Time::now().toSec() - h.last_stamp;
  const int s = static_cast<int>(stream);
  status.add("topic", nh_.resolveName(inputStreamName(stream)));
  status.add("rate [Hz]", formatted("%.1f", h.rate()));
  status.add("received", h.received);
  status.add("rejected", rejected_[s]);
  status.add("last rejection", last_rejection_[s].empty() ? "none" : last_rejection_[s]);
  status.add("late", h.late);
  status.add("gaps", h.gaps);
  status.add("stamp jitter [ms]", formatted("%.3f", h.interval_std * 1e3));
  status.add("longest interval [ms]", formatted("%.1f", h.max_interval * 1e3));
  status.add("age of last stamp [s]", formatted("%.3f", age));
  status.add("implausible values", h.implausible);
  status.add("wild stamps", h.wild_stamps);
  // Wild stamps since the last report: the topic's clock jumped while the others' did not.
  const bool wild_now = h.wild_stamps > wild_reported_[s];
  wild_reported_[s] = h.wild_stamps;
  if (wild_now) {
    status.summary(diagnostic_msgs::DiagnosticStatus::ERROR,
                   "stamps " + formatted("%+.3g s", h.last_wild_offset) +
                       " off the other topics (its clock jumped): " + std::to_string(h.wild_stamps) +
                       " messages rejected so far; the identification goes on without them");
  } else if (h.received == 0 && rejected_[s] == 0) {
    status.summary(diagnostic_msgs::DiagnosticStatus::ERROR, "no messages received");
  } else if (h.accepted == 0) {
    status.summary(diagnostic_msgs::DiagnosticStatus::ERROR, "every message rejected: " + last_rejection_[s]);
  } else if (h.stale) {
    // Silent while the other topics run (judged on stamps, so a processing delay is not staleness).
    status.summary(diagnostic_msgs::DiagnosticStatus::ERROR,
                   "stale: silent for " + formatted("%.2f s", age) + " while the other inputs run");
  } else if (const double silent = allInputsSilentFor(); silent > kSilenceLimit) {
    status.summary(diagnostic_msgs::DiagnosticStatus::ERROR,
                   "no input for " + formatted("%.2f s", silent) + " (all three topics silent)");
  } else if (stream == InputStream::kValve && !(ros::Time::now().toSec() - spool_stamp_ < 1.0)) {
    status.summary(diagnostic_msgs::DiagnosticStatus::WARN,
                   "spool position not measured (NaN): predicted with the valve model");
  } else if (rejected_[s] > 0) {
    status.summary(diagnostic_msgs::DiagnosticStatus::WARN,
                   std::to_string(rejected_[s]) + " messages rejected, last: " + last_rejection_[s]);
  } else {
    status.summary(diagnostic_msgs::DiagnosticStatus::OK, "receiving at " + formatted("%.0f Hz", h.rate()));
  }
}

void IdentificationNode::diagnoseEstimator(diagnostic_updater::DiagnosticStatusWrapper& status) {
  std::lock_guard<std::mutex> lock(mutex_);
  const HydraulicEstimate e = pipeline_->identifier().estimate();
  status.add("effects", e.effects.empty() ? std::string("none (base model)") : join(e.effects, ", "));
  status.add("updates", e.updates);
  status.add("steps without excitation", e.skipped_unexcited);
  status.add("steps outside the model's validity", e.skipped_invalid);
  double worst_relative_std = 0.0;
  std::string problem;
  for (const auto& p : e.parameters) {
    status.add(p.name + " [" + p.unit + "]", formatted("%.4g", p.value) + " +/- " + formatted("%.2g", p.std));
    if (!std::isfinite(p.value) || !std::isfinite(p.std)) problem = p.name + " is not finite";
    if (p.value != 0.0) worst_relative_std = std::max(worst_relative_std, std::abs(p.std / p.value));
  }
  const double k = e.parameters[HydraulicModel::kBulkModulus].value;
  // Effective bulk modulus of mineral oil with hoses: 0.3-2 GPa; entrained air can lower it further.
  if (problem.empty() && e.updates > 100 && (k < 1e8 || k > 3e9)) {
    problem = "bulk modulus " + formatted("%.3g Pa", k) + " is far outside the oil's range 1e8...3e9 Pa";
  }
  if (problem.empty() && e.updates > 100 && e.parameters[HydraulicModel::kValveFlowGain].value <= 0.0) {
    problem = "valve flow gain is not positive";
  }
  if (problem.empty() && e.updates > 100 && e.parameters[HydraulicModel::kDeadVolume].value < 0.0) {
    problem = "dead volume is negative";
  }
  status.add("largest relative std", formatted("%.3f", worst_relative_std));
  if (!problem.empty()) {
    status.summary(diagnostic_msgs::DiagnosticStatus::ERROR, "implausible estimate: " + problem);
  } else if (e.updates < 100) {
    status.summary(
        diagnostic_msgs::DiagnosticStatus::WARN,
        "waiting for excitation (" + std::to_string(e.updates) + " updates; the press must stroke)");
  } else if (worst_relative_std > 0.1) {
    status.summary(diagnostic_msgs::DiagnosticStatus::WARN,
                   "converging: a parameter still has " + formatted("%.0f %%", 100 * worst_relative_std) +
                       " relative std");
  } else {
    status.summary(diagnostic_msgs::DiagnosticStatus::OK, "converged");
  }
}

void IdentificationNode::diagnoseValve(diagnostic_updater::DiagnosticStatusWrapper& status) {
  std::lock_guard<std::mutex> lock(mutex_);
  status.add("sweep", sweepStateName(sweep_.state()));
  status.add("model used for spool prediction", formatted("%.1f Hz", config_.valve.natural_frequency) +
                                                    ", D " + formatted("%.2f", config_.valve.damping) +
                                                    ", K " + formatted("%.4g 1/V", config_.valve.gain) +
                                                    ", Td " +
                                                    formatted("%.2f ms", config_.valve.dead_time * 1e3));
  if (sweep_.running()) {
    status.add("frequency [Hz]", formatted("%.1f", sweep_.currentFrequency()));
    status.add("progress", std::to_string(sweep_.currentIndex()) + " of " +
                               std::to_string(sweep_.request().frequencies.size()));
    status.summary(diagnostic_msgs::DiagnosticStatus::OK, "sweep running");
    return;
  }
  if (sweep_.state() == ValveSweep::State::kAborted) {
    status.summary(diagnostic_msgs::DiagnosticStatus::WARN, "last sweep aborted: " + sweep_.abortReason());
    return;
  }
  if (sweep_.state() == ValveSweep::State::kFinished && !sweep_.fit().success) {
    status.summary(diagnostic_msgs::DiagnosticStatus::WARN, "last sweep not usable: " + sweep_.fit().message);
    return;
  }
  if (!last_valve_fit_.success) {
    status.summary(diagnostic_msgs::DiagnosticStatus::OK, "not identified yet (configured model in use)");
    return;
  }
  const ServoValveFit& f = last_valve_fit_;
  status.add("identified natural frequency [Hz]", formatted("%.2f", f.parameters.natural_frequency));
  status.add("identified damping", formatted("%.3f", f.parameters.damping));
  status.add("identified gain [1/V]", formatted("%.4g", f.parameters.gain));
  status.add("identified dead time [ms]", formatted("%.3f", f.parameters.dead_time * 1e3));
  status.add("points distorted", f.points_rejected);
  if (f.reduced_chi_square > 10.0) {
    status.summary(diagnostic_msgs::DiagnosticStatus::WARN,
                   "identified, but the 2nd-order model misses the measured response (chi2/dof " +
                       formatted("%.1f", f.reduced_chi_square) + ")");
  } else {
    status.summary(diagnostic_msgs::DiagnosticStatus::OK, "identified by the last sweep and in use");
  }
}

void IdentificationNode::diagnoseAdequacy(diagnostic_updater::DiagnosticStatusWrapper& status) {
  std::lock_guard<std::mutex> lock(mutex_);
  const double rms = std::sqrt(residual_square_mean_);
  status.add("simulation error rms [bar]", formatted("%.2f", rms * 1e-5));
  status.add("equation error rms [bar/s]",
             formatted("%.1f", pipeline_->identifier().estimate().equation_error_rms * 1e-5));
  int worst = -1;
  for (int i = 0; i < kStrokePhaseCount; ++i) {
    status.add(
        std::string("simulation error rms in ") + strokePhaseName(static_cast<StrokePhase>(i)) + " [bar]",
        formatted("%.2f", std::sqrt(phase_square_error_[i]) * 1e-5));
    if (worst < 0 || phase_square_error_[i] > phase_square_error_[worst]) worst = i;
  }
  std::string where = std::string("worst in ") + strokePhaseName(static_cast<StrokePhase>(worst));
  if (std::isfinite(last_ranking_seconds_)) {
    status.add("effect ranking duration", formatted("%.3f s (own thread)", last_ranking_seconds_));
  }
  if (ranking_) {
    status.add("effect ranking", ranking_->conclusion);
    for (const auto& c : ranking_->candidates) {
      status.add("candidate " + c.effect,
                 verdictName(c.verdict) + std::string(", ") + formatted("%.0f %% less error", 100 * c.error_reduction));
    }
    if (!ranking_->candidates.empty() && ranking_->candidates.front().verdict == Verdict::kMissing) {
      where += "; suspected missing effect: " + ranking_->candidates.front().effect;
    } else if (!ranking_->proposals.empty() && ranking_->proposals.front().verdict == Verdict::kMissing) {
      where += "; proposed formula: " + ranking_->proposals.front().spec();
    } else if (ranking_->residual_unexplained) {
      where += "; not explained by the effect library: consider a custom effect";
    }
  }
  if (residual_samples_ < 500) {
    const std::uint64_t updates = pipeline_->identifier().updates();
    std::string why;
    if (updates < kUpdatesBeforeComparison) {
      why = "the estimator has " + std::to_string(updates) + " of " + std::to_string(kUpdatesBeforeComparison) +
            " updates (the press must stroke)";
    } else if (comparison_blocker_[0] != '\0') {
      why = std::string("the model cannot run: ") + comparison_blocker_;
    } else {
      why = std::to_string(residual_samples_) + " of 500 samples compared";
    }
    status.add("why no comparison yet", why);
    status.summary(diagnostic_msgs::DiagnosticStatus::OK, "not enough data yet: " + why);
  } else if (rms > settings_.adequacy_error_error) {
    status.summary(
        diagnostic_msgs::DiagnosticStatus::ERROR,
        "the model misses the pressure by " + formatted("%.1f bar", rms * 1e-5) + " rms, " + where);
  } else if (rms > settings_.adequacy_warn_error) {
    status.summary(
        diagnostic_msgs::DiagnosticStatus::WARN,
        "the model misses the pressure by " + formatted("%.1f bar", rms * 1e-5) + " rms, " + where);
  } else {
    status.summary(diagnostic_msgs::DiagnosticStatus::OK,
                   "the model follows the pressure within " + formatted("%.1f bar", rms * 1e-5) + " rms");
  }
}

void IdentificationNode::diagnoseTiming(diagnostic_updater::DiagnosticStatusWrapper& status) {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto& applied = pipeline_->topicDelays();
  for (int s = 0; s < kInputStreamCount; ++s) {
    status.add(std::string("delay of ") + inputStreamName(static_cast<InputStream>(s)) + " stamps [ms]",
               formatted("%+.2f", applied[s] * 1e3));
  }
  status.add("joint", settings_.joint_name.empty() ? std::string("(default)") : settings_.joint_name);
  status.add("velocity derived from position [samples]", pipeline_->derivedVelocitySamples());
  status.add("latency of the velocity stage [ms]", formatted("%.1f", pipeline_->velocityDelay() * 1e3));
  if (joints_.ambiguous()) {
    status.summary(diagnostic_msgs::DiagnosticStatus::WARN, joints_.ambiguity());
    return;
  }
  if (config_.topicDelaysSet() && !delay_estimate_) {
    status.summary(diagnostic_msgs::DiagnosticStatus::OK, "topic delays configured (~topic_delays)");
    return;
  }
  if (!delay_estimate_) {
    status.summary(diagnostic_msgs::DiagnosticStatus::OK,
                   "clock offsets between the topics not estimated yet (needs strokes in the ranking window)");
    return;
  }
  double largest = 0.0;
  for (double d : delay_estimate_->delays) largest = std::max(largest, std::abs(d));
  status.add("estimated position offset [ms]", formatted("%+.2f", delay_estimate_->delays[1] * 1e3));
  status.add("estimated valve offset [ms]", formatted("%+.2f", delay_estimate_->delays[2] * 1e3));
  if (largest > kLargeTopicDelay) {
    status.summary(diagnostic_msgs::DiagnosticStatus::WARN,
                   "topics stamped by different clocks: up to " + formatted("%.1f ms", largest * 1e3) +
                       " apart (estimated and corrected); stamp at the measurement or set ~topic_delays");
  } else {
    status.summary(diagnostic_msgs::DiagnosticStatus::OK,
                   "topics in step (largest offset " + formatted("%.2f ms", largest * 1e3) + ")");
  }
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
    const double batch = node.sweepRunning() ? 2e-4 : std::clamp(0.02 / std::max(speed, 1e-3), 2e-4, 5e-3);
    std::this_thread::sleep_for(std::chrono::duration<double>(batch));
  }
}

}  // namespace die_cushion_ident
