#include "die_cushion_ident/core/model/effect_library.h"

#include <algorithm>
#include <stdexcept>

#include "die_cushion_ident/core/model/effects/entrained_air.h"
#include "die_cushion_ident/core/model/effects/leakage.h"
#include "die_cushion_ident/core/model/effects/oil_temperature.h"
#include "die_cushion_ident/core/model/effects/tank_pressure.h"
#include "die_cushion_ident/core/model/effects/valve_overlap.h"

namespace die_cushion_ident {

const std::vector<std::string>& libraryEffectNames() {
  static const std::vector<std::string> names{"leakage", "entrained_air", "valve_overlap", "tank_pressure",
                                              "oil_temperature"};
  return names;
}

bool isLibraryEffect(const std::string& name) {
  const auto& names = libraryEffectNames();
  return std::find(names.begin(), names.end(), name) != names.end();
}

std::unique_ptr<Effect> makeLibraryEffect(const std::string& name, const OilTemperatureLaw& oil) {
  if (name == "leakage") return std::make_unique<Leakage>();
  if (name == "entrained_air") return std::make_unique<EntrainedAir>();
  if (name == "valve_overlap") return std::make_unique<ValveOverlap>();
  if (name == "tank_pressure") return std::make_unique<TankPressure>();
  if (name == "oil_temperature") return std::make_unique<OilTemperature>(oil);
  std::string known;
  for (const auto& n : libraryEffectNames()) known += (known.empty() ? "" : ", ") + n;
  throw std::invalid_argument("unknown effect '" + name + "' (library effects: " + known +
                              "; custom effects are given as NAME=EXPR)");
}

}  // namespace die_cushion_ident
