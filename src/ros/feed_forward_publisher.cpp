#include "feed_forward_publisher.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "die_cushion_ident/ValveSignal.h"

namespace die_cushion_ident {

FeedForwardPublisher::FeedForwardPublisher(ros::NodeHandle nh, ros::NodeHandle pnh, double valve_gain,
                                           double max_age, double min_voltage, double max_voltage)
    : configured_gain_(valve_gain),
      max_age_(max_age),
      // Symmetric for the inverse, inside the requested range on both sides.
      limit_(std::max(0.0, std::min(-min_voltage, max_voltage))) {
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

void FeedForwardPublisher::update(const GridSample& g, const HydraulicModel& model, const ParameterVector& physical,
                                  bool model_ready, const ServoValveParameters* valve) {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto stop = [&](const std::string& why) {
    blocker_ = why;
    if (!withdrawn_) publish(g.t, 0.0);
    withdrawn_ = true;
  };
  if (!reference_.received()) return stop("no pressure_setpoint received yet");
  if (!model_ready) return stop("the estimator has not identified the model yet (the press must stroke)");
  if (!valve && !std::isfinite(configured_gain_)) {
    return stop("the valve gain is unknown: run a sweep (~start_sweep) or set ~valve_gain");
  }
  ServoValveParameters wanted;
  if (valve) {
    wanted = *valve;
  } else {
    wanted.gain = configured_gain_;
    wanted.dead_time = 0.0;  // no lag known: no lead
    wanted.natural_frequency = std::numeric_limits<double>::infinity();
  }
  try {
    if (!feed_forward_ || model_ != &model || valve_identified_ != (valve != nullptr) ||
        wanted.gain != valve_used_.gain || wanted.dead_time != valve_used_.dead_time ||
        wanted.natural_frequency != valve_used_.natural_frequency || wanted.damping != valve_used_.damping) {
      feed_forward_ = std::make_unique<PressureFeedForward>(model, physical, wanted, limit_);
      model_ = &model;
      valve_used_ = wanted;
      valve_identified_ = valve != nullptr;
    } else {
      feed_forward_->setParameters(physical);
    }
  } catch (const std::invalid_argument& e) {
    feed_forward_.reset();
    return stop(std::string("the identified parameters cannot be used: ") + e.what());
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
  const double u = feed_forward_->command(reference->first, reference->second, g.x + lead * g.v, g.v, &valid);
  if (!valid) return stop("the cushion's position or velocity is not known");
  blocker_.clear();
  withdrawn_ = false;
  publish(g.t, u);
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
}

}  // namespace die_cushion_ident
