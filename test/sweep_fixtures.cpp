#include "sweep_fixtures.h"

#include <random>

namespace die_cushion_ident {
namespace testing {

PlantCondition plantAtRest() {
  PlantCondition rest;
  rest.pressure = 20e5;
  rest.velocity = 0.0;
  rest.pressure_age = 0.001;
  rest.position_age = 0.001;
  rest.valve_age = 0.001;
  rest.spool_age = 0.001;
  return rest;
}

ServoValveParameters randomValve(std::uint64_t seed) {
  std::mt19937_64 rng(seed * 7919 + 17);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  ServoValveParameters valve;
  valve.natural_frequency = 50.0 + 70.0 * unit(rng);
  valve.damping = 0.5 + 0.4 * unit(rng);
  valve.dead_time = 0.001 + 0.002 * unit(rng);
  valve.gain = 0.05 + 0.15 * unit(rng);
  return valve;
}

SimulatorConfig cushionAtRest(const ServoValveParameters& valve, std::uint64_t seed) {
  SimulatorConfig config;
  config.valve = valve;
  config.cycle.rest_time = 1e6;  // the press never strokes during the test
  config.sensors.spool_noise = 0.002;
  config.seed = seed;
  return config;
}

SweepRig::SweepRig(const SimulatorConfig& plant, const SweepLimits& limits) : plant_(plant), sweep_(limits) {
  // The first messages, so that the plant condition is known (the velocity: a slope over 20 ms of positions).
  for (int i = 0; i < 30; ++i) tick();
}

PlantCondition SweepRig::condition() const {
  PlantCondition c = signals_.at(Instant::simulated(plant_.state().t));
  if (pressure_override_) c.pressure = *pressure_override_;
  return c;
}

std::string SweepRig::start(const SweepRequest& request) {
  return sweep_.start(request, Instant::simulated(plant_.state().t), condition());
}

std::optional<double> SweepRig::tick() {
  const auto command = sweep_.command(plant_.state().t);
  if (command) {
    plant_.setValveCommandOverride(*command);
    commands_.push_back(*command);
  }
  messages_.clear();
  plant_.step(&messages_);
  for (const auto& m : messages_) {
    const Instant arrival = Instant::simulated(m.sample.stamp);
    switch (m.stream) {
      case InputStream::kPressure:
        signals_.pressure(m.sample.stamp, m.sample.first, arrival);
        break;
      case InputStream::kPosition:
        signals_.position(m.sample.stamp, m.sample.first, arrival);
        break;
      case InputStream::kValve: {
        if (drop_valve_) break;
        const double spool = spool_override_ ? *spool_override_ : m.sample.second;
        valve_record_.push_back({m.sample.stamp, m.sample.first, spool});
        signals_.valve(m.sample.stamp, spool, arrival);
        sweep_.addValveSample(m.sample.stamp, m.sample.first, spool);
        break;
      }
    }
  }
  sweep_.supervise(Instant::simulated(plant_.state().t), condition());
  return command;
}

void SweepRig::runToEnd(double max_time) {
  const double end = plant_.state().t + max_time;
  while (sweep_.running() && plant_.state().t < end) tick();
  tick();  // the command that returns the valve to its offset
}

}  // namespace testing
}  // namespace die_cushion_ident
