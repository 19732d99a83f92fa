#pragma once

#include <cstdio>
#include <string>
#include <vector>

namespace die_cushion_ident {

/// printf of up to three numbers into a string, for the numbers in messages and explanations.
inline std::string formatted(const char* pattern, double a = 0.0, double b = 0.0, double c = 0.0) {
  char text[512];
  std::snprintf(text, sizeof(text), pattern, a, b, c);
  return text;
}

/// "a, b, c": the items with `separator` between them, for lists in messages.
inline std::string joined(const std::vector<std::string>& items, const char* separator) {
  std::string out;
  for (const auto& item : items) out += (out.empty() ? "" : separator) + item;
  return out;
}

}  // namespace die_cushion_ident
