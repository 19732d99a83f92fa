// libFuzzer entry point (scripts/fuzz builds it with clang, -fsanitize=fuzzer,address,undefined).
#include <cstdio>
#include <cstdlib>

#include "bag_fuzz.h"
#include "config_fuzz.h"
#include "core_fuzz.h"

// The first byte chooses the target: one input in four is an analyze_bag config file, one a bag file for
// BagStreamReader, the rest drive the core.
extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto fail = [](const std::string& what) {
    std::fprintf(stderr, "invariant broken: %s\n", what.c_str());
    std::abort();
  };
  if (size > 0 && data[0] % 4 == 3) {
    die_cushion_ident::fuzz::runConfigCase(data + 1, size - 1, fail);
  } else if (size > 0 && data[0] % 4 == 2) {
    die_cushion_ident::fuzz::runBagCase(data + 1, size - 1, fail);
  } else {
    die_cushion_ident::fuzz::runCase(data, size, fail);
  }
  return 0;
}
