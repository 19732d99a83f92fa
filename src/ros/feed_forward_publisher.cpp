#include "feed_forward_publisher.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "die_cushion_ident/ValveSignal.h"

namespace die_cushion_ident {

namespace {
FeedForwardInterlockLimits interlockLimits(double limit, double slew_rate, double parameter_rate) {
  FeedForwardInterlockLimits l;
  l.max_voltage = limit > 0.0 ? limit : 1e-9;  // a range that excludes 0 V on one side allows nothing
  l.slew_rate = slew_rate;
  l.parameter_rate = parameter_rate;
  return l;
}
}  // namespace

FeedForwardPublisher::FeedForwardPublisher(ros::NodeHandle nh, ros::NodeHandle pnh, double valve_gain,
                                           double max_age, double min_voltage, double max_voltage,
                                           double slew_rate, double parameter_rate)
    : configured_gain_(valve_gain),
      max_age_(max_age),
      // Symmetric for the inverse, inside the requested range on both sides.
      limit_(std::max(0.0, std::min(-min_voltage, max_voltage))),
      interlock_(interlockLimits(limit_, slew_rate, parameter_rate), valve_gain) {
  sub_ = nh.subscribe("pressure_setpoint", 100, &FeedForwardPublisher::onSetpoint, this);
  pub_ = pnh.advertise<ValveSignal>("feed_forward", 10);
}

void FeedForwardPublisher::onSetpoint(const sensor_msgs::FluidPressure::ConstPtr& msg) {
  std::lock_guard<std::mutex> lock(mutex_);
  reference_.push(msg->header.stamp.toSec(), msg->fluid_pressure);
}

void FeedForwardPublisher::modelChanged() {
  feed_forward_.reset();
  model_ = nullptr;
  interlock_.restart();
}

void FeedForwardPublisher::publish(double stamp, double voltage) {
  ValveSignal msg;
  msg.header.stamp = ros::Time(std::max(stamp, 0.0));
  msg.voltage = voltage;
  msg.spool_position = std::numeric_limits<double>::quiet_NaN();
  pub_.publish(msg);
  last_voltage_ = voltage;
  ++published_;
}

std::string FeedForwardPublisher::waitingFor(bool model_ready, const ServoValveParameters* valve,
                                             const std::string& experiment) const {
  if (!reference_.received()) return "no pressure_setpoint received yet";
  if (!experiment.empty()) return experiment + " owns the valve: the feed-forward waits until it ends";
  if (!model_ready) return "the estimator has not identified the model yet (the press must stroke)";
  if (!valve && !std::isfinite(configured_gain_)) {
    return "the valve gain is unknown: run a sweep (~start_sweep) or set ~valve_gain";
  }
  return "";
}

ServoValveParameters FeedForwardPublisher::wantedValve(const ServoValveParameters* valve) const {
  if (valve) return *valve;
  ServoValveParameters wanted;
  wanted.gain = configured_gain_;
  wanted.dead_time = 0.0;  // no lag known: no lead
  wanted.natural_frequency = std::numeric_limits<double>::infinity();
  return wanted;
}

std::string FeedForwardPublisher::followParameters(const HydraulicModel& model, const ParameterVector& used,
                                                   const ServoValveParameters& wanted,
                                                   bool valve_identified) {
  try {
    if (!feed_forward_ || model_ != &model || valve_identified_ != valve_identified ||
        wanted.gain != valve_used_.gain || wanted.dead_time != valve_used_.dead_time ||
        wanted.natural_frequency != valve_used_.natural_frequency || wanted.damping != valve_used_.damping) {
      feed_forward_ = std::make_unique<PressureFeedForward>(model, used, wanted, limit_);
      model_ = &model;
      valve_used_ = wanted;
      valve_identified_ = valve_identified;
    } else {
      feed_forward_->setParameters(used);
    }
  } catch (const std::invalid_argument& e) {
    feed_forward_.reset();
    return std::string("the identified parameters cannot be used: ") + e.what();
  }
  return "";
}

void FeedForwardPublisher::update(const GridSample& g, const HydraulicModel& model, const ParameterVector& physical,
                                  bool model_ready, const ServoValveParameters* valve, const std::string& experiment) {
  std::lock_guard<std::mutex> lock(mutex_);
  const double dt = std::isfinite(last_t_) && g.t > last_t_ ? g.t - last_t_ : 0.0;
  // The velocity previewed over the valve's lag with the acceleration of the last grid step (bounded: a
  // derived velocity's step at impact is not extrapolated into a spike).
  const double acceleration =
      dt > 0.0 && std::isfinite(last_v_) && std::isfinite(g.v) ? std::clamp((g.v - last_v_) / dt, -50.0, 50.0) : 0.0;
  last_t_ = g.t;
  last_v_ = g.v;
  const auto stop = [&](const std::string& why) {
    blocker_ = why;
    // Ramped to 0 V (bumpless), then silent.
    if (!withdrawn_) publish(g.t, interlock_.output(NAN, dt));
    withdrawn_ = interlock_.lastOutput() == 0.0;
  };
  if (const std::string waiting = waitingFor(model_ready, valve, experiment); !waiting.empty())
    return stop(waiting);
  const ServoValveParameters wanted = wantedValve(valve);
  const std::string refusal = interlock_.check(physical, wanted.gain);
  if (!refusal.empty()) {
    ++refused_parameters_;
    return stop("the identified parameters are refused: " + refusal);
  }
  interlock_.acceptValveGain(wanted.gain);
  const ParameterVector& used = interlock_.follow(physical, dt);
  if (const std::string unusable = followParameters(model, used, wanted, valve != nullptr);
      !unusable.empty()) {
    return stop(unusable);
  }
  const auto reference = reference_.at(g.t, feed_forward_->leadTime(), max_age_);
  if (!reference) {
    char text[160];
    std::snprintf(text, sizeof(text), "pressure_setpoint is stale (newest %.3f s old, allowed %.3f s)",
                  g.t - reference_.newestStamp(), max_age_);
    return stop(text);
  }
  bool valid = false;
  const double lead = feed_forward_->leadTime();
  const double v_ahead = g.v + lead * acceleration;
  const double u =
      feed_forward_->command(reference->first, reference->second,
                             g.x + lead * g.v + 0.5 * lead * lead * acceleration, v_ahead, &valid);
  if (!valid) return stop("the cushion's position or velocity is not known");
  blocker_.clear();
  withdrawn_ = false;
  publish(g.t, interlock_.output(u, dt));
}

void FeedForwardPublisher::diagnose(diagnostic_updater::DiagnosticStatusWrapper& status) const {
  std::lock_guard<std::mutex> lock(mutex_);
  using diagnostic_msgs::DiagnosticStatus;
  if (!reference_.received()) {
    status.summary(DiagnosticStatus::OK, "off: no pressure_setpoint received");
  } else if (!blocker_.empty()) {
    status.summary(DiagnosticStatus::WARN, "0 V: " + blocker_);
  } else {
    status.summary(DiagnosticStatus::OK, "publishing the identified model's feed-forward");
  }
  status.add("last voltage [V]", last_voltage_);
  status.add("messages published", published_);
  status.add("set-points refused (NaN or stamp not advancing)", reference_.rejected());
  status.add("valve model", valve_identified_ ? "identified by a sweep" : "~valve_gain, no lag");
  status.add("command limit [V]", limit_);
  status.add("slew-rate limit [V/s]", interlock_.limits().slew_rate);
  status.add("parameter rate limit [1/s]", interlock_.limits().parameter_rate);
  status.add("estimates refused (sign, valve gain band)", refused_parameters_);
}

}  // namespace die_cushion_ident
