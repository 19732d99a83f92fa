#include "identification_node.h"

#include <cmath>

#include "diagnostic_fill.h"
#include "die_cushion_ident/core/monitoring/live_diagnostics.h"
#include "die_cushion_ident/core/util/formatted.h"

namespace die_cushion_ident {

IdentificationNode::IdentificationNode(ros::NodeHandle nh, ros::NodeHandle pnh, const std::string& name)
    : nh_(nh), pnh_(pnh), updater_(nh, pnh, name) {
  IdentificationConfig config;
  const auto problems = loadParameters(pnh_, &config, &limits_, &settings_);
  if (!problems.empty()) throw std::invalid_argument("invalid parameters:\n  " + joined(problems, "\n  "));
  joints_ = JointSelector(settings_.joint_name);
  valve_ = std::make_unique<SupervisedValve>(nh_, pnh_, limits_, feedForwardOutputLimits(settings_, limits_),
                                             config.valve_command_hold);
  if (!settings_.feed_forward_enabled) {
    valve_->locked([](ValveSupervisor& v) { return v.enableFeedForward(false, SupervisedValve::now()); });
  }
  feed_forward_ =
      std::make_unique<FeedForwardPublisher>(nh_, pnh_, feedForwardSettings(settings_, limits_), *valve_);
  live_ = std::make_unique<LiveIdentification>(config, liveIdentificationSettings(settings_, pnh_));
  live_->setCallbacks(
      [this](const GridSample& g, const HydraulicIdentifier& identifier,
             const std::optional<LiveRanking>& ranking) { onGridSample(g, identifier, ranking); },
      [this](const HydraulicIdentifier& identifier) { publishers_->identificationStep(*live_, identifier); });
  generation_ = live_->generation();
  publishers_ = std::make_unique<LivePublishers>(pnh_);
  experiments_ = std::make_unique<ValveExperimentServices>(pnh_, mutex_, *live_, *valve_);
  addDiagnostics();
  thresholds_ = std::make_unique<LiveThresholds>(
      pnh_, mutex_, &settings_, [this] { live_->setMonitorSettings(liveMonitorSettings(settings_)); });

  // The estimates run on stamps, so pressure and position may arrive batched (Nagle: fewer wake-ups and
  // system calls); the valve topic feeds the sweep's safety checks and must not wait.
  pressure_sub_ = nh_.subscribe("pressure", 1000, &IdentificationNode::onPressure, this);
  position_sub_ = nh_.subscribe("position", 1000, &IdentificationNode::onPosition, this);
  valve_sub_ =
      nh_.subscribe("valve", 1000, &IdentificationNode::onValve, this, ros::TransportHints().tcpNoDelay());
  oil_temperature_sub_ = nh_.subscribe("oil_temperature", 10, &IdentificationNode::onOilTemperature, this);
  effects_srv_ = pnh_.advertiseService("set_effects", &IdentificationNode::setEffects, this);
  reset_srv_ = pnh_.advertiseService("reset", &IdentificationNode::reset, this);

  ROS_INFO_STREAM("die_cushion_ident: identifying "
                  << joined(live_->pipeline().identifier().model().effectNames(), ", ")
                  << (config.effects.empty() && config.custom_effects.empty() ? "base model" : "") << " on "
                  << nh_.resolveName("pressure") << ", " << nh_.resolveName("position") << ", "
                  << nh_.resolveName("valve"));
}

// ---- inputs ----

void IdentificationNode::onPressure(const sensor_msgs::FluidPressure::ConstPtr& msg) {
  std::lock_guard<std::mutex> lock(mutex_);
  const double stamp = msg->header.stamp.toSec();
  valve_->pressure(stamp, msg->fluid_pressure);
  push(InputStream::kPressure, {stamp, msg->fluid_pressure, NAN});  // no second value
}

void IdentificationNode::onPosition(const sensor_msgs::JointState::ConstPtr& msg) {
  std::lock_guard<std::mutex> lock(mutex_);
  StreamSample sample;
  if (joints_.select(*msg, &sample) != JointSelector::Result::kSelected) {
    reject(InputStream::kPosition, joints_.problem());
    return;
  }
  if (joints_.ambiguous() && !ambiguity_reported_) {
    ambiguity_reported_ = true;
    ROS_WARN("die_cushion_ident: %s", joints_.ambiguity().c_str());
  }
  valve_->position(sample.stamp, sample.first);
  push(InputStream::kPosition, sample);
}

void IdentificationNode::onValve(const ValveSignal::ConstPtr& msg) {
  std::lock_guard<std::mutex> lock(mutex_);
  const double stamp = msg->header.stamp.toSec();
  valve_->valve(stamp, msg->voltage, msg->spool_position);
  push(InputStream::kValve, {stamp, msg->voltage, msg->spool_position});
  experiments_->poll();
}

void IdentificationNode::onOilTemperature(const sensor_msgs::Temperature::ConstPtr& msg) {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto result = live_->pushOilTemperature(fromTemperatureMsg(*msg));
  if (result == UniformResampler::PushResult::kAccepted) return;
  last_oil_rejection_ = result == UniformResampler::PushResult::kHeld ? "stamped far off the other topics"
                                                                      : pushResultText(result);
  ROS_WARN_THROTTLE(5.0, "die_cushion_ident: oil_temperature message rejected: %s",
                    last_oil_rejection_.c_str());
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
  // Held: a stamp far off the time base, until the other topics confirm the jump (counted as wild by the
  // resampler when they do not).
  if (result != UniformResampler::PushResult::kHeld && result != UniformResampler::PushResult::kAccepted &&
      result != UniformResampler::PushResult::kRestarted) {
    reject(stream, pushResultText(result));
  }
}

void IdentificationNode::reject(InputStream stream, const std::string& why) {
  const int s = static_cast<int>(stream);
  ++rejected_[s];
  last_rejection_[s] = why;
  ROS_WARN_THROTTLE(5.0, "die_cushion_ident: %s message rejected: %s", inputStreamName(stream), why.c_str());
}

void IdentificationNode::onGridSample(const GridSample& g, const HydraulicIdentifier& /*live_'s own*/,
                                      const std::optional<LiveRanking>& ranking) {
  if (ranking) publishers_->ranking(*ranking, live_->monitor().lastSample().t);
  experiments_->poll();
  experiments_->onGridSample(g.t);
  // The supervisor keeps the feed-forward at 0 V while an experiment holds the valve (its command would add
  // to the experiment's on the cell controller's adder).
  feed_forward_->update(g, *live_, experiments_->sweptValve());
}

// ---- services ----

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

void IdentificationNode::addDiagnostics() {
  updater_.setHardwareID("die_cushion");
  for (InputStream stream : {InputStream::kPressure, InputStream::kPosition, InputStream::kValve}) {
    updater_.add(
        std::string("input ") + inputStreamName(stream),
        [this, stream](diagnostic_updater::DiagnosticStatusWrapper& s) { diagnoseInput(s, stream); });
  }
  const auto locked = [this](auto report) {
    return [this, report](diagnostic_updater::DiagnosticStatusWrapper& s) {
      std::lock_guard<std::mutex> lock(mutex_);
      fill(s, report());
    };
  };
  updater_.add("input oil_temperature", locked([this] {
                 OilTemperatureState oil;
                 oil.topic = nh_.resolveName("oil_temperature");
                 oil.input = live_->pipeline().oilTemperature();
                 oil.now = ros::Time::now().toSec();
                 oil.last_rejection = last_oil_rejection_;
                 oil.model_uses_it = live_->pipeline().identifier().model().oilStateParameter() >= 0;
                 return oilTemperatureHealth(oil);
               }));
  updater_.add("estimator", locked([this] {
                 return estimatorHealth(live_->pipeline().identifier().model(), live_->estimate());
               }));
  updater_.add("model adequacy", locked([this] {
                 return adequacyHealth(live_->monitor(),
                                       live_->pipeline().identifier().estimate().equation_error_rms,
                                       settings_.adequacy_warn_error, settings_.adequacy_error_error);
               }));
  updater_.add("input timing", locked([this] {
                 TimingState timing = live_->timing();
                 timing.joint_name = settings_.joint_name;
                 if (joints_.ambiguous()) timing.joint_ambiguity = joints_.ambiguity();
                 return timingHealth(timing);
               }));
  updater_.add("settings", locked([this] { return live_->settingsHealth(); }));
  experiments_->addDiagnostics(updater_);
  updater_.add("feed-forward",
               [this](diagnostic_updater::DiagnosticStatusWrapper& s) { feed_forward_->diagnose(s); });
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
}

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
  input.spool_age =
      valve_->locked([](const ValveSupervisor& v) { return v.condition(SupervisedValve::now()).spool_age; });
  fill(status, inputHealth(input));
}

}  // namespace die_cushion_ident
