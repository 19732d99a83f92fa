#pragma once

#include <memory>
#include <string>
#include <vector>

#include "die_cushion_ident/core/model/effect.h"
#include "die_cushion_ident/core/model/oil_temperature_law.h"

namespace die_cushion_ident {

/// Names of the library effects, as in shared/CONTRACT.md (oil_temperature last: it reads the optional
/// oil temperature topic, and the analyses offer it only where a recording has one).
const std::vector<std::string>& libraryEffectNames();
bool isLibraryEffect(const std::string& name);

/// Creates a library effect by name; throws std::invalid_argument listing the known names. `oil` holds the
/// oil's temperature law (the oil_temperature effect's constants).
std::unique_ptr<Effect> makeLibraryEffect(const std::string& name, const OilTemperatureLaw& oil = {});

}  // namespace die_cushion_ident
