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

/// "1st", "2nd", "3rd", "4th", "11th", "32nd": a count as an English ordinal, for "every 32nd cycle".
inline std::string ordinal(long n) {
  const long teens = n % 100, last = n % 10;
  const char* suffix = teens >= 11 && teens <= 13 ? "th"
                       : last == 1                ? "st"
                       : last == 2                ? "nd"
                       : last == 3                ? "rd"
                                                  : "th";
  return std::to_string(n) + suffix;
}

/// "a, b, c": the items with `separator` between them, for lists in messages.
inline std::string joined(const std::vector<std::string>& items, const char* separator) {
  std::string out;
  for (const auto& item : items) out += (out.empty() ? "" : separator) + item;
  return out;
}

}  // namespace die_cushion_ident
