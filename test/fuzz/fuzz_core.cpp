// libFuzzer entry point (scripts/fuzz builds it with clang, -fsanitize=fuzzer,address,undefined).
#include <cstdio>
#include <cstdlib>

#include "core_fuzz.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  die_cushion_ident::fuzz::runCase(data, size, [](const std::string& what) {
    std::fprintf(stderr, "invariant broken: %s\n", what.c_str());
    std::abort();
  });
  return 0;
}
