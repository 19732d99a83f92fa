#include "simulation_fixtures.h"

#include <random>
#include <stdexcept>

namespace die_cushion_ident {
namespace testing {

SimulatorConfig randomPlant(std::uint64_t seed, const std::vector<std::string>& effects) {
  std::mt19937_64 rng(seed * 7919 + 17);
  auto uniform = [&](double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(rng); };
  SimulatorConfig c;
  c.seed = seed;
  c.effects = effects;
  c.parameters["bulk_modulus"] = uniform(0.9e9, 1.6e9);
  c.parameters["valve_flow_gain"] = uniform(5e-6, 7.5e-6);
  c.parameters["dead_volume"] = uniform(1.5e-3, 5e-3);
  for (const auto& e : effects) {
    if (e == "leakage") c.parameters["leakage_conductance"] = uniform(1e-11, 2.5e-11);
    if (e == "entrained_air") c.parameters["air_volume"] = uniform(2e-4, 5e-4);
    if (e == "valve_overlap") c.parameters["valve_overlap"] = uniform(0.02, 0.05);
    if (e == "tank_pressure") c.parameters["tank_pressure"] = uniform(4e5, 10e5);
  }
  c.controller.nominal_flow_gain = 6e-6;  // the controller does not know the true gain
  return c;
}

Recording record(const SimulatorConfig& plant, int cycles, const UniformResampler::Config& resampler) {
  Recording r;
  r.plant = plant;
  DieCushionSimulator simulator(plant);
  r.grid = simulateGrid(simulator, cycles * simulator.program().cycleDuration(), resampler);
  r.strokes = segmentStrokes(r.grid);
  return r;
}

IdentificationConfig configFor(const SimulatorConfig& plant, const std::vector<std::string>& effects) {
  IdentificationConfig c;
  c.geometry = plant.geometry;
  c.effects = effects;
  return c;
}

void feed(DieCushionSimulator& plant, IdentificationPipeline& pipeline, double duration) {
  feed(plant, duration, {}, [&](InputStream stream, const StreamSample& sample) { pipeline.push(stream, sample); });
}

void feed(DieCushionSimulator& plant, double duration, const std::array<double, kInputStreamCount>& stamp_offsets,
          const std::function<void(InputStream, const StreamSample&)>& take) {
  std::vector<SimulatedMeasurement> messages;
  const double end = plant.state().t + duration;
  while (plant.state().t < end - 1e-12) {
    messages.clear();
    plant.step(&messages);
    for (auto& m : messages) {
      m.sample.stamp += stamp_offsets[static_cast<int>(m.stream)];
      take(m.stream, m.sample);
    }
  }
}

static const IdentifiedParameter& find(const HydraulicEstimate& estimate, const std::string& name) {
  for (const auto& p : estimate.parameters) {
    if (p.name == name) return p;
  }
  throw std::runtime_error("no estimate named " + name);
}

double estimateOf(const HydraulicEstimate& estimate, const std::string& name) {
  return find(estimate, name).value;
}
double stdOf(const HydraulicEstimate& estimate, const std::string& name) { return find(estimate, name).std; }

}  // namespace testing
}  // namespace die_cushion_ident
