#pragma once

#include <memory>
#include <string>
#include <vector>

#include "die_cushion_ident/core/model/effect.h"

namespace die_cushion_ident {

/// Names of the library effects, as in shared/CONTRACT.md.
const std::vector<std::string>& libraryEffectNames();
bool isLibraryEffect(const std::string& name);

/// Creates a library effect by name; throws std::invalid_argument listing the known names.
std::unique_ptr<Effect> makeLibraryEffect(const std::string& name);

}  // namespace die_cushion_ident
