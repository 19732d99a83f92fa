#pragma once

#include <cstdio>
#include <string>
#include <vector>

namespace die_cushion_ident {

/// printf of numbers into a string, for the numbers in messages and explanations. Every number is passed as
/// a double (patterns use %g, %f, %e and their kin, never %d).
template <typename... Numbers>
std::string formatted(const char* pattern, Numbers... numbers) {
  char text[768];
  std::snprintf(text, sizeof(text), pattern, static_cast<double>(numbers)...);
  return text;
}

/// "a, b, c": the items with `separator` between them, for lists in messages.
inline std::string joined(const std::vector<std::string>& items, const char* separator) {
  std::string out;
  for (const auto& item : items) out += (out.empty() ? "" : separator) + item;
  return out;
}

}  // namespace die_cushion_ident
