#pragma once

#include <sys/stat.h>

#include <cerrno>
#include <cstdlib>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

namespace die_cushion_ident {

/// "a,b,,c" -> {a, b, c}: the command-line form of effect lists.
inline std::vector<std::string> splitList(const std::string& text) {
  std::vector<std::string> out;
  std::stringstream stream(text);
  std::string item;
  while (std::getline(stream, item, ',')) {
    if (!item.empty()) out.push_back(item);
  }
  return out;
}

/// The whole of `text` as a number in [low, high]; nullopt for anything else (empty, trailing characters,
/// out of range, NaN).
inline std::optional<double> numberIn(const std::string& text, double low, double high) {
  char* end = nullptr;
  const double value = std::strtod(text.c_str(), &end);
  if (end == text.c_str() || *end != '\0' || !(value >= low && value <= high)) return std::nullopt;
  return value;
}

/// The whole of `text` as a whole number in [low, high]; nullopt for anything else ("2.5" included).
inline std::optional<long> wholeNumberIn(const std::string& text, long low, long high) {
  char* end = nullptr;
  const long value = std::strtol(text.c_str(), &end, 10);
  if (end == text.c_str() || *end != '\0' || value < low || value > high) return std::nullopt;
  return value;
}

/// Creates `path` and its missing parents (mkdir -p); true when it is a directory afterwards.
inline bool makeDirectory(const std::string& path) {
  std::string partial;
  std::stringstream parts(path);
  std::string part;
  if (!path.empty() && path[0] == '/') partial = "/";
  while (std::getline(parts, part, '/')) {
    if (part.empty()) continue;
    partial += part + "/";
    if (mkdir(partial.c_str(), 0755) != 0 && errno != EEXIST) return false;
  }
  struct stat info;
  return stat(path.c_str(), &info) == 0 && S_ISDIR(info.st_mode);
}

}  // namespace die_cushion_ident
