// The fuzz cases of test/fuzz/core_fuzz.cpp as a deterministic property test in the normal suite:
// 300 random byte strings (fixed seed), every invariant checked. scripts/fuzz runs the same body under
// libFuzzer with coverage guidance and sanitizers.
#include <gtest/gtest.h>

#include <random>
#include <vector>

#include "fuzz/core_fuzz.h"

TEST(PropertyFuzz, HostileInputBreaksNoInvariant) {
  std::mt19937 rng(20261121);
  for (int i = 0; i < 300; ++i) {
    std::vector<std::uint8_t> bytes(std::uniform_int_distribution<int>(0, 20000)(rng));
    for (auto& b : bytes) b = static_cast<std::uint8_t>(rng());
    die_cushion_ident::fuzz::runCase(bytes.data(), bytes.size(), [&](const std::string& what) {
      ADD_FAILURE() << "case " << i << ": " << what;
    });
  }
}
