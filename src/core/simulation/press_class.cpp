#include "die_cushion_ident/core/simulation/press_class.h"

#include <cmath>
#include <random>

#include "die_cushion_ident/core/model/effect_library.h"

namespace die_cushion_ident {

namespace {

// A value drawn from [low, high] (uniformly), or the nominal one for variation 0.
class Spread {
 public:
  explicit Spread(std::uint64_t variation) : nominal_(variation == 0), rng_(variation * 104729 + 31) {}
  double operator()(double nominal, double low, double high) {
    const double drawn = std::uniform_real_distribution<double>(low, high)(rng_);
    return nominal_ ? nominal : drawn;
  }

 private:
  bool nominal_;
  std::mt19937_64 rng_;
};

// PI gains for the drawn plant, as commissioned: the loop's crossover set below the valve's bandwidth and its
// dead time's reach (the paper's press: ~150 rad/s), from the chamber at mid-stroke and the nominal flow gain.
void tuneController(SimulatorConfig& plant) {
  const double f0 = plant.valve.natural_frequency, dead_time = plant.valve.dead_time;
  const double crossover = std::min(0.3 * 2.0 * M_PI * f0, 0.3 / std::max(dead_time, 1e-4));  // [rad/s]
  const CylinderGeometry& g = plant.geometry;
  const double volume = plant.parameters.at("dead_volume") + g.piston_area * (g.stroke_length - 0.5 * plant.cycle.drawing_depth);
  const double capacitance = volume / plant.parameters.at("bulk_modulus");
  const double p_mid = 0.5 * (plant.cycle.drawing_start_pressure + plant.cycle.drawing_end_pressure);
  plant.controller.nominal_flow_gain = plant.parameters.at("valve_flow_gain") * 1.1;  // a catalogue value
  plant.controller.proportional_gain =
      crossover * capacitance / (plant.controller.nominal_flow_gain * std::sqrt(p_mid));
  plant.controller.integral_gain = 10.0 * plant.controller.proportional_gain;
}

}  // namespace

const char* pressClassName(PressClass press) {
  switch (press) {
    case PressClass::kSlowHydraulic:
      return "slow_hydraulic";
    case PressClass::kFastMechanical:
      return "fast_mechanical";
    case PressClass::kSmallStiff:
      return "small_stiff";
    case PressClass::kLargeSoft:
      return "large_soft";
  }
  return "?";
}

bool parsePressClass(const std::string& text, PressClass* press) {
  for (PressClass p : allPressClasses()) {
    if (text == pressClassName(p)) {
      *press = p;
      return true;
    }
  }
  return false;
}

std::vector<PressClass> allPressClasses() {
  return {PressClass::kSlowHydraulic, PressClass::kFastMechanical, PressClass::kSmallStiff, PressClass::kLargeSoft};
}

std::map<std::string, double> effectParametersFor(const SimulatorConfig& plant, std::uint64_t variation) {
  Spread spread(variation == 0 ? 0 : variation + 7);
  const CylinderGeometry& g = plant.geometry;
  const PressCycleConfig& c = plant.cycle;
  const double drawing_flow = g.piston_area * c.drawing_speed;
  const double p_mid = 0.5 * (c.drawing_start_pressure + c.drawing_end_pressure);
  return {
      // A worn seal passing 1.5 % of the drawing flow at the drawing pressure.
      {"leakage_conductance", spread(0.015, 0.01, 0.025) * drawing_flow / p_mid},
      // Free air of 2.4 % of the swept volume at atmospheric pressure.
      {"air_volume", spread(0.024, 0.016, 0.04) * g.piston_area * g.stroke_length},
      {"valve_overlap", spread(0.03, 0.02, 0.05)},
      {"tank_pressure", spread(0.05, 0.035, 0.08) * g.supply_pressure},
  };
}

namespace {

// The paper's press: the defaults, only the drawn plant moves away from them.
void drawSlowHydraulic(SimulatorConfig& plant, Spread& spread) {
  PressCycleConfig& cycle = plant.cycle;
  plant.parameters["bulk_modulus"] = spread(1.2e9, 0.9e9, 1.6e9);
  plant.parameters["valve_flow_gain"] = spread(6e-6, 5e-6, 7.5e-6);
  plant.parameters["dead_volume"] = spread(3e-3, 1.5e-3, 5e-3);
  cycle.drawing_speed = spread(0.2, 0.15, 0.25);
}

// A mechanical or servo press: a crank, fast drawing, a short impact, a large fast valve.
void drawFastMechanical(SimulatorConfig& plant, Spread& spread) {
  PressCycleConfig& cycle = plant.cycle;
  ServoValveParameters& valve = plant.valve;
  CylinderGeometry& geometry = plant.geometry;
  geometry.stroke_length = 0.2;
  geometry.supply_pressure = 150e5;
  cycle.motion = RamMotion::kCrank;
  cycle.crank_radius = spread(0.15, 0.12, 0.2);
  cycle.drawing_depth = spread(0.12, 0.1, 0.14);
  cycle.drawing_speed = spread(0.5, 0.4, 0.6);
  cycle.impact_time = spread(0.004, 0.003, 0.005);
  cycle.rest_time = 0.3;
  cycle.bottom_hold_time = 0.05;
  cycle.release_time = 0.04;
  cycle.return_speed = 0.4;
  cycle.return_ramp_time = 0.03;
  cycle.drawing_end_pressure = 140e5;
  plant.parameters["bulk_modulus"] = spread(1.7e9, 1.4e9, 2.0e9);
  plant.parameters["valve_flow_gain"] = spread(2.4e-5, 2e-5, 3e-5);
  plant.parameters["dead_volume"] = spread(2e-3, 1.5e-3, 3e-3);
  valve.natural_frequency = spread(160.0, 140.0, 200.0);
  valve.dead_time = spread(0.001, 0.0007, 0.0012);
}

// A small stiff chamber: a small piston and dead volume, high pressures.
void drawSmallStiff(SimulatorConfig& plant, Spread& spread) {
  PressCycleConfig& cycle = plant.cycle;
  ServoValveParameters& valve = plant.valve;
  CylinderGeometry& geometry = plant.geometry;
  geometry.piston_area = 0.02;
  geometry.stroke_length = 0.15;
  geometry.supply_pressure = 210e5;
  cycle.drawing_depth = 0.12;
  cycle.drawing_speed = spread(0.2, 0.15, 0.3);
  cycle.impact_time = 0.015;
  cycle.pre_pressure = 40e5;
  cycle.drawing_start_pressure = 120e5;
  cycle.drawing_end_pressure = 180e5;
  cycle.release_pressure = 8e5;
  cycle.return_pressure = 20e5;
  plant.parameters["bulk_modulus"] = spread(1.8e9, 1.5e9, 2.0e9);
  plant.parameters["valve_flow_gain"] = spread(2.5e-6, 2e-6, 3.2e-6);
  plant.parameters["dead_volume"] = spread(1e-3, 0.6e-3, 1.5e-3);
  valve.natural_frequency = spread(100.0, 80.0, 120.0);
  valve.dead_time = spread(0.0015, 0.001, 0.002);
}

// A large soft chamber: a large piston and dead volume, a slow valve.
void drawLargeSoft(SimulatorConfig& plant, Spread& spread) {
  PressCycleConfig& cycle = plant.cycle;
  ServoValveParameters& valve = plant.valve;
  CylinderGeometry& geometry = plant.geometry;
  geometry.piston_area = 0.2;
  geometry.stroke_length = 0.3;
  geometry.supply_pressure = 100e5;
  cycle.drawing_depth = 0.22;
  cycle.drawing_speed = spread(0.15, 0.1, 0.2);
  cycle.impact_time = 0.03;
  cycle.pre_pressure = 20e5;
  cycle.drawing_start_pressure = 50e5;
  cycle.drawing_end_pressure = 80e5;
  cycle.release_pressure = 4e5;
  cycle.return_pressure = 10e5;
  plant.parameters["bulk_modulus"] = spread(0.9e9, 0.7e9, 1.1e9);
  plant.parameters["valve_flow_gain"] = spread(2.4e-5, 2e-5, 3e-5);
  plant.parameters["dead_volume"] = spread(20e-3, 10e-3, 30e-3);
  valve.natural_frequency = spread(50.0, 40.0, 60.0);
  valve.dead_time = spread(0.003, 0.0025, 0.004);
}

}  // namespace

SimulatorConfig pressClassPlant(PressClass press, std::uint64_t variation, const std::vector<std::string>& effects,
                                std::uint64_t seed) {
  SimulatorConfig plant;
  plant.seed = seed;
  plant.effects = effects;
  Spread spread(variation);
  switch (press) {
    case PressClass::kSlowHydraulic:
      drawSlowHydraulic(plant, spread);
      break;
    case PressClass::kFastMechanical:
      drawFastMechanical(plant, spread);
      break;
    case PressClass::kSmallStiff:
      drawSmallStiff(plant, spread);
      break;
    case PressClass::kLargeSoft:
      drawLargeSoft(plant, spread);
      break;
  }
  if (press != PressClass::kSlowHydraulic || variation != 0) tuneController(plant);
  if (press == PressClass::kSlowHydraulic && variation == 0) {
    plant.controller = PressureControllerConfig();  // the paper's press as every earlier test knew it
  }
  if (press == PressClass::kSlowHydraulic && variation == 0) return plant;  // defaultTrueParameters()
  const auto effect_parameters = effectParametersFor(plant, variation);
  for (const auto& name : effects) {
    const std::string parameter = makeLibraryEffect(name)->parameterFor(plant.geometry).name;
    const auto it = effect_parameters.find(parameter);
    if (it != effect_parameters.end()) plant.parameters[parameter] = it->second;
  }
  return plant;
}

}  // namespace die_cushion_ident
