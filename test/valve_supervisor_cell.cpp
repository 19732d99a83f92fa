#include "valve_supervisor_cell.h"

#include "sweep_fixtures.h"

namespace die_cushion_ident {
namespace testing {

SupervisedCell::SupervisedCell(std::uint64_t seed, SweepLimits limits, FeedForwardOutputLimits feed_forward)
    : supervisor(limits, feed_forward), plant(cushionAtRest(randomValve(seed), seed)), limits_(limits) {
  for (int i = 0; i < 200; ++i) tick();  // the inputs known, the velocity settled
}

FeedForwardOutputLimits SupervisedCell::feedForwardLimits() {
  FeedForwardOutputLimits ff;
  ff.max_voltage = 4.0;
  ff.slew_rate = 20.0;
  ff.max_step_interval = 0.01;
  return ff;
}

void SupervisedCell::tick() {
  steady += 0.001;
  clock += clock_rate * 0.001;
  // The press steps on the steady clock, or (a simulation under /use_sim_time) one step per millisecond of
  // clock, stamped where each falls, all arriving now.
  plant_credit_ += plant_on_clock ? clock_rate : 1.0;
  const int steps = static_cast<int>(plant_credit_);
  plant_credit_ -= steps;
  for (int k = 0; k < steps; ++k) {
    messages_.clear();
    plant.step(&messages_);
    deliver(clock - (steps - 1 - k) * 0.001 * (plant_on_clock ? 1.0 : clock_rate));
  }
  afterMessages();
}

void SupervisedCell::deliver(double clock_stamp) {
  if (!bus) return;
  for (const auto& m : messages_) {
    const double stamp = clock_stamp + stamp_offset;
    if (m.stream == InputStream::kPressure && pressure_alive)
      supervisor.pressure(stamp, m.sample.first, now());
    if (m.stream == InputStream::kPosition && position_alive)
      supervisor.position(stamp, m.sample.first, now());
    if (m.stream == InputStream::kValve && valve_alive) {
      supervisor.valve(stamp, m.sample.first, nan_spool ? NAN : m.sample.second, now());
    }
    last_message = steady;
  }
}

void SupervisedCell::afterMessages() {
  if (timer && clock_rate > 0.0) {
    // The command timer fires on the clock every command_period / 2: at a fast clock many times per
    // millisecond of steady time, at a slow one rarely.
    timer_credit_ += clock_rate * 0.001 / (0.5 * limits_.command_period);
    while (timer_credit_ >= 1.0) {
      timer_credit_ -= 1.0;
      if (const auto u = supervisor.experimentCommand(now())) record(false, *u);
    }
  }
  if (grid && bus) {
    if (const auto u = supervisor.feedForward(wanted, "no set-point", now())) record(true, *u);
  }
  if (steady >= next_watch_) {
    next_watch_ = steady + ValveSupervisor::watchPeriod(limits_) - 1e-9;
    const auto out = supervisor.watch(now());
    if (out.valve_command) record(false, *out.valve_command);
    if (out.feed_forward) record(true, *out.feed_forward);
  }
}

void SupervisedCell::run(double seconds) {
  const double end = steady + seconds;
  while (steady < end - 1e-9) tick();
}

void SupervisedCell::record(bool feed_forward, double voltage) {
  sent.push_back({steady, feed_forward, voltage});
  if (!feed_forward && apply_commands) plant.setValveCommandOverride(voltage);
}

double SupervisedCell::backAtOffsetAfter(double fault, double offset) const {
  for (const Sent& s : sent) {
    if (!s.feed_forward && s.steady >= fault && s.voltage == offset) return s.steady - fault;
  }
  return NAN;
}

const Sent* SupervisedCell::lastAfter(bool feed_forward, double from) const {
  for (auto it = sent.rbegin(); it != sent.rend() && it->steady >= from; ++it) {
    if (it->feed_forward == feed_forward) return &*it;
  }
  return nullptr;
}

SweepRequest sweepAt(double offset) {
  SweepRequest request;
  request.offset = offset;
  request.frequencies = {20.0, 40.0, 60.0, 80.0, 100.0};
  return request;
}

double safeBound(const SweepLimits& limits) {
  return limits.signal_timeout + ValveSupervisor::watchPeriod(limits) + 0.001;
}

}  // namespace testing
}  // namespace die_cushion_ident
