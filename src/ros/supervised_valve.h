#pragma once

#include <ros/ros.h>

#include <atomic>
#include <functional>
#include <mutex>
#include <thread>

#include "die_cushion_ident/core/control/valve_supervisor.h"

namespace die_cushion_ident {

/// The ROS face of ValveSupervisor, the one owner of what the node sends to the valve: `valve_command` (the
/// experiments) and `~feed_forward`. It has its own mutex, never the node's (a long callback there must not
/// hold up the supervision), a watchdog thread on the steady clock (ValveSupervisor::watch every
/// watchPeriod(), whatever /clock and the callback queue do), and while an experiment holds the valve a
/// command timer on ROS time (the sweep's sine and the step's timing run on the clock the stamps are on).
/// Inputs are recorded as they arrive: their stamps, and the moment on both clocks.
class SupervisedValve {
 public:
  /// Throws std::invalid_argument for invalid limits.
  SupervisedValve(ros::NodeHandle nh, ros::NodeHandle pnh, const SweepLimits& limits,
                  const FeedForwardOutputLimits& feed_forward, double command_hold);
  /// Stops the watchdog, aborts an experiment ("shutdown", its offset sent) and ramps the feed-forward out
  /// (for as long as its slew rate takes, at most kShutdownRamp, then 0 V), then lingers kLinger for the
  /// last messages to leave.
  ~SupervisedValve();

  /// The moment now on the steady clock and ROS time.
  static Instant now();

  void pressure(double stamp, double value);
  void position(double stamp, double x);
  void valve(double stamp, double voltage, double spool);

  /// Runs `f(supervisor)` under the supervisor's mutex (for the services and the diagnostics).
  template <class F>
  auto locked(F&& f) {
    std::lock_guard<std::mutex> lock(mutex_);
    return f(supervisor_);
  }
  template <class F>
  auto locked(F&& f) const {
    std::lock_guard<std::mutex> lock(mutex_);
    return f(static_cast<const ValveSupervisor&>(supervisor_));
  }

  /// Empty when started, else why not; the command timer starts with the experiment.
  std::string startSweep(const SweepRequest& request);
  std::string startStepTest(const StepTestRequest& request);
  /// A grid sample's wanted feed-forward [V] (NaN: none, `why`): sent on ~feed_forward as the supervisor
  /// lets it.
  void feedForward(double wanted, const std::string& why);
  /// True while an experiment holds the valve (lock-free: the spinner asks it after every batch).
  bool experimentHoldsValve() const { return experiment_holds_valve_; }

  /// [s] the longest the destructor ramps the feed-forward before it sends 0 V (10 V at 1 V/s).
  static constexpr double kShutdownRamp = 10.0;
  /// [s] how long the destructor waits for its last messages to leave (roscpp sends from its own threads;
  /// a publisher destroyed right after publish() lost the offset in 1 of 7 to 2 of 6 stops).
  static constexpr double kLinger = 0.1;

 private:
  void watchdog();
  std::string startExperiment(const std::function<std::string(ValveSupervisor&)>& start);
  void onCommandTimer(const ros::TimerEvent&);
  void send(const ValveSupervisor::Commands& commands, Instant decided);
  /// A command on `publisher` (valve_command or ~feed_forward), stamped with the clock of `decided`.
  static void publish(const ros::Publisher& publisher, double voltage, Instant decided);

  mutable std::mutex mutex_;  // the supervisor's; never held while waiting for timer_mutex_
  std::mutex timer_mutex_;    // the command timer's start and stop, taken before mutex_
  ValveSupervisor supervisor_;
  ros::NodeHandle nh_;
  ros::Publisher command_pub_, feed_forward_pub_;
  ros::Timer command_timer_;
  double command_period_;
  std::atomic<bool> experiment_holds_valve_{false};
  std::atomic<bool> stop_{false};
  std::thread watchdog_;  // last: started once everything it reads exists
};

}  // namespace die_cushion_ident
