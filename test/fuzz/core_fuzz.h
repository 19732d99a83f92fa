#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>

namespace die_cushion_ident {
namespace fuzz {

/// Decodes arbitrary bytes into hostile input for every core entry point (configuration values, message
/// streams with NaN/Inf, zero, duplicate, backward and forward-jumping stamps, bursts, gaps, a silent
/// topic, saturated values; sweep limits, requests, plant conditions and valve echoes) and checks the
/// invariants: no crash, no non-finite estimate, no valve command outside the configured bounds, every
/// refusal with a reason. `fail` is called with a description when an invariant breaks.
void runCase(const std::uint8_t* data, std::size_t size, const std::function<void(const std::string&)>& fail);

}  // namespace fuzz
}  // namespace die_cushion_ident
