#include "feed_forward_publisher.h"

#include <algorithm>
#include <cmath>

#include "diagnostic_fill.h"
#include "die_cushion_ident/core/monitoring/live_diagnostics.h"

namespace die_cushion_ident {

namespace {
bool sameValve(const ServoValveParameters& a, const ServoValveParameters& b) {
  return a.gain == b.gain && a.dead_time == b.dead_time && a.natural_frequency == b.natural_frequency &&
         a.damping == b.damping;
}
}  // namespace

FeedForwardPublisher::FeedForwardPublisher(ros::NodeHandle nh, ros::NodeHandle pnh, const Settings& settings,
                                           SupervisedValve& valve)
    : settings_(settings),
      valve_(valve),
      reference_(settings.setpoint),
      interlock_(settings.interlock, settings.valve_gain) {
  sub_ = nh.subscribe("pressure_setpoint", 100, &FeedForwardPublisher::onSetpoint, this);
  enable_srv_ = pnh.advertiseService("enable_feed_forward", &FeedForwardPublisher::enable, this);
}

void FeedForwardPublisher::onSetpoint(const sensor_msgs::FluidPressure::ConstPtr& msg) {
  const double arrival = SupervisedValve::now().steady;
  std::lock_guard<std::mutex> lock(mutex_);
  reference_.push(msg->header.stamp.toSec(), msg->fluid_pressure, arrival);
}

bool FeedForwardPublisher::enable(SetFeedForward::Request& req, SetFeedForward::Response& res) {
  res.message = valve_.locked(
      [&](ValveSupervisor& s) { return s.enableFeedForward(req.enable, SupervisedValve::now()); });
  res.success = true;
  ROS_INFO("die_cushion_ident: %s", res.message.c_str());
  return true;
}

void FeedForwardPublisher::modelChanged() {
  std::lock_guard<std::mutex> lock(mutex_);
  feed_forward_.reset();
}

std::string FeedForwardPublisher::followParameters(const HydraulicModel& model, const ParameterVector& used,
                                                   const ServoValveParameters& valve) {
  try {
    if (!feed_forward_ || !sameValve(valve, valve_used_)) {
      feed_forward_ = std::make_unique<PressureFeedForward>(model, used, valve, settings_.max_voltage);
      valve_used_ = valve;
    } else {
      feed_forward_->setParameters(used);
    }
  } catch (const std::invalid_argument& e) {
    feed_forward_.reset();
    return std::string("the identified parameters cannot be used: ") + e.what();
  }
  return "";
}

double FeedForwardPublisher::wanted(const GridSample& g, const LiveIdentification& live,
                                    const ServoValveParameters* swept, std::string* why) {
  const auto none = [&](const std::string& reason) {
    *why = reason;
    return std::numeric_limits<double>::quiet_NaN();
  };
  const double steady = SupervisedValve::now().steady;
  const double dt = std::isfinite(last_t_) && g.t > last_t_ ? g.t - last_t_ : 0.0;
  const double follow_dt = std::isfinite(last_steady_) ? steady - last_steady_ : 0.0;
  // The velocity previewed over the valve's lag with the acceleration of the last grid step (bounded: a
  // derived velocity's step at impact is not extrapolated into a spike).
  const double acceleration = dt > 0.0 && std::isfinite(last_v_) && std::isfinite(g.v)
                                  ? std::clamp((g.v - last_v_) / dt, -50.0, 50.0)
                                  : 0.0;
  last_t_ = g.t;
  last_v_ = g.v;
  last_steady_ = steady;
  if (swept && (!offered_ || !sameValve(*swept, *offered_))) {
    offered_ = *swept;
    std::string refusal;
    if (!interlock_.offerSweptValve(*swept, &refusal)) {
      ++refused_valves_;
      last_refusal_ = "the sweep's valve model is refused (the last accepted stays in use): " + refusal;
      ROS_WARN("die_cushion_ident: feed-forward: %s", last_refusal_.c_str());
    }
  }
  if (!reference_.received()) return none("no pressure_setpoint received yet");
  if (!live.monitor().estimatorStarted()) {
    return none("the estimator has not identified the model yet (the press must stroke)");
  }
  const std::optional<ServoValveParameters> valve = interlock_.valve();
  if (!valve) return none("the valve gain is unknown: run a sweep (~start_sweep) or set ~valve_gain");
  const HydraulicModel& model = live.pipeline().identifier().model();
  const HydraulicEstimate estimate = live.estimate();
  ParameterVector inside;
  if (const std::string refusal =
          interlock_.checkParameters(model, estimate.values(), estimate.standardDeviations(), &inside);
      !refusal.empty()) {
    ++refused_parameters_;
    last_refusal_ = "the identified parameters are refused: " + refusal;
    return none(last_refusal_);
  }
  const ParameterVector& used = interlock_.follow(model, inside, follow_dt);
  if (const std::string unusable = followParameters(model, used, *valve); !unusable.empty())
    return none(unusable);
  const double lead = feed_forward_->leadTime();
  std::string stale;
  const auto reference = reference_.at(SupervisedValve::now(), lead, &stale);
  if (!reference) return none(stale);
  std::string refusal;
  feed_forward_->setOilTemperature(g.T);  // the oil_temperature effect's parameters at the oil as it is
  const double u = feed_forward_->command(*reference, g.x + lead * g.v + 0.5 * lead * lead * acceleration,
                                          g.v + lead * acceleration, &refusal);
  if (!std::isfinite(u)) return none(refusal);
  return u;
}

void FeedForwardPublisher::update(const GridSample& g, const LiveIdentification& live,
                                  const ServoValveParameters* swept) {
  std::lock_guard<std::mutex> lock(mutex_);
  std::string why;
  const double u = wanted(g, live, swept, &why);
  valve_.feedForward(u, why);
}

void FeedForwardPublisher::diagnose(diagnostic_updater::DiagnosticStatusWrapper& status) const {
  std::lock_guard<std::mutex> lock(mutex_);
  using diagnostic_msgs::DiagnosticStatus;
  const HealthReport output =
      valve_.locked([](const ValveSupervisor& s) { return feedForwardOutputHealth(s); });
  const std::string state = output.value("output");
  if (!reference_.received()) {
    status.summary(DiagnosticStatus::OK, "off: no pressure_setpoint received");
  } else if (output.value("switched") != "on") {
    status.summary(DiagnosticStatus::OK, state);
  } else if (state.rfind("0 V:", 0) == 0 || state.rfind("ramping out", 0) == 0) {
    status.summary(DiagnosticStatus::WARN, state);
  } else {
    status.summary(DiagnosticStatus::OK, state);
  }
  for (const auto& [key, value] : output.values) status.add(key, value);
  status.add("set-points refused (NaN or stamp not advancing)", reference_.rejected());
  status.add("valve model", interlock_.valveFromSweep() ? "identified by a sweep"
                            : interlock_.valve()        ? "~valve_gain, no lag"
                                                        : "none");
  status.add("command limit [V]", settings_.max_voltage);
  status.add("parameter rate limit [1/s]", interlock_.limits().parameter_rate);
  status.add("estimates refused (range, sign)", refused_parameters_);
  status.add("sweeps refused (valve gain band, sanity)", refused_valves_);
  status.add("last refusal", last_refusal_.empty() ? std::string("none") : last_refusal_);
}

}  // namespace die_cushion_ident
