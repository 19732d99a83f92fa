#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "die_cushion_ident/core/simulation/die_cushion_simulator.h"

namespace die_cushion_ident {

/// Kinds of press a die cushion sits in. They differ in what limits the analysis: how fast the pressure can
/// move (the chamber's hydraulic time constant C / (dQ_v/dp)), how short the impact is, how fast the valve
/// is, and so what sampling, filtering and integration resolve them.
enum class PressClass : std::uint8_t {
  /// The paper's: a hydraulic press, 0.15-0.25 m/s drawing, 20 ms impact, 0.05 m^2 cylinder, 3 l dead volume,
  /// an 80 Hz valve (hydraulic time constant ~10 ms).
  kSlowHydraulic,
  /// A mechanical or servo press: the slider-crank meets the cushion at 0.4-0.6 m/s, impact in 3-5 ms, a
  /// valve four times larger and twice as fast, pressure time constant ~2 ms.
  kFastMechanical,
  /// A small, stiff chamber: 0.02 m^2, 0.6-1.5 l dead volume, stiff oil (1.5-2 GPa), ordinary speed.
  kSmallStiff,
  /// A large, soft chamber: 0.2 m^2, 10-30 l of hoses, soft oil (0.7-1.1 GPa), a large, slow valve.
  kLargeSoft,
};
constexpr int kPressClassCount = 4;
const char* pressClassName(PressClass press);
bool parsePressClass(const std::string& text, PressClass* press);
std::vector<PressClass> allPressClasses();

/// A plant of the class with its true parameters. `variation` 0 is the class's nominal press; any other
/// value draws geometry, speeds, oil, valve and effect parameters within the class's spread (a different
/// press of the same kind). The controller is tuned to the drawn plant as a commissioning engineer would,
/// from nominal values (it never knows the true flow gain). Sensors: the acceptance noise (0.2 bar, 2 um,
/// 0.002 spool), 1 kHz per topic, 50 us sampling jitter; `seed` seeds the noise.
SimulatorConfig pressClassPlant(PressClass press, std::uint64_t variation = 0,
                                const std::vector<std::string>& effects = {}, std::uint64_t seed = 1);

/// The true parameter of each library effect for a plant: sized to the plant (a worn seal's leakage a
/// share of the drawing flow, air a share of the swept volume), so that each is as visible in every class.
std::map<std::string, double> effectParametersFor(const SimulatorConfig& plant, std::uint64_t variation = 0);

}  // namespace die_cushion_ident
