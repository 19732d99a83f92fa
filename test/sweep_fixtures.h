#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "die_cushion_ident/core/simulation/die_cushion_simulator.h"
#include "die_cushion_ident/core/valve/plant_signals.h"
#include "die_cushion_ident/core/valve/recorded_sweep.h"
#include "die_cushion_ident/core/valve/valve_sweep.h"

namespace die_cushion_ident {
namespace testing {

/// A valve inside the acceptance ranges: natural frequency 50-120 Hz, damping 0.5-0.9, dead time 1-3 ms,
/// gain 0.05-0.2 1/V.
ServoValveParameters randomValve(std::uint64_t seed);

/// The plant as the valve experiments' interlocks see a cushion at rest: 20 bar, not moving, every input
/// arrived 1 ms ago, the stamps on the clock.
PlantCondition plantAtRest();

/// A cushion that stays at rest (the sweep's safe state) with the given valve and spool noise 0.002.
SimulatorConfig cushionAtRest(const ServoValveParameters& valve, std::uint64_t seed);

/// Closes the loop between a ValveSweep and the simulator, tick by tick (one control period), as the node
/// does: the plant condition from the latest messages, the valve echo into the sweep, the command out.
class SweepRig {
 public:
  SweepRig(const SimulatorConfig& plant, const SweepLimits& limits);

  std::string start(const SweepRequest& request = {});
  /// One control period; returns the command applied (if any).
  std::optional<double> tick();
  /// Ticks until the sweep is no longer running or `max_time` seconds have passed.
  void runToEnd(double max_time = 600.0);

  DieCushionSimulator& plant() { return plant_; }
  ValveSweep& sweep() { return sweep_; }
  /// The plant as the interlocks see it now: the messages arrive as they are stamped.
  PlantCondition condition() const;
  /// Every command the sweep produced, and every valve message (for the offline analysis).
  const std::vector<double>& commands() const { return commands_; }
  const std::vector<ValveSample>& valveRecord() const { return valve_record_; }
  /// Replaces the spool of the next valve messages (fault injection); nullopt = measured.
  void overrideSpool(std::optional<double> spool) { spool_override_ = spool; }
  /// Stops delivering valve messages (a silent topic).
  void dropValveMessages(bool drop) { drop_valve_ = drop; }
  void overridePressure(std::optional<double> pressure) { pressure_override_ = pressure; }

 private:
  DieCushionSimulator plant_;
  ValveSweep sweep_;
  std::vector<SimulatedMeasurement> messages_;
  PlantSignals signals_;
  std::optional<double> spool_override_, pressure_override_;
  bool drop_valve_ = false;
  std::vector<double> commands_;
  std::vector<ValveSample> valve_record_;
};

}  // namespace testing
}  // namespace die_cushion_ident
