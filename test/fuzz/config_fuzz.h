#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>

namespace die_cushion_ident {
namespace fuzz {

/// Turns arbitrary bytes into an analyze_bag config file (YAML text built from the real keys, hostile values
/// and structures: lists as keys, mappings as values, fractions, NaN, huge numbers, unknown keys) and checks:
/// no crash or exception escapes, every problem is a sentence, and a config reported without problems is
/// one the pipeline really accepts.
void runConfigCase(const std::uint8_t* data, std::size_t size,
                   const std::function<void(const std::string&)>& fail);

}  // namespace fuzz
}  // namespace die_cushion_ident
