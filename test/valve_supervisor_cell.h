#pragma once

#include <cmath>
#include <cstdint>
#include <vector>

#include "die_cushion_ident/core/control/valve_supervisor.h"
#include "die_cushion_ident/core/simulation/die_cushion_simulator.h"

namespace die_cushion_ident {
namespace testing {

/// One command as the cell saw it go out.
struct Sent {
  double steady;      ///< [s] steady time it was sent
  bool feed_forward;  ///< else valve_command
  double voltage;     ///< [V]
};

/// A die cushion cell around one ValveSupervisor, on injected time (issue 45): a simulated cushion at rest
/// whose messages reach the supervisor as the node would receive them (arriving on the steady clock,
/// stamped on the drives' clock), a command timer on the ROS clock (every command_period / 2 of it), the
/// watchdog every watchPeriod() of steady time, and a grid that asks for a feed-forward. Every fault is a
/// switch: the bus or one topic dead, a NaN spool, the drives' stamps off, the clock at any rate (0: a
/// stopped /clock) or jumped, the command timer stalled, the press stepping on the clock (a simulation).
class SupervisedCell {
 public:
  explicit SupervisedCell(std::uint64_t seed, SweepLimits limits = SweepLimits(),
                          FeedForwardOutputLimits feed_forward = feedForwardLimits());

  /// 4 V, 20 V/s, steps of at most 10 ms.
  static FeedForwardOutputLimits feedForwardLimits();

  Instant now() const { return {steady, clock}; }
  /// One millisecond of steady time: the plant, its messages, the command timer, the grid's feed-forward,
  /// the watchdog when due.
  void tick();
  void run(double seconds);
  /// A command sent: kept, and (valve_command) applied to the plant.
  void record(bool feed_forward, double voltage);
  /// [s] from `fault` to the first valve_command at `offset` after it (NaN: none).
  double backAtOffsetAfter(double fault, double offset) const;
  /// The last command on a channel sent at or after `from` [steady s]; nullptr when none.
  const Sent* lastAfter(bool feed_forward, double from) const;

  ValveSupervisor supervisor;
  DieCushionSimulator plant;
  double steady = 100.0, clock = 1000.0;
  double clock_rate = 1.0;    ///< clock seconds per steady second (0: a stopped /clock)
  double stamp_offset = 0.0;  ///< [s] the drives' stamps against the clock
  bool bus = true, timer = true, grid = false;
  bool apply_commands = true;  ///< the valve follows valve_command
  bool pressure_alive = true, position_alive = true, valve_alive = true, nan_spool = false;
  bool plant_on_clock = false;  ///< the press steps on the clock (a simulation), not on the steady clock
  double wanted = NAN;          ///< [V] the grid's feed-forward
  double last_message = 0.0;    ///< [s] steady time of the last message delivered
  std::vector<Sent> sent;

 private:
  void deliver(double clock_stamp);
  void afterMessages();

  SweepLimits limits_;
  std::vector<SimulatedMeasurement> messages_;
  double next_watch_ = 0.0, timer_credit_ = 0.0, plant_credit_ = 0.0;
};

/// A sweep of 20-100 Hz (5 frequencies, about 2.9 s) around `offset` [V].
SweepRequest sweepAt(double offset);
/// [s] the stated bound (doc/hardening.md): the timeout, one watch period, one tick of the cell.
double safeBound(const SweepLimits& limits);

}  // namespace testing
}  // namespace die_cushion_ident
