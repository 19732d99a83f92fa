#pragma once

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

}  // namespace die_cushion_ident
