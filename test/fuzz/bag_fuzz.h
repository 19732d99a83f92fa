#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>

namespace die_cushion_ident {
namespace fuzz {

/// Turns arbitrary bytes into a bag file (the version 2.0 magic, then records built from the bytes: chunks
/// compressed or not, connections, messages of the three input types with hostile lengths, cut anywhere)
/// and reads it with BagStreamReader, decoding every message. Invariants: no crash, no exception, no huge
/// allocation; a read that stops says why.
void runBagCase(const std::uint8_t* data, std::size_t size, const std::function<void(const std::string&)>& fail);

}  // namespace fuzz
}  // namespace die_cushion_ident
