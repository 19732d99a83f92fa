#pragma once

#include <diagnostic_updater/diagnostic_updater.h>
#include <ros/ros.h>
#include <sensor_msgs/FluidPressure.h>

#include <limits>
#include <memory>
#include <mutex>
#include <string>

#include "die_cushion_ident/core/control/feed_forward_interlock.h"
#include "die_cushion_ident/core/control/pressure_feed_forward.h"
#include "die_cushion_ident/core/signal/uniform_resampler.h"

namespace die_cushion_ident {

/// The node's feed-forward (paper, Fig. 19): subscribes to the cell controller's `pressure_setpoint`
/// (sensor_msgs/FluidPressure) and publishes on `~feed_forward` (ValveSignal, `voltage`) the command the
/// identified model needs for it at the cushion's measured motion, for the controller to add to its PI
/// output. Published once per grid sample while everything it needs is there; otherwise ramped to 0 V (so an
/// adder does not hold a stale value) and the reason in the `feed-forward` diagnostic. Behind
/// FeedForwardInterlock: parameters of the wrong sign or a valve gain far from the reference are refused,
/// accepted ones followed at a bounded rate, the command slew-limited (bumpless on and off) with hysteresis.
class FeedForwardPublisher {
 public:
  /// `valve_gain` [1/V]: until a sweep identifies the valve; NaN for none. `min_voltage`, `max_voltage`:
  /// the requested safe command range.
  FeedForwardPublisher(ros::NodeHandle nh, ros::NodeHandle pnh, double valve_gain, double max_age,
                       double min_voltage, double max_voltage, double slew_rate, double parameter_rate);

  /// Called by the node (under its lock) for each grid sample with the current model and estimate;
  /// `valve` is the identified valve model, or null.
  /// `experiment`: a valve experiment (sweep, step test) owns the valve: the feed-forward ramps out.
  void update(const GridSample& g, const HydraulicModel& model, const ParameterVector& physical,
              bool model_ready, const ServoValveParameters* valve, const std::string& experiment = "");
  /// The model was rebuilt (effects changed): the next update starts afresh.
  void modelChanged();
  void diagnose(diagnostic_updater::DiagnosticStatusWrapper& status) const;
  /// A command other than 0 V went out last (the cell controller adds it).
  bool engaged() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return !withdrawn_;
  }

 private:
  void onSetpoint(const sensor_msgs::FluidPressure::ConstPtr& msg);
  void publish(double stamp, double voltage);
  /// Why the feed-forward must not drive the valve before the parameters are looked at; "" where it may.
  std::string waitingFor(bool model_ready, const ServoValveParameters* valve,
                         const std::string& experiment) const;
  /// The valve model the feed-forward inverts: the identified one, or the configured gain without lag.
  ServoValveParameters wantedValve(const ServoValveParameters* valve) const;
  /// The feed-forward built for (or moved to) the parameters; why it cannot be, "" where it is.
  std::string followParameters(const HydraulicModel& model, const ParameterVector& used,
                               const ServoValveParameters& wanted, bool valve_identified);

  ros::Subscriber sub_;
  ros::Publisher pub_;
  double configured_gain_, max_age_, limit_;
  mutable std::mutex mutex_;  // the set-point arrives in its own callback
  PressureReference reference_;
  std::unique_ptr<PressureFeedForward> feed_forward_;
  const HydraulicModel* model_ = nullptr;
  ServoValveParameters valve_used_;
  bool valve_identified_ = false;
  bool withdrawn_ = true;  // the last message sent was 0 V (or none)
  std::string blocker_ = "no pressure_setpoint received yet";
  double last_voltage_ = 0.0;
  std::uint64_t published_ = 0;
  FeedForwardInterlock interlock_;
  double last_t_ = std::numeric_limits<double>::quiet_NaN(), last_v_ = std::numeric_limits<double>::quiet_NaN();
  std::uint64_t refused_parameters_ = 0;
};

}  // namespace die_cushion_ident
