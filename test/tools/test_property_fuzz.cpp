// The fuzz cases of test/fuzz/core_fuzz.cpp and config_fuzz.cpp as a deterministic property test in the
// normal suite: random byte strings (fixed seed), every invariant checked. scripts/fuzz runs the same body under
// libFuzzer with coverage guidance and sanitizers.
#include <gtest/gtest.h>

#include <random>
#include <vector>

#include "fuzz/bag_fuzz.h"
#include "fuzz/config_fuzz.h"
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

// analyze_bag config files built from the real keys with hostile values and shapes (the review found a
// non-scalar key aborting the program and `moving_average_width: 31.5` reported as "= -1").
TEST(PropertyFuzz, HostileConfigFilesBreakNoInvariant) {
  std::mt19937 rng(20261123);
  for (int i = 0; i < 2000; ++i) {
    std::vector<std::uint8_t> bytes(std::uniform_int_distribution<int>(0, 64)(rng));
    for (auto& b : bytes) b = static_cast<std::uint8_t>(rng());
    die_cushion_ident::fuzz::runConfigCase(bytes.data(), bytes.size(), [&](const std::string& what) {
      ADD_FAILURE() << "case " << i << ": " << what;
    });
  }
}

// Bag files built from random bytes (chunks, connections, messages with hostile lengths, damage, cuts) for
// analyze_bag's reader: a generated bag with 200 corrupted bytes crashed rosbag itself.
TEST(PropertyFuzz, HostileBagFilesBreakNoInvariant) {
  std::mt19937 rng(20261124);
  for (int i = 0; i < 500; ++i) {
    std::vector<std::uint8_t> bytes(std::uniform_int_distribution<int>(0, 2000)(rng));
    for (auto& b : bytes) b = static_cast<std::uint8_t>(rng());
    die_cushion_ident::fuzz::runBagCase(bytes.data(), bytes.size(), [&](const std::string& what) {
      ADD_FAILURE() << "case " << i << ": " << what;
    });
  }
}
