#include "supervised_valve.h"

#include <chrono>
#include <cmath>
#include <limits>

#include "die_cushion_ident/ValveSignal.h"

namespace die_cushion_ident {

SupervisedValve::SupervisedValve(ros::NodeHandle nh, ros::NodeHandle pnh, const SweepLimits& limits,
                                 const FeedForwardOutputLimits& feed_forward, double command_hold)
    : supervisor_(limits, feed_forward), nh_(nh), command_period_(limits.command_period) {
  supervisor_.setCommandHold(command_hold);
  // Small queues: a command that waits behind others is worth less than the newest one.
  command_pub_ = nh_.advertise<ValveSignal>("valve_command", 10);
  feed_forward_pub_ = pnh.advertise<ValveSignal>("feed_forward", 10);
  watchdog_ = std::thread([this] { watchdog(); });
}

SupervisedValve::~SupervisedValve() {
  stop_ = true;
  if (watchdog_.joinable()) watchdog_.join();
  command_timer_.stop();  // no callback runs any more: the owner's spinner has stopped
  std::lock_guard<std::mutex> lock(mutex_);
  Instant t = now();
  supervisor_.abortExperiment("shutdown", t);
  if (const auto u = supervisor_.experimentCommand(t)) publish(command_pub_, *u, t);
  // The feed-forward ramps out as it would on any other fault: as long as its slew rate takes, up to
  // kShutdownRamp, then 0 V (a node that goes must not leave a voltage on the adder).
  supervisor_.enableFeedForward(false, t);
  const double period = ValveSupervisor::watchPeriod(supervisor_.limits());
  const double end =
      t.steady + std::min(kShutdownRamp, 2.0 * period + std::abs(supervisor_.feedForwardOutput()) /
                                                            supervisor_.feedForwardSlewRate());
  while (supervisor_.feedForwardEngaged() && t.steady < end) {
    std::this_thread::sleep_for(std::chrono::duration<double>(period));
    t = now();
    send(supervisor_.watch(t), t);
  }
  if (supervisor_.feedForwardEngaged()) publish(feed_forward_pub_, 0.0, now());
  // roscpp sends from its own threads: the last commands must leave before their publishers go.
  std::this_thread::sleep_for(std::chrono::duration<double>(kLinger));
}

Instant SupervisedValve::now() {
  const double steady =
      std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
  return {steady, ros::Time::now().toSec()};
}

void SupervisedValve::pressure(double stamp, double value) {
  std::lock_guard<std::mutex> lock(mutex_);
  supervisor_.pressure(stamp, value, now());
}

void SupervisedValve::position(double stamp, double x) {
  std::lock_guard<std::mutex> lock(mutex_);
  supervisor_.position(stamp, x, now());
}

void SupervisedValve::valve(double stamp, double voltage, double spool) {
  std::lock_guard<std::mutex> lock(mutex_);
  supervisor_.valve(stamp, voltage, spool, now());
  experiment_holds_valve_ = supervisor_.experimentHoldsValve();
}

std::string SupervisedValve::startSweep(const SweepRequest& request) {
  return startExperiment([&](ValveSupervisor& s) { return s.startSweep(request, now()); });
}

std::string SupervisedValve::startStepTest(const StepTestRequest& request) {
  return startExperiment([&](ValveSupervisor& s) { return s.startStepTest(request, now()); });
}

std::string SupervisedValve::startExperiment(const std::function<std::string(ValveSupervisor&)>& start) {
  // Lock order: the timer's mutex, then the supervisor's (as in onCommandTimer). The timer is only ever
  // stopped by its own callback, which roscpp allows without waiting for itself.
  std::lock_guard<std::mutex> timer_lock(timer_mutex_);
  std::lock_guard<std::mutex> lock(mutex_);
  const std::string refusal = start(supervisor_);
  experiment_holds_valve_ = supervisor_.experimentHoldsValve();
  if (!refusal.empty()) return refusal;
  if (!command_timer_.isValid()) {
    // Commands at twice the valve rate, so that every valve update finds a fresh one despite jitter.
    command_timer_ =
        nh_.createTimer(ros::Duration(0.5 * command_period_), &SupervisedValve::onCommandTimer, this);
  } else {
    command_timer_.start();
  }
  return "";
}

void SupervisedValve::feedForward(double wanted, const std::string& why) {
  std::lock_guard<std::mutex> lock(mutex_);
  const Instant t = now();
  if (const auto u = supervisor_.feedForward(wanted, why, t)) publish(feed_forward_pub_, *u, t);
}

void SupervisedValve::onCommandTimer(const ros::TimerEvent&) {
  std::lock_guard<std::mutex> timer_lock(timer_mutex_);
  std::lock_guard<std::mutex> lock(mutex_);
  const Instant t = now();
  if (const auto u = supervisor_.experimentCommand(t)) publish(command_pub_, *u, t);
  experiment_holds_valve_ = supervisor_.experimentHoldsValve();
  if (!experiment_holds_valve_) command_timer_.stop();  // the offset has been sent
}

void SupervisedValve::watchdog() {
  const auto period = std::chrono::duration_cast<std::chrono::steady_clock::duration>(
      std::chrono::duration<double>(ValveSupervisor::watchPeriod(supervisor_.limits())));
  auto next = std::chrono::steady_clock::now();
  while (!stop_) {
    next += period;
    std::this_thread::sleep_until(next);
    // A stalled thread does not catch up in a burst: the next tick is a period from now.
    next = std::max(next, std::chrono::steady_clock::now());
    std::lock_guard<std::mutex> lock(mutex_);
    const Instant t = now();
    send(supervisor_.watch(t), t);
    // The command timer stops itself at its next call (stopping it from here could wait for that very
    // call, which waits for this lock).
    experiment_holds_valve_ = supervisor_.experimentHoldsValve();
  }
}

void SupervisedValve::send(const ValveSupervisor::Commands& commands, Instant decided) {
  if (commands.valve_command) publish(command_pub_, *commands.valve_command, decided);
  if (commands.feed_forward) publish(feed_forward_pub_, *commands.feed_forward, decided);
}

void SupervisedValve::publish(const ros::Publisher& publisher, double voltage, Instant decided) {
  ValveSignal msg;
  // Stamped with the moment the supervisor decided it (the one its slew limit counted from), not when
  // publish() ran: a thread preempted in between would show a step the limit never allowed.
  msg.header.stamp = ros::Time(std::max(decided.clock, 0.0));
  msg.voltage = voltage;
  msg.spool_position = std::numeric_limits<double>::quiet_NaN();  // a command: no spool measured
  publisher.publish(msg);
}

}  // namespace die_cushion_ident
