#pragma once

// fmt header-only: a package built on our installed headers needs libfmt-dev's headers and no link line.
#ifndef FMT_HEADER_ONLY
#define FMT_HEADER_ONLY
#endif
#include <fmt/format.h>

#include <string>
#include <type_traits>
#include <utility>
#include <vector>

namespace die_cushion_ident {

/// Numbers (and words) into a string by a pattern checked at compile time, for messages and explanations:
/// `formatted(FMT_STRING("{:.1f} bar"), p * 1e-5)`. A pattern that does not fit its arguments (a precision on
/// an integer, one placeholder too many) does not compile, arguments keep their types, and the text has no
/// length limit (the printf formatter this replaces cast every argument to double, left a %d or %s undefined
/// and cut its output at 768 bytes). Only a pattern wrapped in FMT_STRING is accepted: C++17 checks nothing
/// else at compile time.
template <typename Pattern, typename... Args>
std::string formatted(const Pattern& pattern, Args&&... args) {
  static_assert(
      fmt::detail::is_compile_string<Pattern>::value,
      "wrap the pattern in FMT_STRING(\"...\"): it is then checked against the arguments at compile time");
  return fmt::format(pattern, std::forward<Args>(args)...);
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
