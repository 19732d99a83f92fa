#pragma once

#include <diagnostic_updater/diagnostic_updater.h>
#include <ros/ros.h>
#include <sensor_msgs/FluidPressure.h>

#include <limits>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include "die_cushion_ident/SetFeedForward.h"
#include "die_cushion_ident/core/control/feed_forward_interlock.h"
#include "die_cushion_ident/core/control/pressure_feed_forward.h"
#include "die_cushion_ident/core/monitoring/live_identification.h"
#include "die_cushion_ident/core/signal/uniform_resampler.h"
#include "supervised_valve.h"

namespace die_cushion_ident {

/// The node's feed-forward (paper, Fig. 19): subscribes to the cell controller's `pressure_setpoint`
/// (sensor_msgs/FluidPressure) and, at each grid sample, computes the command the identified model needs for
/// it at the cushion's measured motion, which the SupervisedValve sends on `~feed_forward` (ValveSignal,
/// `voltage`) for the controller to add to its PI output, ramped, limited and stopped as the supervisor
/// decides. Before that, FeedForwardInterlock: parameters out of their physical range or a valve model off
/// its reference or its sanity ranges are refused, accepted parameters followed at a bounded rate; and the
/// set-point is used only fresh on both clocks, its rate from a window, bounded. `~enable_feed_forward`
/// switches it on and off; the `feed-forward` diagnostic says what it sends and why.
class FeedForwardPublisher {
 public:
  struct Settings {
    /// [1/V] the valve's static gain until a sweep identifies the valve; NaN: none.
    double valve_gain = std::numeric_limits<double>::quiet_NaN();
    double max_voltage = 10.0;  ///< [V] symmetric, inside the requested safe command range
    SetpointLimits setpoint;
    FeedForwardInterlockLimits interlock;
  };
  FeedForwardPublisher(ros::NodeHandle nh, ros::NodeHandle pnh, const Settings& settings,
                       SupervisedValve& valve);

  /// Called by the node (under its lock) for each grid sample with the live identification (its model and
  /// estimate); `swept` is the last sweep's valve model, or null.
  void update(const GridSample& g, const LiveIdentification& live, const ServoValveParameters* swept);
  /// The model was rebuilt (effects changed, a new pipeline): the inverse is built afresh at the next update
  /// (the parameters it uses go on from where they were, at the bounded rate).
  void modelChanged();
  void diagnose(diagnostic_updater::DiagnosticStatusWrapper& status) const;

 private:
  void onSetpoint(const sensor_msgs::FluidPressure::ConstPtr& msg);
  bool enable(SetFeedForward::Request& request, SetFeedForward::Response& response);
  /// The wanted command [V] for this grid sample, or NaN with the reason in `why`.
  double wanted(const GridSample& g, const LiveIdentification& live, const ServoValveParameters* swept,
                std::string* why);
  /// The inverse built for (or moved to) `used` with `valve`; why it cannot be, "" where it is.
  std::string followParameters(const HydraulicModel& model, const ParameterVector& used,
                               const ServoValveParameters& valve);

  Settings settings_;
  SupervisedValve& valve_;
  ros::Subscriber sub_;
  ros::ServiceServer enable_srv_;
  mutable std::mutex mutex_;  // the set-point arrives in its own callback
  PressureReference reference_;
  std::unique_ptr<PressureFeedForward> feed_forward_;
  ServoValveParameters valve_used_;
  FeedForwardInterlock interlock_;
  std::string last_refusal_;                     // the last estimate or valve model refused
  std::optional<ServoValveParameters> offered_;  // the sweep's model last offered to the interlock
  double last_t_ = std::numeric_limits<double>::quiet_NaN(),
         last_v_ = std::numeric_limits<double>::quiet_NaN();
  double last_steady_ = std::numeric_limits<double>::quiet_NaN();
  std::uint64_t refused_parameters_ = 0, refused_valves_ = 0;
};

}  // namespace die_cushion_ident
