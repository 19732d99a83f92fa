#pragma once

#include <string>
#include <vector>

#include "die_cushion_ident/core/estimation/hydraulic_identifier.h"
#include "die_cushion_ident/core/model/hydraulic_model.h"

namespace die_cushion_ident {

/// Each parameter outside its physical range (ParameterInfo bounds) by more than `sigmas` standard
/// deviations, in words; empty when all are plausible. Those outside but within `sigmas` of the range go to
/// `uncertain` (may be null). A bulk modulus or flow gain at or below zero is always implausible.
std::vector<std::string> implausibleParameters(const HydraulicModel& model, const HydraulicEstimate& estimate,
                                               double sigmas, std::vector<std::string>* uncertain);

}  // namespace die_cushion_ident
